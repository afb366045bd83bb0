/*
 * sim_motor.h - the "sim" backend of the motor and line HALs: the model/ plant behind the HAL
 * with the sensors of the paper's set-up (noisy currents, quantised encoders, a 25 Hz camera
 * with 1 cm / 3 deg noise). Each read() advances the plant by one loop period with the
 * voltages last written, so the loop and the plant run in lockstep whatever the wall clock.
 * Sensor faults a robot's INI may ask for ([sim], off by default): a constant offset per
 * current channel (also with the bridges off) and an eccentric encoder on each motor shaft
 * (motor angle = l x wheel angle, read as theta + e sin(theta - phi_j), phases from the seed:
 * a once-per-motor-turn speed ripple of relative amplitude e).
 */
#ifndef OMNI4_SIM_MOTOR_H
#define OMNI4_SIM_MOTOR_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/hal.h"
#include "omni4/params.h"
#include "omni4/plant.h"
#include "omni4/rng.h"
#include "omni4/sim_settings.h"

struct sim_motor_config {
	struct model_params params;
	double period_s;               /* loop period: plant step per read() [s] */
	double supply_v;               /* [V] */
	double current_noise_a;        /* std dev [A] */
	int encoder_cpr;               /* counts per wheel revolution; 0 = exact speeds */
	double camera_rate_hz;
	double camera_pos_noise_m;     /* std dev [m] */
	double camera_theta_noise_rad; /* std dev [rad] */
	uint64_t seed;
	double current_offset_a[4];    /* added to each channel's current readings [A] */
	double encoder_eccentricity;   /* e of the motor-shaft encoders, in [0, 0.1]; 0 = none */
};

/* Faults a test can inject (all off after init). */
struct sim_motor_faults {
	bool silent;              /* read() returns -ETIMEDOUT: the driver stopped answering */
	bool encoder_stuck[4];    /* that wheel's speed reading freezes at its last value */
	double encoder_jump_rad;  /* added once to every wheel angle at the next read, then cleared */
	double current_clip_a;    /* > 0: currents saturate at this magnitude (sensor range) */
	double current_offset_a;  /* added to every current reading */
	double supply_v;          /* > 0: overrides the supply reading (sag) */
	uint32_t driver_faults;   /* reported in motor_sample.faults */
};

typedef void (*sim_pose_cb)(void *user, int64_t utime, const double pose[3]);

struct sim_motor {
	struct sim_motor_config cfg;
	struct plant plant;
	struct rng rng;
	struct sim_motor_faults inject;
	double volts[4];
	bool enabled;
	double wheel_angle[4];  /* true wheel angle [rad] */
	int64_t counts[4];      /* encoder counts at the last read */
	double ecc_phase[4];    /* phi_j of the eccentric encoders [rad] */
	double ecc_read[4];     /* their last reading as a wheel angle [rad] (encoder_cpr 0) */
	float last_speed[4];    /* last reported wheel speeds [rad/s] */
	int64_t t_us;           /* simulated time since start [us] */
	int64_t period_us;
	double cam_period_s;
	double next_cam_s;
	sim_pose_cb on_pose;
	void *on_pose_user;
	int64_t utime0;         /* added to t_us in pose timestamps */
};

extern const struct motor_hal_ops sim_motor_ops;
extern const struct line_hal_ops sim_line_ops;

/* The [sim] settings (sensor noise and faults, or exact sensors when noise is false; the camera
 * rate and the seed either way) with `plant` as the simulated robot, stepped every period_s
 * from a supply of supply_v. */
struct sim_motor_config sim_motor_config_from(const struct sim_settings *sim, bool noise,
					      const struct model_params *plant, double period_s,
					      double supply_v);

/* -EINVAL for invalid parameters or settings. */
int sim_motor_init(struct sim_motor *s, const struct sim_motor_config *cfg);

static inline struct motor_hal sim_motor_hal(struct sim_motor *s)
{
	return (struct motor_hal){.ops = &sim_motor_ops, .ctx = s};
}

/* Camera samples are handed to cb (from inside read(), i.e. in the loop's context). */
void sim_motor_set_pose_cb(struct sim_motor *s, sim_pose_cb cb, void *user, int64_t utime0);

/* The sim line backend: an e-stop a test can press. */
struct sim_lines {
	atomic_bool estop; /* may be pressed from another thread */
	bool enable;
	bool led;
};

static inline struct line_hal sim_line_hal(struct sim_lines *l)
{
	return (struct line_hal){.ops = &sim_line_ops, .ctx = l};
}

#endif /* OMNI4_SIM_MOTOR_H */
