/*
 * goal.h - position control: go to a world pose, or follow a path of poses without stopping at
 * the intermediate ones (docs/goal.md). The trajectory generator (traj.h) plans the reference
 * from the state estimate (est.h); each tick the reference's velocity and acceleration, turned
 * into the robot frame, plus a P correction on the pose error, become the controller's
 * VELOCITY-style reference (ctl_goal_reference), which the model feedforward and the wheel PI
 * track. Portable like the rest of the core: C11, single precision in the tick, fixed sizes, no
 * allocation, no OS; an instance with init / start / step.
 *
 * Plans are made outside the tick (docs/goal.md, "Where plans are made"): a plan costs far more
 * than a tick on the Cortex-M4 (up to ~15 M instructions). The tick asks for one (goal_command,
 * a stepped goal's next pose) from where the reference will be a lead ahead; goal_work, called
 * by whatever runs beside the loop (a thread, the microcontroller's main loop, a simulator
 * after each tick), makes it; the tick hands it over when its clock gets there (traj_take_over:
 * no jump), or at once from rest. The tick's own cost stays that of a traj_step.
 *
 * Safety, as for velocity commands (docs/goal.md):
 * - kept alive by its sender: the controller's watchdog (cmd_timeout_ms) stops a goal whose
 *   sender stops repeating it (REASON_WATCHDOG);
 * - refused with a reason, never applied: a NaN or infinite field, a pose or option out of
 *   range, a plan longer than GOAL_PLAN_MAX_S or none at all (unreachable), a goal while the
 *   controller is in FAULT or ESTOP, a goal without an estimate or a recent camera pose;
 * - aborted with the stop ramp (ctl_stop): the estimator's COLLISION flag, or a stale estimate:
 *   odometry alone may carry a goal GOAL_ODOM_ONLY_US after the last camera pose.
 */
#ifndef OMNI4_GOAL_H
#define OMNI4_GOAL_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/vocab.h"
#include "omni4/core/ctl.h"
#include "omni4/core/est.h"
#include "omni4/core/goal_fixed.h"
#include "omni4/core/planner/traj.h"

#define GOAL_POSES_MAX 32         /* goal_t.MAX_POSES */
#define GOAL_RANGE_M 100.0        /* |x|, |y| of a pose [m] */
#define GOAL_THETA_MAX_RAD 1000.0 /* |theta| of a pose [rad] (wrapped before use) */
#define GOAL_PLAN_MAX_S 120.0f    /* a longer plan is unreachable [s] */
#define GOAL_BLEND_DEFAULT_M 0.15f
#define GOAL_BLEND_MIN_M 0.01
#define GOAL_BLEND_MAX_M 2.0
#define GOAL_KP_POS 5.0f   /* pose error -> velocity correction, x and y [1/s] */
#define GOAL_KP_THETA 5.0f /* heading error -> turn-rate correction [1/s] */
/* Odometry alone may carry a goal this long after the last camera pose: the estimator flags
 * CAMERA_STALE 0.5 s after it (EST_CAMERA_STALE_US), the goal stops GOAL_STALE_GRACE_US later.
 * At 2 m/s odometry drifts ~1 cm in that second (EST_ODOM_POS 5 mm per metre, 1 sigma). */
#define GOAL_STALE_GRACE_US 500000
#define GOAL_ODOM_ONLY_US (EST_CAMERA_STALE_US + GOAL_STALE_GRACE_US)
/* REACHED: the plan has ended and the estimate is within these of the last pose, at rest, */
#define GOAL_REACHED_POS_M 0.005f
#define GOAL_REACHED_THETA_RAD 0.0087f /* 0.5 deg */
#define GOAL_REACHED_SPEED_M_S 0.02f
/* and the estimate is sure of it: its error plus two of its own standard deviations (the
 * covariance: sqrt(var x + var y), sqrt(var theta)) within the arrival tolerance, 1 cm and 1 deg.
 * Until then the goal stays ACTIVE with REASON_SETTLING, holding the pose while the camera's
 * frames average the estimate down (docs/goal.md "Arrival"). */
#define GOAL_TOL_POS_M 0.01f
#define GOAL_TOL_THETA_RAD 0.01745f /* 1 deg */
/* No progress: a goal whose plan has ended (or whose next pose's plan never came) and that is
 * not REACHED this long after is ABORTED with REASON_NO_PROGRESS, and the robot stops. */
#define GOAL_SETTLE_MAX_US 10000000
/* A cancelled goal brakes to rest under the planner's limits (a plan to where it can stop,
 * made beside the loop), then the stop ramp; a brake whose plan has not brought the robot to
 * rest this long after the cancel ends with the ramp at once. */
#define GOAL_BRAKE_MAX_US 5000000

