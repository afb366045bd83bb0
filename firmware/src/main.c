/*
 * omni4-fw - the robot controller: fixed-rate loop on the configured HAL backends, commands
 * from OMNI4_CMD, one OMNI4_MOTORS per tick. Outputs are switched off on every exit path.
 */
#include <errno.h>
#include <getopt.h>
#include <lcm/lcm.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/config.h"
#include "omni4/fw.h"
#include "omni4/getopt_exact.h"
#include "omni4/gpiod_lines.h"
#include "omni4/lcmio.h"
#include "omni4/param_service.h"
#include "omni4/rtloop.h"
#include "omni4/sim_motor.h"
#include "omni4/socketcan_motor.h"
#include "omni4/version.h"

static volatile sig_atomic_t g_stop;

/* Before the loop starts, OMNI4_MOTORS is listened for this long: another controller on the
 * URL publishes one per tick (1 ms at 1 kHz, 20 ms at 50 Hz), so 300 ms hears at least 15 of
 * its samples even at 50 Hz and a lost datagram or a scheduling hiccup of 100 ms on either side
 * cannot hide it, while adding little to start-up. */
#define PEER_LISTEN_MS 300
/* A foreign OMNI4_MOTORS sample keeps FAULT_BUS present this long: MODE_CLEAR_FAULT is
 * refused until the other controller has been silent for 1 s. */
#define PEER_HOLD_US 1000000

struct app {
	struct fw fw;
	struct motor_hal motor;            /* the backend; fw.motor is it behind peer_guard */
	const char *url;
	_Atomic int64_t peer_last_us;      /* rtloop_clock_us() of the last foreign sample; 0 none */
	struct sim_motor sim;
	struct sim_lines sim_lines;
	struct socketcan_motor can;
	struct gpiod_lines gpio;
	struct param_service params;
};

static struct app *g_app; /* for the crash handler only */

static void on_signal(int sig)
{
	(void)sig;
	g_stop = 1;
}

static void usage(FILE *f)
{
	fprintf(f,
		"usage: omni4-fw --config ROBOT.ini [--duration S] [--quiet]\n"
		"Runs the omni4 controller: the fixed-rate loop on the HAL backends of ROBOT.ini\n"
		"([hal] motor = sim|socketcan, lines = none|sim|gpiod), commands from OMNI4_CMD,\n"
		"one OMNI4_MOTORS message per tick on the [lcm] url. Parameters can be read and\n"
		"changed while it runs (omni4-param, channel OMNI4_PARAM_REQ); 'save' rewrites\n"
		"ROBOT.ini atomically (the previous file is kept as ROBOT.ini.bak).\n"
		"  -c, --config FILE   robot INI file (required)\n"
		"  -d, --duration S    stop after S seconds (default: run until SIGINT/SIGTERM)\n"
		"  -q, --quiet         no status line\n"
		"  -h, --help          this text\n"
		"      --version       the version and the git description it was built from\n"
		"example: omni4-fw --config /etc/omni4/robot.ini\n");
}

/* SIGSEGV/SIGABRT/...: switch the outputs off (the HAL writes are plain syscalls), then let
 * the signal kill the process as it would have (SA_RESETHAND restored the default action).
 * The loop thread keeps running while this handler runs on whichever thread crashed: with the
 * CAN backend, socketcan_motor_halt() first closes the driver's write gate and waits for a
 * CMD_VOLTAGE the loop may be sending at this instant, so that the handler's DISABLE + 0 V
 * frames are the last ones on the bus (fw_emergency_off alone raced with a tick that had read
 * the old state and sent its non-zero frame after them). */
static void on_crash(int sig)
{
	if (g_app) {
		if (g_app->motor.ops == &socketcan_motor_ops)
			socketcan_motor_halt(&g_app->can);
		fw_emergency_off(&g_app->fw);
	}
	raise(sig);
}

static void install_crash_handler(void)
{
	static const int sigs[] = {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL};
	struct sigaction sa = {.sa_handler = on_crash, .sa_flags = SA_RESETHAND};

	sigemptyset(&sa.sa_mask);
	for (unsigned i = 0; i < sizeof(sigs) / sizeof(sigs[0]); i++)
		sigaction(sigs[i], &sa, NULL);
}

/* Parameter changes with the CAN backend: its plausibility limits follow [model] and [limits]
 * (checked on the parameter thread, set by the loop between two ticks). */
