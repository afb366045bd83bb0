/*
 * traj_int.h - what traj.c and traj_line.c share inside the trajectory generator: the drive
 * envelope as linear rows and the phases of a 1D profile. Not part of the core's API.
 */
#ifndef OMNI4_TRAJ_INT_H
#define OMNI4_TRAJ_INT_H

#include "omni4/core/traj.h"

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

/* The duration of a profile [s] (0 when at rest at the goal). */
float traj_1d_duration(const struct traj_1d *o);

/* Appends a phase from (*p, *v) at a for dt; advances *t, *p, *v to its end. */
void traj_ph_add(struct traj_1d *o, float *t, float *p, float *v, float a, float dt);

/*
 * traj_line_plan - the fastest profile along the unit direction (ex, ey) (world frame; for the
 * heading (1, 0)) from p0 at v0 to rest at goal, with the acceleration in TRAJ_ACC_STEPS speed
 * steps, each the rows' at the step's worst speed, the top speed among fractions of the
 * largest. Returns the duration, or INFINITY if |v0| is beyond the rows' top speed.
 */
float traj_line_plan(const struct row *r, int n, float ex, float ey, float p0, float v0, float goal,
                     float cap, struct traj_1d *o);

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

#endif /* OMNI4_TRAJ_INT_H */
