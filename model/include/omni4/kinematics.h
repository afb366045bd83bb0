/*
 * kinematics.h - robot <-> wheel velocities (eqs 2-5) and world <-> robot frame (eq 1).
 * Robot velocity x = [v, vn, w] ([m/s], [m/s], [rad/s]); wheel linear speeds [m/s].
 * Each fixed-point function (q16.h) has its double twin next to it.
 */
#ifndef OMNI4_KINEMATICS_H
#define OMNI4_KINEMATICS_H

#include "omni4/q16.h"

/* eq 2: v_j = IK(d) x, rows [0 1 d], [-1 0 d], [0 -1 d], [1 0 d]. */
void ik_wheel_speeds(double d, const double x[3], double v_wheel[4]);

/* eqs 3-5: the least-squares inverse of eq 2. */
void fk_robot_velocity(double d, const double v_wheel[4], double x[3]);

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

#endif /* OMNI4_KINEMATICS_H */
