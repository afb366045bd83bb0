/* dynamics.c - forces, motor equation, state-space matrices (derived signs), steady state. */
#include "omni4/model/dynamics.h"

#include "omni4/model/kinematics.h"
#include "omni4/model/wheels.h"

#include <errno.h>

#include <math.h>

/* Eq 27's Coulomb terms of the state space: the friction's deceleration [m/s^2], [rad/s^2]. */
static void coulomb_terms(const struct model_params *p, double K[3])
{
	K[0] = -p->Cv / p->M;
	K[1] = -p->Cvn / p->M;
	K[2] = -p->Cw / p->J;
}

void dyn_wheel_forces(const struct model_params *p, const double current_a[4], double force_n[4])
{
	const double k = p->l * p->Kt / p->r; /* eqs 12-13 */

	for (int j = 0; j < 4; j++)
		force_n[j] = k * current_a[j];
}

void dyn_robot_forces(double d, const double f[4], double robot_f[3])
{
	robot_f[0] = f[3] - f[1];                     /* eq 9 */
	robot_f[1] = f[0] - f[2];                     /* eq 10 */
	robot_f[2] = d * (f[0] + f[1] + f[2] + f[3]); /* eq 11 */
}

double motor_speed_rad_s(const struct model_params *p, double wheel_speed_m_s)
{
	return p->l * wheel_speed_m_s / p->r;
}

double motor_voltage(const struct model_params *p, double current_a, double w_m)
{
	return p->R * current_a + p->Kv * w_m; /* eq 21 */
}

double motor_current(const struct model_params *p, double voltage_v, double w_m)
{
	return (voltage_v - p->Kv * w_m) / p->R;
}

void dyn_state_space(const struct model_params *p, struct model_ss *ss)
{
	const double emf = p->Kt * p->Kv * p->l * p->l / (p->r * p->r * p->R);
	const double b = p->l * p->Kt / (p->r * p->R); /* eq 26 common factor */
	const double d = p->d;

	ss->A_coast[0] = -p->Bv / p->M;
	ss->A_coast[1] = -p->Bvn / p->M;
	ss->A_coast[2] = -p->Bw / p->J;
	ss->A[0] = -2.0 * emf / p->M + ss->A_coast[0];
	ss->A[1] = -2.0 * emf / p->M + ss->A_coast[1];
	ss->A[2] = -4.0 * d * d * emf / p->J + ss->A_coast[2];

	const double B[3][4] = {
	    {0.0, -b / p->M, 0.0, b / p->M},
	    {b / p->M, 0.0, -b / p->M, 0.0},
	    {b * d / p->J, b * d / p->J, b * d / p->J, b * d / p->J},
	};
	for (int k = 0; k < 3; k++)
		for (int j = 0; j < 4; j++)
			ss->B[k][j] = B[k][j];

	coulomb_terms(p, ss->K);
}

void dyn_steady_velocity(const struct model_ss *ss, const double u[4], double x[3])
{
	for (int k = 0; k < 3; k++) {
		double b = 0.0;

		for (int j = 0; j < 4; j++)
			b += ss->B[k][j] * u[j];
		if (fabs(b) <= -ss->K[k]) {
			x[k] = 0.0; /* stiction: drive below the Coulomb level */
			continue;
		}
		x[k] = -(b + ss->K[k] * (b > 0 ? 1.0 : -1.0)) / ss->A[k];
	}
}

/* Each expression below is its scalar twin's with wheel j's constants, in the same order: with
 * equal wheels the results are the same bits (tests/model/test_wheels.c). */
void dyn_wheel_forces_wheels(const struct model_params *p, const struct model_wheels *w,
                             const double current_a[4], double force_n[4])
{
	for (int j = 0; j < 4; j++)
		force_n[j] = p->l * w->Kt[j] / w->r[j] * current_a[j]; /* eqs 12-13 */
}

void motor_speeds_wheels(const struct model_params *p, const struct model_wheels *w,
                         const double wheel_speed_m_s[4], double motor_rad_s[4])
{
	for (int j = 0; j < 4; j++)
		motor_rad_s[j] = p->l * wheel_speed_m_s[j] / w->r[j];
}

