/*
 * ctl.h - the controller of one robot: mode state machine, command validation, watchdog,
 * fault latching, reference shaping, fixed-point IK + feedforward, PI on wheel speed.
 * Pure logic: no time source, no I/O, no allocation. ctl_step runs once per loop tick, in
 * single precision and Q16.16 (a command is checked in double once, on arrival).
 *
 * Modes and fault bits: vocab.def (what each drives, keeps alive, latches).
 */
#ifndef OMNI4_CTL_H
#define OMNI4_CTL_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/ctl_blocks.h"
#include "omni4/core/ctl_settings.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/kinematics.h"
#include "omni4/core/hal.h"
#include "omni4/model/q16.h"
#include "omni4/core/traction.h"
#include "omni4/core/vocab.h"

/* Modes (enum ctl_mode) and fault bits (CTL_FAULT_*): vocab.h, from vocab.def. Latching faults
 * force CTL_FAULT and stay until a successful CTL_CLEAR_FAULT; the others are reported, not
 * latching. CURRENT_SENSOR also covers a calibrated offset beyond CTL_CAL_LIMIT_A; OVERRUN and
 * LOG_OVERFLOW are set by the loop (fw.c). */

/*
 * Current-sense offsets (docs/faults.md): measured with the bridges off (true current 0) once
 * they have been off for CTL_CAL_SETTLE_US, as the mean of CTL_CAL_SAMPLES readings per
 * channel, again and again while they stay off; a new set comes into force only if a channel
 * moved by more than CTL_CAL_CHANGE_MIN_A and CTL_CAL_CHANGE_SIGMAS standard errors (the first
 * always). The set in force is subtracted from every reading the controller uses and reports
 * (over-current check, ctl_output.current); the sensor-rail check looks at the raw reading.
 * Until the first set, the offsets are 0 and commands are taken as always. An offset beyond
 * CTL_CAL_LIMIT_A latches FAULT_CURRENT_SENSOR, present until a set within it comes into force.
 */
#define CTL_CAL_SAMPLES 400
#define CTL_CAL_SETTLE_US 50000
#define CTL_CAL_LIMIT_A 0.25f
#define CTL_CAL_CHANGE_MIN_A 0.005f
#define CTL_CAL_CHANGE_SIGMAS 5.0f

/* A command as received (command_t fields). */
struct ctl_command {
	int64_t utime;
	int64_t seq;
	int8_t mode;
	double velocity[3]; /* [m/s, m/s, rad/s] */
	double voltage[4];  /* [V] */
	double ramp_s;      /* [s] */
};

struct ctl_output {
	float volts[4]; /* [V], within +-supply_v; 0 whenever !enable */
	bool enable;    /* H-bridges on */
	int8_t mode;
	int32_t faults;   /* CTL_FAULT_* */
	float current[4]; /* the sample's currents minus the offsets in force [A]; NaN: none */
};

struct ctl_counters {
	uint64_t cmd_accepted;
	uint64_t cmd_rejected;
	uint64_t watchdog_trips;
	uint64_t faults_latched;
};

/* The settings as the tick and the command check use them (single precision, the Cortex-M4F's
 * FPU; the command limits in double, as commands are checked): derived from struct ctl_settings
 * at init and at every parameter change, never per tick. The fast path reads only these. */
struct ctl_tuning {
	float dt;          /* loop period [s] */
	float r[4];        /* each wheel's radius (its own r_j, else r) [m] */
	float u_max;       /* supply: output bound [V] */
	float current_max; /* over-current level [A] */
	float sensor_max;  /* a current reading at or beyond this is a saturated sensor [A] */
	float supply_min;  /* [V] */
	int64_t cmd_timeout_us;
	int encoder_bad_ticks_max; /* ticks the rigid-body residual may stay too large */
	float stop_ramp_s;         /* watchdog stop ramp [s] */
	bool feedforward;
	bool feedback;
	double vel_lin_max; /* command limits [m/s], [rad/s], [V] */
	double vel_rot_max;
	double supply_v;
};

