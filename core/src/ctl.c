/* ctl.c - modes, watchdog, faults, reference shaping, IK + feedforward (Q16.16) and PI; the
 * tick in single precision and Q16.16 (ctl.h). */
#include "omni4/core/ctl.h"

#include "omni4/model/kinematics.h"

#include <errno.h>
#include <math.h>
#include <string.h>

/* Rigid-body check of the redundant wheel (eqs 2-5): the rims' share along the layout's null
 * vector (the paper's: v0 - v1 + v2 - v3) is 0 without slip. Three wheels have no redundant
 * one: a stuck or jumping encoder is caught by the step check below alone (and the estimator's
 * model check sees the wheel disagree with the motion the voltages drive). */
#define ENCODER_RESIDUAL_MAX_M_S 0.5f
#define ENCODER_BAD_TIME_S 0.05
/* No wheel can change speed faster than this (about 10x what the motors can do): a larger
 * step between two readings, over the time between them (at least one period: a late tick
 * after a stall of the loop or the bus sees a larger, real change), is an encoder jump. */
#define ENCODER_MAX_ACCEL_RAD_S2 5000.0f

/* The HAL's driver-side fault bits in the controller's vocabulary. */
static int32_t from_hal_faults(uint32_t hal)
{
	return ((hal & HAL_FAULT_DRIVER_TIMEOUT) ? CTL_FAULT_DRIVER_TIMEOUT : 0) |
	       ((hal & HAL_FAULT_DRIVER) ? CTL_FAULT_DRIVER : 0) |
	       ((hal & HAL_FAULT_BUS) ? CTL_FAULT_BUS : 0);
}

/* The layout for model/'s prepares: NULL for the paper's (their closed forms). */
static const struct wheel_geom *layout_geom(const struct ctl_layout *L)
{
	return L->paper ? NULL : &L->geom;
}

/* The layout of cfg (checked at the door), off the loop. */
static int layout_prepare(struct ctl_layout *L, const struct ctl_settings *cfg)
{
	const struct wheel_geom *g;
	struct wheel_phys ph;
	double nv[4];

	memset(L, 0, sizeof(*L));
	if (ctl_settings_layout(cfg, &L->geom, &g))
		return -EINVAL;
	L->paper = g == NULL;
	if (L->paper)
		wheel_geom_paper(cfg->model.d, &L->geom);
	if (kin_rows_q16_init(&L->kin, cfg->model.d, g) || wheel_phys_layout(&ph, &L->geom))
		return -EINVAL;
	L->wheels = ph.n;
	wheel_null(&ph, nv);
	for (int j = 0; j < 4; j++)
		L->null_m[j] = (float)nv[j];
	return 0;
}

static void tune(struct ctl *c)
{
	const struct ctl_settings *cfg = &c->set;
	const double dt = 1.0 / cfg->rate_hz;
	const float acc_max[3] = {(float)cfg->limits.acc_lin_max, (float)cfg->limits.acc_lin_max,
	                          (float)cfg->limits.acc_rot_max};
	struct model_wheels w;

	ctl_settings_wheels(cfg, &w);

	c->t = (struct ctl_tuning){
	    .dt = (float)dt,
	    .r = {(float)w.r[0], (float)w.r[1], (float)w.r[2], (float)w.r[3]},
	    .u_max = (float)cfg->limits.supply_v,
	    /* Limits compared at the samples' precision (float): a reading of 10.2 A is the
	     * float nearest 10.2, which is below the double 10.2. */
	    .current_max = (float)cfg->limits.current_max_a,
	    .sensor_max = (float)cfg->limits.current_sensor_max_a,
	    .supply_min = (float)cfg->limits.supply_min_v,
	    .cmd_timeout_us = (int64_t)cfg->control.cmd_timeout_ms * 1000,
	    .stop_ramp_s = (float)cfg->control.stop_ramp_s,
	    .feedforward = cfg->control.feedforward,
	    .feedback = cfg->control.feedback,
	    .vel_lin_max = cfg->limits.vel_lin_max,
	    .vel_rot_max = cfg->limits.vel_rot_max,
	    .supply_v = cfg->limits.supply_v,
	    .encoder_bad_ticks_max = (int)ceil(ENCODER_BAD_TIME_S / dt - 1e-9),
	};
	for (int j = 0; j < 4; j++)
		ctl_pi_set_gains(&c->pi[j], (float)cfg->control.kp, (float)cfg->control.ki, c->t.dt,
		                 c->t.u_max);
	const struct ctl_shaper keep = c->shaper;

	ctl_shaper_init(&c->shaper, acc_max, c->t.dt);
	traction_set(&c->trac, &cfg->model, &w, layout_geom(&c->lay), cfg->limits.traction_mu,
	             cfg->limits.traction_margin, cfg->limits.com_height, c->t.dt);
	memcpy(c->shaper.ref, keep.ref, sizeof(keep.ref));
	memcpy(c->shaper.acc, keep.acc, sizeof(keep.acc));
}

