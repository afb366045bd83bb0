/* sim_motor.c - the model/ plant behind the motor HAL, with the paper's sensor noise. */
#include "omni4/drivers/sim_motor.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define TWO_PI 6.283185307179586477

void sim_settings_defaults(struct sim_settings *s)
{
	*s = (struct sim_settings){0};
#define OMNI4_KEY(kind, section, key, field, def, ...) s->field = (def);
#include "omni4/drivers/sim_keys.def"
#undef OMNI4_KEY
}

struct sim_motor_config sim_motor_config_from(const struct sim_settings *sim, bool noise,
                                              const struct model_params *plant, double period_s,
                                              double supply_v)
{
	return (struct sim_motor_config){
	    .params = *plant,
	    .period_s = period_s,
	    .supply_v = supply_v,
	    .current_noise_a = noise ? sim->current_noise_a : 0.0,
	    .encoder_cpr = noise ? sim->encoder_cpr : 0,
	    .camera_rate_hz = sim->camera_rate_hz,
	    .camera_pos_noise_m = noise ? sim->camera_pos_noise_m : 0.0,
	    .camera_theta_noise_rad = noise ? sim->camera_theta_noise_rad : 0.0,
	    .seed = (uint64_t)sim->seed,
	    .current_offset_a = {noise ? sim->current_offset_a[0] : 0.0,
	                         noise ? sim->current_offset_a[1] : 0.0,
	                         noise ? sim->current_offset_a[2] : 0.0,
	                         noise ? sim->current_offset_a[3] : 0.0},
	    .encoder_eccentricity = noise ? sim->encoder_eccentricity : 0.0,
	    /* The floor and the camera's timing: the world's, with exact sensors too. */
	    .floor = {.traction_mu = sim->traction_mu,
	              .wheel_inertia = sim->wheel_inertia,
	              .radius_error = {sim->wheel_radius_error[0], sim->wheel_radius_error[1],
	                               sim->wheel_radius_error[2], sim->wheel_radius_error[3]},
	              .R_error = {sim->motor_R_error[0], sim->motor_R_error[1],
	                          sim->motor_R_error[2], sim->motor_R_error[3]},
	              .Kv_error = {sim->motor_Kv_error[0], sim->motor_Kv_error[1],
	                           sim->motor_Kv_error[2], sim->motor_Kv_error[3]},
	              .slip_noise = sim->slip_noise,
	              .com_height = sim->com_height},
	    .camera_latency_s = sim->camera_latency_ms * 1e-3,
	    .camera = true,
	    .truth = sim->truth,
	    .changes = {.thermal = sim->thermal,
	                .thermal_resistance_k_w = sim->thermal_resistance,
	                .thermal_capacity_j_k = sim->thermal_capacity,
	                .ambient_c = sim->ambient,
	                .battery = sim->battery,
	                .battery_capacity_ah = sim->battery_capacity,
	                .battery_resistance_ohm = sim->battery_resistance,
	                .floor_change_s = sim->floor_change_s,
	                .floor_friction_scale = sim->floor_friction_scale},
	    .drive = {.current = sim->current_drive, .R_ohm = plant->R, .Kv = plant->Kv},
	};
}

/* What an eccentric motor-shaft encoder reads, as a wheel angle: the motor turns l times the
 * wheel, and its encoder reads theta + e sin(theta - phi). */
static double eccentric_reading(const struct sim_motor *s, int j, double wheel_angle)
{
	const double l = s->cfg.params.l, theta = l * wheel_angle;

	return (theta + s->cfg.encoder_eccentricity * sin(theta - s->ecc_phase[j])) / l;
}

/* Encoder counts of a wheel angle (encoder_cpr counts per wheel revolution). */
static int64_t encoder_counts(const struct sim_motor *s, double angle)
{
	return (int64_t)floor(angle * s->cfg.encoder_cpr / TWO_PI);
}

/* The changing robot's state at start: windings at ambient, a full battery, the first floor;
 * -EINVAL for settings out of range. */
