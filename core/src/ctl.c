/* ctl.c - modes, watchdog, faults, reference shaping, IK + feedforward (Q16.16) and PI. */
#include "omni4/ctl.h"

#include "omni4/kinematics.h"

#include <errno.h>
#include <math.h>
#include <string.h>


/* Bits that force MODE_FAULT and stay until a successful clear. */
#define LATCHING_FAULTS                                                                    \
	(CTL_FAULT_OVERCURRENT | CTL_FAULT_DRIVER_TIMEOUT |           \
	 CTL_FAULT_DRIVER | CTL_FAULT_BUS | CTL_FAULT_ENCODER | \
	 CTL_FAULT_CURRENT_SENSOR | CTL_FAULT_SUPPLY)

/* Rigid-body check of the redundant wheel (eqs 2-5): v0 - v1 + v2 - v3 = 0 without slip. */
#define ENCODER_RESIDUAL_MAX_M_S 0.5
#define ENCODER_BAD_TIME_S 0.05
/* No wheel can change speed faster than this (about 10x what the motors can do): a larger
 * step between two readings, over the time between them (at least one period: a late tick
 * after a stall of the loop or the bus sees a larger, real change), is an encoder jump. */
#define ENCODER_MAX_ACCEL_RAD_S2 5000.0

/* The HAL's driver-side fault bits in the controller's vocabulary. */
static int32_t from_hal_faults(uint32_t hal)
{
	return ((hal & HAL_FAULT_DRIVER_TIMEOUT) ? CTL_FAULT_DRIVER_TIMEOUT : 0) |
	       ((hal & HAL_FAULT_DRIVER) ? CTL_FAULT_DRIVER : 0) |
	       ((hal & HAL_FAULT_BUS) ? CTL_FAULT_BUS : 0);
}

int ctl_init(struct ctl *c, const struct omni4_config *cfg)
{
	memset(c, 0, sizeof(*c));
	if (!(cfg->loop.rate_hz > 0.0))
		return -EINVAL;
	if (ff_q16_init(&c->ff, &cfg->model, cfg->limits.supply_v))
		return -EINVAL;
	c->cfg = *cfg;
	c->dt = 1.0 / cfg->loop.rate_hz;
	c->inv_4d = q16_from_double(1.0 / (4.0 * cfg->model.d));
	c->mode = CTL_IDLE;
	return 0;
}

void ctl_flag(struct ctl *c, int32_t bits)
{
	c->warnings |= bits;
}

static bool all_finite(const double *v, int n)
{
	for (int i = 0; i < n; i++)
		if (!isfinite(v[i]))
			return false;
	return true;
}

static int reject(struct ctl *c, int rc)
{
	c->n.cmd_rejected++;
	c->warnings |= CTL_FAULT_CMD_REJECTED;
	return rc;
}

static bool command_in_range(const struct ctl *c, const struct ctl_command *cmd)
{
	const double lin = c->cfg.limits.vel_lin_max, rot = c->cfg.limits.vel_rot_max;
	const double u = c->cfg.limits.supply_v;

	if (!all_finite(cmd->velocity, 3) || !all_finite(cmd->voltage, 4) || !isfinite(cmd->ramp_s))
		return false;
	if (cmd->ramp_s < 0.0 || cmd->ramp_s > 60.0)
		return false;
	if (fabs(cmd->velocity[0]) > lin || fabs(cmd->velocity[1]) > lin ||
	    fabs(cmd->velocity[2]) > rot)
		return false;
	for (int j = 0; j < 4; j++)
		if (fabs(cmd->voltage[j]) > u)
			return false;
	return true;
}

static void start_ramp(struct ctl *c, const double to[4], double len_s, int64_t now_us)
{
	for (int j = 0; j < 4; j++) {
		c->ramp_from[j] = c->out[j];
		c->ramp_to[j] = to[j];
	}
	c->ramp_t0_us = now_us;
	c->ramp_len_us = (int64_t)llround(len_s * 1e6);
}

