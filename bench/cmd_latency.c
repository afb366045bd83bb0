/*
 * cmd_latency: OMNI4_CMD publish -> HAL write of the new voltage, through the real stack of
 * omni4-fw (LCM receive thread, command mailbox, fixed-rate loop at 1 kHz) on the sim backend.
 * A second LCM instance publishes VOLTAGE steps with distinct values at random moments; a thin
 * HAL in front of the sim backend stamps the first write of each value.
 * usage: cmd_latency URL N   -> prints "p50 P p99 Q max M us over N commands"
 */
#include <lcm/lcm.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/base/clock.h"
#include "omni4/firmware/lcmio.h"
#include "omni4/firmware/robot.h"
#include "omni4/firmware/rtloop.h"
#include "omni4_command_t.h"

static _Atomic int64_t seen_ns; /* when the awaited value was first written */
static _Atomic float awaited;

static int stamp_write(void *ctx, const float volts[4])
{
	if (volts[0] == atomic_load(&awaited) && atomic_load(&seen_ns) == 0)
		atomic_store(&seen_ns, omni4_monotonic_ns());
	return sim_motor_ops.write(ctx, volts);
}

/* The sim backend with writes stamped (robot_spec.wrap). */
static struct motor_hal stamped(void *ctx, struct motor_hal backend)
{
	static struct motor_hal_ops ops;

	(void)ctx;
	ops = *backend.ops;
	ops.write = stamp_write;
	return (struct motor_hal){.ops = &ops, .ctx = backend.ctx};
}

static int cmp(const void *a, const void *b)
{
	const double x = *(const double *)a, y = *(const double *)b;

	return x < y ? -1 : x > y;
}

static void tick(void *ctx, int64_t now_us)
{
	fw_tick(ctx, now_us);
}

/*
 * Publishes n VOLTAGE commands with distinct values, each at a random phase against the loop,
 * and puts the latency of each one that reached the HAL within 50 ms into lat [us]. Returns
 * how many did.
 */
static int measure(lcm_t *tx, int n, double *lat)
{
	int got = 0;

	srand(7);
	for (int k = 0; k < n; k++) {
		const float v = 0.5f + 0.01f * (float)(k % 500);
		const struct timespec wait = {.tv_sec = 0, .tv_nsec = 2000000 + rand() % 1000000};
		omni4_command_t c = {.seq = k,
		                     .mode = OMNI4_COMMAND_T_MODE_VOLTAGE,
		                     .voltage = {v, v, v, v},
		                     .ramp_s = 0};

		nanosleep(&wait, NULL); /* a random phase against the loop */
		atomic_store(&seen_ns, 0);
		atomic_store(&awaited, v);
		const int64_t t0 = omni4_monotonic_ns();

		omni4_command_t_publish(tx, OMNI4_CHANNEL_CMD, &c);
		while (!atomic_load(&seen_ns) && omni4_monotonic_ns() - t0 < 50000000) {
			const struct timespec nap = {.tv_sec = 0, .tv_nsec = 20000};

			nanosleep(&nap, NULL);
		}
		if (atomic_load(&seen_ns))
			lat[got++] = (double)(atomic_load(&seen_ns) - t0) / 1000.0;
	}
	return got;
}

int main(int argc, char **argv)
{
	static struct robot robot;
	struct ctl_settings ctl;
	struct sim_settings sim;
	char why[256];
	const int n = argc > 2 ? atoi(argv[2]) : 200;

	if (argc < 2 || n <= 0 || n > 100000) {
		fprintf(stderr, "usage: cmd_latency URL N\n");
		return 2;
	}
	ctl_settings_defaults(&ctl);
	sim_settings_defaults(&sim);
	const struct robot_spec spec = {.ctl = &ctl,
	                                .motor = OMNI4_MOTOR_SIM,
	                                .lines = OMNI4_LINES_NONE,
	                                .sim = &sim,
	                                .sim_exact = true,
	                                .utime0 = rtloop_clock_us(),
	                                .wrap = stamped};
	struct fw *fw = &robot.fw;

	if (robot_open(&robot, &spec, why, sizeof(why))) {
		fprintf(stderr, "cmd_latency: %s\n", why);
		return 1;
	}
	lcm_t *rx = lcm_create(argv[1]), *tx = lcm_create(argv[1]);

	if (!rx || !tx) {
		fprintf(stderr, "cmd_latency: cannot open LCM at %s\n", argv[1]);
		return 1;
	}
	struct lcmio io;
	struct rtloop loop;

	if (lcmio_start(&io, rx, fw) || rtloop_start(&loop, 1000.0, 80, 0, tick, fw))
		return 1;
	double *lat = calloc((size_t)n, sizeof(double));
	const int got = measure(tx, n, lat);

	rtloop_request_stop(&loop);
	rtloop_join(&loop);
	lcmio_stop(&io);
	robot_close(&robot);
	qsort(lat, (size_t)got, sizeof(double), cmp);
	if (!got) {
		printf("no command reached the HAL\n");
		return 1;
	}
	printf("p50 %.0f p99 %.0f max %.0f us over %d of %d commands\n", lat[got / 2],
	       lat[(int)(0.99 * (got - 1))], lat[got - 1], got, n);
	lcm_destroy(tx);
	lcm_destroy(rx);
	free(lat);
	return got == n ? 0 : 1;
}