static int changes_init(struct sim_motor *s, const struct sim_changes *c)
{
	s->supply_v = s->cfg.supply_v;
	s->floor_change_us = -1;
	if (c->thermal && thermal_init(&s->thermal, c->thermal_resistance_k_w,
	                               c->thermal_capacity_j_k, c->ambient_c, s->plant.R_eff))
		return -EINVAL;
	if (c->battery && battery_init(&s->battery, s->cfg.supply_v, c->battery_capacity_ah,
	                               c->battery_resistance_ohm))
		return -EINVAL;
	if (!(c->floor_change_s >= 0.0 && c->floor_change_s <= 1e9) ||
	    !(c->floor_friction_scale >= 0.0 && isfinite(c->floor_friction_scale)))
		return -EINVAL;
	if (c->floor_change_s > 0.0)
		s->floor_change_us = (int64_t)llround(c->floor_change_s * 1e6);
	return 0;
}

int sim_motor_init(struct sim_motor *s, const struct sim_motor_config *cfg)
{
	if (!(cfg->period_s > 0.0) || !(cfg->supply_v > 0.0) || cfg->encoder_cpr < 0 ||
	    !(cfg->camera_rate_hz > 0.0) || !(cfg->current_noise_a >= 0.0) ||
	    !(cfg->camera_pos_noise_m >= 0.0) || !(cfg->camera_theta_noise_rad >= 0.0) ||
	    !(cfg->encoder_eccentricity >= 0.0 && cfg->encoder_eccentricity <= 0.1))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		if (!isfinite(cfg->current_offset_a[j]))
			return -EINVAL;
	/* The queue holds latency x rate frames, plus the one captured at the delivery tick. */
	if (!(cfg->camera_latency_s >= 0.0) ||
	    !(cfg->camera_latency_s * cfg->camera_rate_hz < SIM_CAM_QUEUE - 1))
		return -EINVAL;
	if (cfg->drive.current && !(cfg->drive.R_ohm > 0.0 && isfinite(cfg->drive.R_ohm) &&
	                            cfg->drive.Kv > 0.0 && isfinite(cfg->drive.Kv)))
		return -EINVAL;
	memset(s, 0, sizeof(*s));
	struct plant_floor floor = cfg->floor;

	/* The creep from a generator of its own: the sensor noise stream stays the same. */
	floor.seed = cfg->seed ^ 0x5851f42d4c957f2dull;
	if (plant_init(&s->plant, &cfg->params) || plant_set_floor(&s->plant, &floor) ||
	    (cfg->has_geom && plant_set_geom(&s->plant, &cfg->geom)))
		return -EINVAL;
	s->cfg = *cfg;
	if (changes_init(s, &cfg->changes))
		return -EINVAL;
	s->cam_latency_us = (int64_t)llround(cfg->camera_latency_s * 1e6);
	rng_seed(&s->rng, cfg->seed);
	s->period_us = (int64_t)llround(cfg->period_s * 1e6);
	s->cam_period_s = 1.0 / cfg->camera_rate_hz;
	s->next_cam_s = 0.0;
	/* The encoders' phases from a generator of their own (seeded from the seed), so that the
	 * noise stream is the same with and without eccentricity. */
	struct rng phases;

	rng_seed(&phases, cfg->seed ^ 0x9e3779b97f4a7c15ull);
	for (int j = 0; j < 4; j++) {
		s->ecc_phase[j] = rng_uniform(&phases, 0.0, TWO_PI);
		if (cfg->encoder_eccentricity >
		    0.0) { /* the reading at rest is where counting starts */
			s->ecc_read[j] = eccentric_reading(s, j, 0.0);
			s->counts[j] = encoder_counts(s, s->ecc_read[j]);
		}
	}
	return 0;
}

void sim_motor_set_clock(struct sim_motor *s, int64_t utime0)
{
	s->utime0 = utime0;
}

