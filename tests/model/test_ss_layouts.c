/* eq 23 for any layout (dyn_state_space_layout) against the derivation written out here, with
 * the rows from the angles (layout_by_hand.h) and each wheel's back-EMF braking
 * e_j = l^2 Kt_j Kv_j / (R_j r_j^2) [N/(m/s)] and drive gain b_j = l Kt_j / (R_j r_j) [N/V]
 * from eqs 12, 13 and 21:
 * - three equal wheels at 0/120/240 deg at one d: G^T G = diag(3/2, 3/2, 3 d^2), so A is
 *   diagonal, -diag(3 e / (2 M), 3 e / (2 M), 3 d^2 e / J) plus the body's friction;
 * - an asymmetric four (60/135/225/300 deg, unequal distances and drives): A = A_coast -
 *   m^-1 G^T diag(e) G with non-zero off-diagonals, B = m^-1 G^T diag(b);
 * - no layout: the bits of dyn_state_space_wheels; a layout that does not drive the body:
 *   -EINVAL. */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "layout_by_hand.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/params.h"
#include "omni4/model/wheels.h"

#define REL_TOL 1e-12 /* double rounding of a few dozen products; measured below 1e-15 */

static void equal_wheels(const struct model_params *p, struct model_wheels *w)
{
	for (int j = 0; j < 4; j++) {
		w->r[j] = p->r;
		w->Kv[j] = p->Kv;
		w->Kt[j] = p->Kt;
		w->R[j] = p->R;
	}
}

/* |a - b| within REL_TOL of scale. */
static void near_rel(double a, double b, double scale)
{
	if (!(fabs(a - b) <= REL_TOL * scale)) {
		printf("  %.17g vs %.17g (scale %.3g)\n", a, b, scale);
		fail();
	}
}

static void test_three_equal_wheels_closed_form(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_wheels w;
	const struct layout L = {3, {0.0, 120.0, 240.0}, {p->d, p->d, p->d}};
	struct wheel_geom g;
	struct model_ss_wheels ss;
	double G[4][3] = {{0}}, inv[3][3];

	equal_wheels(p, &w);
	assert_int_equal(wheel_geom_angles(L.n, L.angle_deg, L.dist_m, &g), 0);
	assert_int_equal(dyn_state_space_layout(p, &w, &g, &ss), 0);
	layout_by_hand(&L, G, inv);
	const double e = p->l * p->l * p->Kt * p->Kv / (p->R * p->r * p->r);
	const double b = p->l * p->Kt / (p->R * p->r);
	const double diag[3] = {-1.5 * e / p->M - p->Bv / p->M, -1.5 * e / p->M - p->Bvn / p->M,
	                        -3.0 * p->d * p->d * e / p->J - p->Bw / p->J};
	const double m[3] = {p->M, p->M, p->J};
	const double a_scale = fabs(diag[2]);

	printf("three equal wheels: A diag %.4f %.4f %.4f 1/s (closed form %.4f %.4f %.4f), "
	       "off-diagonal at most %.2e\n",
	       ss.A[0][0], ss.A[1][1], ss.A[2][2], diag[0], diag[1], diag[2],
	       fmax(fmax(fabs(ss.A[0][1]), fabs(ss.A[0][2])), fabs(ss.A[1][2])));
	for (int k = 0; k < 3; k++) {
		for (int c = 0; c < 3; c++)
			near_rel(ss.A[k][c], k == c ? diag[k] : 0.0, a_scale);
		for (int j = 0; j < 3; j++)
			near_rel(ss.B[k][j], G[j][k] * b / m[k], b / p->M);
		assert_true(ss.B[k][3] == 0.0); /* no fourth motor */
	}
	near_rel(ss.K[2], -p->Cw / p->J, p->Cw / p->J);
	near_rel(ss.A_coast[0], -p->Bv / p->M, p->Bv / p->M);
}