/* The wheels' layout in force ([model] wheels, wheel_angle_j, d_j), prepared off the loop
 * (ctl_init): what the tick needs of it, no trigonometry per tick. */
struct ctl_layout {
	bool paper;              /* the paper's layout: model/'s closed forms, to the bit */
	int wheels;              /* 3 or 4: slot 3 of a three-wheel robot is driven at 0 V */
	struct wheel_geom geom;  /* its rows and maps (the paper's too) */
	struct kin_rows_q16 kin; /* eq 2's rows and eqs 3-5, Q16.16 */
	float null_m[4];         /* the rigid-body check's vector (wheel_null; 0 for 3 wheels) */
};

struct ctl {
	struct ctl_settings set; /* the settings in force (read off the loop: reports, tests) */
	/* the per-wheel feedforward of the wheels in force (ctl_settings_wheels) */
	struct ff_q16_wheels ff;
	struct ff_wheels_per_ohm
	    ff_ohm; /* the same gains per ohm of each R_j (ctl_set_resistance) */
	struct ff_wheels_per_ohm
	    ff_ohm_use;        /* ff_ohm with the friction in use (ctl_set_friction) */
	float R_use[4];        /* each R_j in the gains [ohm] */
	struct ctl_layout lay; /* the wheels' layout in force */
	int64_t period_us;     /* loop period [us] */
	struct ctl_tuning t;
	enum ctl_mode mode;
	int32_t latched;        /* latching fault bits */
	int32_t present;        /* fault conditions seen in the last tick */
	int32_t reading_faults; /* conditions of the last reading: a tick without one (-EAGAIN)
	                         * keeps them, so a clear cannot slip through such a tick */
	int32_t warnings;       /* non-latching bits */
	int64_t last_cmd_us;    /* controller time of the last valid motion command */
	/* VELOCITY */
	float vel_target[3];
	struct ctl_shaper shaper; /* shaped reference [m/s, m/s, rad/s] and its derivative */
	struct ctl_pi pi[4];      /* PI on each wheel's linear speed */
	struct traction trac;     /* the shaper's traction limit ([limits] traction_mu) */
	bool slipping;            /* the estimator's slip flag of the last tick */
	/* GOAL: the reference of this tick (ctl_goal_reference), robot frame */
	float goal_vel[3]; /* [m/s, m/s, rad/s] */
	float goal_acc[3]; /* [m/s^2, m/s^2, rad/s^2] */
	/* The speed tracking of this tick (VELOCITY, GOAL with a reading): the wheels' rim speed
	 * reference minus their reading, squared and summed [(m/s)^2] */
	bool tracked;
	float track_e2;
	/* VOLTAGE ramp */
	struct ctl_ramp ramp;
	bool stopping; /* watchdog stop ramp in progress */
	/* Last output and plausibility state */
	float out[4];
	float x_est[3]; /* robot velocity from the wheel speeds (eqs 3-5) */
	int encoder_bad_ticks;
	float last_wheel[4];   /* last wheel speeds [rad/s], for the jump check */
	int64_t last_wheel_us; /* controller time of that reading [us] */
	bool have_wheel;
	/* Current-sense offsets */
	struct ctl_cal cal;
	bool enabled_prev; /* bridges on after the last tick (while this tick's reading was
	                    * taken) */
	struct ctl_counters n;
};

/* -EINVAL if the configuration is unusable (bad model, non-positive rate): ctl_settings_check,
 * the door a model comes in by. */
int ctl_init(struct ctl *c, const struct ctl_settings *cfg);
/* The same for cfg that passed ctl_settings_check (asserted in debug builds, not checked again):
 * a parameter change checked at its door. -EINVAL only for a supply_v <= 0. */
int ctl_init_checked(struct ctl *c, const struct ctl_settings *cfg);