void sim_motor_plant_state(const struct sim_motor *s, struct sim_plant_state *out)
{
	out->utime = s->utime0 + s->t_us;
	/* With thermal: at the windings' temperature now (the next step's). */
	if (s->cfg.changes.thermal)
		thermal_resistance(&s->thermal, out->R_ohm);
	else
		memcpy(out->R_ohm, s->plant.R_eff, sizeof(out->R_ohm));
	for (int j = 0; j < 4; j++)
		out->winding_c[j] =
		    s->cfg.changes.thermal ? s->thermal.temp_c[j] : s->cfg.changes.ambient_c;
	out->supply_v = s->supply_v;
	out->friction_scale = s->plant.friction_scale;
}

void sim_motor_truth(const struct sim_motor *s, struct hal_truth *t)
{
	t->utime = s->utime0 + s->t_us;
	memcpy(t->pose, s->plant.pose, sizeof(t->pose));
	memcpy(t->vel, s->plant.x, sizeof(t->vel));
	plant_wheel_slip(&s->plant, t->wheel_slip);
	t->flags = plant_slip_flags(&s->plant);
	if (s->inject.blocked)
		t->flags |= SIM_TRUTH_BLOCKED;
	if (s->inject.ext_force[0] != 0.0 || s->inject.ext_force[1] != 0.0 ||
	    s->inject.ext_force[2] != 0.0)
		t->flags |= SIM_TRUTH_PUSHED;
	if (s->inject.camera_off)
		t->flags |= SIM_TRUTH_CAMERA_OFF;
}

static int sim_enable(void *ctx, bool on)
{
	struct sim_motor *s = ctx;

	s->enabled = on;
	return 0;
}

static int sim_write(void *ctx, const float volts[4])
{
	struct sim_motor *s = ctx;

	for (int j = 0; j < 4; j++) {
		if (!isfinite(volts[j]))
			return -EINVAL;
		/* The H-bridge cannot exceed its supply. */
		const double v = volts[j];

		s->volts[j] = fmax(-s->supply_v, fmin(s->supply_v, v));
	}
	return 0;
}

/* A queued frame whose latency has passed by simulated time t_us. */
static bool frame_due(const struct sim_motor *s, int64_t t_us)
{
	return s->cam_count && s->cam_q[s->cam_head].capture_us + s->cam_latency_us <= t_us;
}

static void drop_frame(struct sim_motor *s)
{
	s->cam_head = (s->cam_head + 1) % SIM_CAM_QUEUE;
	s->cam_count--;
}

/* The camera: a frame captured every camera period (the plant's pose plus noise) and queued
 * until its latency has passed (read_pose then hands it out with its capture time). A frame
 * due at the previous read and not taken is lost; while camera_off nothing is captured and
 * what falls due is lost. */
static void camera(struct sim_motor *s, double t_s)
{
	while (frame_due(s, s->t_us - s->period_us))
		drop_frame(s);
	if (t_s + 1e-9 >= s->next_cam_s) {
		s->next_cam_s += s->cam_period_s;
		if (s->cfg.camera && !s->inject.camera_off) {
			if (s->cam_count == SIM_CAM_QUEUE) {
				s->cam_lost++;
			} else {
				struct sim_cam_frame *f =
				    &s->cam_q[(s->cam_head + s->cam_count) % SIM_CAM_QUEUE];

				f->capture_us = s->t_us;
				f->pose[0] = s->plant.pose[0] +
				             rng_normal(&s->rng, s->cfg.camera_pos_noise_m);
				f->pose[1] = s->plant.pose[1] +
				             rng_normal(&s->rng, s->cfg.camera_pos_noise_m);
				f->pose[2] = s->plant.pose[2] +
				             rng_normal(&s->rng, s->cfg.camera_theta_noise_rad);
				s->cam_count++;
			}
		}
	}
	while (s->inject.camera_off && frame_due(s, s->t_us))
		drop_frame(s);
}

