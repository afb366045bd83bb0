/*
 * traj.h - trajectory generator: from the current reference (pose and velocity) to a goal pose,
 * at rest there, in the world frame (x, y, theta), within the limits the per-wheel model puts on
 * the drives (docs/trajectory.md). Portable like the rest of the core: C11, single precision,
 * fixed sizes, no allocation, no OS; an instance with init / reset / plan / step (CMSIS style).
 *
 * A move is one curve (traj_curve.c, docs/trajectory.md "One curve"): a cubic Bezier in (x, y)
 * whose first tangent follows the start's velocity, the heading a cubic Bezier over a span of
 * the way or a cruise at the heading where the robot is fastest along the chord, its few
 * parameters chosen by a bounded search on the duration that the path timing gives
 * (traj_topp.c: each wheel's rows linear in s'' and s'^2 at each grid point, checked); a
 * moving start also as the brake prelude (traj_brake.c) and the curve from rest, the sooner
 * kept. Paths through several poses (traj_plan_path): lines and rounded corners on the same
 * timing. Only where no curve is timed (a floor too slippery to turn and move at once: a
 * turn's Coulomb friction and a translation's together beyond traction) the prelude also turns
 * in place to the goal's heading (in TRAJ_ACC_STEPS speed steps, traj_line.c) and the curve
 * holds the heading.
 * - Limits: every wheel's voltage (back-EMF included), traction on its own load and rim speed,
 *   from the wheels' physics (model/wheels.h), Coulomb friction with its worst sign. A plan is
 *   feasible by construction or by its checked timing (bound: docs/trajectory.md); it is not
 *   exactly time-optimal.
 *
 * Units: m, rad, s throughout; x, y, theta in the world frame. theta of the reference is
 * continuous (not wrapped): a plan from 3.0 rad to -3.0 rad ends at 3.283 rad.
 */
#ifndef OMNI4_TRAJ_H
#define OMNI4_TRAJ_H

#include <stdint.h>

#include "omni4/model/params.h"
#include "omni4/model/wheels.h"

#define TRAJ_ACC_STEPS 6 /* speed steps of a straight profile, each with its own acceleration */
#define TRAJ_PHASES (3 * TRAJ_ACC_STEPS + 2) /* a prelude's heading: stop, wait, speed up, */
                                             /* cruise and stop, in steps */
#define TRAJ_SHARE_ITERS 8        /* bisection steps of the heading's share in the brake prelude */
#define TRAJ_HEADINGS_MAX 9       /* headings at which the envelope is checked over a turn */
#define TRAJ_HANDOVER_TOL_S 1e-4f /* a clock this close to a hand-over has reached it (a */
                                  /* clock summed from 1 ms ticks drifts by ~1e-5 s) */
#define TRAJ_IDLE_POS 1e-6f       /* an axis closer than this [m or rad] and ... */
#define TRAJ_IDLE_VEL 1e-6f       /* ... slower than this [m/s or rad/s] does not move */
#define TRAJ_PATH_MAX 8           /* poses of a path (traj_plan_path), the last one included */
#define TRAJ_PIECES (3 * TRAJ_PATH_MAX + 3) /* lines and half arcs of a path */
#define TRAJ_KNOTS (TRAJ_PATH_MAX + 4)      /* heading knots along a path */
#define TRAJ_GRID 64                        /* segments of the progress grid a path is timed on */

/*
 * The limits in force. The model is the per-wheel one (struct model_wheels for r, Kv, Kt, R;
 * struct model_params for d, l, M, J and the body's friction). All values SI.
 */
