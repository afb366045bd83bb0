/* Tests for the planner on other wheel layouts (traj_limits.geom, core/src/planner/): three
 * wheels at 120 deg and an asymmetric four (RoboCup small-size style: 60/135/225/300 deg, the
 * front pair nearer the centre), each plan sampled every millisecond against every wheel's
 * voltage, traction on its own load and rim speed, with the per-wheel model written out here
 * from the angles alone (rows, the least-norm force split and loads solved here by cofactors,
 * sharing no code with model/wheels.c); the paper's layout given as angles plans as without. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "omni4/core/planner/traj.h"
#include "omni4/model/wheels.h"
#include "traj_limits.h"

#define DT 1e-3
#define G_M_S2 9.80665
#define DEG (3.14159265358979323846 / 180.0)

struct layout {
	const char *name;
	int n;
	double deg[4], dist[4]; /* wheel j's position from the v axis, counter-clockwise [deg], */
	                        /* and from the centre [m] */
	double com_height;      /* [m] */
};

static const struct layout three = {
    "three at 120 deg", 3, {60, 180, 300, 0}, {0.089, 0.089, 0.089, 0}, 0.0};
static const struct layout robocup = {
    "asymmetric four", 4, {60, 135, 225, 300}, {0.080, 0.089, 0.089, 0.080}, 0.04};

/* The goal mode's limits from the key table's defaults, no speed caps, the layout's geometry. */
static struct traj_limits limits(const struct layout *lay, struct wheel_geom *g)
{
	struct traj_limits l = test_traj_limits();

	l.com_height_m = lay->com_height;
	assert_int_equal(wheel_geom_angles(lay->n, lay->deg, lay->dist, g), 0);
	l.geom = g;
	return l;
}

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
		const double a = lay->deg[j] * DEG, d = lay->dist[j];
		Gt[0][j] = -sin(a), Gt[1][j] = cos(a), Gt[2][j] = d; /* drive: perpendicular, CCW */
		P[0][j] = 1.0, P[1][j] = d * cos(a), P[2][j] = d * sin(a);
	}
	least_norm(n, Gt, F, f); /* F = G^T f */
	const double h = l->com_height_m;
	const double moments[3] = {M * G_M_S2, -M * h * a_com[0], -M * h * a_com[1]};
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

/* Start pose/velocity (world) -> goal pose: from rest along each axis and turning, a turn in
 * place, moving toward the goal and across it. */
static const float moves[][9] = {
    {0, 0, 0, 0, 0, 0, 1.0f, 0, 0},         {0, 0, 0, 0, 0, 0, 0, 1.2f, 0},
    {0, 0, 0, 0, 0, 0, 0.7f, 0.7f, 0},      {0, 0, 0, 0, 0, 0, 1.5f, 0.5f, 2.0f},
    {0, 0, 0, 0, 0, 0, 0, 0, 3.0f},         {0, 0, 0, 0, 0, 0, 0.3f, 0.1f, 0.4f},
    {0, 0, 0, 0.8f, 0, 0, 2.0f, 0, 0},      {0, 0, 0.5f, 0.5f, 0.3f, 0, 0, 1.0f, -0.5f},
    {0, 0, 0, 0, 0, 2.0f, 0.5f, 0.5f, 0.5f}};

/* Every plan of every move: every wheel within its limits all the way, at the goal at rest at
 * the end. */
static void plans_stay_within_every_wheel(const struct layout *lay)
{
	struct wheel_geom g;
	const struct traj_limits l = limits(lay, &g);
	static struct traj tr;

	assert_int_equal(traj_init(&tr, &l), 0);
	for (size_t m = 0; m < sizeof(moves) / sizeof(moves[0]); m++) {
		const float *k = moves[m];
		const struct traj_ref from = {{k[0], k[1], k[2]}, {k[3], k[4], k[5]}, {0, 0, 0}};
		struct traj_ref r;
		double worst = 0.0;

		assert_int_equal(traj_reset(&tr, from.pose), 0);
		assert_int_equal(traj_plan(&tr, &from, k + 6), 0);
		assert_true(tr.duration_s > 0.0f && tr.duration_s < 30.0f);
		for (double t = 0.0; t < tr.duration_s + DT; t += DT) {
			traj_eval(&tr, (float)t, &r);
			worst = fmax(worst, use_of_limits(&r, &l, lay));
		}
		printf("%s, move %zu: %.3f s, largest use of a wheel's limit %.4f\n", lay->name, m,
		       tr.duration_s, worst);
		assert_true(worst <= 1.01);
		traj_eval(&tr, tr.duration_s + 0.01f, &r);
		for (int i = 0; i < 2; i++) {
			assert_true(fabsf(r.pose[i] - k[6 + i]) < 1e-4f);
			assert_true(r.vel[i] == 0.0f);
		}
		assert_true(fabsf(remainderf(r.pose[2] - k[8], 2.0f * 3.14159265f)) < 1e-4f);
	}
}

static void test_three_wheels_plan_within_every_wheel(void **state)
{
	(void)state;
	plans_stay_within_every_wheel(&three);
}

static void test_asymmetric_four_plan_within_every_wheel(void **state)
{
	(void)state;
	plans_stay_within_every_wheel(&robocup);
}

/* The paper's layout given as angles (0/90/180/270 deg at d) plans what no layout plans. */
static void test_paper_layout_as_angles_plans_the_same(void **state)
{
	(void)state;
	const struct layout paper = {
	    "paper", 4, {0, 90, 180, 270}, {0.089, 0.089, 0.089, 0.089}, 0.0};
	struct wheel_geom g;
	struct traj_limits l = limits(&paper, &g);
	static struct traj a, b;

	l.p.d = 0.089;
	assert_int_equal(traj_init(&a, &l), 0);
	l.geom = NULL;
	assert_int_equal(traj_init(&b, &l), 0);
	for (size_t m = 0; m < sizeof(moves) / sizeof(moves[0]); m++) {
		const float *k = moves[m];
		const struct traj_ref from = {{k[0], k[1], k[2]}, {k[3], k[4], k[5]}, {0, 0, 0}};

		assert_int_equal(traj_plan(&a, &from, k + 6), 0);
		assert_int_equal(traj_plan(&b, &from, k + 6), 0);
		assert_true(a.duration_s == b.duration_s);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_three_wheels_plan_within_every_wheel),
	    cmocka_unit_test(test_asymmetric_four_plan_within_every_wheel),
	    cmocka_unit_test(test_paper_layout_as_angles_plans_the_same),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