/* The lead of a plan asked for while the reference moves [s]: goal_work must finish it within
 * that time, or it is asked again with twice the lead (up to GOAL_PLAN_LEAD_MAX_S). A PC makes
 * the dearest plan in a few ms; the Cortex-M4 build sets 0.2 s (mcu/: ~15 M instructions at
 * 168 MHz beside the loop). */
#ifndef GOAL_PLAN_LEAD_S
#define GOAL_PLAN_LEAD_S 0.02f
#endif
#define GOAL_PLAN_LEAD_MAX_S 1.0f
#define GOAL_PLAN_LATE_S 0.0025f /* a plan handed over later than this past its start: asked */
                                 /* again (the reference would jump) */
/* A robot not under a goal slower than these is at rest: its plan starts from the estimate
 * and is handed over as soon as it is made. */
#define GOAL_REST_SPEED_M_S 0.02f
#define GOAL_REST_RATE_RAD_S 0.05f

enum goal_action { GOAL_CANCEL = 0, GOAL_GO = 1 };

/* goal_status_t.STATUS_* and REASON_*: vocab.def's rows (goalcodec checks them against the LCM
 * constants at compile time). */
enum goal_status {
#define OMNI4_GOAL_STATUS(name, value, ...) GOAL_##name = value,
#include OMNI4_VOCAB_DEF
};

enum goal_reason {
#define OMNI4_GOAL_REASON(name, value, ...) GOAL_R_##name = value,
#include OMNI4_VOCAB_DEF
};

/* A goal as received (goal_t; doubles, checked once on arrival). */
struct goal_cmd {
	int64_t utime;
	int64_t id;
	int8_t action; /* enum goal_action */
	int32_t n;
	double poses[GOAL_POSES_MAX][3]; /* world x [m], y [m], theta [rad] */
	double blend_m;                  /* 0: GOAL_BLEND_DEFAULT_M */
	double speed_max;                /* [m/s]; 0: the model's limits */
};

/* The progress (goal_status_t). */
struct goal_report {
	int64_t id;
	int8_t status; /* enum goal_status */
	int8_t reason; /* enum goal_reason */
	int32_t index, n;
	float distance_m, angle_rad, time_to_go_s;
	float ref[3];     /* world pose of the reference */
	float ref_vel[3]; /* world velocity of the reference */
	float error[3];   /* reference - estimate (theta wrapped) */
};

/* A plan the tick asks for (goal_command, a stepped goal's next pose) and goal_work makes. The
 * tick writes it only while IDLE and reads it only once DONE; goal_work touches it only while
 * POSTED. */
enum goal_job_state { GOAL_JOB_IDLE = 0, GOAL_JOB_POSTED = 1, GOAL_JOB_DONE = 2 };
/* FIRST: a new goal's plan; NEXT: a stepped goal's next pose; BRAKE: a cancelled goal's stop;
 * REPLAN: the goal in force under new limits (goal_init), from its reference a lead ahead. */
enum goal_job_kind {
	GOAL_JOB_FIRST = 0,
	GOAL_JOB_NEXT = 1,
	GOAL_JOB_BRAKE = 2,
	GOAL_JOB_REPLAN = 3,
};

/* Goal ids that ended, remembered so that a repeat never starts one again: its sender is told
 * how it ended instead (a second client's goal replaced it: ABORTED, REASON_REPLACED). */
#define GOAL_ENDED_IDS 16

struct goal_job {
	atomic_int state; /* enum goal_job_state */
	/* asked for */
	int64_t id;    /* the goal's */
	uint32_t gen;  /* goal.gen when asked (new limits make it stale) */
	int8_t kind;   /* enum goal_job_kind */
	bool on_clock; /* handed over on the plan clock of the goal in force, at tr.handover_s */
	bool asap;     /* !on_clock: handed over as soon as made (from rest) */
	bool fixed;    /* under fx ([goal] limits = fixed), else the envelope */
	int64_t handover_us; /* !on_clock && !asap: the tick time it starts at */
	float lead_s;
	int n, index; /* the poses, the one aimed at */
	float blend_m;
	struct goal_fixed fx;
	struct traj_ref
	    from; /* where it starts: the reference (or the estimate) at the hand-over */
	float poses[GOAL_POSES_MAX][3];
	/* made */
	int8_t reason; /* GOAL_R_NONE, or why there is no plan */
	/* in: REPLAN of a path in force; out: the plan goes through every pose to the last (a
	 * path), else to poses[index] */
	bool whole;
	struct traj tr; /* its limits when asked; the plan when made */
};