struct traj_limits {
	struct model_params p;
	struct model_wheels w;
	double supply_v;        /* bridge supply [V] */
	double margin_v;        /* voltage kept for the feedback [V]; supply_v - margin_v > 0 */
	double mu;              /* floor friction coefficient [-] (> 0) */
	double traction_margin; /* share of mu M g / 4 kept in reserve, 0 <= . < 1 */
	double com_height_m;    /* centre of mass above the floor [m] (>= 0; 0: no load */
	                        /* transfer): the traction controller's (traction.h) */
	double motor_speed_max_rad_s;  /* motor shaft speed limit [rad/s] (> 0) */
	double speed_cap_m_s;          /* optional cap on the speed [m/s]; INFINITY: none (> 0) */
	double omega_cap_rad_s;        /* optional cap on |w| [rad/s]; INFINITY: none (> 0) */
	const struct wheel_geom *geom; /* the wheels' layout (model/wheels.h: 3 or 4 wheels at */
	                               /* any angles); NULL: the paper's, at p.d */
	double rot_share;              /* share of each wheel's budget the heading gets when both */
	                               /* the heading and the position move, 0 < . < 1: in the */
	                               /* fixed-limits peer (goal_fixed.h) only */
};

/* One axis: phase k (0 <= k < n) starts at ps[k], vs[k] and runs at acc[k] until t_end_s[k];
 * the last one is anchored at its end (the goal, at rest). */
struct traj_1d {
	float t_end_s[TRAJ_PHASES];
	float acc[TRAJ_PHASES]; /* [m/s^2] or [rad/s^2] */
	float ps[TRAJ_PHASES];  /* [m] or [rad] */
	float vs[TRAJ_PHASES];  /* [m/s] or [rad/s] */
	float p0, v0;           /* start [m, m/s] or [rad, rad/s] */
	float p1, v1;           /* where the top speed is reached, and that speed (cruise) */
	float goal;             /* [m] or [rad] */
	int n;                  /* phases in use (0: at rest at the goal) */
};

/* A point of the reference, world frame: [x, y, theta], their rates and accelerations. */
struct traj_ref {
	float pose[3]; /* [m, m, rad] */
	float vel[3];  /* [m/s, m/s, rad/s] */
	float acc[3];  /* [m/s^2, m/s^2, rad/s^2] */
};

/*
 * traj_1d_plan - one axis: the time-optimal profile speeding up at a_up and slowing down at
 * a_dn (both > 0) with |v| <= vmax (a start faster than vmax slows to it at once), from p0 at
 * v0 to rest at goal; returns its duration [s] (0 if already there, INFINITY if a limit is not
 * > 0). Through zero speed if the start moves away or cannot stop before the goal (that part
 * at a_up). Fast loop: a few operations and one sqrtf.
 */
float traj_1d_plan(struct traj_1d *o, float p0, float v0, float goal, float a_up, float a_dn,
                   float vmax);

/* traj_1d_eval - position, velocity, acceleration at t [s] (before 0: the start; after the end:
 * the goal at rest). Fast loop. */
void traj_1d_eval(const struct traj_1d *o, float t, float *p, float *v, float *a);

/* Per-wheel coefficients, prepared by traj_init (no double after it). */
struct traj_coef {
	struct wheel_phys_f32 wh; /* the wheels (wheels.h): eq 2's rows, force split, loads */
	float e[4];       /* back-EMF braking b_j kemf_j = l^2 Kt_j Kv_j / (R_j r_j^2) [N/(m/s)] */
	float rim_max[4]; /* rim speed limit motor_speed_max r_j / l [m/s] */
	float turn[4];    /* |wh.split[j][0..1]|: wheel j's most of a unit translation force */
	float M, J;       /* [kg], [kg m^2] */
	float B[3], C[3]; /* viscous [N/(m/s)], [N m/(rad/s)] and Coulomb [N], [N m] friction */
	float u_max_v;    /* supply_v - margin_v */
	float f_max_n[4]; /* wheel j's traction at rest, mu N_j (1 - traction_margin) [N] */
	float f_load[4]
	            [2];   /* its fall per m/s^2 of the centre of mass's acceleration (a_v, a_vn) */
	                   /* in the robot frame: -mu (1 - traction_margin) dN_j/da [kg] */
	float lift_max[4]; /* the most of f_max_n[j] an acceleration may take off: the load keeps */
	                   /* traction_margin's share of its static value [N] */
	float speed_cap_m_s, omega_cap_rad_s, rot_share;
};

/* A piece of a path: an arc of constant curvature (0: a line), by arc length. */
struct traj_piece {
	float s0_m, len_m; /* where it starts on the path, its length */
	float p0[2];       /* its start point [m] */
	float dir0_rad;    /* tangent's angle at its start */
	float curv;        /* signed curvature [1/m] (> 0: to the left) */
};

