/* scenarios.c - the core's HIL scenarios (see scenarios.h). */
#include "scenarios.h"
#include "scenario_adapt.h"
#include "scenario_goal.h"
#include "scenario_layouts.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "omni4/core/est.h"
#include "omni4/model/plant.h"
#include "omni4/model/rng.h"
#include "omni4/firmware/robot.h"

/* One robot (the controller on the sim backends): static (an MCU has no heap, and struct fw
 * holds rings). */
static struct robot g_robot;
static struct ctl_settings g_ctl;
static struct sim_settings g_sim_set;
static int64_t g_now_us, g_period_us, g_cmd_seq;
static scenario_print_fn g_print;
static scenario_wait_fn g_wait;
static const struct scenario_meter *g_meter;

/* Per-tick cost: the whole fw_tick, and the part spent in the HAL (the plant's step, which a
 * real board does not run), measured by wrapping the sim backend's ops. */
static struct {
	uint32_t hal, n, tick_max, ctl_max, last, last_ctl; /* the latest tick's whole cost, and
	                                                     * less the HAL's */
	uint64_t tick_sum, ctl_sum;
} g_cost;

static int metered_read(void *ctx, struct motor_sample *out)
{
	const uint32_t t0 = g_meter ? g_meter->read() : 0;
	const int rc = sim_motor_ops.read(ctx, out);

	if (g_meter)
		g_cost.hal += g_meter->read() - t0;
	return rc;
}

static int metered_write(void *ctx, const float volts[4])
{
	const uint32_t t0 = g_meter ? g_meter->read() : 0;
	const int rc = sim_motor_ops.write(ctx, volts);

	if (g_meter)
		g_cost.hal += g_meter->read() - t0;
	return rc;
}

static int metered_read_pose(void *ctx, struct hal_pose *out)
{
	const uint32_t t0 = g_meter ? g_meter->read() : 0;
	const int rc = sim_motor_ops.read_pose(ctx, out);

	if (g_meter)
		g_cost.hal += g_meter->read() - t0;
	return rc;
}

static int metered_read_truth(void *ctx, struct hal_truth *out)
{
	const uint32_t t0 = g_meter ? g_meter->read() : 0;
	const int rc = sim_motor_ops.read_truth(ctx, out);

	if (g_meter)
		g_cost.hal += g_meter->read() - t0;
	return rc;
}

/* robot_spec.wrap: the sim backend with its read, write, camera and truth metered. */
static struct motor_hal metered(void *ctx, struct motor_hal backend)
{
	static struct motor_hal_ops ops;

	(void)ctx;
	ops = *backend.ops;
	ops.read = metered_read;
	ops.write = metered_write;
	ops.read_pose = metered_read_pose;
	ops.read_truth = metered_read_truth;
	return (struct motor_hal){.ops = &ops, .ctx = backend.ctx};
}

void scenarios_set_meter(const struct scenario_meter *m)
{
	g_meter = m;
}

static void say(const char *fmt_name, bool ok, const char *figures)
{
	char line[256];

	snprintf(line, sizeof(line), "%s %s %s", fmt_name, ok ? "ok" : "FAILED", figures);
	g_print(line);
}

static int start_with(const struct scenario_layout *lay)
{
	char why[128];

	ctl_settings_defaults(&g_ctl);
	if (lay) {
		g_ctl.layout.wheels = lay->wheels;
		for (int j = 0; j < 4; j++) {
			g_ctl.layout.angle_deg[j] = lay->angle_deg[j];
			g_ctl.layout.d[j] = lay->d_m[j];
		}
		g_ctl.layout_keys = (uint8_t)((1u << lay->wheels) - 1u);
	}
	sim_settings_defaults(&g_sim_set);
	/* Exact sensors; the camera's poses go to the ring, where tick() passes over them. */
	const struct robot_spec spec = {.ctl = &g_ctl,
	                                .motor = OMNI4_MOTOR_SIM,
	                                .lines = OMNI4_LINES_SIM,
	                                .sim = &g_sim_set,
	                                .sim_exact = true,
	                                .wrap = metered};

	if (robot_open(&g_robot, &spec, why, sizeof(why)))
		return -1;
	g_period_us = (int64_t)llround(1e6 / g_ctl.rate_hz);
	g_now_us = 0;
	g_cmd_seq = 0;
	return 0;
}