struct goal {
	struct traj tr;
	struct traj scratch;    /* a new goal's plan before it is taken */
	bool traj_ok;           /* traj_init took the limits: goals can be planned */
	float speed_cap_m_s;    /* the limits' own cap (traj's coefficient when no goal caps it) */
	float kp_pos, kp_theta; /* GOAL_KP_POS, GOAL_KP_THETA */
	bool kinematic;         /* [goal] feedforward = kinematic: no acceleration fed forward */
	bool fixed;             /* [goal] limits = fixed: planned under fx, not the envelope */
	struct goal_fixed fx;
	float poses[GOAL_POSES_MAX][3];
	int n, index;
	bool whole; /* the plan in force goes through every pose (a path); else it ends at
	             * poses[index] and the next pose is planned when the reference nears it */
	float blend_m;
	struct goal_report rep;     /* the goal in force (or the last one) */
	bool changed;               /* rep.status, reason or index changed (goal_report) */
	struct goal_report refused; /* the last goal refused (goal_take_refused) */
	bool refused_pending;
	int64_t stale_since_us; /* CAMERA_STALE seen since (0: not stale) */
	int64_t ended_us;       /* the plan in force ended at (0: it runs) */
	/* a cancelled goal braking to rest on a plan of its own (GOAL_JOB_BRAKE), then stopped: */
	int8_t brake;           /* 0 no, 1 its plan asked for, 2 on its plan */
	bool brake_want;        /* its plan still to be posted */
	int64_t brake_since_us; /* braking since (stopped with the ramp GOAL_BRAKE_MAX_US on) */
	struct goal_report ended[GOAL_ENDED_IDS]; /* the last goals that ended, as they ended */
	int ended_next;                           /* where the next one is written */
	/* a new goal accepted for planning, not yet in force */
	struct goal_cmd want;
	bool want_set, want_posted;
	int64_t want_alive_us; /* its sender's last keep-alive */
	bool next_want;        /* a stepped goal's next pose needs its plan */
	bool replan_want;      /* new limits: the goal in force needs its plan again */
	float lead_s;          /* the next request's lead */
	uint32_t gen;          /* new limits (goal_init) */
	struct goal_job job;
};

/* Start-up or new parameters (double arithmetic: not the fast loop). The planner's limits
 * from the controller's settings (goal_limits); if they leave no acceleration every goal is refused
 * as unreachable, and a goal in force is aborted (UNREACHABLE) at the next step. A goal in force is
 * re-planned from its reference under the new limits (no jump). Keeps the report. */
void goal_init(struct goal *g, const struct ctl_settings *cfg);
/* The same with the planner's limits given (goal_limits' with the motor constants and friction
 * the controller adapted online, [adapt]); cfg for the goal's own keys and, where lim gives no
 * layout (geom NULL), the wheels' layout. */
void goal_init_limits(struct goal *g, const struct ctl_settings *cfg,
                      const struct traj_limits *lim);

/* The planner's limits from the settings (not the fast loop): the model and each drive's
 * constants, the supply less [goal] margin_v (at most a quarter of it) for the feedback, [goal]
 * motor_speed_max and rot_share, [limits] vel_lin_max / vel_rot_max as caps, com_height, and the
 * floor's traction: [limits] traction_mu, or [goal] floor_mu while it is 0, less [limits]
 * traction_margin. Tests and tools build their limits here too. */
void goal_limits(const struct ctl_settings *cfg, struct traj_limits *lim);

/*
 * Fast loop, on arrival. A new goal (action GO, a goal id other than the active one) is checked
 * (fields, estimate est (NULL: none), the controller's mode) and its plan asked for (goal_work);
 * once planned, goal_step hands it over and the controller enters GOAL (ctl_goal), or refuses
 * it (unreachable, FAULT meanwhile) and the goal in force goes on. A repeat of the active (or
 * waiting) goal's id keeps it alive. CANCEL ends the active goal (the controller stops with the
 * ramp) or drops the waiting one. Returns 0 taken, else the negative errno and the report says
 * REFUSED with the reason.
 */
int goal_command(struct goal *g, struct ctl *c, const struct goal_cmd *cmd,
                 const struct est_output *est, int64_t now_us);

/*
 * Fast loop, every tick before ctl_step: follows the controller (a goal ends as ABORTED when
 * the controller left GOAL: watchdog, fault, another command), checks the estimate (collision,
 * stale), steps the plan, passes the intermediate poses, and hands the robot-frame reference
 * to the controller.
 */
void goal_step(struct goal *g, struct ctl *c, const struct est_output *est, int64_t now_us);

/*
 * Beside the loop, never in the tick: makes the plan the tick asked for, if any (up to ~15 M
 * instructions on the Cortex-M4); returns true if it made one. Safe to call from another
 * thread than the tick's (one caller at a time).
 */
bool goal_work(struct goal *g);

/* The progress; *changed (may be NULL) whether status, reason or index changed since the last
 * call. */
const struct goal_report *goal_report(struct goal *g, bool *changed);

/* The report of a goal refused since the last call (REFUSED with its reason), or NULL. The goal
 * in force, if any, goes on. */
const struct goal_report *goal_take_refused(struct goal *g);

#endif /* OMNI4_GOAL_H */