/*
 * A plan along a path (traj_plan_path: lines and arcs by arc length s, the heading a smoothstep
 * between knots; or one curve, traj_plan_curve: see `curve`) and its timing: on each grid
 * segment s'' is constant (docs/trajectory.md, "Paths", "One curve").
 */
struct traj_path {
	struct traj_piece pc[TRAJ_PIECES];
	float knot_s[TRAJ_KNOTS], knot_th[TRAJ_KNOTS]; /* [m], [rad] */
	float pass_s[TRAJ_PATH_MAX]; /* where pose k is passed closest [m] (the last: len_m) */
	float grid_s[TRAJ_GRID + 1]; /* [m] */
	float grid_t[TRAJ_GRID + 1]; /* [s] */
	float grid_v[TRAJ_GRID + 1]; /* s' [m/s] */
	float grid_a[TRAJ_GRID];     /* s'' on each segment [m/s^2] */
	float goal[3];               /* the end, at rest */
	float len_m;
	float bez[4][2];   /* a curve's control points [m] (curve: 1) */
	float bez_span[2]; /* the shares of the progress over which it runs (held outside) */
	float head[2][4]; /* its heading's turns' control points [rad], over knot_s[0..1], [2..3] */
	int n_pieces, n_knots, n_grid, n_poses;
	int curve; /* 1: the path is the cubic Bezier bez in (x, y) over the shares bez_span of
	            * [0, len_m] (still before and after), its heading
	            * the cubic Beziers head[0], head[1] over [knot_s[0], knot_s[1]] and
	            * [knot_s[2], knot_s[3]], held outside them */
};

struct traj {
	struct traj_coef c;
	struct traj_path path;  /* in use when on_path */
	int on_path;            /* 1: the reference follows path; 0: the three axes */
	struct traj_1d axis[3]; /* x, y, theta */
	struct traj_1d pre[3];  /* the brake prelude (x, y, theta) before the rest of the plan */
	float pre_s;            /* its duration (0: none); path and axes run from this time on */
	float t_s;              /* time since the plan started */
	float duration_s;       /* the plan's end (at rest at the goal) */
	float handover_s;       /* traj_plan_ahead: when (on the active plan's clock) it starts */
};

/*
 * traj_init - checks the limits and prepares the coefficients; holds still at the origin.
 * -EINVAL if the model fails its checks, a limit is NaN or out of its range above, or the
 * limits leave no acceleration at rest (Coulomb friction beyond traction or voltage).
 * Not for the fast loop (double arithmetic): at start-up or with new parameters.
 */
int traj_init(struct traj *tr, const struct traj_limits *lim);

/* traj_reset - hold still at pose [m, m, rad]. Fast loop; -EINVAL (unchanged) if NaN. */
int traj_reset(struct traj *tr, const float pose[3]);

/*
 * traj_plan - a new plan from the state `from` (pose and world velocity used; acc ignored) to
 * goal [x m, y m, theta rad], at rest there; the plan's clock restarts at 0: the one curve
 * (traj_plan_curve, 48 timings), else the brake prelude, a turn in place and the curve with the
 * heading held.
 * Bounded time (fixed iteration counts, no blocking), but not for the fast loop: up to ~30 M
 * instructions on the Cortex-M4 (beside the loop: traj_plan_ahead). -EINVAL (plan unchanged)
 * if any input is NaN or infinite; -ERANGE (plan unchanged) if neither is timed (no braking
 * from a start far outside the envelope, or no curve after the turn in place).
 */
int traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3]);

/*
 * traj_replan - traj_plan from the reference at the plan's current time: the new plan starts
 * where the reference is, with its velocity, so the reference does not jump. Fast loop. On a
 * path toward its end: the same path re-timed from the reference; -ERANGE (plan unchanged) if
 * the limits in force cannot hold the path from there.
 */
int traj_replan(struct traj *tr, const float goal[3]);