static struct sc_limits can_limits(const struct omni4_config *cfg)
{
	return sc_limits_from_model(cfg->limits.supply_v, cfg->model.R, cfg->model.Kt,
				    cfg->model.l, cfg->model.r, cfg->model.M, cfg->model.J,
				    cfg->model.d, 1.0 / cfg->loop.rate_hz, cfg->sim.current_noise_a,
				    cfg->limits.current_max_a);
}

static int can_limits_check(void *ctx, const struct omni4_config *cfg, char *why, size_t n)
{
	struct socketcan_motor probe; /* set_limits only validates and copies the limits */
	const struct sc_limits lim = can_limits(cfg);

	(void)ctx;
	if (socketcan_motor_set_limits(&probe, &lim)) {
		snprintf(why, n, "the [model] and [limits] give no valid CAN plausibility limits");
		return -EINVAL;
	}
	return 0;
}

static void can_limits_apply(void *ctx, const struct omni4_config *cfg)
{
	const struct sc_limits lim = can_limits(cfg);

	socketcan_motor_set_limits(ctx, &lim); /* checked by can_limits_check */
}

/* Logger thread: a new set of current-sense offsets (it also goes out on
 * OMNI4_PARAM_CHANGED); a channel beyond the limit is always said, the rest unless --quiet. */
static void on_calibration(void *ctx, const struct log_entry *e)
{
	const bool quiet = *(const int *)ctx;
	const float *a = e->current;

	if (e->faults) {
		char ch[8];

		lcmio_fault_channels((uint32_t)e->faults, ch);
		for (int j = 0; j < 4; j++)
			if (e->faults & (1 << j))
				fprintf(stderr,
					"omni4-fw: FAULT_CURRENT_SENSOR: channel %d: current offset "
					"%.6f A beyond the %.2f A limit (bridges off, mean of %u "
					"readings, tick %lld)\n",
					j, (double)a[j], (double)CTL_CAL_LIMIT_A,
					(unsigned)e->cal_samples, (long long)e->seq);
		fprintf(stderr, "omni4-fw: current sensor fault on channel%s %s: the controller stays "
			"in FAULT until a calibration within the limit and MODE_CLEAR_FAULT\n",
			strchr(ch, ',') ? "s" : "", ch);
		return;
	}
	if (!quiet)
		fprintf(stderr,
			"omni4-fw: current offsets %.6f %.6f %.6f %.6f A subtracted from tick %lld "
			"on (bridges off, mean of %u readings)\n",
			(double)a[0], (double)a[1], (double)a[2], (double)a[3], (long long)e->seq,
			(unsigned)e->cal_samples);
}

/* The backend as the controller sees it: while another controller's OMNI4_MOTORS samples are
 * heard (the last less than PEER_HOLD_US ago) every reading carries HAL_FAULT_BUS, which the
 * controller latches as FAULT_BUS (outputs off): two controllers on one bus. */
static int guard_enable(void *ctx, bool on)
{
	return hal_motor_enable(&((struct app *)ctx)->motor, on);
}

static int guard_write(void *ctx, const float volts[4])
{
	return hal_motor_write(&((struct app *)ctx)->motor, volts);
}

static int guard_read(void *ctx, struct motor_sample *out)
{
	struct app *app = ctx;
	const int rc = hal_motor_read(&app->motor, out);
	const int64_t last = atomic_load_explicit(&app->peer_last_us, memory_order_relaxed);

	if (rc == 0 && last && rtloop_clock_us() - last < PEER_HOLD_US)
		out->faults |= HAL_FAULT_BUS;
	return rc;
}

static int guard_clear_faults(void *ctx)
{
	return hal_motor_clear_faults(&((struct app *)ctx)->motor);
}

static const struct motor_hal_ops peer_guard_ops = {
	.enable = guard_enable, .write = guard_write, .read = guard_read,
	.clear_faults = guard_clear_faults, .close = NULL, /* main closes the backend */
};

/* Receive thread: an OMNI4_MOTORS sample this process did not publish. Said once per
 * episode (after PEER_HOLD_US of silence), counted always. */
