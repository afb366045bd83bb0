/*
 * sim_motor.h - the "sim" backend of the motor and line HALs: the model/ plant behind the HAL
 * with the sensors of the paper's set-up (noisy currents, quantised encoders, a 25 Hz camera
 * with 1 cm / 3 deg noise and 40 ms latency). Each read() advances the plant by one loop period
 * with the voltages last written, so the loop and the plant run in lockstep whatever the wall
 * clock. Sensor faults a robot's INI may ask for ([sim], off by default): a constant offset per
 * current channel (also with the bridges off) and an eccentric encoder on each motor shaft
 * (motor angle = l x wheel angle, read as theta + e sin(theta - phi_j), phases from the seed:
 * a once-per-motor-turn speed ripple of relative amplitude e).
 * The floor ([sim] traction_mu, wheel_inertia, wheel_radius_error_0..3, motor_R_error_0..3,
 * motor_Kv_error_0..3, slip_noise; plant.h)
 * is the plant's, with the wheel speed readings following the wheels' own speeds, and applies
 * with exact sensors too. The camera's latency ([sim] camera_latency_ms) likewise: a pose is
 * delivered that much after its capture, stamped with the capture time, through a fixed queue
 * of SIM_CAM_QUEUE frames (latency x rate must stay below SIM_CAM_QUEUE - 1).
 * The camera's poses and the plant's true state after each read are the HAL's optional
 * read_pose / read_truth ops (hal.h), which the loop polls: the backend calls nothing above it.
 * A robot that changes as it runs ([sim] thermal, battery, floor_change_s; struct sim_changes,
 * all off by default and then without effect to the last bit): each winding's resistance
 * follows its temperature (model/thermal.h), the bridges' supply is a battery's
 * (model/battery.h: the write clamp and the supply reading follow it), and the body's friction
 * changes at a set time (plant_set_friction_scale). sim_motor_plant_state reports them.
 * A current drive ([sim] current_drive, off by default; struct sim_drive): the written voltages
 * are the controller's model voltages, turned into the currents the drive commands with the
 * model's R and Kv at the last reported wheel speeds (eq 21 solved for i, as the ODrive and VESC
 * current backends do, drive_consts.h); an ideal current loop holds each winding at its current
 * over the period, whatever the plant's own R and back-EMF, and the current readings are those
 * currents with the sensor noise. The wheels' forces l Kt_j i_j / r_j (each motor's own Kt and
 * radius) push the body with the bridges' back-EMF braking gone; the traction limit does not
 * see them (the wheels grip).
 */
#ifndef OMNI4_SIM_MOTOR_H
#define OMNI4_SIM_MOTOR_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/hal.h"
#include "omni4/model/battery.h"
#include "omni4/model/params.h"
#include "omni4/model/plant.h"
#include "omni4/model/rng.h"
#include "omni4/model/thermal.h"
#include "omni4/drivers/sim_settings.h"

/* A robot that changes as it runs ([sim] keys of the same names). */
struct sim_changes {
	bool thermal;                  /* windings heat: R_j(T_j) */
	double thermal_resistance_k_w; /* winding to ambient [K/W] */
	double thermal_capacity_j_k;   /* [J/K] */
	double ambient_c;              /* [deg C] */
	bool battery;                  /* the supply is a battery's, from supply_v when full */
	double battery_capacity_ah;    /* [Ah] */
	double battery_resistance_ohm; /* [ohm] */
	double floor_change_s;         /* simulated time of the floor change [s]; 0 = never */
	double floor_friction_scale;   /* the body's B and C times this from then on */
};

/* A current drive: the model constants it turns voltages into currents with. */
struct sim_drive {
	bool current; /* false: a voltage drive (H-bridges), the plant's own eq 21 */
	double R_ohm; /* the model's motor + bridge resistance [ohm] */
	double Kv;    /* the model's motor constant [V s/rad] */
};

struct sim_motor_config {
	struct model_params params;
	double period_s;        /* loop period: plant step per read() [s] */
	double supply_v;        /* [V] */
	double current_noise_a; /* std dev [A] */
	int encoder_cpr;        /* counts per wheel revolution; 0 = exact speeds */
	double camera_rate_hz;
	double camera_pos_noise_m;     /* std dev [m] */
	double camera_theta_noise_rad; /* std dev [rad] */
	uint64_t seed;
	double current_offset_a[4];  /* added to each channel's current readings [A] */
	double encoder_eccentricity; /* e of the motor-shaft encoders, in [0, 0.1]; 0 = none */
	struct plant_floor floor;    /* traction limit, radius errors, creep (seed: ignored) */
	double camera_latency_s;     /* capture -> delivery [s] */
	bool camera;                 /* a camera (read_pose); false: none, no frame captured */
	bool truth;                  /* the true state after each read (read_truth) */
	struct sim_changes changes;
	struct sim_drive drive;
	/* The wheels' layout (plant_set_geom; model/wheels.h): has_geom false: the paper's four at
	 * params.d. A three-wheel robot's slot 3 reads 0 A, 0 rad/s. */
	bool has_geom;
	struct wheel_geom geom;
};

#define SIM_CAM_QUEUE 32 /* camera frames in flight */