int ctl_command(struct ctl *c, const struct ctl_command *cmd, int64_t now_us)
{
	if (cmd->mode < CTL_IDLE || cmd->mode > CTL_CLEAR_FAULT || !command_in_range(c, cmd))
		return reject(c, -EINVAL);

	if (cmd->mode == CTL_CLEAR_FAULT) {
		if (c->mode == CTL_FAULT || c->mode == CTL_ESTOP) {
			/* ctl_step re-latches anything still present; clear only a gone cause. */
			if (c->warnings & CTL_FAULT_ESTOP || c->present)
				return reject(c, -EBUSY);
			c->mode = CTL_IDLE;
		}
		c->latched = 0;
		c->warnings = 0;
		c->n.cmd_accepted++;
		return 0;
	}
	if (c->mode == CTL_FAULT || c->mode == CTL_ESTOP)
		return reject(c, -EPERM);

	switch (cmd->mode) {
	case CTL_IDLE:
		c->mode = CTL_IDLE;
		c->stopping = false;
		break;
	case CTL_COAST:
		c->mode = CTL_COAST;
		c->stopping = false;
		break;
	case CTL_VELOCITY:
		if (c->mode != CTL_VELOCITY) {
			/* Bumpless start: the reference begins at the measured velocity. */
			memcpy(c->vel_ref, c->x_est, sizeof(c->vel_ref));
			memset(c->integ, 0, sizeof(c->integ));
		}
		memcpy(c->vel_target, cmd->velocity, sizeof(c->vel_target));
		c->mode = CTL_VELOCITY;
		c->stopping = false;
		break;
	case CTL_VOLTAGE: {
		/* A repeated command (keep-alive) must not restart a ramp in progress. */
		const bool same = c->mode == CTL_VOLTAGE && !c->stopping &&
				  !memcmp(c->ramp_to, cmd->voltage, sizeof(c->ramp_to));

		if (!same)
			start_ramp(c, cmd->voltage, cmd->ramp_s, now_us);
		c->mode = CTL_VOLTAGE;
		c->stopping = false;
		break;
	}
	}
	c->last_cmd_us = now_us;
	c->warnings &= ~(CTL_FAULT_CMD_TIMEOUT | CTL_FAULT_CMD_REJECTED);
	c->n.cmd_accepted++;
	return 0;
}

static int32_t check_sample(struct ctl *c, const struct motor_sample *s, int read_rc,
			    int64_t now_us)
{
	int32_t f = 0;

	if (read_rc == -EAGAIN)
		return 0; /* no new reading this tick: keep the last estimate */
	if (read_rc < 0 || !s)
		return CTL_FAULT_DRIVER_TIMEOUT;
	f |= from_hal_faults(s->faults);

	double vw[4];
	bool speeds_ok = true;

	/* Limits compared at the samples' precision (float): a reading of 10.2 A is the float
	 * nearest 10.2, which is below the double 10.2. */
	const float sensor_max = (float)c->cfg.limits.current_sensor_max_a;
	const float current_max = (float)c->cfg.limits.current_max_a;
	const double since_s = fmax(c->dt, (double)(now_us - c->last_wheel_us) * 1e-6);
	const double max_step = ENCODER_MAX_ACCEL_RAD_S2 * since_s;

	for (int j = 0; j < 4; j++) {
		const float i = s->current_a[j], w = s->wheel_rad_s[j];

		if (!isfinite(i) || fabsf(i) >= sensor_max)
			f |= CTL_FAULT_CURRENT_SENSOR; /* no reading, or at the rail */
		if (isfinite(i) && fabsf(i) > current_max)
			f |= CTL_FAULT_OVERCURRENT;
		if (!isfinite(w)) {
			f |= CTL_FAULT_ENCODER;
			speeds_ok = false;
		} else if (c->have_wheel && fabs((double)w - c->last_wheel[j]) > max_step) {
			f |= CTL_FAULT_ENCODER;
		}
		vw[j] = (double)w * c->cfg.model.r;
	}
	for (int j = 0; j < 4 && speeds_ok; j++)
		c->last_wheel[j] = s->wheel_rad_s[j];
	if (speeds_ok)
		c->last_wheel_us = now_us;
	c->have_wheel = speeds_ok;
	if (isfinite(s->supply_v) && s->supply_v < (float)c->cfg.limits.supply_min_v)
		f |= CTL_FAULT_SUPPLY;
	if (!speeds_ok)
		return f;

	fk_robot_velocity(c->cfg.model.d, vw, c->x_est);
	if (fabs(vw[0] - vw[1] + vw[2] - vw[3]) > ENCODER_RESIDUAL_MAX_M_S)
		c->encoder_bad_ticks++;
	else
		c->encoder_bad_ticks = 0;
	if (c->encoder_bad_ticks * c->dt >= ENCODER_BAD_TIME_S)
		f |= CTL_FAULT_ENCODER;
	return f;
}