static void on_foreign(void *ctx, int64_t seq, int64_t utime)
{
	struct app *app = ctx;
	const int64_t now = rtloop_clock_us();
	const int64_t prev = atomic_exchange(&app->peer_last_us, now);

	if (!prev || now - prev >= PEER_HOLD_US)
		fprintf(stderr, "omni4-fw: FAULT_BUS: another controller is publishing OMNI4_MOTORS "
			"on %s (seq %lld utime %lld is not one of ours): outputs off; the "
			"controller stays in FAULT until it has been silent for 1 s and "
			"MODE_CLEAR_FAULT\n", app->url, (long long)seq, (long long)utime);
}

static void tick(void *ctx, int64_t now_us)
{
	fw_tick(ctx, now_us);
}

static void on_pose(void *user, int64_t utime, const double pose[3])
{
	fw_push_pose(user, utime, pose);
}

struct options {
	const char *config_path;
	double duration_s;    /* 0: until SIGINT / SIGTERM */
	double crash_after_s; /* test hook: raise SIGSEGV after this long */
	int quiet;
};

/* -1 to go on, else the exit status (0 for --help, 2 for a usage error). */
static int parse_options(int argc, char **argv, struct options *o)
{
	static const struct option opts[] = {
		{"config", required_argument, NULL, 'c'}, {"duration", required_argument, NULL, 'd'},
		{"quiet", no_argument, NULL, 'q'},        {"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, 'V'},
		/* Test hook (not in the help): crash with SIGSEGV after S seconds, to check that the
		 * crash handler switches the outputs off. */
		{"crash-after", required_argument, NULL, 'X'},
		{NULL, 0, NULL, 0},
	};
	int c;

	*o = (struct options){0};
	while ((c = omni4_getopt_long("omni4-fw", argc, argv, "c:d:qh", opts)) != -1) {
		switch (c) {
		case 'c':
			o->config_path = optarg;
			break;
		case 'd': {
			char *end;

			o->duration_s = strtod(optarg, &end);
			if (end == optarg || *end || !(o->duration_s > 0.0)) {
				fprintf(stderr, "omni4-fw: --duration must be a positive number\n");
				return 2;
			}
			break;
		}
		case 'q':
			o->quiet = 1;
			break;
		case 'X':
			o->crash_after_s = strtod(optarg, NULL);
			break;
		case 'h':
			usage(stdout);
			return 0;
		case 'V':
			printf("omni4-fw %s\n", OMNI4_VERSION);
			return 0;
		default: /* '?': omni4_getopt_long said what */
			return 2;
		}
	}
	if (!o->config_path) {
		fprintf(stderr, "omni4-fw: --config is required (see omni4-fw --help)\n");
		return 2;
	}
	return -1;
}

/* The SocketCAN backend: the bus must carry the protocol, the interface must open, the
 * plausibility limits must follow from the model. 0 or -1 (said on stderr). */
static int open_socketcan(struct app *app, const struct omni4_config *cfg, const char *path)
{
	/* [can] bitrate: the protocol's worst-case share of the bus (both boards' STATUS and
	 * CMD_VOLTAGE every tick, HEALTH at 100 Hz, worst-case bit stuffing) at this loop rate
	 * must stay at or below half of it. */
	const double load = can_bus_load_1khz(cfg->can.bitrate) * cfg->loop.rate_hz / 1000.0;

	if (load > 0.5) {
		fprintf(stderr, "omni4-fw: %s: [can] bitrate %d bit/s is too slow for [loop] "
			"rate_hz %g: the motor-driver protocol would take %.0f %% of the bus "
			"(at most 50 %%)\n", path, cfg->can.bitrate, cfg->loop.rate_hz, 100.0 * load);
		return -1;
	}
	const int rc = socketcan_motor_open(&app->can, cfg->can.iface, cfg->can.status_timeout_ms);

	if (rc) {
		fprintf(stderr, "omni4-fw: CAN interface '%s': %s\n", cfg->can.iface,
			strerror(-rc));
		return -1;
	}
	/* Plausibility limits of this robot (STATUS every tick), not Table III's. */
	const struct sc_limits lim = can_limits(cfg);

	if (socketcan_motor_set_limits(&app->can, &lim)) {
		fprintf(stderr, "omni4-fw: %s: the [model] and [limits] give no valid CAN "
			"plausibility limits\n", path);
		hal_motor_close(&(struct motor_hal){.ops = &socketcan_motor_ops, .ctx = &app->can});
		return -1;
	}
	return 0;
}

/* [hal] motor. 0 or -1 (said on stderr). */
static int open_motor(struct app *app, const struct omni4_config *cfg, const char *path,
		      struct motor_hal *motor)
{
	if (!strcmp(cfg->hal.motor, "sim")) {
		const struct sim_motor_config sc = sim_motor_config_from(cfg, &cfg->model, true);

		if (sim_motor_init(&app->sim, &sc)) {
			fprintf(stderr, "omni4-fw: %s: invalid [sim] settings\n", path);
			return -1;
		}
		*motor = sim_motor_hal(&app->sim);
		return 0;
	}
	if (!strcmp(cfg->hal.motor, "socketcan")) {
		if (open_socketcan(app, cfg, path))
			return -1;
		*motor = socketcan_motor_hal(&app->can);
		return 0;
	}
	fprintf(stderr, "omni4-fw: %s: [hal] motor = %s is not available in this build\n", path,
		cfg->hal.motor);
	return -1;
}

/* [hal] lines. 0 or -1 (said on stderr). */
static int open_lines(struct app *app, const struct omni4_config *cfg, const char *path,
		      struct line_hal *lines)
{
	*lines = (struct line_hal){.ops = &line_none_ops, .ctx = NULL};
	if (!strcmp(cfg->hal.lines, "sim")) {
		*lines = sim_line_hal(&app->sim_lines);
	} else if (!strcmp(cfg->hal.lines, "gpiod")) {
		const struct gpiod_lines_config gc = {
			.chip = cfg->gpio.chip,
			.estop_line = cfg->gpio.estop_line,
			.estop_active_low = cfg->gpio.estop_active_low,
			.enable_line = cfg->gpio.enable_line,
			.led_line = cfg->gpio.led_line,
		};
		const int rc = gpiod_lines_open(&app->gpio, &gc);

		if (rc) {
			fprintf(stderr, "omni4-fw: GPIO chip '%s': %s\n", cfg->gpio.chip,
				strerror(-rc));
			return -1;
		}
		*lines = gpiod_lines_hal(&app->gpio);
	} else if (strcmp(cfg->hal.lines, "none")) {
		fprintf(stderr, "omni4-fw: %s: [hal] lines = %s is not available in this build\n",
			path, cfg->hal.lines);
		return -1;
	}
	return 0;
}

/* The controller on its HALs, the CAN limits' hooks, the parameter service, the crash
 * handler, the simulated camera. 0 or -1 (said on stderr). */
static int set_up_controller(struct app *app, const struct omni4_config *cfg, const char *path,
			     struct motor_hal motor, struct line_hal lines)
{
	if (fw_init(&app->fw, cfg, motor, lines)) {
		fprintf(stderr, "omni4-fw: %s: invalid controller settings\n", path);
		return -1;
	}
	if (!strcmp(cfg->hal.motor, "socketcan")) {
		const struct fw_param_hooks hooks = {.check = can_limits_check,
						     .apply = can_limits_apply, .ctx = &app->can};

		fw_set_param_hooks(&app->fw, &hooks);
	}
	if (param_service_init(&app->params, &app->fw, cfg, path, (struct param_out){0})) {
		fprintf(stderr, "omni4-fw: %s: path too long\n", path);
		return -1;
	}
	g_app = app;
	install_crash_handler();
	if (!strcmp(cfg->hal.motor, "sim"))
		sim_motor_set_pose_cb(&app->sim, on_pose, &app->fw,
				      rtloop_clock_us() - app->sim.period_us);
	return 0;
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define OMNI4_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define OMNI4_SANITIZED 1
#endif
#endif
#ifndef OMNI4_SANITIZED
#define OMNI4_SANITIZED 0
#endif

/* The process before the threads start: small default stacks under mlockall, locked memory,
 * the CPU idle-state limit, SIGINT / SIGTERM. Failures here are warnings. */
static void prepare_process(const struct omni4_config *cfg)
{
	/* With mlockall every page of every thread stack is resident: threads that libraries
	 * start (LCM, glib) get a small stack too. (Only then, and not in a sanitizer build: the
	 * sanitizer runtimes need more, and ThreadSanitizer refuses such a thread outright.) */
	if (cfg->loop.mlockall && !OMNI4_SANITIZED) {
		pthread_attr_t small_stack;

		pthread_attr_init(&small_stack);
		pthread_attr_setstacksize(&small_stack, 2 * RTLOOP_STACK_BYTES);
		pthread_setattr_default_np(&small_stack);
		pthread_attr_destroy(&small_stack);
	}
	int rc;

	if (cfg->loop.mlockall && (rc = rtloop_lock_memory()))
		fprintf(stderr, "omni4-fw: warning: mlockall: %s\n", strerror(-rc));
	/* The fd is held open while the loop runs and closed at exit by the kernel. */
	if (cfg->loop.cpu_dma_latency_us >= 0) {
		const int dma_fd = rtloop_cpu_dma_latency(cfg->loop.cpu_dma_latency_us);

		if (dma_fd < 0)
			fprintf(stderr, "omni4-fw: warning: /dev/cpu_dma_latency: %s\n",
				strerror(-dma_fd));
	}
	struct sigaction sa = {.sa_handler = on_signal};

	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
}

/* Until SIGINT / SIGTERM or --duration (and the --crash-after test hook). */
static void wait_for_stop(const struct options *o)
{
	const int64_t t0 = rtloop_clock_us();

	while (!g_stop &&
	       !(o->duration_s > 0 && (rtloop_clock_us() - t0) * 1e-6 >= o->duration_s)) {
		const struct timespec nap = {.tv_sec = 0, .tv_nsec = 20000000};

		nanosleep(&nap, NULL);
		if (o->crash_after_s > 0 && (rtloop_clock_us() - t0) * 1e-6 >= o->crash_after_s)
			raise(SIGSEGV);
	}
}

static void print_summary(const struct app *app, const struct omni4_config *cfg,
			  struct lcmio *io, const struct rtloop *loop)
{
	fprintf(stderr,
		"omni4-fw: %llu ticks, %llu overruns, wake-up latency p50 %.0f us p99 %.0f us "
		"max %.0f us; published %llu, log dropped %llu, commands rejected %llu, "
		"undecodable %llu\n",
		(unsigned long long)loop->ticks, (unsigned long long)loop->overruns,
		rtloop_latency_percentile_us(loop, 50), rtloop_latency_percentile_us(loop, 99),
		loop->latency_max_ns / 1e3, (unsigned long long)atomic_load(&io->published),
		(unsigned long long)app->fw.n.log_dropped,
		(unsigned long long)app->fw.ctl.n.cmd_rejected,
		(unsigned long long)atomic_load(&io->rx_bad));
	const struct param_counters *p = &app->params.n;

	fprintf(stderr,
		"omni4-fw: params: requests %llu, applied %llu, refused %llu, denied %llu, "
		"bad %llu, busy %llu, saved %llu\n",
		(unsigned long long)atomic_load(&p->requests),
		(unsigned long long)atomic_load(&p->applied),
		(unsigned long long)atomic_load(&p->refused),
		(unsigned long long)atomic_load(&p->denied),
		(unsigned long long)atomic_load(&p->bad), (unsigned long long)atomic_load(&p->busy),
		(unsigned long long)atomic_load(&p->saved));
	if (strcmp(cfg->hal.motor, "socketcan"))
		return;
	const struct sc_counters *n = &app->can.n;

	fprintf(stderr,
		"omni4-fw: can: rx %llu tx %llu tx_dropped %llu crc_errors %llu replayed %llu "
		"lost %llu error_frames %llu bus_off %llu flood_cut %llu implausible %llu "
		"confirmed %llu\n",
		(unsigned long long)n->rx_frames, (unsigned long long)n->tx_frames,
		(unsigned long long)n->tx_dropped, (unsigned long long)n->crc_errors,
		(unsigned long long)n->replayed, (unsigned long long)n->lost,
		(unsigned long long)n->error_frames, (unsigned long long)n->bus_off,
		(unsigned long long)n->flood_cut, (unsigned long long)n->implausible,
		(unsigned long long)n->confirmed);
}

/* LCM, the parameter service, the LCM threads and the loop; runs until stopped, then stops
 * them in reverse order with the outputs off. The exit status. */
static int run(struct app *app, const struct omni4_config *cfg, const struct options *o,
	       lcm_t *lcm)
{
	struct lcmio io;
	struct rtloop loop;
	int rc;

	/* Subscribed before the receive thread starts; handled on its own thread. */
	rc = param_service_start(&app->params, lcm);
	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start the parameter service: %s\n",
			strerror(-rc));
		return 1;
	}
	rc = lcmio_start_watching(&io, lcm, &app->fw, on_calibration, (void *)&o->quiet,
				  on_foreign, app);
	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start LCM threads: %s\n", strerror(-rc));
		param_service_stop(&app->params);
		return 1;
	}
	rc = rtloop_start(&loop, cfg->loop.rate_hz, cfg->loop.sched_fifo ? cfg->loop.priority : 0,
			  0, tick, &app->fw);
	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start the loop: %s\n", strerror(-rc));
		rc = 1;
	} else {
		if (loop.warning[0])
			fprintf(stderr, "omni4-fw: warning: %s\n", loop.warning);
		if (!o->quiet)
			fprintf(stderr, "omni4-fw: running at %.0f Hz, motor=%s lines=%s lcm=%s\n",
				cfg->loop.rate_hz, cfg->hal.motor, cfg->hal.lines, cfg->lcm.url);
		wait_for_stop(o);
		rtloop_request_stop(&loop);
		rtloop_join(&loop);
	}
	fw_outputs_off(&app->fw);
	lcmio_stop(&io);
	param_service_stop(&app->params);
	if (!o->quiet || rc)
		print_summary(app, cfg, &io, &loop);
	if (atomic_load(&io.foreign)) {
		fprintf(stderr, "omni4-fw: %llu OMNI4_MOTORS samples from another controller heard "
			"on %s\n", (unsigned long long)atomic_load(&io.foreign), cfg->lcm.url);
		rc = 1;
	}
	return rc;
}