static int sim_read_pose(void *ctx, struct hal_pose *out)
{
	struct sim_motor *s = ctx;

	if (!frame_due(s, s->t_us))
		return -EAGAIN;
	const struct sim_cam_frame *f = &s->cam_q[s->cam_head];

	out->utime = s->utime0 + f->capture_us;
	memcpy(out->pose, f->pose, sizeof(out->pose));
	drop_frame(s);
	return 0;
}

static int sim_read_truth(void *ctx, struct hal_truth *out)
{
	struct sim_motor *s = ctx;

	if (!s->truth_due)
		return -EAGAIN;
	s->truth_due = false;
	sim_motor_truth(s, out);
	return 0;
}

/* Wheel j's speed as its encoder reports it after the tick [rad/s]: the true speed w, or the
 * difference of two quantised (and, with eccentricity, motor-shaft) readings over the period. */
static double encoder_speed(struct sim_motor *s, int j, double w)
{
	const int cpr = s->cfg.encoder_cpr;
	const double dt = s->cfg.period_s;
	double speed = w;

	if (s->cfg.encoder_eccentricity > 0.0) {
		/* The motor-shaft encoder's reading, quantised (or exact with cpr 0). */
		const double read = eccentric_reading(s, j, s->wheel_angle[j]);

		if (cpr > 0) {
			const int64_t c = encoder_counts(s, read);

			speed = (double)(c - s->counts[j]) * TWO_PI / cpr / dt;
			s->counts[j] = c;
		} else {
			speed = (read - s->ecc_read[j]) / dt;
		}
		s->ecc_read[j] = read;
	} else if (cpr > 0) {
		const int64_t c = encoder_counts(s, s->wheel_angle[j]);

		speed = (double)(c - s->counts[j]) * TWO_PI / cpr / dt;
		s->counts[j] = c;
	}
	return speed;
}

/* The robot as it is at the start of the step: the floor from its change on, each winding's
 * resistance at its temperature. */
static void changes_before_step(struct sim_motor *s)
{
	if (s->floor_change_us >= 0 && s->t_us >= s->floor_change_us) {
		plant_set_friction_scale(&s->plant, s->cfg.changes.floor_friction_scale);
		s->floor_change_us = -1;
	}
	if (s->cfg.changes.thermal) {
		double R[4];

		thermal_resistance(&s->thermal, R);
		plant_set_resistance(&s->plant, R);
	}
}

/* The windings' heating and the battery's discharge over the step just taken (its currents
 * held). */
static void changes_after_step(struct sim_motor *s, double dt)
{
	if (s->cfg.changes.thermal)
		thermal_step(&s->thermal, s->plant.current_a, dt);
	if (s->cfg.changes.battery) {
		double p = 0.0;

		for (int j = 0; j < 4; j++)
			p += s->plant.voltage_v[j] * s->plant.current_a[j];
		battery_step(&s->battery, p, dt);
		s->supply_v = s->battery.v_supply;
	}
}

/* A current drive's step: the currents it commands for the voltages written (eq 21 solved for
 * i with the model's R and Kv at the last reported wheel speeds), held by its current loop over
 * the step; their wheel forces (each motor's own Kt and radius, eqs 12-13, 9-11) push the
 * body with the bridges off (no back-EMF braking). The plant's currents are then theirs, its
 * voltages what the windings took at the step's end (R_j i_j + Kv_j l w_j). */
static void current_drive_step(struct sim_motor *s, double dt)
{
	struct plant *pl = &s->plant;
	const double l = s->cfg.params.l;
	struct model_params drive = s->cfg.params; /* the model's R and Kv: the drive's */
	double i[4], f[4], body[3], w[4];

	drive.Kv = s->cfg.drive.Kv;
	drive.R = s->cfg.drive.R_ohm;
	for (int j = 0; j < 4; j++) {
		i[j] = s->enabled ? motor_current(&drive, s->volts[j], l * s->last_speed[j]) : 0.0;
		f[j] = l * pl->Kt_eff[j] * i[j] / pl->r_eff[j];
	}
	dyn_robot_forces(s->cfg.params.d, f, body);
	for (int k = 0; k < 3; k++)
		pl->ext_force[k] += body[k];
	plant_step(pl, s->volts, false, dt);
	plant_wheel_speeds(pl, w);
	for (int j = 0; j < 4; j++) {
		pl->current_a[j] = i[j];
		pl->voltage_v[j] = pl->R_eff[j] * i[j] + pl->Kv_eff[j] * l * w[j];
	}
	pl->driven = s->enabled;
}

