/*
 * fw.h - one controller instance: the controller (ctl), its HAL devices, the command mailbox
 * (receive side -> loop) and the log ring (loop -> logger). fw_tick is the body of the
 * fixed-rate loop; the same function runs in the robot binary, in the lockstep simulator and
 * on the microcontroller. Portable C11: no OS, no allocation, no I/O, no 64-bit atomics (a
 * Cortex-M4 has none); the other side of each mailbox (a thread, an interrupt) is the
 * adapter's.
 */
#ifndef OMNI4_FW_H
#define OMNI4_FW_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/adapt.h"
#include "omni4/core/ctl.h"
#include "omni4/core/ctl_settings.h"
#include "omni4/core/est.h"
#include "omni4/core/goal.h"
#include "omni4/core/hal.h"
#include "omni4/core/ring.h"

#ifndef FW_LOG_RING_SLOTS
#define FW_LOG_RING_SLOTS 8192 /* 8 s of samples at 1 kHz; a power of two */
#endif
#define FW_CMD_RING_SLOTS 64
#define FW_GOAL_RING_SLOTS 4      /* goals from a receive thread (a few keep-alives) */
#define FW_POSE_RING_SLOTS 16     /* camera poses from a receive thread (about 0.6 s at 25 Hz) */
#define FW_POSES_PER_TICK 4       /* backend camera poses the estimator takes in one tick */
#define FW_POSE_POLLS_PER_TICK 16 /* backend camera poses read (and logged) in one tick */
#define FW_STATE_HZ 100.0         /* OMNI4_STATE rate (and on every change of its flags) */
#define FW_ADAPT_HZ 10.0          /* OMNI4_ADAPT rate */
#define FW_ROBOT_HZ 1.0           /* OMNI4_ROBOT rate (and at the first tick) */

enum log_kind {
	LOG_MOTORS = 1,
	LOG_POSE = 2,
	LOG_CALIBRATION = 3,
	LOG_STATE = 4,
	LOG_TRUTH = 5,
	LOG_GOAL = 6,
	LOG_ADAPT = 7,
	LOG_ADAPT_CHANGE = 8,
	LOG_ROBOT = 9,
};

/* LOG_ROBOT: the wheels' layout in force (robot_t); slot 3 of a three-wheel robot holds 0. */
struct log_robot {
	int32_t wheels;
	double angle_rad[4]; /* from the v axis, counter-clockwise [rad] */
	double dist_m[4];    /* from the centre [m] */
	double radius_m[4];  /* [m] */
	double l;            /* gearbox reduction [-] */
};

/* LOG_ADAPT: the motors' constants in use (adapt_t); LOG_ADAPT_CHANGE: an acceptance or a
 * revert of the R_j in use (a param_changed_t with source "adapt"), pushed at the tick that
 * made it, before that tick's LOG_ADAPT. */
struct log_adapt {
	float R[4];        /* in use [ohm] */
	float R_est[4];    /* the estimates [ohm] */
	float R_var[4];    /* their variances [ohm^2] */
	float R_before[4]; /* LOG_ADAPT_CHANGE: in use before [ohm] */
	float supply_v;    /* the drives' supply as last read [V] */
	float track_rms; /* the wheels' speed tracking error since the last LOG_ADAPT, RMS [m/s] */
	float C[3];      /* Coulomb friction in use: Cv, Cvn [N], Cw [N m] */
	uint32_t flags;  /* ADAPT_FLAG_* */
};

/* LOG_MOTORS: the tick's motors_t sample. */
struct log_sample {
	int8_t mode;          /* controller mode (vocab.def) */
	int32_t faults;       /* fault bits (vocab.def) */
	float voltage[4];     /* commanded [V] */
	float current[4];     /* measured, the offsets in force subtracted [A] */
	float wheel_speed[4]; /* [rad/s] */
};

/* LOG_POSE: a camera pose that came through the motor backend (pose_t). */
struct log_pose {
	double pose[3]; /* world x, y [m], theta [rad] */
};

/* LOG_TRUTH (simulators only): the plant's true state after the tick's step (sim_truth_t). */
struct log_truth {
	double pose[3];      /* world x, y [m], theta [rad] */
	float vel[3];        /* robot frame v, vn [m/s], w [rad/s] */
	float wheel_slip[4]; /* rim speed minus ground speed at the wheel [m/s] */
	uint32_t flags;      /* sim_truth_t flags */
};

/* LOG_CALIBRATION: a new set of current-sense offsets (announced as a param_changed_t with
 * source "calibration"); the entry's seq is the first tick whose currents have them subtracted
 * (pushed before that tick's sample). */