int ctl_init(struct ctl *c, const struct ctl_settings *cfg)
{
	int bad;
	const char *why;

	memset(c, 0, sizeof(*c));
	traction_reset(&c->trac);
	if (ctl_settings_check(cfg, &bad, &why))
		return -EINVAL;
	return ctl_init_checked(c, cfg);
}

int ctl_init_checked(struct ctl *c, const struct ctl_settings *cfg)
{
	struct model_wheels w;

	memset(c, 0, sizeof(*c));
	traction_reset(&c->trac);
	ctl_settings_wheels(cfg, &w);
	if (layout_prepare(&c->lay, cfg))
		return -EINVAL;
	const struct wheel_geom *g = layout_geom(&c->lay);

	if (ff_q16_wheels_prepare_layout(&c->ff, &cfg->model, &w, g, cfg->limits.supply_v) ||
	    ff_wheels_per_ohm_prepare_layout(&c->ff_ohm, &cfg->model, &w, g))
		return -EINVAL;
	c->ff_ohm_use = c->ff_ohm;
	for (int j = 0; j < 4; j++)
		c->R_use[j] = (float)w.R[j];
	c->set = *cfg;
	c->period_us = llround(1e6 / cfg->rate_hz);
	tune(c);
	ctl_ramp_reset(&c->ramp, c->out); /* outputs at 0 V, no ramp in progress */
	c->mode = CTL_IDLE;
	static const struct ctl_cal_cfg cal = {
	    .samples = CTL_CAL_SAMPLES,
	    .settle_us = CTL_CAL_SETTLE_US,
	    .limit_a = CTL_CAL_LIMIT_A,
	    .change_min_a = CTL_CAL_CHANGE_MIN_A,
	    .change_sigmas = CTL_CAL_CHANGE_SIGMAS,
	};

	ctl_cal_init(&c->cal, &cal);
	c->enabled_prev = false; /* the adapter starts with the outputs off */
	return 0;
}

void ctl_retune(struct ctl *c, const struct ctl_settings *cfg, const struct ff_q16_wheels *ff,
                const struct ff_wheels_per_ohm *ff_ohm, const struct ctl_layout *lay)
{
	c->set = *cfg;
	c->ff = *ff;
	c->ff_ohm = *ff_ohm;
	c->ff_ohm_use = *ff_ohm;
	c->lay = *lay;
	tune(c);
	struct model_wheels w;

	ctl_settings_wheels(cfg, &w);
	for (int j = 0; j < 4; j++)
		c->R_use[j] = (float)w.R[j];
}

void ctl_set_resistance(struct ctl *c, int j, float R_ohm)
{
	c->R_use[j] = R_ohm;
	ff_q16_wheels_set_resistance(&c->ff, &c->ff_ohm_use, j, R_ohm);
}

/* value / the settings' (1 where the settings' is 0: a zero gain stays 0) */
static float ratio(float value, double settings)
{
	return settings > 0.0 ? value / (float)settings : 1.0f;
}