static int sim_read(void *ctx, struct motor_sample *out)
{
	struct sim_motor *s = ctx;
	const double dt = s->cfg.period_s;
	double w_before[4], w_after[4];

	plant_wheel_speeds(&s->plant, w_before);
	memcpy(s->plant.ext_force, s->inject.ext_force, sizeof(s->plant.ext_force));
	s->plant.blocked = s->inject.blocked;
	changes_before_step(s);
	if (s->cfg.drive.current)
		current_drive_step(s, dt);
	else
		plant_step(&s->plant, s->volts, s->enabled, dt);
	changes_after_step(s, dt);
	plant_wheel_speeds(&s->plant, w_after);
	s->t_us += s->period_us;
	s->truth_due = s->cfg.truth;
	camera(s, (double)s->t_us * 1e-6);

	if (s->inject.silent)
		return -ETIMEDOUT;

	for (int j = 0; j < 4; j++) {
		s->wheel_angle[j] +=
		    0.5 * dt * (w_before[j] + w_after[j]) + s->inject.encoder_jump_rad;
		const double speed = encoder_speed(s, j, w_after[j]);

		out->wheel_rad_s[j] = s->inject.encoder_stuck[j] ? s->last_speed[j] : (float)speed;
		s->last_speed[j] = out->wheel_rad_s[j];

		double i =
		    s->plant.current_a[j] + s->cfg.current_offset_a[j] + s->inject.current_offset_a;

		if (s->enabled)
			i += rng_normal(&s->rng, s->cfg.current_noise_a);
		if (s->inject.current_clip_a > 0.0)
			i = fmax(-s->inject.current_clip_a, fmin(s->inject.current_clip_a, i));
		out->current_a[j] = (float)i;
	}
	s->inject.encoder_jump_rad = 0.0;
	out->supply_v = (float)(s->inject.supply_v > 0.0 ? s->inject.supply_v : s->supply_v);
	out->faults = s->inject.driver_faults;
	return 0;
}

void sim_motor_advance(struct sim_motor *s, int n)
{
	struct motor_sample discarded;

	for (int k = 0; k < n; k++)
		(void)sim_read(s, &discarded);
}

static int sim_clear_faults(void *ctx)
{
	struct sim_motor *s = ctx;

	s->inject.driver_faults = 0;
	return 0;
}

static void sim_close(void *ctx)
{
	struct sim_motor *s = ctx;

	s->enabled = false;
	memset(s->volts, 0, sizeof(s->volts));
}

const struct motor_hal_ops sim_motor_ops = {
    .enable = sim_enable,
    .write = sim_write,
    .read = sim_read,
    .clear_faults = sim_clear_faults,
    .read_pose = sim_read_pose,
    .read_truth = sim_read_truth,
    .close = sim_close,
};

static int sim_read_estop(void *ctx, bool *active)
{
	struct sim_lines *l = ctx;

	*active = atomic_load(&l->estop);
	return 0;
}

static int sim_set_enable(void *ctx, bool on)
{
	((struct sim_lines *)ctx)->enable = on;
	return 0;
}

static int sim_set_led(void *ctx, bool on)
{
	((struct sim_lines *)ctx)->led = on;
	return 0;
}

const struct line_hal_ops sim_line_ops = {
    .read_estop = sim_read_estop,
    .set_enable = sim_set_enable,
    .set_led = sim_set_led,
    .close = NULL,
};