void motor_voltages_wheels(const struct model_wheels *w, const double current_a[4],
                           const double motor_rad_s[4], double voltage_v[4])
{
	for (int j = 0; j < 4; j++)
		voltage_v[j] = w->R[j] * current_a[j] + w->Kv[j] * motor_rad_s[j]; /* eq 21 */
}

void motor_currents_wheels(const struct model_wheels *w, const double voltage_v[4],
                           const double motor_rad_s[4], double current_a[4])
{
	for (int j = 0; j < 4; j++)
		current_a[j] = (voltage_v[j] - w->Kv[j] * motor_rad_s[j]) / w->R[j];
}

void dyn_state_space_wheels(const struct model_params *p, const struct model_wheels *w,
                            struct model_ss_wheels *ss)
{
	const double l = p->l, d = p->d, M = p->M, J = p->J;
	double e[4], b[4]; /* back-EMF braking [N/(m/s)] and drive gain [N/V] of each wheel */

	for (int j = 0; j < 4; j++) {
		e[j] = w->Kt[j] * w->Kv[j] * l * l / (w->r[j] * w->r[j] * w->R[j]);
		b[j] = l * w->Kt[j] / (w->r[j] * w->R[j]);
	}
	ss->A_coast[0] = -p->Bv / M;
	ss->A_coast[1] = -p->Bvn / M;
	ss->A_coast[2] = -p->Bw / J;
	/* A = -Minv (IK^T diag(e) IK + diag(B)); the pairs summed first: e + e is exact. */
	const double e13 = e[1] + e[3], e02 = e[0] + e[2];

	ss->A[0][0] = -e13 / M + ss->A_coast[0];
	ss->A[1][1] = -e02 / M + ss->A_coast[1];
	ss->A[2][2] = -d * d * (e02 + e13) / J + ss->A_coast[2];
	ss->A[0][1] = ss->A[1][0] = 0.0;     /* no wheel pushes along both v and vn */
	ss->A[0][2] = d * (e[1] - e[3]) / M; /* +0 with equal wheels */
	ss->A[1][2] = d * (e[2] - e[0]) / M;
	ss->A[2][0] = d * (e[1] - e[3]) / J;
	ss->A[2][1] = d * (e[2] - e[0]) / J;

	const double B[3][4] = {
	    {0.0, -b[1] / M, 0.0, b[3] / M},
	    {b[0] / M, 0.0, -b[2] / M, 0.0},
	    {b[0] * d / J, b[1] * d / J, b[2] * d / J, b[3] * d / J},
	};
	for (int k = 0; k < 3; k++)
		for (int j = 0; j < 4; j++)
			ss->B[k][j] = B[k][j];

	coulomb_terms(p, ss->K);
}

int dyn_state_space_layout(const struct model_params *p, const struct model_wheels *w,
                           const struct wheel_geom *g, struct model_ss_wheels *ss)
{
	struct wheel_phys ph;

	if (!g) {
		dyn_state_space_wheels(p, w, ss);
		return 0;
	}
	if (wheel_phys_init(&ph, g, p, w, 0.0))
		return -EINVAL;
	const double m[3] = {p->M, p->M, p->J};

	ss->A_coast[0] = -p->Bv / p->M;
	ss->A_coast[1] = -p->Bvn / p->M;
	ss->A_coast[2] = -p->Bw / p->J;
	for (int k = 0; k < 3; k++) {
		for (int c = 0; c < 3; c++) {
			double geg = 0.0; /* (G^T diag(e) G)[k][c] [N/(m/s)] */

			for (int j = 0; j < ph.n; j++)
				geg += ph.row[j][k] * ph.b[j] * ph.kemf[j] * ph.row[j][c];
			ss->A[k][c] = (k == c ? ss->A_coast[k] : 0.0) - geg / m[k];
		}
		for (int j = 0; j < 4; j++)
			ss->B[k][j] = j < ph.n ? ph.row[j][k] * ph.b[j] / m[k] : 0.0;
	}
	coulomb_terms(p, ss->K);
	return 0;
}
