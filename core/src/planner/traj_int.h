/*
 * traj_int.h - what the trajectory generator's files share: the drive envelope as linear rows
 * (the brake prelude's), the phases of a 1D profile, the path and its timing. Not part of the
 * core's API.
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
 * times the half widths; traj_init's check of the acceleration at rest). On a straight line
 * (unit e): |(sa . e) a + (sv . e) s + Coulomb| <= c (traj_line.c, whose braking takes the
 * credit where the terms have one sign along e).
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
	/* at a fixed heading (fixed; cos_h 1), along a line its Coulomb friction and its
	 * braking credit are exact: each body axis' Coulomb term, signed (cs: the row's value for
	 * a positive velocity along that axis), and the heading's cos, sin (ph) */
	float cs[2], ph[2];
	bool fixed;
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

/* The state moves: translates or turns at TRAJ_IDLE_VEL or more. */
static inline bool traj_ref_moving(const struct traj_ref *r)
{
	return fabsf(r->vel[0]) >= TRAJ_IDLE_VEL || fabsf(r->vel[1]) >= TRAJ_IDLE_VEL ||
	       fabsf(r->vel[2]) >= TRAJ_IDLE_VEL;
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

/* ---- the envelope as rows (traj_rows.c) ---- */

/* Largest A with every row met over the box (A ca, A sa) x (wx, wy); -1 if a velocity-only
 * row fails. */
float traj_rows_acc(const struct row *r, int n, float ca, float sa, float wx, float wy);

/* Translation rows at heading phi with a share of each budget, the room scaled by cos_h,
 * the heading turning at w_max [rad/s] at most; 3 rows a wheel into r (4 with a load
 * transfer: the load's floor, lift_max, whatever the share), returns how many. */
int traj_rows_translation(const struct traj_coef *c, float phi, float share, float cos_h,
                          float w_max, struct row *r);

/* Rotation rows with a share of each budget; 3 rows a wheel into r, returns how many. */
int traj_rows_rotation(const struct traj_coef *c, float share, struct row *r);

/* Translation rows at every sampled heading of a plan: at most this many. */
#define TRAJ_ROWS_MAX (TRAJ_HEADINGS_MAX * 4 * 4)

/* Headings sampled over [lo, hi] (a whole turn at most) into phi, and cos of half their
 * spacing (the room every row keeps in between); returns how many. */
int traj_heading_samples(float lo, float hi, float phi[TRAJ_HEADINGS_MAX], float *cos_h);

/* ---- a straight profile in speed steps (traj_line.c) ---- */

/*
 * traj_line_plan - the fastest profile along the unit direction (ex, ey) (world frame; for the
 * heading (1, 0)) from p0 at v0 to rest at goal, with the acceleration in TRAJ_ACC_STEPS speed
 * steps, each the rows' at the step's worst speed, the top speed by golden sections between
 * |v0| and the largest. Returns the duration, or INFINITY if |v0| is beyond the rows' top
 * speed.
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
/* The prelude with the heading's share (0..1) of every wheel's budget, the translation's the
 * rest; *t_rot its heading's stop [s]. Returns the later stop [s], or INFINITY. */
float traj_brake_share(const struct traj *tr, const struct traj_ref *from, float share,
                       struct traj_1d pre[3], float stop[3], float *t_rot);

/*
 * traj_turn_in_place - after a prelude at rest at pre's ends (t_pre [s]: when the last axis
 * stops), the heading turns in place to th_goal with the whole of each wheel's budget (in the
 * speed steps of traj_line_plan), appended to pre[2]. Returns the prelude's new duration, or
 * INFINITY.
 */
float traj_turn_in_place(const struct traj *tr, struct traj_1d pre[3], float t_pre, float th_goal);

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

/* Times pa from arc length s0 at speed v0 >= 0 along it to rest at its end, inside the
 * envelope (checked); the duration, or INFINITY if none was found. */
float traj_topp(const struct traj_coef *c, struct traj_path *pa, float s0, float v0);

/* traj_topp on a grid of at most grid segments (<= TRAJ_GRID), a timing whose largest use of
 * a limit is at most 1 + over taken as it is (a search's estimate: the shape it keeps is timed
 * by traj_topp). */
float traj_topp_within(const struct traj_coef *c, struct traj_path *pa, float s0, float v0,
                       float over, int grid);

/* traj_topp of a timed path from s0 on its own grid (s0, then its points beyond s0): a plan
 * re-timed where its reference is keeps its end but for what the new first segment changes. */
float traj_topp_retime(const struct traj_coef *c, struct traj_path *pa, float s0, float v0);

/* Segment i of a timed path tau [s] after its start: the progress s and its rate sd. */
void traj_grid_at(const struct traj_path *pa, int i, float tau, float *s, float *sd);

/* The reference at time t of a timed path (after its end: at rest at the goal). */
void traj_path_eval(const struct traj_path *pa, float t, struct traj_ref *out);

/* A path plan re-timed from its reference now (the same geometry: no jump): 0; -ERANGE
 * (unchanged) if the timing fails. */
int traj_path_retime(struct traj *tr);

#endif /* OMNI4_TRAJ_INT_H */