struct log_calibration {
	float offset[4];         /* the new offsets [A] */
	float prev_offset[4];    /* the previous ones [A] */
	uint32_t over_limit;     /* channels beyond the limit (bit j = channel j) */
	int32_t prev_over_limit; /* the previous set's such bits; -1: this is the first set */
	uint16_t samples;        /* readings per channel the new offsets are the mean of */
};

/*
 * One log ring entry, not yet encoded: kind says which member of the union holds it.
 * LOG_STATE: the state estimate (a state_t). LOG_GOAL: the goal's progress (a goal_status_t),
 * at the rate of LOG_STATE while a goal is tracked, at every change of its status or pose aimed
 * at, and for every goal refused.
 */
struct log_entry {
	int64_t utime;
	int64_t seq;
	uint8_t kind; /* enum log_kind */
	union {
		struct log_sample sample;   /* LOG_MOTORS */
		struct log_pose camera;     /* LOG_POSE */
		struct log_truth truth;     /* LOG_TRUTH */
		struct log_calibration cal; /* LOG_CALIBRATION */
		struct est_output state;    /* LOG_STATE */
		struct goal_report goal;    /* LOG_GOAL */
		struct log_adapt adapt;     /* LOG_ADAPT, LOG_ADAPT_CHANGE */
		struct log_robot robot;     /* LOG_ROBOT */
	};
};

/* A camera pose as a receive thread hands it to the loop (fw_post_pose). */
struct fw_pose {
	int64_t utime; /* capture time [us] */
	double pose[3];
};

struct fw_counters {
	uint64_t ticks;
	uint64_t log_dropped;          /* ring full: samples lost (never blocks the loop) */
	_Atomic uint32_t cmd_dropped;  /* command mailbox full (wraps after 2^32) */
	_Atomic uint32_t goal_dropped; /* goal mailbox full (wraps after 2^32) */
	uint64_t read_errors;
	uint64_t write_errors;
	uint64_t overruns; /* ticks that started a whole period or more late (FAULT_OVERRUN) */
	_Atomic uint32_t pose_dropped; /* camera poses the estimator never saw: mailbox full, or
	                                * more in one tick than FW_POSES_PER_TICK (wraps at 2^32) */
};

/*
 * A parameter change, prepared off the loop (fw_param_prepare: validated, feedforward gains
 * recomputed) and taken whole by the loop between two ticks: the loop never runs on a mix of
 * old and new values.
 */
struct fw_param_update {
	struct ctl_settings set;
	struct ff_q16_wheels ff;
	struct ff_wheels_per_ohm ff_ohm; /* ff's parts per ohm of each R_j (ctl_set_resistance) */
	struct ctl_layout lay;
	struct adapt adapt; /* adapt_init of set, for adapt_retune */
	bool idle_only; /* the loop refuses it (-EBUSY) if the bridges are driven at that tick */
	uint32_t gen;   /* set by fw_param_offer */
};

/* What the HAL needs when parameters change (e.g. the CAN plausibility limits, which follow
 * the model and the limits). Both may be NULL. */
struct fw_param_hooks {
	/* Parameter thread: 0 if the HAL accepts cfg, else -EINVAL and why. */
	int (*check)(void *ctx, const struct ctl_settings *cfg, char *why, size_t n);
	/* Loop thread, between two ticks, right after the controller took cfg. No allocation. */
	void (*apply)(void *ctx, const struct ctl_settings *cfg);
	void *ctx;
};

struct fw_param_result {
	int rc;        /* 0 applied; -EBUSY refused by the loop (driving, idle_only); -ETIMEDOUT
	                * the loop did not take it within timeout_us (withdrawn: nothing changed) */
	int mode;      /* controller mode when the loop took it */
	int64_t seq;   /* first tick that ran with it */
	int64_t utime; /* controller time of that tick [us] */
};