static int start(void)
{
	return start_with(NULL);
}

static void send(int8_t mode, const double vel[3])
{
	struct ctl_command c = {.utime = g_now_us, .seq = g_cmd_seq++, .mode = mode};

	if (vel)
		memcpy(c.velocity, vel, sizeof(c.velocity));
	fw_post_command(&g_robot.fw, &c);
}

/* One tick; returns its motors sample (the ring may also hold a camera pose). */
static struct log_entry tick(void)
{
	struct log_entry e, last = {.kind = 0};

	if (g_wait)
		g_wait();
	g_cost.hal = 0;
	const uint32_t t0 = g_meter ? g_meter->read() : 0;

	fw_tick(&g_robot.fw, g_now_us);
	if (g_meter) {
		const uint32_t all = g_meter->read() - t0, ctl = all - g_cost.hal;

		g_cost.n++;
		g_cost.last = all;
		g_cost.last_ctl = ctl;
		g_cost.tick_sum += all;
		g_cost.ctl_sum += ctl;
		g_cost.tick_max = all > g_cost.tick_max ? all : g_cost.tick_max;
		g_cost.ctl_max = ctl > g_cost.ctl_max ? ctl : g_cost.ctl_max;
	}
	g_now_us += g_period_us;
	while (fw_pop_log(&g_robot.fw, &e))
		if (e.kind == LOG_MOTORS)
			last = e;
	return last;
}

static bool outputs_off(const struct log_entry *e)
{
	for (int j = 0; j < 4; j++)
		if (e->sample.voltage[j] != 0.0f)
			return false;
	return !g_robot.sim.enabled && !g_robot.sim_lines.enable;
}

/* Drive at vel for n ticks with a keep-alive every 50 ms; returns the last sample. */
static struct log_entry drive(const double vel[3], int n)
{
	struct log_entry e = {.kind = 0};

	for (int i = 0; i < n; i++) {
		if (i % 50 == 0)
			send(CTL_VELOCITY, vel);
		e = tick();
	}
	return e;
}

/* ---- tracking: FF + PI on a plant equal to the model, exact sensors ----------------------- */

static int tracking(void)
{
	static const double segs[2][3] = {{0.5, 0.0, 0.0}, {0.0, 0.3, 2.0}};
	static const double bound[2] = {3e-7, 1.8e-4}; /* rms of x - target [m/s, rad/s] */
	double rms[2];
	bool ok = start() == 0;

	for (int s = 0; s < 2 && ok; s++) {
		double sum = 0;
		int n = 0;

		for (int i = 0; i < 1500; i++) {
			if (i % 50 == 0)
				send(CTL_VELOCITY, segs[s]);
			tick();
			if (i >= 1000) { /* settled: the last 0.5 s of the 1.5 s hold */
				for (int k = 0; k < 3; k++) {
					const double e = g_robot.sim.plant.x[k] - segs[s][k];

					sum += e * e;
				}
				n += 3;
			}
		}
		rms[s] = sqrt(sum / n);
		/* What is left is the Q16.16 feedforward's rounding, held by the PI. Measured
		 * 9.9e-8 and 5.9e-5 (host and Cortex-M4 alike); bounds 3x. */
		ok &= rms[s] < bound[s] && g_robot.fw.ctl.mode == CTL_VELOCITY;
	}
	char fig[160];

	snprintf(fig, sizeof(fig), "rms_v=%.6e rms_vn_w=%.6e mode=%d", rms[0], rms[1],
	         (int)g_robot.fw.ctl.mode);
	say("tracking", ok, fig);
	return ok ? 0 : 1;
}

/* ---- watchdog: no command after the first one ------------------------------------------ */