/* RoboCup-like: 60/135/225/300 deg, wheel 2 farther out, wheel 1 with its own drive. */
static void test_asymmetric_four_by_hand(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_wheels w;
	const struct layout L = {4, {60.0, 135.0, 225.0, 300.0}, {p->d, p->d, 1.2 * p->d, p->d}};
	struct wheel_geom g;
	struct model_ss_wheels ss;
	double G[4][3], inv[3][3], e[4], b[4], GeG[3][3] = {{0}};

	equal_wheels(p, &w);
	w.r[1] *= 1.04;
	w.Kv[1] *= 1.05;
	w.Kt[1] *= 1.05;
	w.R[1] *= 0.95;
	assert_int_equal(wheel_geom_angles(L.n, L.angle_deg, L.dist_m, &g), 0);
	assert_int_equal(dyn_state_space_layout(p, &w, &g, &ss), 0);
	layout_by_hand(&L, G, inv);
	for (int j = 0; j < 4; j++) {
		e[j] = p->l * p->l * w.Kt[j] * w.Kv[j] / (w.R[j] * w.r[j] * w.r[j]);
		b[j] = p->l * w.Kt[j] / (w.R[j] * w.r[j]);
		for (int k = 0; k < 3; k++)
			for (int c = 0; c < 3; c++)
				GeG[k][c] += G[j][k] * e[j] * G[j][c];
	}
	const double m[3] = {p->M, p->M, p->J}, fr[3] = {p->Bv, p->Bvn, p->Bw};
	double off = 0.0;

	for (int k = 0; k < 3; k++) {
		for (int c = 0; c < 3; c++) {
			const double want = -(GeG[k][c] + (k == c ? fr[k] : 0.0)) / m[k];

			near_rel(ss.A[k][c], want, fabs(GeG[2][2] / p->J));
			if (k != c)
				off = fmax(off, fabs(ss.A[k][c]) * (k == 2 ? p->d : 1.0) /
				                    (c == 2 ? p->d : 1.0));
		}
		for (int j = 0; j < 4; j++)
			near_rel(ss.B[k][j], G[j][k] * b[j] / m[k], b[0] * p->d / p->J);
	}
	printf("asymmetric four: A row v %.4f %.4f %.4f, vn %.4f %.4f %.4f, w %.4f %.4f %.4f; "
	       "largest off-diagonal %.4f 1/s (in m/s units)\n",
	       ss.A[0][0], ss.A[0][1], ss.A[0][2], ss.A[1][0], ss.A[1][1], ss.A[1][2], ss.A[2][0],
	       ss.A[2][1], ss.A[2][2], off);
	/* the coupling is there: v with vn (60 and 300 deg are not opposite 135 and 225), w with
	 * both (the unequal distance and drive) */
	assert_true(fabs(ss.A[0][1]) > 0.01 * fabs(ss.A[0][0]));
	assert_true(fabs(ss.A[0][2]) > 1e-3 * fabs(ss.A[0][0]) * p->d);
	assert_true(fabs(ss.A[1][2]) > 1e-3 * fabs(ss.A[1][1]) * p->d);
	/* the mass-weighted A is symmetric: m A = -(G^T diag(e) G + friction) */
	for (int k = 0; k < 3; k++)
		for (int c = 0; c < 3; c++)
			near_rel(m[k] * ss.A[k][c], m[c] * ss.A[c][k], GeG[2][2]);
}

static void test_no_layout_is_the_paper_bits(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_wheels w;
	struct model_ss_wheels a, b, c;
	struct wheel_geom g;

	equal_wheels(p, &w);
	w.R[3] *= 1.1;
	memset(&a, 0x5a, sizeof(a));
	memset(&b, 0x5a, sizeof(b));
	assert_int_equal(dyn_state_space_layout(p, &w, NULL, &a), 0);
	dyn_state_space_wheels(p, &w, &b);
	assert_memory_equal(&a, &b, sizeof(a));
	/* the paper's rows given as a layout: the same matrices to rounding */
	wheel_geom_paper(p->d, &g);
	assert_int_equal(dyn_state_space_layout(p, &w, &g, &c), 0);
	for (int k = 0; k < 3; k++) {
		for (int j = 0; j < 3; j++)
			near_rel(c.A[k][j], b.A[k][j], fabs(b.A[2][2]));
		for (int j = 0; j < 4; j++)
			near_rel(c.B[k][j], b.B[k][j], fabs(b.B[2][0]));
	}
	/* a layout that does not drive the body: refused, ss untouched */
	g.n = 5;
	memset(&c, 0x5a, sizeof(c));
	assert_int_equal(dyn_state_space_layout(p, &w, &g, &c), -EINVAL);
	memset(&b, 0x5a, sizeof(b));
	assert_memory_equal(&b, &c, sizeof(c));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_three_equal_wheels_closed_form),
	    cmocka_unit_test(test_asymmetric_four_by_hand),
	    cmocka_unit_test(test_no_layout_is_the_paper_bits),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
