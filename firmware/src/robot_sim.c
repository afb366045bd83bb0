/* robot_sim.c - the portable backends as the robot opens them (robot.h): the simulated plant,
 * the simulated lines, no lines. */
#include "omni4/firmware/robot.h"

#include <stdio.h>

/* ---- motor: sim ---------------------------------------------------------------------------- */

static int open_sim_motor(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct ctl_settings *c = spec->ctl;
	struct sim_motor_config sc = sim_motor_config_from(spec->sim, !spec->sim_exact,
	                                                   spec->plant ? spec->plant : &c->model,
	                                                   1.0 / c->rate_hz, c->limits.supply_v);

	/* A current drive turns voltages into currents with the controller's model. */
	sc.drive.R_ohm = c->model.R;
	sc.drive.Kv = c->model.Kv;
	/* The simulated robot's wheels where the controller's settings put them. */
	const struct wheel_geom *g;

	if (ctl_settings_layout(c, &sc.geom, &g)) {
		snprintf(why, n,
		         "[model] wheels, wheel_angle_j, d_j: not a layout that drives the body");
		return -1;
	}
	sc.has_geom = g != NULL;

	if (sim_motor_init(&r->sim, &sc)) {
		snprintf(why, n, "invalid [sim] settings");
		return -1;
	}
	r->motor = sim_motor_hal(&r->sim);
	return 0;
}

/* The sim backend's clock (its camera poses and truth, which the loop polls) on the
 * controller's. */
static void sim_started(struct robot *r, const struct robot_spec *spec)
{
	sim_motor_set_clock(&r->sim, spec->utime0 - r->sim.period_us);
}

static void sim_follow_clock(struct robot *r, int64_t now_us)
{
	/* the periods the plant lags the clock: this tick's read makes one more */
	const int64_t lag = (now_us - r->sim.utime0 - r->sim.t_us) / r->sim.period_us - 1;

	if (lag > 0 && lag <= ROBOT_SIM_CATCH_UP_MAX)
		sim_motor_advance(&r->sim, (int)lag);
	sim_motor_set_clock(&r->sim, now_us - r->sim.t_us - r->sim.period_us);
}

const struct robot_backend robot_backend_sim = {
    .open = open_sim_motor, .started = sim_started, .follow_clock = sim_follow_clock};

/* ---- lines: none, sim ---------------------------------------------------------------------- */

static int open_no_lines(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	(void)spec, (void)why, (void)n;
	r->lines = (struct line_hal){.ops = &line_none_ops, .ctx = NULL};
	return 0;
}

static int open_sim_lines(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	(void)spec, (void)why, (void)n;
	r->lines = sim_line_hal(&r->sim_lines);
	return 0;
}

const struct robot_backend robot_backend_no_lines = {.open = open_no_lines};
const struct robot_backend robot_backend_sim_lines = {.open = open_sim_lines};