static int watchdog(void)
{
	static const double v[3] = {1.0, 0.0, 0.0};
	long trip = -1, idle = -1;
	bool ok = start() == 0;

	send(CTL_VELOCITY, v);
	for (long i = 0; i < 1000 && ok; i++) {
		const struct log_entry e = tick();

		if (trip < 0 && (e.sample.faults & CTL_FAULT_CMD_TIMEOUT))
			trip = i;
		if (trip >= 0 && idle < 0 && e.sample.mode == CTL_IDLE)
			idle = i;
	}
	/* docs/faults.md: [control] cmd_timeout_ms 200 and stop_ramp_s 0.2 at 1 kHz. The command
	 * is taken at tick 0: no trip while 200 ms or less have passed (tick 200), the trip on
	 * tick 201, then the stop ramp takes 200 ticks to reach 0 V and IDLE. */
	ok &= trip == 201 && idle - trip == 200 && g_robot.fw.ctl.n.watchdog_trips == 1;
	char fig[96];

	snprintf(fig, sizeof(fig), "trip_tick=%ld idle_after=%ld", trip, idle - trip);
	say("watchdog", ok, fig);
	return ok ? 0 : 1;
}

/* ---- e-stop: outputs off on the tick the line reads pressed; clear once released ----------- */

static int estop(void)
{
	static const double v[3] = {1.0, 0.0, 0.0};
	bool ok = start() == 0;

	drive(v, 500);
	atomic_store(&g_robot.sim_lines.estop, true);
	const struct log_entry on = tick();
	const bool off_at_once =
	    on.sample.mode == CTL_ESTOP && outputs_off(&on) && (on.sample.faults & CTL_FAULT_ESTOP);

	send(CTL_CLEAR_FAULT, NULL); /* refused while pressed */
	const struct log_entry held = tick();

	atomic_store(&g_robot.sim_lines.estop, false);
	const struct log_entry released = tick(); /* still ESTOP: latched until cleared */

	send(CTL_CLEAR_FAULT, NULL);
	const struct log_entry cleared = tick();

	ok &= off_at_once && held.sample.mode == CTL_ESTOP && released.sample.mode == CTL_ESTOP &&
	      cleared.sample.mode == CTL_IDLE && outputs_off(&cleared);
	char fig[128];

	snprintf(fig, sizeof(fig), "mode_pressed=%d mode_released=%d mode_cleared=%d",
	         (int)on.sample.mode, (int)released.sample.mode, (int)cleared.sample.mode);
	say("estop", ok, fig);
	return ok ? 0 : 1;
}

/* ---- over-current: a reading above [limits] current_max_a latches FAULT on that tick ------- */

static int overcurrent(void)
{
	static const double v[3] = {1.0, 0.0, 0.0};
	bool ok = start() == 0;

	drive(v, 500);
	const struct log_entry before = tick();

	/* 0.1 A above the 5 A limit of the defaults, whatever the wheel currents are. */
	g_robot.sim.inject.current_offset_a =
	    g_ctl.limits.current_max_a + 0.1 + fabs((double)before.sample.current[0]) +
	    fabs((double)before.sample.current[1]) + fabs((double)before.sample.current[2]) +
	    fabs((double)before.sample.current[3]);
	const struct log_entry at = tick();

	g_robot.sim.inject.current_offset_a = 0;
	const struct log_entry after = tick();

	ok &= before.sample.mode == CTL_VELOCITY && at.sample.mode == CTL_FAULT &&
	      (at.sample.faults & CTL_FAULT_OVERCURRENT) && outputs_off(&at) &&
	      after.sample.mode == CTL_FAULT;
	char fig[96];

	snprintf(fig, sizeof(fig), "mode_at=%d faults_at=0x%04x", (int)at.sample.mode,
	         (unsigned)at.sample.faults);
	say("overcurrent", ok, fig);
	return ok ? 0 : 1;
}

/* ---- stuck encoder: the redundant wheel's residual finds a frozen reading ------------------ */

