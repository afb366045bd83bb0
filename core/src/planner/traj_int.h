/*
 * traj_int.h - what traj.c and traj_line.c share inside the trajectory generator: the drive
 * envelope as linear rows and the phases of a 1D profile. Not part of the core's API.
 */
#ifndef OMNI4_TRAJ_INT_H
#define OMNI4_TRAJ_INT_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/planner/traj.h"
#include "omni4/model/consts.h"

/*
 * One wheel constraint in the world frame at one heading. On a symmetric box of accelerations
 * (half widths A ca, A sa) and velocities (half widths wx, wy): ka . (A ca, A sa) + kv . (wx, wy)
 * <= c, every k >= 0 (the largest value of |L z| over a box centred at 0 is the sum of |L_i|
 * times the half widths). On a straight line (unit e): |(sa . e) a + (sv . e) s| <= c, where
 * sa . e and sv . e have the same sign (one axis of the robot per wheel).
 */
struct row {
	float ka[2], kv[2], c;
	float c0; /* room for the acceleration alone (no velocity, no Coulomb): stopping */
	float sa[2], sv[2]; /* ka and kv with their signs */
	float kc; /* M w x v of a turning body (eq 23's axes turn), per unit speed, either sign */
	float sl[2]; /* traction rows: the bound an acceleration toward the wheel takes off it */
	             /* (load transfer), signed; ka holds |sa| + |sl| (the worse sign) */
	bool credit; /* its velocity terms (viscous, back-EMF, Coulomb) all oppose an acceleration
	              * against the velocity: the wheel pushes along one body axis (the paper's
	              * layout; the heading's rows). Else braking gets no credit (c, not c0). */
};

/* min and max of finite floats: a compare and a select (fminf and fmaxf are library calls
 * on a Cortex-M4, which has no VMINNM). */
static inline float minf(float a, float b)
{
	return a < b ? a : b;
}

static inline float maxf(float a, float b)
{
	return a > b ? a : b;
}

#define PI_F MODEL_PI_F

/* The one comparator of candidate plans (t [s] and TRAJ_F_* flags of each): a plan that keeps
 * inside the envelope comes first, then the earliest arrival; a candidate that found no plan
 * (t not finite) never wins. */
static inline bool traj_sooner(float t_cand, uint32_t f_cand, float t_best, uint32_t f_best)
{
	const bool out_c = f_cand & TRAJ_F_BEYOND_ENVELOPE;
	const bool out_b = f_best & TRAJ_F_BEYOND_ENVELOPE;

	if (!(t_cand < INFINITY))
		return false;
	return out_c == out_b ? t_cand < t_best : out_b;
}

/* ---- one axis (traj_1d.c) ---- */

/* The duration of a profile [s] (0 when at rest at the goal). */
float traj_1d_duration(const struct traj_1d *o);

/* Appends a phase from (*p, *v) at a for dt; advances *t, *p, *v to its end. */
void traj_ph_add(struct traj_1d *o, float *t, float *p, float *v, float a, float dt);

/* At rest at p. */
void traj_1d_hold(struct traj_1d *o, float p);

/* Closer than TRAJ_IDLE_POS to goal and slower than TRAJ_IDLE_VEL: nothing to plan. */
bool traj_1d_idle(float p0, float v0, float goal);

/* Smallest and largest position the profile passes through. */
void traj_1d_range(const struct traj_1d *o, float *lo, float *hi);

/* Largest speed the profile reaches [m/s or rad/s]. */
float traj_1d_speed_max(const struct traj_1d *o);

/* ---- the envelope as rows (traj_rows.c) ---- */

/* Largest A with every row met over the box (A ca, A sa) x (wx, wy); -1 if a velocity-only
 * row fails. */
float traj_rows_acc(const struct row *r, int n, float ca, float sa, float wx, float wy);

/* Largest stopping acceleration over the velocity box (wx, wy) (the rows without their
 * velocity and Coulomb terms, less the turning body's term). */
float traj_rows_stop(const struct row *r, int n, float ca, float sa, float wx, float wy);

/* Largest V with the velocity box (V ca, V sa) meeting every row at zero acceleration. */
float traj_rows_top(const struct row *r, int n, float ca, float sa);

/* Translation rows at heading phi with a share of each budget, the room scaled by cos_h,
 * the heading turning at w_max [rad/s] at most; 12 rows into r, returns 12. */
int traj_rows_translation(const struct traj_coef *c, float phi, float share, float cos_h,
                          float w_max, struct row *r);

/* Rotation rows with a share of each budget; 12 rows into r, returns 12. */
int traj_rows_rotation(const struct traj_coef *c, float share, struct row *r);

/* Translation rows at every sampled heading of a plan: at most this many. */
#define TRAJ_ROWS_MAX (TRAJ_HEADINGS_MAX * 4 * 3)

/* Headings sampled over [lo, hi] (a whole turn at most) into phi, and cos of half their
 * spacing (the room every row keeps in between); returns how many. */
int traj_heading_samples(float lo, float hi, float phi[TRAJ_HEADINGS_MAX], float *cos_h);

/* ---- the x/y box (traj_box.c) ---- */

struct axes {
	int n;     /* 1 (heading) or 2 (x, y) */
	bool stop; /* stopping opposes the velocity in every wheel: traj_rows_stop applies */
	float p0[2], v0[2], goal[2];
	float cap; /* on V */
	struct traj_1d *out[2];
};

/* For the share (ca, sa): the top speed with the earliest arrival, planned into ax->out;
 * returns the arrival time. */
