/*
 * wheel_use.h - the tests' own per-wheel model of a wheel layout, written from the wheels'
 * angles alone (rows, the least-norm force split and the loads solved by cofactors; it shares
 * no code with model/wheels.c): the largest use of any wheel's voltage, traction on its own
 * load and rim speed at a reference. For the planner's tests.
 */
#ifndef OMNI4_TEST_WHEEL_USE_H
#define OMNI4_TEST_WHEEL_USE_H

#include <math.h>

#include "omni4/core/planner/traj.h"

#define WHEEL_USE_G_M_S2 9.80665
#define WHEEL_USE_DEG (3.14159265358979323846 / 180.0)

struct layout {
	const char *name;
	int n;
	double deg[4], dist[4]; /* wheel j's position from the v axis, counter-clockwise [deg], */
	                        /* and from the centre [m] */
	double com_height;      /* [m] */
};

static double sgn(double x)
{
	return (x > 1e-6) - (x < -1e-6);
}

/* x = A^-1 y for a 3 x 3 A, by cofactors. */
static void solve3(const double A[3][3], const double y[3], double x[3])
{
	double inv[3][3];

	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++) {
			const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3,
			          c1 = (i + 2) % 3;
			inv[i][j] = A[r0][c0] * A[r1][c1] - A[r0][c1] * A[r1][c0];
		}
	const double det = A[0][0] * inv[0][0] + A[0][1] * inv[1][0] + A[0][2] * inv[2][0];
	for (int i = 0; i < 3; i++)
		x[i] = (inv[i][0] * y[0] + inv[i][1] * y[1] + inv[i][2] * y[2]) / det;
}

/* Least norm: the m-vector z with B z = y, B 3 x m (B^T (B B^T)^-1 y). */
static void least_norm(int m, const double B[3][4], const double y[3], double z[4])
{
	double BBt[3][3] = {{0}}, k[3];

	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			for (int c = 0; c < m; c++)
				BBt[i][j] += B[i][c] * B[j][c];
	solve3(BBt, y, k);
	for (int c = 0; c < m; c++)
		z[c] = B[0][c] * k[0] + B[1][c] * k[1] + B[2][c] * k[2];
}

/* The largest use of any wheel's limit (1: at it) at reference r. */
static double use_of_limits(const struct traj_ref *r, const struct traj_limits *l,
                            const struct layout *lay)
{
	const double M = l->p.M, J = l->p.J, th = r->pose[2], c = cos(th), s = sin(th);
	const double x[3] = {c * r->vel[0] + s * r->vel[1], -s * r->vel[0] + c * r->vel[1],
	                     r->vel[2]};
	/* the body-frame rate of the body velocity (eq 23's axes turn with the body), and the
	 * centre of mass's acceleration */
	const double a_com[2] = {c * r->acc[0] + s * r->acc[1], -s * r->acc[0] + c * r->acc[1]};
	const double ab[2] = {a_com[0] + x[2] * x[1], a_com[1] - x[2] * x[0]};
	const double F[3] = {M * ab[0] + l->p.Bv * x[0] + l->p.Cv * sgn(x[0]),
	                     M * ab[1] + l->p.Bvn * x[1] + l->p.Cvn * sgn(x[1]),
	                     J * r->acc[2] + l->p.Bw * x[2] + l->p.Cw * sgn(x[2])};
	double Gt[3][4], P[3][4], f[4], N[4];
	const int n = lay->n;

	for (int j = 0; j < n; j++) {
		const double a = lay->deg[j] * WHEEL_USE_DEG, d = lay->dist[j];
		Gt[0][j] = -sin(a), Gt[1][j] = cos(a), Gt[2][j] = d; /* drive: perpendicular, CCW */
		P[0][j] = 1.0, P[1][j] = d * cos(a), P[2][j] = d * sin(a);
	}
	least_norm(n, Gt, F, f); /* F = G^T f */
	const double h = l->com_height_m;
	const double moments[3] = {M * WHEEL_USE_G_M_S2, -M * h * a_com[0], -M * h * a_com[1]};
	least_norm(n, P, moments, N);
	double worst = 0.0;

	for (int j = 0; j < n; j++) {
		const double b = l->p.l * l->w.Kt[j] / (l->w.R[j] * l->w.r[j]);
		const double e =
		    l->p.l * l->p.l * l->w.Kt[j] * l->w.Kv[j] / (l->w.R[j] * l->w.r[j] * l->w.r[j]);
		const double v = Gt[0][j] * x[0] + Gt[1][j] * x[1] + Gt[2][j] * x[2]; /* eq 2 */
		const double rim = l->motor_speed_max_rad_s * l->w.r[j] / l->p.l;
		const double hold = l->mu * (1.0 - l->traction_margin) * N[j];

		worst = fmax(worst, fabs((f[j] + e * v) / b) / (l->supply_v - l->margin_v));
		worst = fmax(worst, hold > 0.0 ? fabs(f[j]) / hold : INFINITY);
		worst = fmax(worst, fabs(v) / rim);
	}
	return worst;
}

/* A plan sampled every millisecond: the largest use of any wheel's limit over it; asserts
 * (cmocka, included before this header) that it ends at rest at goal. */
static double plan_worst_use(const struct traj *tr, const struct traj_limits *l,
                             const struct layout *lay, const float goal[3])
{
	struct traj_ref r, prev;
	double worst = 0.0;

	traj_eval(tr, 0.0f, &prev);
	for (double t = 0.0; t < tr->duration_s + 1e-3; t += 1e-3) {
		traj_eval(tr, (float)t, &r);
		worst = fmax(worst, use_of_limits(&r, l, lay));
		/* no jump: each axis moves as far as its speeds and accelerations take it */
		for (int i = 0; i < 3; i++) {
			const double v = fmax(fabs(r.vel[i]), fabs(prev.vel[i]));
			const double a = fmax(fabs(r.acc[i]), fabs(prev.acc[i]));
			assert_true(fabs(r.pose[i] - prev.pose[i]) <= (v + a * 1e-3) * 1e-3 + 1e-5);
			assert_true(fabs(r.vel[i] - prev.vel[i]) <= 1.5 * a * 1e-3 + 1e-4);
		}
		prev = r;
	}
	traj_eval(tr, tr->duration_s + 0.01f, &r);
	for (int i = 0; i < 2; i++) {
		assert_true(fabsf(r.pose[i] - goal[i]) < 1e-4f);
		assert_true(r.vel[i] == 0.0f);
	}
	assert_true(r.vel[2] == 0.0f);
	assert_true(fabsf(remainderf(r.pose[2] - goal[2], 2.0f * 3.14159265f)) < 1e-4f);
	return worst;
}

#endif /* OMNI4_TEST_WHEEL_USE_H */