static int stuck_encoder(void)
{
	static const double v[3] = {1.0, 0.0, 0.0}, stop[3] = {0.0, 0.0, 0.0};
	bool ok = start() == 0;

	drive(v, 1000);
	ok &= g_robot.fw.ctl.mode == CTL_VELOCITY;
	g_robot.sim.inject.encoder_stuck[3] = true;
	int ms = 0;

	while (g_robot.fw.ctl.mode != CTL_FAULT && ms < 2000) {
		if (ms % 50 == 0)
			send(CTL_VELOCITY, stop);
		tick();
		ms++;
	}
	/* Wheel 3 frozen at 1 m/s while the robot brakes at 3 m/s^2: the residual passes 0.5 m/s
	 * after 167 ms and must persist 50 ms (217 ms, the PI can only make it sooner, never
	 * sooner than the 50 ms confirmation). */
	ok &= ms >= 50 && ms <= 217 + 10 && (g_robot.fw.ctl.latched & CTL_FAULT_ENCODER);
	char fig[96];

	snprintf(fig, sizeof(fig), "fault_after_ms=%d", ms);
	say("stuck_encoder", ok, fig);
	return ok ? 0 : 1;
}

/*
 * The estimator's cost (core/ est.h), measured on its own: not a scenario (its figures are
 * costs, left out of the host comparison). The plant drives it for EST_COST_TICKS ticks with
 * noisy wheels and a 25 Hz camera 40 ms late; est_step and est_camera (the replay from the
 * frame's tick) are metered apart.
 */
#define EST_COST_TICKS 3000
#define EST_CAM_PERIOD 40
#define EST_CAM_LATENCY 40
static struct est g_est;

/* Cycle counts of one kind of call: sum, maximum, calls. */
struct cost_meter {
	uint64_t sum;
	uint32_t max, n;
};

static void cost_add(struct cost_meter *m, uint32_t c)
{
	m->sum += c;
	m->max = c > m->max ? c : m->max;
	m->n++;
}

/* Tick i's input: the plant driven by four sines, its wheel speeds with 0.2 rad/s noise. */
static void cost_input(struct plant *pl, struct rng *g, int i, struct est_input *in)
{
	const double t = i * 1e-3;
	double u[4], w[4];

	*in = (struct est_input){.utime = (int64_t)i * 1000, .driven = true, .have_wheels = true};
	for (int j = 0; j < 4; j++)
		u[j] = 7.0 * sin(6.283185307179586 * (0.2 + 0.1 * j) * t + j);
	plant_step(pl, u, true, 1e-3);
	plant_wheel_speeds(pl, w);
	for (int j = 0; j < 4; j++) {
		in->volts[j] = (float)u[j];
		in->wheel_rad_s[j] = (float)(w[j] + rng_normal(g, 0.2));
	}
}

/* The frame of tick ci arriving at tick i (now_us): est_step of tick i ran as sequence number
 * i - 1, so the replay runs from the snapshot before the frame's tick up to it (the ticks since
 * it are re-run by the next est_steps, EST_REPLAY_PER_TICK each); *taken counts the frames the
 * filter took. */
static void cost_camera(int ci, const double pose[3], int64_t now_us, struct cost_meter *cam,
                        uint32_t *taken)
{
	const uint32_t t0 = g_meter->read();
	const int rc = est_camera(&g_est, (int64_t)ci * 1000, pose, now_us);

	cost_add(cam, g_meter->read() - t0);
	*taken += rc == 0;
}

/* step[0]: est_step alone; step[1]: est_step with a late frame's re-run under way. */
static void cost_report(const struct cost_meter step[2], const struct cost_meter *cam,
                        uint32_t taken, const struct plant *pl)
{
	const struct est_output *o = est_get(&g_est);
	char line[360];

	snprintf(
	    line, sizeof(line),
	    "estimator cost: est_step mean %lu max %lu %s over %lu ticks, with a re-run under "
	    "way (%d ticks each) mean %lu max %lu over %lu; est_camera (frame %d ms late) "
	    "mean %lu max %lu, %lu of %lu frames taken; sizeof(struct est) %lu bytes; position "
	    "error at the end %.1f mm",
	    (unsigned long)(step[0].n ? step[0].sum / step[0].n : 0), (unsigned long)step[0].max,
	    g_meter->unit, (unsigned long)step[0].n, EST_REPLAY_PER_TICK,
	    (unsigned long)(step[1].n ? step[1].sum / step[1].n : 0), (unsigned long)step[1].max,
	    (unsigned long)step[1].n, EST_CAM_LATENCY,
	    (unsigned long)(cam->n ? cam->sum / cam->n : 0), (unsigned long)cam->max,
	    (unsigned long)taken, (unsigned long)cam->n, (unsigned long)sizeof(struct est),
	    1e3 * hypot(o->pose[0] - pl->pose[0], o->pose[1] - pl->pose[1]));
	g_print(line);
}