struct fw {
	struct ctl ctl;
	struct est est;     /* the state estimate (est.h), stepped after the controller */
	struct goal goal;   /* position control (goal.h), stepped before the controller */
	struct adapt adapt; /* the motors' resistances online (adapt.h), after the estimator */
	int adapt_every;    /* ticks between two LOG_ADAPT entries */
	int robot_every;    /* ticks between two LOG_ROBOT entries */
	bool goal_stale;    /* the planner's limits wait for an adapted value (fw.c goal_follow) */
	struct motor_hal motor;
	struct line_hal lines;
	struct spsc_ring cmd_ring;
	struct spsc_ring log_ring;
	int64_t seq;
	bool hw_enabled;
	atomic_bool halted; /* fw_emergency_off was called: the loop writes nothing but 0 V */
	struct ctl_output last_out;
	struct motor_sample last_sample;
	uint32_t cal_gen;     /* the controller's offset sets announced in the log ring */
	int64_t last_tick_us; /* start of the previous tick (overrun check) */
	int64_t late_us;      /* two loop periods [us]: a tick this far after the last is late */
	int state_every;      /* ticks between two LOG_STATE entries */
	uint32_t state_flags; /* flags of the last LOG_STATE entry */
	bool no_estimate;     /* the estimator is left out (no LOG_STATE entries; camera poses
	                       * still go to the log); false after fw_init. Set before the loop
	                       * runs (an adapter may; the lockstep simulator does on request) */
	struct fw_pose tick_poses[FW_POSES_PER_TICK]; /* poses handed in during this tick */
	int n_tick_poses;
	struct fw_counters n;
	/* Parameter change hand-over (parameter thread -> loop). */
	_Atomic(struct fw_param_update *) param_pending;
	_Atomic uint32_t param_done_gen; /* gen of the last update the loop took or refused; the
	                                  * loop writes param_done below, then this (release) */
	struct fw_param_result param_done;
	uint32_t param_gen; /* parameter side only */
	struct fw_param_hooks param_hooks;
	struct spsc_ring pose_ring;
	struct fw_pose pose_buf[FW_POSE_RING_SLOTS];
	struct ctl_command cmd_buf[FW_CMD_RING_SLOTS];
	struct spsc_ring goal_ring;
	struct goal_cmd goal_buf[FW_GOAL_RING_SLOTS];
	struct log_entry log_buf[FW_LOG_RING_SLOTS];
};

/* Start-up. Outputs are switched off. -EINVAL for a bad configuration. */
int fw_init(struct fw *fw, const struct ctl_settings *cfg, struct motor_hal motor,
            struct line_hal lines);

/* Fast loop. One tick at controller time now_us. */
void fw_tick(struct fw *fw, int64_t now_us);

/*
 * fw_background - the work beside the loop, never in the tick: a goal's plan the tick asked for
 * (goal_work). A thread of the adapter calls it (the robot binary), or the microcontroller's
 * main loop, or a simulator after each tick; returns true if it did some work. One caller at a
 * time; safe beside fw_tick in another thread.
 */
bool fw_background(struct fw *fw);

/* Receive thread. false if the mailbox is full (counted). */
bool fw_post_command(struct fw *fw, const struct ctl_command *cmd);

/* Receive thread. A goal (goal_t) for the loop; false if the mailbox is full (counted). */
bool fw_post_goal(struct fw *fw, const struct goal_cmd *goal);

/* Receive thread (a camera on the bus): the pose goes to the estimator at the next tick, at its
 * capture time utime (not to the log: it is on the bus already). false if the mailbox is full
 * (counted). A camera behind the motor backend (the simulator's) is the HAL's read_pose op
 * instead, which fw_tick polls: its poses also go to the log (pose_t); the backend's
 * read_truth op likewise gives LOG_TRUTH entries. */
bool fw_post_pose(struct fw *fw, int64_t utime, const double pose[3]);

/* Logger thread. */
bool fw_pop_log(struct fw *fw, struct log_entry *e);

/* Start-up, before the loop runs. */
void fw_set_param_hooks(struct fw *fw, const struct fw_param_hooks *hooks);

/* Parameter side. cfg passed ctl_settings_check (the door: config_check; asserted in debug
 * builds, not checked again). Validate what start-up adds (the loop rate, the HAL's hook) and
 * precompute what the loop needs into u. 0, or -EINVAL and why. */
int fw_param_prepare(struct fw *fw, const struct ctl_settings *cfg, bool idle_only,
                     struct fw_param_update *u, char *why, size_t n);

/* Parameter side (one update at a time; the adapter waits between these calls: a thread polls,
 * an MCU's main loop checks once per pass). Offer u to the loop, which takes it whole between
 * two ticks; u must stay valid until fw_param_done returns true or fw_param_withdraw
 * succeeds. The Linux adapter's bounded wait: fw_param.h. */
void fw_param_offer(struct fw *fw, struct fw_param_update *u);
/* true once the loop took or refused u; *r then holds its answer. */
bool fw_param_done(struct fw *fw, const struct fw_param_update *u, struct fw_param_result *r);
/* Take u back if the loop has not taken it yet (true: nothing changed). */
bool fw_param_withdraw(struct fw *fw, struct fw_param_update *u);

/* Shutdown / any exit path: outputs off (voltages 0, bridges and enable line off). */
void fw_outputs_off(struct fw *fw);
/* Crash handlers (any thread, async-signal-safe): the loop stops driving for good, the motor
 * backend's halt op runs (if it has one), then outputs off. */
void fw_emergency_off(struct fw *fw);

#endif /* OMNI4_FW_H */