/* Faults a test can inject (all off after init). */
struct sim_motor_faults {
	bool silent;           /* read() returns -ETIMEDOUT: the driver stopped answering */
	bool encoder_stuck[4]; /* that wheel's speed reading freezes at its last value */
	double
	    encoder_jump_rad;  /* added once to every wheel angle at the next read, then cleared */
	double current_clip_a; /* > 0: currents saturate at this magnitude (sensor range) */
	double current_offset_a; /* added to every current reading */
	double supply_v;         /* > 0: overrides the supply reading (sag) */
	uint32_t driver_faults;  /* reported in motor_sample.faults */
	/* The world (plant.h), held while set */
	double ext_force[3]; /* on the body [Fv N, Fvn N, T N m] (a push, a collision) */
	bool blocked;        /* body held at rest; the motors keep pushing (stall or slip) */
	bool camera_off;     /* no frames captured nor delivered (a dropout) */
};

/* hal_truth.flags of the sim backend (sim_truth_t). */
#define SIM_TRUTH_SLIP_MASK 0x0fu /* bit j: wheel j slips (beyond the traction limit) */
#define SIM_TRUTH_BLOCKED 0x10u   /* the body is held (sim_motor_faults.blocked) */
#define SIM_TRUTH_PUSHED 0x20u    /* an external force acts (sim_motor_faults.ext_force) */
#define SIM_TRUTH_CAMERA_OFF 0x40u

struct sim_cam_frame {
	int64_t capture_us; /* t_us at capture */
	double pose[3];
};

struct sim_motor {
	struct sim_motor_config cfg;
	struct plant plant;
	struct rng rng;
	struct sim_motor_faults inject;
	double volts[4];
	bool enabled;
	double wheel_angle[4]; /* true wheel angle [rad] */
	int64_t counts[4];     /* encoder counts at the last read */
	double ecc_phase[4];   /* phi_j of the eccentric encoders [rad] */
	double ecc_read[4];    /* their last reading as a wheel angle [rad] (encoder_cpr 0) */
	float last_speed[4];   /* last reported wheel speeds [rad/s] */
	int64_t t_us;          /* simulated time since start [us] */
	int64_t period_us;
	double cam_period_s;
	double next_cam_s;
	int64_t utime0; /* added to t_us in pose and truth timestamps */
	int64_t cam_latency_us;
	struct sim_cam_frame cam_q[SIM_CAM_QUEUE]; /* captured, not yet delivered (FIFO) */
	unsigned cam_head, cam_count;
	uint64_t cam_lost; /* frames that found the queue full (never with a valid config) */
	bool truth_due;    /* a read stepped the plant; its truth not yet taken */
	/* A robot that changes (cfg.changes) */
	struct thermal thermal;  /* with changes.thermal */
	struct battery battery;  /* with changes.battery */
	double supply_v;         /* the bridges' supply now [V] (cfg.supply_v without a battery) */
	int64_t floor_change_us; /* t_us of the floor change; < 0: never, or done */
};

/* The plant's slowly changing state (sim_plant_t): constant unless cfg.changes says. */
struct sim_plant_state {
	int64_t utime;         /* utime0 + the simulated time [us] */
	double R_ohm[4];       /* each motor + bridge resistance now [ohm] */
	double winding_c[4];   /* each winding's temperature [deg C] (ambient without thermal) */
	double supply_v;       /* the bridges' supply [V] */
	double friction_scale; /* of the body's B and C [-] */
};

extern const struct motor_hal_ops sim_motor_ops;
extern const struct line_hal_ops sim_line_ops;

/* The [sim] settings (sensor noise and faults, or exact sensors when noise is false; the camera
 * rate and the seed either way) with `plant` as the simulated robot, stepped every period_s
 * from a supply of supply_v. A current drive takes plant's R and Kv as the model's (the caller
 * sets drive.R_ohm, drive.Kv where the controller's model differs). */
struct sim_motor_config sim_motor_config_from(const struct sim_settings *sim, bool noise,
                                              const struct model_params *plant, double period_s,
                                              double supply_v);

/* -EINVAL for invalid parameters or settings. */
int sim_motor_init(struct sim_motor *s, const struct sim_motor_config *cfg);

static inline struct motor_hal sim_motor_hal(struct sim_motor *s)
{
	return (struct motor_hal){.ops = &sim_motor_ops, .ctx = s};
}

/* Poses and truth are stamped utime0 + the simulated time (0 after init). */
void sim_motor_set_clock(struct sim_motor *s, int64_t utime0);
/* The plant's changing parameters now. */
void sim_motor_plant_state(const struct sim_motor *s, struct sim_plant_state *out);
/* The true state now (t->utime: utime0 + the simulated time). */
void sim_motor_truth(const struct sim_motor *s, struct hal_truth *t);
/* n more periods of the plant (n >= 0) under the voltages and enable of the last write, as
 * the loop's reads would make them (encoders, camera, truth and noise follow; a frame or truth
 * the loop does not take before the next read is lost, as ever), the samples discarded: a real
 * robot moves on while its loop is late. In the loop's context. */
void sim_motor_advance(struct sim_motor *s, int n);

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