/*
 * traj_plan_ahead - a plan computed outside the tick (a re-plan costs more than a 1 ms tick on
 * the Cortex-M4: docs/trajectory.md): next gets tr's limits and a plan from tr's reference
 * lead_s [s] ahead of tr's clock now, to goal; traj_take_over hands it over when tr's clock
 * gets there, so the reference does not jump. tr is only read. Not for the fast loop (the cost
 * of a plan); -EINVAL (next unchanged) if lead_s < 0 or an input is NaN or infinite.
 */
int traj_plan_ahead(const struct traj *tr, float lead_s, const float goal[3], struct traj *next);

/*
 * traj_take_over - in the tick, before traj_step: if tr's clock has reached next's start (or tr
 * is at rest at its end, where next starts too), tr becomes next, its clock the time past the
 * start, and returns 1 (next is then spent: the caller drops it); else 0. Fast loop (a copy
 * of struct traj).
 */
int traj_take_over(struct traj *tr, const struct traj *next);

/*
 * traj_plan_path - a plan from `from` through poses[0..n-1] (n <= TRAJ_PATH_MAX) without
 * stopping: lines joined by arcs that pass each intermediate pose's position within radius_m
 * (nearer if its legs are short), the heading smoothly from pose to pose, at rest at the last
 * pose. A start velocity off the first leg turns onto it through a first arc. Timed inside
 * the envelope (the grid of TRAJ_GRID segments, checked); traj_replan toward the last pose
 * re-times the same path from the reference (no jump); tr->path.pass_s[k] is where pose k is
 * passed. Not for the fast loop (a plan's cost: docs/trajectory.md). -EINVAL (plan
 * unchanged) for NaN, n or radius_m out of range, two consecutive poses at one place;
 * -ERANGE if the start turns (w != 0) or is too fast to stay on the path.
 */
int traj_plan_path(struct traj *tr, const struct traj_ref *from, const float (*poses)[3], int n,
                   float radius_m);

/*
 * traj_plan_curve - a plan along one curve (docs/trajectory.md, "One curve"): a cubic Bezier in
 * (x, y) from `from` to goal, at rest there, whose first tangent follows the start's velocity
 * (world), the heading a cubic Bezier over a span of the way (its start rate the start's), or
 * a cruise at the heading where the robot is fastest along the chord; its free parameters
 * chosen by a bounded Nelder-Mead search on estimated timings, the shape kept timed in full
 * and checked inside the envelope; about evals timings in all (a moving start: half of them
 * for the curve from it, half for the brake prelude and the curve from where it stops, the
 * sooner kept). The goal mode's plan (traj_plan, 48 timings). Not for the fast loop. -EINVAL
 * (plan unchanged) for NaN or infinite input or evals outside [CURVE_EVALS_MIN,
 * CURVE_EVALS_MAX]; -ERANGE (unchanged) if no curve was timed.
 */
#define CURVE_EVALS_MIN 24
#define CURVE_EVALS_MAX 1000
int traj_plan_curve(struct traj *tr, const struct traj_ref *from, const float goal[3], int evals);

/* traj_eval - the reference at time t_s of the plan (t_s < 0: the start; beyond the end: at
 * rest at the goal). Fast loop; pure. */
void traj_eval(const struct traj *tr, float t_s, struct traj_ref *out);

/* traj_step - advance the plan's clock by dt_s and give the reference there. Fast loop. */
void traj_step(struct traj *tr, float dt_s, struct traj_ref *out);

/*
 * traj_envelope - the largest acceleration [m/s^2] along the unit direction dir (robot frame,
 * [v, vn]) when moving along it at speed_m_s >= 0 without turning, and the largest speed
 * [m/s] along dir (the speed where that acceleration reaches 0, the rim speed limit, the cap).
 * Each wheel's voltage, traction and rim speed (the feedforward's force sharing; Coulomb
 * friction with the signs of dir). acc may be negative beyond the top speed.
 * -EINVAL for NaN, a negative speed or a direction far from unit length. Fast loop.
 */
int traj_envelope(const struct traj *tr, const float dir[2], float speed_m_s, float *acc_m_s2,
                  float *speed_max_m_s);

#endif /* OMNI4_TRAJ_H */