static void watchdog(struct ctl *c, int64_t now_us)
{
	const bool moving = c->mode == CTL_VELOCITY || c->mode == CTL_COAST ||
			    (c->mode == CTL_VOLTAGE && !c->stopping);

	if (!moving || now_us - c->last_cmd_us <= (int64_t)c->cfg.control.cmd_timeout_ms * 1000)
		return;
	c->warnings |= CTL_FAULT_CMD_TIMEOUT;
	c->n.watchdog_trips++;
	if (c->mode == CTL_COAST) {
		c->mode = CTL_IDLE;
		return;
	}
	static const double zero[4] = {0, 0, 0, 0};

	start_ramp(c, zero, c->cfg.control.stop_ramp_s, now_us);
	c->mode = CTL_VOLTAGE;
	c->stopping = true;
}

static double clampd(double x, double lim)
{
	return x > lim ? lim : (x < -lim ? -lim : x);
}

static void voltage_mode(struct ctl *c, int64_t now_us)
{
	const double frac = c->ramp_len_us > 0
				    ? fmin(1.0, (double)(now_us - c->ramp_t0_us) / (double)c->ramp_len_us)
				    : 1.0;

	for (int j = 0; j < 4; j++)
		c->out[j] = c->ramp_from[j] + (c->ramp_to[j] - c->ramp_from[j]) * frac;
	if (c->stopping && frac >= 1.0) {
		c->mode = CTL_IDLE;
		c->stopping = false;
	}
}

static void velocity_mode(struct ctl *c, const struct motor_sample *s)
{
	const double acc_max[3] = {c->cfg.limits.acc_lin_max, c->cfg.limits.acc_lin_max,
				   c->cfg.limits.acc_rot_max};
	const double u_max = c->cfg.limits.supply_v;
	q16_t ref_q[3], acc_q[3], ff_q[4], wheel_ref_q[4];

	/* Reference shaping: rate-limit the target to the acceleration limits. */
	for (int k = 0; k < 3; k++) {
		const double step = clampd(c->vel_target[k] - c->vel_ref[k], acc_max[k] * c->dt);

		c->vel_ref[k] += step;
		c->acc_ref[k] = step / c->dt;
		ref_q[k] = q16_from_double(c->vel_ref[k]);
		acc_q[k] = q16_from_double(c->acc_ref[k]);
	}
	ik_wheel_speeds_q16(c->ff.d, ref_q, wheel_ref_q);
	if (c->cfg.control.feedforward)
		ff_voltages_q16(&c->ff, ref_q, acc_q, ff_q);
	else
		memset(ff_q, 0, sizeof(ff_q));

	for (int j = 0; j < 4; j++) {
		const double ff = q16_to_double(ff_q[j]);
		double u = ff;

		if (c->cfg.control.feedback && s) {
			const double e = q16_to_double(wheel_ref_q[j]) -
					 (double)s->wheel_rad_s[j] * c->cfg.model.r;
			const double p = c->cfg.control.kp * e;
			const double unsat = ff + p + c->integ[j];

			/* Anti-windup: integrate unless it would push further into saturation. */
			if (!(fabs(unsat) >= u_max && e * unsat > 0))
				c->integ[j] = clampd(c->integ[j] + c->cfg.control.ki * e * c->dt, u_max);
			u = ff + p + c->integ[j];
		}
		c->out[j] = clampd(u, u_max);
	}
}

void ctl_step(struct ctl *c, int64_t now_us, const struct motor_sample *sample, int read_rc,
	      bool estop, struct ctl_output *out)
{
	const int32_t now_faults = check_sample(c, sample, read_rc, now_us);
	const struct motor_sample *s = read_rc == 0 ? sample : NULL;

	c->present = now_faults;
	if (now_faults & ~c->latched)
		c->n.faults_latched++;
	c->latched |= now_faults;
	if (estop) {
		c->warnings |= CTL_FAULT_ESTOP;
		c->mode = CTL_ESTOP;
	} else {
		c->warnings &= ~CTL_FAULT_ESTOP;
		if (c->latched && c->mode != CTL_ESTOP)
			c->mode = CTL_FAULT;
	}
	watchdog(c, now_us);

	if (c->mode == CTL_VOLTAGE)
		voltage_mode(c, now_us);
	else if (c->mode == CTL_VELOCITY)
		velocity_mode(c, s);

	const bool on = c->mode == CTL_VOLTAGE || c->mode == CTL_VELOCITY;

	if (!on) {
		memset(c->out, 0, sizeof(c->out));
		memset(c->integ, 0, sizeof(c->integ));
	}
	for (int j = 0; j < 4; j++)
		out->volts[j] = (float)c->out[j];
	out->enable = on;
	out->mode = (int8_t)c->mode;
	out->faults = c->latched | c->warnings;
}