void ctl_set_friction(struct ctl *c, const float B[3], const float C[3])
{
	const struct model_params *p = &c->set.model;
	/* the settings' gains are linear in B and C: scaled by the values over the settings' */
	const float sb[3] = {ratio(B[0], p->Bv), ratio(B[1], p->Bvn), ratio(B[2], p->Bw)};
	const float sc[3] = {ratio(C[0], p->Cv), ratio(C[1], p->Cvn), ratio(C[2], p->Cw)};

	for (int j = 0; j < 4; j++) {
		for (int k = 0; k < 3; k++) {
			c->ff_ohm_use.vel[j][k] = sb[k] * c->ff_ohm.vel[j][k];
			c->ff_ohm_use.coul[j][k] = sc[k] * c->ff_ohm.coul[j][k];
		}
		ff_q16_wheels_set_resistance(&c->ff, &c->ff_ohm_use, j, c->R_use[j]);
	}
	memcpy(c->trac.B, B, sizeof(c->trac.B));
	memcpy(c->trac.C, C, sizeof(c->trac.C));
}

void ctl_set_slip(struct ctl *c, bool slipping)
{
	c->slipping = slipping;
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
	const double lin = c->t.vel_lin_max, rot = c->t.vel_rot_max;
	const double u = c->t.supply_v;

	if (!all_finite(cmd->velocity, 3) || !all_finite(cmd->voltage, 4) || !isfinite(cmd->ramp_s))
		return false;
	if (cmd->ramp_s < 0.0 || cmd->ramp_s > 60.0)
		return false;
	if (fabs(cmd->velocity[0]) > lin || fabs(cmd->velocity[1]) > lin ||
	    fabs(cmd->velocity[2]) > rot)
		return false;
	for (int j = 0; j < 4; j++)
		if (fabs(cmd->voltage[j]) > u || (j >= c->lay.wheels && cmd->voltage[j] != 0.0))
			return false; /* (a three-wheel robot has no motor in slot 3) */
	return true;
}

