/*
 * dynamics.h - forces, motor equation and the state-space model (eqs 6-15, 21, 23-27).
 *
 * Sign convention (docs/design.md, "Model conventions"): the paper's printed A (eq 25) has the
 * back-EMF term with a plus sign; derived from eqs 9-15 and 21 it decelerates the robot, so here
 *   A11 = -(2 Kt Kv l^2 / (r^2 R M) + Bv / M), A22 likewise with Bvn,
 *   A33 = -(4 d^2 Kt Kv l^2 / (r^2 R J) + Bw / J).
 * B (eq 26) and K (eq 27) are as printed.
 */
#ifndef OMNI4_DYNAMICS_H
#define OMNI4_DYNAMICS_H

#include "omni4/model/params.h"

/* eqs 12-13: wheel traction force [N] from motor current [A]: f = l Kt i / r. */
void dyn_wheel_forces(const struct model_params *p, const double current_a[4], double force_n[4]);

/* eqs 9-11: robot forces [Fv, Fvn, T] ([N], [N], [N m]) from wheel forces. */
void dyn_robot_forces(double d, const double force_n[4], double robot_f[3]);

/* Motor speed [rad/s] before the gearbox for a wheel linear speed [m/s]: w_m = l v / r. */
double motor_speed_rad_s(const struct model_params *p, double wheel_speed_m_s);

/* eq 21 (L neglected): u = R i + Kv w_m. */
double motor_voltage(const struct model_params *p, double current_a, double motor_speed_rad_s);
/* eq 21 solved for i. */
double motor_current(const struct model_params *p, double voltage_v, double motor_speed_rad_s);

/* The model of eq 23: dx/dt = A x + B u + K sign(x); A and K are diagonal. */
struct model_ss {
	double A[3];       /* diagonal of A [1/s] */
	double B[3][4];    /* [(m/s^2)/V] rows 0,1; [(rad/s^2)/V] row 2 */
	double K[3];       /* diagonal of K [m/s^2], [m/s^2], [rad/s^2] */
	double A_coast[3]; /* diagonal of A with the H-bridges off (no back-EMF braking) */
};

void dyn_state_space(const struct model_params *p, struct model_ss *ss);

/*
 * Steady velocity under constant voltages u: the x with A x + B u + K sign(x) = 0, axis by axis;
 * an axis whose drive does not overcome its Coulomb friction stays at 0 (stiction).
 */
void dyn_steady_velocity(const struct model_ss *ss, const double u[4], double x[3]);

/*
 * Per-wheel drives (struct model_wheels; docs/model.md). Wheel j has its own r_j, Kv_j, Kt_j,
 * R_j; with b_j = l Kt_j / (R_j r_j) [N/V] and e_j = l^2 Kt_j Kv_j / (R_j r_j^2) [N/(m/s)] its
 * force is f_j = b_j u_j - e_j v_j (eqs 12, 13, 21 with v_j from eq 2), and eqs 9-11 give
 *   A = -diag(1/M, 1/M, 1/J) (IK^T diag(e) IK + diag(Bv, Bvn, Bw)),
 *   B = diag(1/M, 1/M, 1/J) IK^T diag(b):
 *   A = -[ (e1+e3+Bv)/M    0                d (e3-e1)/M
 *          0               (e0+e2+Bvn)/M    d (e0-e2)/M
 *          d (e3-e1)/J     d (e0-e2)/J      (d^2 (e0+e1+e2+e3) + Bw)/J ]
 *   B =  [ 0        -b1/M     0        b3/M
 *          b0/M      0       -b2/M     0
 *          d b0/J    d b1/J   d b2/J   d b3/J ]
 * v and vn never couple; w couples with v when e1 != e3 and with vn when e0 != e2. With four
 * equal wheels A is diagonal and every entry is the bits of dyn_state_space's.
 */
struct model_ss_wheels {
	double A[3][3]; /* [1/s], rows/columns v, vn, w (row w, columns v, vn: [rad/s^2 / (m/s)]) */
	double B[3][4]; /* [(m/s^2)/V] rows 0,1; [(rad/s^2)/V] row 2 */
	double K[3];    /* diagonal of K, as struct model_ss */
	double A_coast[3]; /* diagonal of A with the H-bridges off, as struct model_ss */
};

void dyn_state_space_wheels(const struct model_params *p, const struct model_wheels *w,
                            struct model_ss_wheels *ss);

/*
 * eq 23 for any layout (struct wheel_geom: three or four wheels, eq 2's rows g_j; wheels.h),
 * derived again from eqs 9-13, 21 with eq 2's rows as data: wheel j's force
 * f_j = b_j u_j - e_j (g_j . x), e_j = b_j kemf_j (struct wheel_phys), the body force G^T f, so
 *   A = A_coast - m^-1 G^T diag(e) G,   B = m^-1 G^T diag(b),   m = (M, M, J),
 * a full 3 x 3 A whenever the layout or the drives are not symmetric (every off-diagonal term
 * is the back-EMF of the wheels that move along both axes). K and A_coast as eq 27, the body's
 * friction. A three-wheel robot's column 3 of B is 0. g NULL: exactly dyn_state_space_wheels
 * (the paper's layout, its closed forms, the same bits). p and w checked as for
 * wheel_phys_init; -EINVAL (ss untouched) for a layout wheel_phys_init refuses.
 */
struct wheel_geom;
int dyn_state_space_layout(const struct model_params *p, const struct model_wheels *w,
                           const struct wheel_geom *g, struct model_ss_wheels *ss);

/* eqs 12-13 per wheel: f_j = l Kt_j i_j / r_j [N]. */
void dyn_wheel_forces_wheels(const struct model_params *p, const struct model_wheels *w,
                             const double current_a[4], double force_n[4]);

/* Motor speeds before the gearbox [rad/s] for the wheels' rim speeds [m/s]: l v_j / r_j. */
void motor_speeds_wheels(const struct model_params *p, const struct model_wheels *w,
                         const double wheel_speed_m_s[4], double motor_rad_s[4]);
/* eq 21 per wheel (L neglected): u_j = R_j i_j + Kv_j w_mj, and solved for i_j. */
void motor_voltages_wheels(const struct model_wheels *w, const double current_a[4],
                           const double motor_rad_s[4], double voltage_v[4]);
void motor_currents_wheels(const struct model_wheels *w, const double voltage_v[4],
                           const double motor_rad_s[4], double current_a[4]);

#endif /* OMNI4_DYNAMICS_H */
