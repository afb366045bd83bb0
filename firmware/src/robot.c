/* robot.c - a robot built from its settings (robot.h): one table per HAL maps the backend enums
 * onto the code that opens them. */
#include "omni4/robot.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

/* ---- motor backends ----------------------------------------------------------------------- */

static int open_sim_motor(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct ctl_settings *c = spec->ctl;
	const struct sim_motor_config sc = sim_motor_config_from(
	    spec->sim, !spec->sim_exact, spec->plant ? spec->plant : &c->model, 1.0 / c->rate_hz,
	    c->limits.supply_v);

	if (sim_motor_init(&r->sim, &sc)) {
		snprintf(why, n, "invalid [sim] settings");
		return -1;
	}
	r->motor = sim_motor_hal(&r->sim);
	return 0;
}

#ifdef OMNI4_ROBOT_LINUX
#include "omni4/can_limits.h"

/* Parameter thread: the CAN plausibility limits that new settings would give must be valid. */
static int can_limits_check(void *ctx, const struct ctl_settings *s, char *why, size_t n)
{
	struct socketcan_motor probe; /* set_limits only validates and copies the limits */
	const struct sc_limits lim = can_limits_for(s);

	(void)ctx;
	if (socketcan_motor_set_limits(&probe, &lim)) {
		snprintf(why, n, "the [model] and [limits] give no valid CAN plausibility limits");
		return -EINVAL;
	}
	return 0;
}

/* Loop thread, between two ticks: the limits follow the settings now in force. */
static void can_limits_apply(void *ctx, const struct ctl_settings *s)
{
	const struct sc_limits lim = can_limits_for(s);

	socketcan_motor_set_limits(ctx, &lim); /* checked by can_limits_check */
}

/* The bus must carry the protocol (its worst-case share at this loop rate at most half of the
 * bit rate), the interface must open, the plausibility limits must follow from the settings. */
static int open_socketcan(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct socketcan_settings *cs = spec->can;
	const double load = can_bus_load_1khz(cs->bitrate) * spec->ctl->rate_hz / 1000.0;

	if (load > 0.5) {
		snprintf(
		    why, n,
		    "[can] bitrate %d bit/s is too slow for [loop] rate_hz %g: the motor-driver "
		    "protocol would take %.0f %% of the bus (at most 50 %%)",
		    cs->bitrate, spec->ctl->rate_hz, 100.0 * load);
		return -1;
	}
	if (can_limits_check(NULL, spec->ctl, why, n))
		return -1;
	const struct sc_limits lim = can_limits_for(spec->ctl);
	const int rc = socketcan_motor_open(&r->can, cs->iface, cs->status_timeout_ms, &lim);

	if (rc) {
		char text[256];

		snprintf(why, n, "CAN interface '%s': %s", cs->iface,
		         sc_os_strerror(rc, text, sizeof(text)));
		return -1;
	}
	r->motor = socketcan_motor_hal(&r->can);
	return 0;
}
#endif

static const struct {
	enum omni4_motor_backend kind;
	int (*open)(struct robot *r, const struct robot_spec *spec, char *why, size_t n);
} motor_backends[] = {
    {OMNI4_MOTOR_SIM, open_sim_motor},
#ifdef OMNI4_ROBOT_LINUX
    {OMNI4_MOTOR_SOCKETCAN, open_socketcan},
#endif
};

static int open_motor(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	for (size_t i = 0; i < sizeof(motor_backends) / sizeof(motor_backends[0]); i++)
		if (motor_backends[i].kind == spec->motor)
			return motor_backends[i].open(r, spec, why, n);
	snprintf(why, n, "[hal] motor backend %d is not available in this build", spec->motor);
	return -1;
}

/* ---- line backends ------------------------------------------------------------------------ */

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

#ifdef OMNI4_ROBOT_LINUX
static int open_gpiod_lines(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const int rc = gpiod_lines_open(&r->gpio, spec->gpio);

	if (rc) {
		snprintf(why, n, "GPIO chip '%s': %s", spec->gpio->chip, strerror(-rc));
		return -1;
	}
	r->lines = gpiod_lines_hal(&r->gpio);
	return 0;
}
#endif

static const struct {
	enum omni4_lines_backend kind;
	int (*open)(struct robot *r, const struct robot_spec *spec, char *why, size_t n);
} line_backends[] = {
    {OMNI4_LINES_NONE, open_no_lines},
    {OMNI4_LINES_SIM, open_sim_lines},
#ifdef OMNI4_ROBOT_LINUX
    {OMNI4_LINES_GPIOD, open_gpiod_lines},
#endif
};

static int open_lines(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	for (size_t i = 0; i < sizeof(line_backends) / sizeof(line_backends[0]); i++)
		if (line_backends[i].kind == spec->lines)
			return line_backends[i].open(r, spec, why, n);
	snprintf(why, n, "[hal] lines backend %d is not available in this build", spec->lines);
	return -1;
}

/* ---- the robot ---------------------------------------------------------------------------- */

/* The controller on the opened backends, with the backend's hooks; the sim backend's clock
 * (its camera poses and truth, which the loop polls) on the controller's. */
static int start_controller(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct motor_hal motor = spec->wrap ? spec->wrap(spec->wrap_ctx, r->motor) : r->motor;

	if (fw_init(&r->fw, spec->ctl, motor, r->lines)) {
		snprintf(why, n, "invalid controller settings");
		return -1;
	}
#ifdef OMNI4_ROBOT_LINUX
	if (spec->motor == OMNI4_MOTOR_SOCKETCAN) {
		const struct fw_param_hooks hooks = {
		    .check = can_limits_check, .apply = can_limits_apply, .ctx = &r->can};

		fw_set_param_hooks(&r->fw, &hooks);
	}
#endif
	if (spec->motor == OMNI4_MOTOR_SIM)
		sim_motor_set_clock(&r->sim, spec->utime0 - r->sim.period_us);
	return 0;
}

void robot_sim_follow_clock(struct robot *r, int64_t now_us)
{
	if (r->motor_kind != OMNI4_MOTOR_SIM)
		return;
	/* the periods the plant lags the clock: this tick's read makes one more */
	const int64_t lag = (now_us - r->sim.utime0 - r->sim.t_us) / r->sim.period_us - 1;

	if (lag > 0 && lag <= ROBOT_SIM_CATCH_UP_MAX)
		sim_motor_advance(&r->sim, (int)lag);
	sim_motor_set_clock(&r->sim, now_us - r->sim.t_us - r->sim.period_us);
}

int robot_open(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	memset(r, 0, sizeof(*r));
	r->motor_kind = spec->motor;
	if (open_motor(r, spec, why, n))
		return -1;
	if (open_lines(r, spec, why, n)) {
		hal_motor_close(&r->motor);
		return -1;
	}
	if (start_controller(r, spec, why, n)) {
		hal_line_close(&r->lines);
		hal_motor_close(&r->motor);
		return -1;
	}
	return 0;
}

void robot_close(struct robot *r)
{
	if (r->fw.motor.ops)
		fw_outputs_off(&r->fw);
	hal_line_close(&r->lines);
	hal_motor_close(&r->motor);
}
