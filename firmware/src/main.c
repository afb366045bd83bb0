/*
 * omni4-fw - the robot controller: fixed-rate loop on the configured HAL backends, commands
 * from OMNI4_CMD, one OMNI4_MOTORS per tick. Outputs are switched off on every exit path.
 */
#include <errno.h>
#include <malloc.h>
#include <getopt.h>
#include <lcm/lcm.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/config/config.h"
#include "omni4/base/getopt_exact.h"
#include "omni4/firmware/lcmio.h"
#include "omni4/firmware/param_service.h"
#include "omni4/firmware/peer.h"
#include "omni4/firmware/robot.h"
#include "omni4/firmware/rtloop.h"
#include "omni4/version.h"

static volatile sig_atomic_t g_stop;

struct app {
	struct robot robot;
	struct peer_guard guard;
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

/* SIGSEGV/SIGABRT/...: switch the outputs off (the HAL writes are plain syscalls; the motor
 * backend's halt op makes its off command the last one even while the loop thread, still
 * running, is in a write), then let the signal kill the process as it would have
 * (SA_RESETHAND restored the default action). */
static void on_crash(int sig)
{
	if (g_app)
		fw_emergency_off(&g_app->robot.fw);
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

/* Logger thread: the feedforward's R_j changed online ([adapt]; also on OMNI4_PARAM_CHANGED):
 * a revert is always said, an acceptance unless --quiet. */
static void on_adapt_change(bool quiet, const struct log_entry *e)
{
	const struct log_adapt *a = &e->adapt;
	const bool reverted = a->flags & ADAPT_FLAG_REVERTED;

	if (quiet && !reverted)
		return;
	fprintf(stderr,
	        "omni4-fw: adapt: R %.4f %.4f %.4f %.4f ohm %s at tick %lld (was %.4f %.4f %.4f "
	        "%.4f)%s\n",
	        (double)a->R[0], (double)a->R[1], (double)a->R[2], (double)a->R[3],
	        reverted ? "put back" : "accepted", (long long)e->seq, (double)a->R_before[0],
	        (double)a->R_before[1], (double)a->R_before[2], (double)a->R_before[3],
	        reverted ? ": the tracking worsened after the last acceptance" : "");
}

/* Logger thread: a new set of current-sense offsets (it also goes out on
 * OMNI4_PARAM_CHANGED); a channel beyond the limit is always said, the rest unless --quiet.
 * The controller's [adapt] changes come through the same log kind's callback. */
static void on_calibration(void *ctx, const struct log_entry *e)
{
	const bool quiet = *(const int *)ctx;
	const struct log_calibration *c = &e->cal;

	if (e->kind == LOG_ADAPT_CHANGE) {
		on_adapt_change(quiet, e);
		return;
	}
	const float *a = c->offset;

	if (c->over_limit) {
		char ch[8];

		lcmio_fault_channels(c->over_limit, ch);
		for (int j = 0; j < 4; j++)
			if (c->over_limit & (1u << j))
				fprintf(
				    stderr,
				    "omni4-fw: FAULT_CURRENT_SENSOR: channel %d: current offset "
				    "%.6f A beyond the %.2f A limit (bridges off, mean of %u "
				    "readings, tick %lld)\n",
				    j, (double)a[j], (double)CTL_CAL_LIMIT_A, (unsigned)c->samples,
				    (long long)e->seq);
		fprintf(stderr,
		        "omni4-fw: current sensor fault on channel%s %s: the controller stays "
		        "in FAULT until a calibration within the limit and MODE_CLEAR_FAULT\n",
		        strchr(ch, ',') ? "s" : "", ch);
		return;
	}
	if (!quiet)
		fprintf(stderr,
		        "omni4-fw: current offsets %.6f %.6f %.6f %.6f A subtracted from tick %lld "
		        "on (bridges off, mean of %u readings)\n",
		        (double)a[0], (double)a[1], (double)a[2], (double)a[3], (long long)e->seq,
		        (unsigned)c->samples);
}

static void tick(void *ctx, int64_t now_us)
{
	struct robot *r = ctx;

	robot_sim_follow_clock(r, now_us);
	fw_tick(&r->fw, now_us);
}

struct options {
	const char *config_path;
	double duration_s; /* 0: until SIGINT / SIGTERM */
	int quiet;
};

/* -1 to go on, else the exit status (0 for --help, 2 for a usage error). */
static int parse_options(int argc, char **argv, struct options *o)
{
	static const struct option opts[] = {
	    {"config", required_argument, NULL, 'c'}, {"duration", required_argument, NULL, 'd'},
	    {"quiet", no_argument, NULL, 'q'},        {"help", no_argument, NULL, 'h'},
	    {"version", no_argument, NULL, 'V'},      {NULL, 0, NULL, 0},
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

/* The robot of cfg behind the peer guard, and its parameter service. 0 or -1 (said on
 * stderr). */
static int build(struct app *app, const struct omni4_config *cfg, const char *path)
{
	const struct robot_spec spec = {
	    .ctl = &cfg->ctl,
	    .motor = (enum omni4_motor_backend)cfg->fw.motor,
	    .lines = (enum omni4_lines_backend)cfg->fw.lines,
#define SPEC_SETTINGS(member, settings) .member = &cfg->member,
	    OMNI4_BACKEND_SETTINGS(SPEC_SETTINGS)
#undef SPEC_SETTINGS
	        .utime0 = rtloop_clock_us(),
	    .wrap = peer_guard_wrap,
	    .wrap_ctx = &app->guard,
	};
	char why[256];

	app->guard.url = cfg->fw.lcm_url;
	if (robot_open(&app->robot, &spec, why, sizeof(why))) {
		fprintf(stderr, "omni4-fw: %s: %s\n", path, why);
		return -1;
	}
	if (param_service_init(&app->params, &app->robot.fw, cfg, path, (struct param_out){0})) {
		fprintf(stderr, "omni4-fw: %s: path too long\n", path);
		robot_close(&app->robot);
		return -1;
	}
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
	if (cfg->fw.loop.mlockall && !OMNI4_SANITIZED) {
		pthread_attr_t small_stack;

		/* One malloc arena for every thread: each further one is 132 kB made resident by
		 * mlockall, for threads that allocate next to nothing. */
		mallopt(M_ARENA_MAX, 1);

		pthread_attr_init(&small_stack);
		pthread_attr_setstacksize(&small_stack, 2 * RTLOOP_STACK_BYTES);
		pthread_setattr_default_np(&small_stack);
		pthread_attr_destroy(&small_stack);
	}
	int rc;

	if (cfg->fw.loop.mlockall && (rc = rtloop_lock_memory()))
		fprintf(stderr, "omni4-fw: warning: mlockall: %s\n", strerror(-rc));
	/* The fd is held open while the loop runs and closed at exit by the kernel. */
	if (cfg->fw.loop.cpu_dma_latency_us >= 0) {
		const int dma_fd = rtloop_cpu_dma_latency(cfg->fw.loop.cpu_dma_latency_us);

		if (dma_fd < 0)
			fprintf(stderr, "omni4-fw: warning: /dev/cpu_dma_latency: %s\n",
			        strerror(-dma_fd));
	}
	struct sigaction sa = {.sa_handler = on_signal};

	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
}

/* Until SIGINT / SIGTERM or --duration, doing the work beside the loop (a goal's plan,
 * fw_background) within a millisecond of the tick asking for it. */
static void wait_for_stop(struct fw *fw, const struct options *o)
{
	const int64_t t0 = rtloop_clock_us();

	while (!g_stop &&
	       !(o->duration_s > 0 && (rtloop_clock_us() - t0) * 1e-6 >= o->duration_s)) {
		const struct timespec nap = {.tv_sec = 0, .tv_nsec = 1000000};

		if (!fw_background(fw))
			nanosleep(&nap, NULL);
	}
}

static void print_summary(const struct app *app, struct lcmio *io, const struct rtloop *loop)
{
	const struct fw *fw = &app->robot.fw;
	const struct param_counters *p = &app->params.n;

	fprintf(stderr,
	        "omni4-fw: %llu ticks, %llu overruns, wake-up latency p50 %.0f us p99 %.0f us "
	        "max %.0f us; published %llu, log dropped %llu, commands rejected %llu, "
	        "undecodable %llu\n",
	        (unsigned long long)loop->ticks, (unsigned long long)loop->overruns,
	        rtloop_latency_percentile_us(loop, 50), rtloop_latency_percentile_us(loop, 99),
	        loop->latency_max_ns / 1e3, (unsigned long long)atomic_load(&io->published),
	        (unsigned long long)fw->n.log_dropped, (unsigned long long)fw->ctl.n.cmd_rejected,
	        (unsigned long long)atomic_load(&io->rx_bad));
	fprintf(stderr,
	        "omni4-fw: params: requests %llu, applied %llu, refused %llu, denied %llu, "
	        "bad %llu, busy %llu, saved %llu\n",
	        (unsigned long long)atomic_load(&p->requests),
	        (unsigned long long)atomic_load(&p->applied),
	        (unsigned long long)atomic_load(&p->refused),
	        (unsigned long long)atomic_load(&p->denied),
	        (unsigned long long)atomic_load(&p->bad), (unsigned long long)atomic_load(&p->busy),
	        (unsigned long long)atomic_load(&p->saved));
	robot_summary(&app->robot);
}

/* "motor=sim lines=sim lcm=URL": the backends by their INI names. */
static void describe(const struct omni4_config *cfg, char *buf, size_t n)
{
	char motor[32] = "?", lines[32] = "?";

	config_key_format(cfg, config_key_find("hal.motor"), motor, sizeof(motor));
	config_key_format(cfg, config_key_find("hal.lines"), lines, sizeof(lines));
	snprintf(buf, n, "motor=%s lines=%s lcm=%s", motor, lines, cfg->fw.lcm_url);
}

/* The loop from start to stop (SIGINT / SIGTERM, --duration). 0 or 1 (said on stderr). */
static int run_loop(struct app *app, const struct omni4_config *cfg, const struct options *o,
                    struct rtloop *loop)
{
	const struct fw_settings *f = &cfg->fw;
	const int rc =
	    rtloop_start(loop, cfg->ctl.rate_hz, f->loop.sched_fifo ? f->loop.priority : 0, 0, tick,
	                 &app->robot);
	char what[256];

	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start the loop: %s\n", strerror(-rc));
		return 1;
	}
	if (loop->warning[0])
		fprintf(stderr, "omni4-fw: warning: %s\n", loop->warning);
	describe(cfg, what, sizeof(what));
	if (!o->quiet)
		fprintf(stderr, "omni4-fw: running at %.0f Hz, %s\n", cfg->ctl.rate_hz, what);
	wait_for_stop(&app->robot.fw, o);
	rtloop_request_stop(loop);
	rtloop_join(loop);
	return 0;
}

/* The parameter service, the LCM threads and the loop; runs until stopped, then stops them in
 * reverse order with the outputs off. The exit status. */
static int run(struct app *app, const struct omni4_config *cfg, const struct options *o, lcm_t *lcm)
{
	struct lcmio io;
	struct rtloop loop = {0};
	int rc;

	/* Subscribed before the receive thread starts; handled on its own thread. */
	rc = param_service_start(&app->params, lcm);
	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start the parameter service: %s\n",
		        strerror(-rc));
		return 1;
	}
	rc = lcmio_start_watching(&io, lcm, &app->robot.fw, on_calibration, (void *)&o->quiet,
	                          peer_on_foreign, &app->guard);
	if (rc) {
		fprintf(stderr, "omni4-fw: cannot start LCM threads: %s\n", strerror(-rc));
		param_service_stop(&app->params);
		return 1;
	}
	/* a backend without a camera of its own: the poses come over the bus */
	if (!app->robot.motor.ops->read_pose && lcmio_take_camera(&io))
		fprintf(stderr, "omni4-fw: warning: cannot subscribe to OMNI4_POSE: the estimate "
		                "runs on the wheels and the model alone\n");
	rc = run_loop(app, cfg, o, &loop);
	fw_outputs_off(&app->robot.fw);
	lcmio_stop(&io);
	param_service_stop(&app->params);
	if (!o->quiet || rc)
		print_summary(app, &io, &loop);
	if (atomic_load(&io.foreign)) {
		fprintf(stderr,
		        "omni4-fw: %llu OMNI4_MOTORS samples from another controller heard "
		        "on %s\n",
		        (unsigned long long)atomic_load(&io.foreign), cfg->fw.lcm_url);
		rc = 1;
	}
	return rc;
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
	lcm_t *lcm = peer_open_lcm_alone(cfg.fw.lcm_url);

	if (!lcm)
		return 1;

	struct app *app = calloc(1, sizeof(*app)); /* start-up only */

	if (!app) {
		fprintf(stderr, "omni4-fw: out of memory\n");
		lcm_destroy(lcm);
		return 1;
	}
	rc = 1;
	if (build(app, &cfg, o.config_path) == 0) {
		g_app = app;
		install_crash_handler();
		rc = run(app, &cfg, &o, lcm);
		robot_close(&app->robot);
	}
	free(app);
	lcm_destroy(lcm);
	return rc;
}
