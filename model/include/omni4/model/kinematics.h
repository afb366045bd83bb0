/*
 * kinematics.h - robot <-> wheel velocities (eqs 2-5) and world <-> robot frame (eq 1).
 * Robot velocity x = [v, vn, w] ([m/s], [m/s], [rad/s]); wheel linear speeds [m/s].
 * Each fixed-point function (q16.h) has its double twin next to it.
 */
#ifndef OMNI4_KINEMATICS_H
#define OMNI4_KINEMATICS_H

#include "omni4/model/q16.h"

struct wheel_geom; /* model/wheels.h */

/* eq 2: v_j = IK(d) x, rows [0 1 d], [-1 0 d], [0 -1 d], [1 0 d]. */
void ik_wheel_speeds(double d, const double x[3], double v_wheel[4]);

/* eqs 3-5: the least-squares inverse of eq 2. */
void fk_robot_velocity(double d, const double v_wheel[4], double x[3]);

/* Single-precision twins (the estimator's arithmetic on a Cortex-M4F), inline: a fast-loop
 * call costs no more than the expressions. */
static inline void ik_wheel_speeds_f32(float d, const float x[3], float v_wheel[4])
{
	const float dw = d * x[2];

	v_wheel[0] = x[1] + dw;
	v_wheel[1] = -x[0] + dw;
	v_wheel[2] = -x[1] + dw;
	v_wheel[3] = x[0] + dw;
}

static inline void fk_robot_velocity_f32(float d, const float v_wheel[4], float x[3])
{
	x[0] = 0.5f * (v_wheel[3] - v_wheel[1]);
	x[1] = 0.5f * (v_wheel[0] - v_wheel[2]);
	x[2] = (v_wheel[0] + v_wheel[1] + v_wheel[2] + v_wheel[3]) / (4.0f * d);
}

/* eq 1: world velocity [vx, vy, w] -> robot velocity [v, vn, w] at heading theta [rad]. */
void frame_world_to_robot(double theta, const double x_world[3], double x_robot[3]);
/* Inverse of eq 1. */
void frame_robot_to_world(double theta, const double x_robot[3], double x_world[3]);

/*
 * ik_wheel_speeds_q16 - eq 2 in Q16.16.
 * Scaling and overflow: x and d in Q16.16; d*w formed in int64 and rounded (q16_mul_wide);
 * each wheel's exact sum saturates once at +-32768 m/s (far outside any wheel speed).
 */
void ik_wheel_speeds_q16(q16_t d, const q16_t x[3], q16_t v_wheel[4]);

/*
 * fk_robot_velocity_q16 - eqs 3-5 in Q16.16.
 * Scaling and overflow: sums of four Q16.16 values in int64 (exact); halving rounds to nearest;
 * the w term multiplies by inv_4d = 1/(4 d) in Q16.16 (pass it precomputed: no division per
 * tick). Saturates at the q16_t range.
 */
void fk_robot_velocity_q16(q16_t inv_4d, const q16_t v_wheel[4], q16_t x[3]);

/*
 * Per-wheel radius (docs/model.md): wheel j's angular speed after the gearbox [rad/s] is its rim
 * speed / r_j. ik_wheel_rates: eq 2, then / r_j. fk_robot_velocity_rates: rim speeds r_j w_j,
 * then eqs 3-5. With four equal radii r, the bits of ik_wheel_speeds then / r, and of * r then
 * fk_robot_velocity (what a scalar caller does).
 */
void ik_wheel_rates(double d, const double r[4], const double x[3], double wheel_rad_s[4]);
void fk_robot_velocity_rates(double d, const double r[4], const double wheel_rad_s[4], double x[3]);

/* Fixed-point geometry with per-wheel radii, prepared once by kin_wheels_q16_init. */
struct kin_wheels_q16 {
	q16_t d;          /* [m], Q16.16 */
	q16_t inv_4d;     /* 1/(4 d) [1/m], Q16.16 */
	q16_t inv_r[4];   /* 1/r_j [1/m], Q16.16 (30.77 for r = 0.0325: 2^-16 is 5e-7 of it) */
	int32_t r_q31[4]; /* r_j [m] in Q0.31 (2^-31 m): Q16.16 would keep only 11 bits of 0.0325 */
};

/* -EINVAL unless d > 0 and every r_j is in (0, 1) m (Q0.31) and not below 2^-15 m (1/r_j
 * fits Q16.16); everything finite. */
int kin_wheels_q16_init(struct kin_wheels_q16 *k, double d, const double r[4]);

/*
 * ik_wheel_rates_q16 - eq 2 then / r_j, in Q16.16.
 * Scaling and overflow: x in Q16.16; the rim speeds are ik_wheel_speeds_q16's (saturated at
 * +-32768 m/s); each times inv_r_j (Q16.16 x Q16.16 -> Q32.32 in int64_t, exact) rounded to
 * Q16.16 and saturated at +-32768 rad/s (a rim speed of +-1065 m/s for r = 0.0325 m).
 */
void ik_wheel_rates_q16(const struct kin_wheels_q16 *k, const q16_t x[3], q16_t wheel_rad_s[4]);

/*
 * fk_robot_velocity_rates_q16 - r_j w_j then eqs 3-5, in Q16.16.
 * Scaling and overflow: w_j in Q16.16 times r_j in Q0.31 -> Q16.47 in int64_t (exact, |.| <
 * 2^62), rounded to Q16.16 (|rim speed| < |w_j| since r_j < 1 m: never saturates); then
 * fk_robot_velocity_q16 with inv_4d (saturates at the q16_t range).
 */
void fk_robot_velocity_rates_q16(const struct kin_wheels_q16 *k, const q16_t wheel_rad_s[4],
                                 q16_t x[3]);

/*
 * Any layout (model/wheels.h; docs/model.md "Layouts"), in Q16.16: eq 2's rows and their
 * least-squares inverse (eqs 3-5 for the layout) rounded once, prepared off the loop. The
 * paper's layout (g NULL) keeps ik_wheel_speeds_q16 / fk_robot_velocity_q16 (closed forms).
 */
struct kin_rows_q16 {
	int n;           /* 3 or 4 */
	int paper;       /* 1: the paper's closed forms with d and inv_4d below */
	q16_t d, inv_4d; /* the paper's [m], [1/m] */
	q16_t row[4][3]; /* eq 2: rim j = row[j] . (v, vn, w) */
	q16_t fk[3][4];  /* eqs 3-5: (v, vn, w) = fk . rims */
};
/* -EINVAL for a layout that does not drive the body, or (paper) d outside (2^-14, 32767) m. */
int kin_rows_q16_init(struct kin_rows_q16 *k, double d, const struct wheel_geom *g);
/*
 * Rim speeds [m/s] of x: each a sum of three Q16.16 products rounded once each (q16_mul_wide)
 * in int64_t, saturated once; the paper's: ik_wheel_speeds_q16's bits (a row's 0 and +-1
 * terms are exact). A three-wheel layout's slot 3 is 0. v_wheel may not alias x.
 */
void ik_rows_q16(const struct kin_rows_q16 *k, const q16_t x[3], q16_t v_wheel[4]);
/* Body velocity of the rims: sums of n rounded products, saturated once; the paper's:
 * fk_robot_velocity_q16. */
void fk_rows_q16(const struct kin_rows_q16 *k, const q16_t v_wheel[4], q16_t x[3]);

#endif /* OMNI4_KINEMATICS_H */