int ctl_command(struct ctl *c, const struct ctl_command *cmd, int64_t now_us)
{
	if (!mode_commandable(cmd->mode) || !command_in_range(c, cmd))
		return reject(c, -EINVAL);

	if (cmd->mode == CTL_CLEAR_FAULT) {
		if (mode_faulted(c->mode)) {
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
	if (mode_faulted(c->mode))
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
		if (c->mode != CTL_VELOCITY && c->mode != CTL_GOAL) {
			/* Bumpless start: the reference begins at the measured velocity. */
			ctl_shaper_reset(&c->shaper, c->x_est);
			for (int j = 0; j < 4; j++)
				ctl_pi_reset(&c->pi[j]);
		}
		for (int k = 0; k < 3; k++)
			c->vel_target[k] = (float)cmd->velocity[k];
		c->mode = CTL_VELOCITY;
		c->stopping = false;
		break;
	case CTL_VOLTAGE: {
		const float to[4] = {(float)cmd->voltage[0], (float)cmd->voltage[1],
		                     (float)cmd->voltage[2], (float)cmd->voltage[3]};
		/* A repeated command (keep-alive) must not restart a ramp in progress. */
		const bool same =
		    c->mode == CTL_VOLTAGE && !c->stopping && !memcmp(c->ramp.to, to, sizeof(to));

		if (!same)
			ctl_ramp_start(&c->ramp, c->out, to, (float)cmd->ramp_s, now_us);
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

/* s: the raw reading; cur: its currents minus the offsets in force. */
static int32_t check_sample(struct ctl *c, const struct motor_sample *s, const float cur[4],
                            int read_rc, int64_t now_us)
{
	int32_t f = 0;

	if (read_rc == -EAGAIN)
		return c->reading_faults; /* no new reading: its conditions still stand */
	if (read_rc < 0 || !s)
		return CTL_FAULT_DRIVER_TIMEOUT;
	f |= from_hal_faults(s->faults);

	float vw[4] = {0, 0, 0, 0}, res = 0.0f;
	bool speeds_ok = true;
	const float since_s = fmaxf(c->t.dt, (float)(now_us - c->last_wheel_us) * 1e-6f);
	const float max_step = ENCODER_MAX_ACCEL_RAD_S2 * since_s;

	for (int j = 0; j < c->lay.wheels; j++) {
		const float raw = s->current_a[j], i = cur[j], w = s->wheel_rad_s[j];

		if (!isfinite(raw) || fabsf(raw) >= c->t.sensor_max)
			f |= CTL_FAULT_CURRENT_SENSOR; /* no reading, or the sensor at its rail */
		if (isfinite(i) && fabsf(i) > c->t.current_max)
			f |= CTL_FAULT_OVERCURRENT;
		if (!isfinite(w)) {
			f |= CTL_FAULT_ENCODER;
			speeds_ok = false;
		} else if (c->have_wheel && fabsf(w - c->last_wheel[j]) > max_step) {
			f |= CTL_FAULT_ENCODER;
		}
		vw[j] = w * c->t.r[j]; /* rim speed: wheel j's own radius */
	}
	for (int j = 0; j < c->lay.wheels && speeds_ok; j++)
		c->last_wheel[j] = s->wheel_rad_s[j];
	if (speeds_ok)
		c->last_wheel_us = now_us;
	c->have_wheel = speeds_ok;
	if (isfinite(s->supply_v) && s->supply_v < c->t.supply_min)
		f |= CTL_FAULT_SUPPLY;
	if (!speeds_ok)
		return f;

	/* Robot velocity (eqs 3-5) in Q16.16, as the model's fixed-point path computes it. */
	q16_t vq[4], xq[3];

	for (int j = 0; j < 4; j++)
		vq[j] = q16_from_float(vw[j]);
	fk_rows_q16(&c->lay.kin, vq, xq);
	for (int k = 0; k < 3; k++)
		c->x_est[k] = q16_to_float(xq[k]);
	for (int j = 0; j < 4; j++) /* (the paper's: v0 - v1 + v2 - v3, the same bits) */
		res += c->lay.null_m[j] * vw[j];
	if (fabsf(res) > ENCODER_RESIDUAL_MAX_M_S)
		c->encoder_bad_ticks++;
	else
		c->encoder_bad_ticks = 0;
	if (c->encoder_bad_ticks >= c->t.encoder_bad_ticks_max)
		f |= CTL_FAULT_ENCODER;
	return f;
}

/* The stop ramp: from the present outputs to 0 V over stop_ramp_s, then IDLE. */
static void stop_ramp(struct ctl *c, int64_t now_us)
{
	static const float zero[4] = {0, 0, 0, 0};

	ctl_ramp_start(&c->ramp, c->out, zero, c->t.stop_ramp_s, now_us);
	c->mode = CTL_VOLTAGE;
	c->stopping = true;
}

static void watchdog(struct ctl *c, int64_t now_us)
{
	/* stopping: the watchdog's own stop ramp already runs */
	const bool moving = mode_keep_alive(c->mode) && !c->stopping;

	if (!moving || now_us - c->last_cmd_us <= c->t.cmd_timeout_us)
		return;
	c->warnings |= CTL_FAULT_CMD_TIMEOUT;
	c->n.watchdog_trips++;
	if (c->mode == CTL_COAST) {
		c->mode = CTL_IDLE;
		return;
	}
	stop_ramp(c, now_us);
}

int ctl_goal(struct ctl *c, int64_t now_us)
{
	if (c->mode == CTL_FAULT || c->mode == CTL_ESTOP)
		return -EPERM;
	if (c->mode != CTL_GOAL && c->mode != CTL_VELOCITY) {
		ctl_shaper_reset(&c->shaper, c->x_est);
		for (int j = 0; j < 4; j++)
			ctl_pi_reset(&c->pi[j]);
	}
	if (c->mode != CTL_GOAL) {
		memcpy(c->goal_vel, c->shaper.ref, sizeof(c->goal_vel));
		memset(c->goal_acc, 0, sizeof(c->goal_acc));
	}
	c->mode = CTL_GOAL;
	c->stopping = false;
	c->last_cmd_us = now_us;
	c->warnings &= ~(CTL_FAULT_CMD_TIMEOUT | CTL_FAULT_CMD_REJECTED);
	c->n.cmd_accepted++;
	return 0;
}

void ctl_goal_keep(struct ctl *c, int64_t now_us)
{
	if (c->mode == CTL_GOAL)
		c->last_cmd_us = now_us;
}

void ctl_goal_reference(struct ctl *c, const float vel[3], const float acc[3])
{
	memcpy(c->goal_vel, vel, sizeof(c->goal_vel));
	memcpy(c->goal_acc, acc, sizeof(c->goal_acc));
}

void ctl_stop(struct ctl *c, int64_t now_us)
{
	if (c->mode == CTL_VELOCITY || c->mode == CTL_GOAL)
		stop_ramp(c, now_us);
}

static void voltage_mode(struct ctl *c, int64_t now_us)
{
	const bool done = ctl_ramp_step(&c->ramp, now_us, c->out);

	if (c->stopping && done) {
		c->mode = CTL_IDLE;
		c->stopping = false;
	}
}

/* VELOCITY and GOAL: feedforward + PI on the reference in c->shaper (ref, acc). */
/* The outputs' bound this tick [V]: [limits] supply_v, or the supply the drives measure when it
 * is lower (a sagging battery: what the bridges can give), so the PI's anti-windup stops where
 * the bridges saturate. A reading that is not a positive number is not taken. */
static float output_bound(const struct ctl *c, const struct motor_sample *s)
{
	return s && s->supply_v > 0.0f && s->supply_v < c->t.u_max ? s->supply_v : c->t.u_max;
}

static void track(struct ctl *c, const struct motor_sample *s)
{
	q16_t ref_q[3], acc_q[3], ff_q[4], wheel_ref_q[4];

	for (int k = 0; k < 3; k++) {
		ref_q[k] = q16_from_float(c->shaper.ref[k]);
		acc_q[k] = q16_from_float(c->shaper.acc[k]);
	}
	ik_rows_q16(&c->lay.kin, ref_q, wheel_ref_q);
	/* Per-wheel feedforward (each drive's own R_j r_j / (l Kt_j) and Kv_j l / r_j, prepared
	 * at init / retune). Scaling and overflow: ref and acc in Q16.16 from the shaper's floats
	 * (within the command limits, far inside the format's +-32768); wheel j sums two axis terms
	 * of three rounded Q16.16 products in int64_t (below 2^48, no overflow for any input); the
	 * one saturation is the final clamp to +-u_max. Equal wheels: ff_voltages_q16's bits. */
	if (c->t.feedforward)
		ff_voltages_q16_wheels(&c->ff, ref_q, acc_q, ff_q);
	else
		memset(ff_q, 0, sizeof(ff_q));

	float integ[4]; /* the PI integrals before this tick (the traction limit's anti-windup) */
	const float lim = output_bound(c, s);

	c->tracked = s != NULL;
	c->track_e2 = 0.0f;
	for (int j = 0; j < 4; j++) {
		if (j >= c->lay.wheels) { /* no motor in slot 3 */
			c->out[j] = 0.0f;
			continue;
		}
		const float ff = q16_to_float(ff_q[j]);
		const float e =
		    s ? q16_to_float(wheel_ref_q[j]) - s->wheel_rad_s[j] * c->t.r[j] : 0.0f;

		c->track_e2 += e * e;
		integ[j] = c->pi[j].integ;
		c->pi[j].limit = lim;
		if (c->t.feedback && s) {
			c->out[j] = ctl_pi_step(&c->pi[j], ff, e);
		} else {
			c->out[j] = ff > lim ? lim : (ff < -lim ? -lim : ff);
		}
	}
	if (s) { /* the traction limit on each wheel's force: no integration on a tick it cut */
		float rim[4], taken[4];

		for (int j = 0; j < 4; j++)
			rim[j] = s->wheel_rad_s[j] * c->t.r[j];
		traction_clamp_volts(&c->trac, c->shaper.ref, c->shaper.acc, rim, c->out, taken);
		for (int j = 0; j < 4; j++)
			if (taken[j] != 0.0f)
				c->pi[j].integ = integ[j];
	}
}

static void velocity_mode(struct ctl *c, const struct motor_sample *s)
{
	float prev[3];

	memcpy(prev, c->shaper.ref, sizeof(prev));
	ctl_shaper_step(&c->shaper, c->vel_target);
	traction_step(&c->trac, prev, c->shaper.ref, c->shaper.acc, c->slipping);
	track(c, s);
}

/* GOAL: the goal's reference replaces the shaper's (so VELOCITY starts from it). */
static void goal_mode(struct ctl *c, const struct motor_sample *s)
{
	memcpy(c->shaper.ref, c->goal_vel, sizeof(c->goal_vel));
	memcpy(c->shaper.acc, c->goal_acc, sizeof(c->goal_acc));
	track(c, s);
}

/* A reading the offset calibration may take: complete, finite, off the rail, no driver-side
 * fault. */
static bool cal_reading_ok(const struct ctl *c, const struct motor_sample *s)
{
	if (s->faults)
		return false;
	for (int j = 0; j < c->lay.wheels; j++)
		if (!isfinite(s->current_a[j]) || fabsf(s->current_a[j]) >= c->t.sensor_max)
			return false;
	return true;
}

/* The offset calibration's step on this tick's reading, then the reading's currents minus the
 * offsets in force (NaN without a reading). */
static void calibrate(struct ctl *c, int64_t now_us, const struct motor_sample *sample, int read_rc,
                      float cur[4])
{
	const bool off = !c->enabled_prev;

	if (read_rc == 0 && sample && cal_reading_ok(c, sample)) {
		ctl_cal_step(&c->cal, now_us, off, sample->current_a);
	} else {
		ctl_cal_step(&c->cal, now_us, off, NULL);
		if (read_rc != -EAGAIN)
			ctl_cal_restart(&c->cal); /* a lost or untrustworthy reading */
	}
	for (int j = 0; j < 4; j++)
		cur[j] = sample ? sample->current_a[j] - c->cal.offset[j] : NAN;
}

/* The last check before the motor HAL: a driven output that is not finite, or beyond the
 * supply the clamps hold it to, latches OUTPUT (FAULT, 0 V, bridges off) instead of being
 * written. Whatever produced it (a model the door let through, a bug), no NaN reaches a motor. */
static void output_guard(struct ctl *c)
{
	if (!mode_drives(c->mode))
		return;
	for (int j = 0; j < 4; j++) {
		if (isfinite(c->out[j]) && fabsf(c->out[j]) <= c->t.u_max)
			continue;
		if (!(c->latched & CTL_FAULT_OUTPUT))
			c->n.faults_latched++;
		c->latched |= CTL_FAULT_OUTPUT;
		c->mode = CTL_FAULT;
		c->stopping = false;
		return;
	}
}

void ctl_step(struct ctl *c, int64_t now_us, const struct motor_sample *sample, int read_rc,
              bool estop, struct ctl_output *out)
{
	float cur[4];

	calibrate(c, now_us, sample, read_rc, cur);
	c->tracked = false;

	c->reading_faults = check_sample(c, sample, cur, read_rc, now_us);
	const int32_t now_faults =
	    c->reading_faults | (c->cal.fault_mask ? CTL_FAULT_CURRENT_SENSOR : 0);
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
	else if (c->mode == CTL_GOAL)
		goal_mode(c, s);

	output_guard(c);
	const bool on = mode_drives(c->mode);

	if (!on) {
		memset(c->out, 0, sizeof(c->out));
		for (int j = 0; j < 4; j++)
			ctl_pi_reset(&c->pi[j]);
	}
	memcpy(out->volts, c->out, sizeof(out->volts));
	memcpy(out->current, cur, sizeof(out->current));
	out->enable = on;
	out->mode = (int8_t)c->mode;
	out->faults = c->latched | c->warnings;
	c->enabled_prev = on;
}
