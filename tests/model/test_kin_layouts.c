/*
 * Eqs 2-5 in Q16.16 for any layout (kinematics.h: kin_rows_q16_init, ik_rows_q16, fk_rows_q16)
 * against the geometry written out here (rows -sin a, cos a, d from the angles; eqs 3-5 as the
 * least-squares inverse (G^T G)^-1 G^T by cofactors), sharing no code with model/. The paper's
 * layout given by its angles must give the closed form's rim speeds to the bit (its rows' 0 and
 * +-1 are exact in Q16.16) and its body velocity to a step.
 */
#include "omni4_test.h"

#include "layout_by_hand.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>

#include "omni4/model/kinematics.h"
#include "omni4/model/q16.h"
#include "omni4/model/rng.h"
#include "omni4/model/wheels.h"

#define STEP (1.0 / 65536.0)

/* Rows and the least-squares inverse by hand. */
static void by_hand(const struct layout *L, double G[4][3], double fk[3][4])
{
	double inv[3][3];

	layout_by_hand(L, G, inv);
	for (int r = 0; r < 3; r++)
		for (int j = 0; j < L->n; j++)
			fk[r][j] = inv[r][0] * G[j][0] + inv[r][1] * G[j][1] + inv[r][2] * G[j][2];
}

/* Worst |ik - rows x| and |fk - inverse rims| in Q16.16 steps over random inputs. */
static void check(const struct layout *L, double *ik_steps, double *fk_steps)
{
	struct wheel_geom g;
	struct kin_rows_q16 k;
	struct rng r;
	double G[4][3], fk[3][4];

	assert_int_equal(wheel_geom_angles(L->n, L->angle_deg, L->dist_m, &g), 0);
	assert_int_equal(kin_rows_q16_init(&k, 0.0, &g), 0);
	assert_int_equal(k.n, L->n);
	by_hand(L, G, fk);
	rng_seed(&r, 3);
	for (int n = 0; n < 2000; n++) {
		q16_t xq[3], vq[4], rq[4], bq[3];
		double rims[4];

		for (int m = 0; m < 3; m++)
			xq[m] = q16_from_double(rng_uniform(&r, -3.0, 3.0) * (m < 2 ? 1.0 : 10.0));
		ik_rows_q16(&k, xq, vq);
		for (int j = 0; j < 4; j++) {
			double want = 0.0;

			for (int m = 0; m < 3 && j < L->n; m++)
				want += G[j][m] * q16_to_double(xq[m]);
			*ik_steps = fmax(*ik_steps, fabs(q16_to_double(vq[j]) - want) / STEP);
			rq[j] = q16_from_double(rng_uniform(&r, -3.0, 3.0));
			rims[j] = j < L->n ? q16_to_double(rq[j]) : 0.0;
		}
		fk_rows_q16(&k, rq, bq);
		for (int m = 0; m < 3; m++) {
			double want = 0.0;

			for (int j = 0; j < L->n; j++)
				want += fk[m][j] * rims[j];
			*fk_steps = fmax(*fk_steps, fabs(q16_to_double(bq[m]) - want) / STEP);
		}
		if (L->n == 3)
			assert_true(vq[3] == 0);
	}
}

static void test_three_and_asymmetric_four_against_the_geometry(void **state)
{
	(void)state;
	const struct layout three = {3, {0, 120, 240, 0}, {0.09, 0.09, 0.09, 0}};
	const struct layout robocup = {4, {60, 135, 225, 300}, {0.08, 0.085, 0.085, 0.08}};
	double ik3 = 0, fk3 = 0, ik4 = 0, fk4 = 0;

	check(&three, &ik3, &fk3);
	check(&robocup, &ik4, &fk4);
	printf("Q16.16 against the geometry by hand, worst steps: three wheels eq 2 %.2f, eqs 3-5 "
	       "%.2f; RoboCup four eq 2 %.2f, eqs 3-5 %.2f\n",
	       ik3, fk3, ik4, fk4);
	/* measured 8.4 / 14.3 and 3.7 / 4.5 steps: each coefficient rounded to half a step times
	 * an input of up to 30 rad/s (the d w term: 2.2e-4 m/s at 30 rad/s, as the paper's own d in
	 * Q16.16); bounds at about 2-3x */
	assert_true(ik3 < 30.0 && ik4 < 30.0);
	assert_true(fk3 < 12.0 && fk4 < 12.0);
}

static void test_the_papers_angles_give_its_closed_form(void **state)
{
	(void)state;
	const double d = 0.089, ang[4] = {0, 90, 180, 270}, dist[4] = {d, d, d, d};
	struct wheel_geom g;
	struct kin_rows_q16 general, paper;
	struct rng r;
	double fk_worst = 0.0;

	assert_int_equal(wheel_geom_angles(4, ang, dist, &g), 0);
	assert_int_equal(kin_rows_q16_init(&general, d, &g), 0);
	assert_int_equal(kin_rows_q16_init(&paper, d, NULL), 0);
	assert_int_equal(kin_rows_q16_init(&paper, 0.0, NULL), -EINVAL);
	assert_int_equal(kin_rows_q16_init(&paper, d, NULL), 0);
	rng_seed(&r, 4);
	for (int n = 0; n < 5000; n++) {
		q16_t xq[3], v1[4], v2[4], x1[3], x2[3];

		for (int m = 0; m < 3; m++)
			xq[m] = q16_from_double(rng_uniform(&r, -3.0, 3.0) * (m < 2 ? 1.0 : 10.0));
		ik_rows_q16(&general, xq, v1);
		ik_rows_q16(&paper, xq, v2);
		assert_memory_equal(v1, v2, sizeof(v1));
		fk_rows_q16(&general, v1, x1);
		fk_rows_q16(&paper, v1, x2);
		for (int m = 0; m < 3; m++)
			fk_worst = fmax(fk_worst, fabs((double)x1[m] - (double)x2[m]));
	}
	printf(
	    "the paper's angles: eq 2 to the bit, eqs 3-5 within %.0f steps of the closed form\n",
	    fk_worst);
	assert_true(fk_worst <= 3.0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_three_and_asymmetric_four_against_the_geometry),
	    cmocka_unit_test(test_the_papers_angles_give_its_closed_form),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