float traj_box_limits(const struct row *r, int n, const struct axes *ax, float ca, float sa,
                      uint32_t *flags);

/* x and y: the straight line's share from rest, else alpha by bisection; into tr->axis[0..1]
 * (tr->alpha_rad, tr->flags); returns the arrival time. */
float traj_box_plan(struct traj *tr, const struct row *r, int n, struct axes *ax);

/*
 * traj_line_plan - the fastest profile along the unit direction (ex, ey) (world frame; for the
 * heading (1, 0)) from p0 at v0 to rest at goal, with the acceleration in TRAJ_ACC_STEPS speed
 * steps, each the rows' at the step's worst speed, the top speed among fractions of the
 * largest. Returns the duration, or INFINITY if |v0| is beyond the rows' top speed.
 */
float traj_line_plan(const struct row *r, int n, float ex, float ey, float p0, float v0, float goal,
                     float cap, struct traj_1d *o);

/*
 * traj_line_stop - a start at speed sp >= 0 along the unit direction (ex, ey) stopped in the
 * braking steps with the rows' credit (its own top speed may be beyond the rows': only braking
 * is asked of them). The profile from 0 at sp to rest at its end, o->goal the distance; returns
 * the duration, or INFINITY if a step has no braking.
 */
float traj_line_stop(const struct row *r, int n, float ex, float ey, float sp, struct traj_1d *o);

/* traj_line_project - axis `e` share of a line profile that starts at p0 and ends at goal. */
void traj_line_project(const struct traj_1d *line, float e, float p0, float goal,
                       struct traj_1d *out);

/*
 * traj_line_brake_go - a start moving off the line to the goal: stop along the velocity (the
 * stopping credit, in steps), then a straight profile from rest to the goal; into out[0..1]
 * (x, y). Returns the duration, or INFINITY if the start is beyond the rows' top speed.
 */
float traj_line_brake_go(const struct row *r, int n, const float p0[2], const float v0[2],
                         const float goal[2], float cap, struct traj_1d out[2]);

/* ---- the brake prelude (traj_brake.c) ---- */

/*
 * traj_brake_prelude - a moving start brought to rest: the translation stops along its velocity
 * and the heading's rate falls to 0, together, in the braking steps with the rows' credit; the
 * translation's rows at the headings the stop passes and with the start's turn rate. When both
 * move the heading's share of every wheel's budget is bisected until both stop together.
 * pre[3] (x, y, theta) end at rest at stop[3]. Returns the duration, or INFINITY.
 */
float traj_brake_prelude(const struct traj *tr, const struct traj_ref *from, struct traj_1d pre[3],
                         float stop[3]);

/* ---- paths (traj_path.c, traj_topp.c) ---- */

/* The path's point, tangent, curvature vector and heading [theta, dtheta/ds, d2theta/ds2]
 * at arc length s. */
void traj_path_at(const struct traj_path *pa, float s, float p[2], float ps[2], float pss[2],
                  float th[3]);

/* Lines and corner arcs from start through wp[0..n-1] (each intermediate passed within
 * radius), headings as knots at the poses; via: a first corner (the start velocity's
 * direction), or NULL. -EINVAL if two consecutive points coincide or n is out of range. */
int traj_path_build(struct traj_path *pa, const float start[3], const float (*wp)[3], int n,
                    float radius, const float via[2]);

/* A straight path's heading: to th_mid over the first fa of the length, held, to the end's
 * over the last fb (fa = fb = 0: from the start's to the end's over the whole length). */
void traj_path_swing(struct traj_path *pa, float th_mid, float fa, float fb);

/* One arc from start to goal (goal[2] unwrapped from start[2]) whose tangent turns k times the
 * heading's change (k = 0: the straight line), the heading turning lin times its change
 * linearly in s and the rest as a smoothstep over the whole length. With lin = k the body's
 * velocity keeps its direction (eq 23's axes) for that share; a heading linear in s turns at a
 * rate that follows the speed. -EINVAL if the move has no length. */
int traj_path_arc(struct traj_path *pa, const float start[3], const float goal[3], float k,
                  float lin);

/* Times pa from arc length s0 at speed v0 >= 0 along it to rest at its end, inside the
 * envelope (checked); the duration, or INFINITY if none was found. */
float traj_topp(const struct traj_coef *c, struct traj_path *pa, float s0, float v0);

/* traj_topp on a grid of at most grid segments (<= TRAJ_GRID), a timing whose largest use of
 * a limit is at most 1 + over taken as it is (a search's estimate: the shape it keeps is timed
 * by traj_topp). */
float traj_topp_within(const struct traj_coef *c, struct traj_path *pa, float s0, float v0,
                       float over, int grid);

/* The reference at time t of a timed path (after its end: at rest at the goal). */
void traj_path_eval(const struct traj_path *pa, float t, struct traj_ref *out);

/* A straight move (from rest or moving toward the goal at v0 >= 0, heading still) timed on
 * paths: the line with the heading swung toward the robot's diagonal and back, a small turn at
 * one end alone, and (from rest) arcs whose tangent turns with the heading. The soonest is taken
 * into tr if sooner than tr's plan; returns the duration kept. */
float traj_line_paths_try(struct traj *tr, const struct traj_ref *from, const float goal[3],
                          float v0);

/* A path plan re-timed from its reference now (the same geometry: no jump): 0; -ERANGE
 * (unchanged) if the timing fails. */
int traj_path_retime(struct traj *tr);

#endif /* OMNI4_TRAJ_INT_H */