/*
 * Fast loop. Validate and apply a command received at now_us. Returns 0 if accepted; a
 * rejection is counted and flagged, never applied: -EINVAL (NaN/inf, out of range, unknown
 * mode), -EBUSY (a clear while the cause persists, as of the last reading), -EPERM (a motion
 * command in FAULT or ESTOP).
 */
int ctl_command(struct ctl *c, const struct ctl_command *cmd, int64_t now_us);

/*
 * Fast loop. One tick at now_us: sample (NULL or read_rc < 0 = no reading this tick),
 * estop = e-stop line state. Fills out. The sample's currents are raw readings: the offsets
 * in force are subtracted here (c->cal; c->cal.gen counts the sets that came into force, the
 * first tick of a new set being the one whose step changed it).
 */
void ctl_step(struct ctl *c, int64_t now_us, const struct motor_sample *sample, int read_rc,
              bool estop, struct ctl_output *out);

/* Between two ticks: run from now on with cfg (already checked by ctl_init on a scratch
 * instance) and its precomputed feedforward (gains, and their parts per ohm); the PI integrals
 * and the modes are kept. */
void ctl_retune(struct ctl *c, const struct ctl_settings *cfg, const struct ff_q16_wheels *ff,
                const struct ff_wheels_per_ohm *ff_ohm, const struct ctl_layout *lay);

/* Fast loop, between two ticks: wheel j's feedforward gains for its resistance R_ohm (an
 * accepted estimate, adapt.h; > 0 and finite, within the model's range), the rest as they are:
 * nine float products (ff_q16_wheels_set_resistance). The next retune puts the settings' back. */
void ctl_set_resistance(struct ctl *c, int j, float R_ohm);

/* Fast loop, between two ticks: the body's viscous friction B (Bv, Bvn [N/(m/s)], Bw
 * [N m/(rad/s)]) and Coulomb friction C (Cv, Cvn [N], Cw [N m]) in the feedforward and the
 * traction limit (an accepted estimate, adapt.h; each > 0 and finite: the caller's bounds), the
 * wheels' R_j as they are: 24 products for the gains per ohm, then ctl_set_resistance's nine
 * per wheel. The next retune puts the settings' back. */
void ctl_set_friction(struct ctl *c, const float B[3], const float C[3]);

/* Between two ticks: the estimator's slip flag (the traction limit backs off while it is set). */
void ctl_set_slip(struct ctl *c, bool slipping);

/*
 * Fast loop. Enter (or stay in) GOAL, as an accepted command does: a keep-alive for the
 * watchdog. Bumpless: from VELOCITY the PI integrals are kept; from any other mode the
 * reference starts at the measured velocity and the integrals at 0. -EPERM in FAULT or ESTOP
 * (nothing changes).
 */
int ctl_goal(struct ctl *c, int64_t now_us);

/* Fast loop. The goal mode's own keep-alive while it brakes a cancelled goal to rest (a
 * bounded plan of its own, its sender gone): the watchdog's clock only, in GOAL alone. */
void ctl_goal_keep(struct ctl *c, int64_t now_us);

/* Fast loop, before ctl_step: the reference GOAL tracks in this tick (robot frame): velocity
 * [m/s, m/s, rad/s] and its rate [m/s^2, m/s^2, rad/s^2]; the caller keeps it finite and
 * within the command limits. Leaving GOAL for VELOCITY starts from it (bumpless). */
void ctl_goal_reference(struct ctl *c, const float vel[3], const float acc[3]);

/* Fast loop. Stop as the watchdog does: the outputs ramp to 0 V over stop_ramp_s, then IDLE.
 * Only from VELOCITY or GOAL (elsewhere nothing changes). */
void ctl_stop(struct ctl *c, int64_t now_us);

/* Flag bits raised outside the controller (log overflow, overrun): reported until cleared. */
void ctl_flag(struct ctl *c, int32_t bits);

#endif /* OMNI4_CTL_H */