static void estimator_cost(void)
{
	struct plant pl;
	struct rng g;
	double cam[EST_COST_TICKS / EST_CAM_PERIOD + 1][3];
	struct cost_meter step[2] = {{0}, {0}}, cam_cost = {0};
	uint32_t taken = 0;

	if (!g_meter || plant_init(&pl, &model_params_table3) ||
	    est_init(&g_est, NULL, &model_params_table3, 1000.0))
		return;
	rng_seed(&g, 1);
	for (int i = 1; i <= EST_COST_TICKS; i++) {
		struct est_input in;

		cost_input(&pl, &g, i, &in);
		const bool rerun = g_est.job.on;
		const uint32_t t0 = g_meter->read();

		est_step(&g_est, &in);
		cost_add(&step[rerun], g_meter->read() - t0);
		if (i % EST_CAM_PERIOD == 0)
			for (int k = 0; k < 3; k++)
				cam[i / EST_CAM_PERIOD][k] =
				    pl.pose[k] + rng_normal(&g, k < 2 ? 0.01 : 0.05);
		const int ci = i - EST_CAM_LATENCY; /* the tick of the frame arriving now */

		if (ci > 0 && ci % EST_CAM_PERIOD == 0)
			cost_camera(ci, cam[ci / EST_CAM_PERIOD], in.utime, &cam_cost, &taken);
	}
	cost_report(step, &cam_cost, taken, &pl);
}

/* ---- for scenarios in files of their own (scenario_goal.h) ------------------------------- */

int scenario_start(void)
{
	return start();
}

int scenario_start_layout(const struct scenario_layout *lay)
{
	return start_with(lay);
}

uint32_t scenario_tick(void)
{
	tick();
	return g_cost.last;
}

uint32_t scenario_last_ctl_cost(void)
{
	return g_cost.last_ctl;
}

struct robot *scenario_robot(void)
{
	return &g_robot;
}

int64_t scenario_now_us(void)
{
	return g_now_us;
}

void scenario_say(const char *name, bool ok, const char *figures)
{
	say(name, ok, figures);
}

const struct scenario_meter *scenario_meter(void)
{
	return g_meter;
}

void scenario_print(const char *line)
{
	g_print(line);
}

int scenarios_run(scenario_print_fn print, scenario_wait_fn wait_tick)
{
	int failed = 0;

	g_print = print;
	g_wait = wait_tick;
	memset(&g_cost, 0, sizeof(g_cost));
	failed += tracking();
	const uint32_t n = g_cost.n ? g_cost.n : 1;
	char line[200];

	if (g_meter) {
		/* Not compared between builds: a cost, not a result. */
		snprintf(line, sizeof(line),
		         "cost: whole tick mean %lu max %lu %s; controller (tick minus the sim "
		         "plant's HAL read/write) mean %lu max %lu %s, over %lu ticks",
		         (unsigned long)(g_cost.tick_sum / n), (unsigned long)g_cost.tick_max,
		         g_meter->unit, (unsigned long)(g_cost.ctl_sum / n),
		         (unsigned long)g_cost.ctl_max, g_meter->unit, (unsigned long)g_cost.n);
		print(line);
	}
	failed += watchdog();
	failed += estop();
	failed += overcurrent();
	failed += stuck_encoder();
	failed += scenario_goal();
	failed += scenario_adapt();
	failed += scenario_layouts();
	estimator_cost();
	snprintf(line, sizeof(line), "%d passed, %d failed", 9 - failed, failed);
	print(line);
	return failed;
}