/* LCM at the configured URL, then OMNI4_MOTORS listened for PEER_LISTEN_MS: another controller
 * there means refusing to start (before any backend is opened: nothing is driven, no frame
 * reaches the other controller's bus). The lcm_t, or NULL (said on stderr). */
static lcm_t *open_lcm_alone(const struct omni4_config *cfg)
{
	lcm_t *lcm = lcm_create(cfg->lcm.url);
	int64_t seq = 0, utime = 0;

	if (!lcm) {
		fprintf(stderr, "omni4-fw: cannot open LCM at '%s'\n", cfg->lcm.url);
		return NULL;
	}
	const long heard = lcmio_listen_motors(lcm, PEER_LISTEN_MS, &seq, &utime);

	if (heard < 0) {
		fprintf(stderr, "omni4-fw: cannot receive on LCM at '%s'\n", cfg->lcm.url);
	} else if (heard > 0) {
		fprintf(stderr, "omni4-fw: another controller is publishing OMNI4_MOTORS on %s "
			"(seq %lld utime %lld heard within %d ms): refusing to start\n",
			cfg->lcm.url, (long long)seq, (long long)utime, PEER_LISTEN_MS);
	} else {
		return lcm;
	}
	lcm_destroy(lcm);
	return NULL;
}

int main(int argc, char **argv)
{
	struct options o;
	int rc = parse_options(argc, argv, &o);

	if (rc >= 0)
		return rc;

	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	if (config_load(o.config_path, &cfg, &err)) {
		fprintf(stderr, "omni4-fw: %s\n", err.msg);
		return 2;
	}

	prepare_process(&cfg); /* first: LCM may start threads of its own */
	lcm_t *lcm = open_lcm_alone(&cfg);

	if (!lcm)
		return 1;

	struct app *app = calloc(1, sizeof(*app)); /* start-up only */
	struct motor_hal motor;
	struct line_hal lines;

	if (!app) {
		fprintf(stderr, "omni4-fw: out of memory\n");
		lcm_destroy(lcm);
		return 1;
	}
	rc = 1;
	app->url = cfg.lcm.url;
	if (open_motor(app, &cfg, o.config_path, &motor))
		goto out_free;
	app->motor = motor;
	if (open_lines(app, &cfg, o.config_path, &lines))
		goto out_close_motor;
	if (set_up_controller(app, &cfg, o.config_path,
			      (struct motor_hal){.ops = &peer_guard_ops, .ctx = app}, lines) == 0)
		rc = run(app, &cfg, &o, lcm);
	if (app->fw.motor.ops)
		fw_outputs_off(&app->fw);
	hal_line_close(&lines);
out_close_motor:
	hal_motor_close(&motor);
out_free:
	free(app);
	lcm_destroy(lcm);
	return rc;
}
