/* peer.c - one controller per bus (peer.h). */
#include "omni4/firmware/peer.h"

#include <stdio.h>

#include "omni4/firmware/lcmio.h"
#include "omni4/firmware/rtloop.h"

lcm_t *peer_open_lcm_alone(const char *url)
{
	lcm_t *lcm = lcm_create(url);
	int64_t seq = 0, utime = 0;

	if (!lcm) {
		fprintf(stderr, "omni4-fw: cannot open LCM at '%s'\n", url);
		return NULL;
	}
	const long heard = lcmio_listen_motors(lcm, PEER_LISTEN_MS, &seq, &utime);

	if (heard < 0) {
		fprintf(stderr, "omni4-fw: cannot receive on LCM at '%s'\n", url);
	} else if (heard > 0) {
		fprintf(stderr,
		        "omni4-fw: another controller is publishing OMNI4_MOTORS on %s "
		        "(seq %lld utime %lld heard within %d ms): refusing to start\n",
		        url, (long long)seq, (long long)utime, PEER_LISTEN_MS);
	} else {
		return lcm;
	}
	lcm_destroy(lcm);
	return NULL;
}

static int guard_enable(void *ctx, bool on)
{
	return hal_motor_enable(&((struct peer_guard *)ctx)->backend, on);
}

static int guard_write(void *ctx, const float volts[4])
{
	return hal_motor_write(&((struct peer_guard *)ctx)->backend, volts);
}

/* While another controller's samples are heard (the last less than PEER_HOLD_US ago) every
 * reading carries HAL_FAULT_BUS. */
static int guard_read(void *ctx, struct motor_sample *out)
{
	struct peer_guard *g = ctx;
	const int rc = hal_motor_read(&g->backend, out);
	const int64_t last = atomic_load_explicit(&g->last_us, memory_order_relaxed);

	if (rc == 0 && last && rtloop_clock_us() - last < PEER_HOLD_US)
		out->faults |= HAL_FAULT_BUS;
	return rc;
}

static int guard_clear_faults(void *ctx)
{
	return hal_motor_clear_faults(&((struct peer_guard *)ctx)->backend);
}

static void guard_halt(void *ctx)
{
	hal_motor_halt(&((struct peer_guard *)ctx)->backend);
}

/* The backend's other sensors (a simulated camera and truth) pass through. */
static int guard_read_pose(void *ctx, struct hal_pose *out)
{
	return hal_motor_read_pose(&((struct peer_guard *)ctx)->backend, out);
}

static int guard_read_truth(void *ctx, struct hal_truth *out)
{
	return hal_motor_read_truth(&((struct peer_guard *)ctx)->backend, out);
}

static const struct motor_hal_ops peer_guard_ops = {
    .enable = guard_enable,
    .write = guard_write,
    .read = guard_read,
    .read_pose = guard_read_pose,
    .read_truth = guard_read_truth,
    .clear_faults = guard_clear_faults,
    .halt = guard_halt,
    .close = NULL, /* the robot closes the backend */
};

struct motor_hal peer_guard_wrap(void *ctx, struct motor_hal backend)
{
	struct peer_guard *g = ctx;

	g->backend = backend;
	return (struct motor_hal){.ops = &peer_guard_ops, .ctx = g};
}

void peer_on_foreign(void *ctx, int64_t seq, int64_t utime)
{
	struct peer_guard *g = ctx;
	const int64_t now = rtloop_clock_us();
	const int64_t prev = atomic_exchange(&g->last_us, now);

	if (!prev || now - prev >= PEER_HOLD_US)
		fprintf(stderr,
		        "omni4-fw: FAULT_BUS: another controller is publishing OMNI4_MOTORS "
		        "on %s (seq %lld utime %lld is not one of ours): outputs off; the "
		        "controller stays in FAULT until it has been silent for 1 s and "
		        "MODE_CLEAR_FAULT\n",
		        g->url, (long long)seq, (long long)utime);
}
