/* Tests for model/src/kinematics.c and kinematics_q16.c: eqs 1-5, fixed vs double. */
#include "omni4_test.h"

#include <float.h>
#include <math.h>

#include "omni4/model/kinematics.h"
#include "omni4/model/params.h"
#include "omni4/model/rng.h"

static const double d = 0.089;

static void test_ik_rows_match_eq2(void **state)
{
	(void)state;
	/* Unit inputs pick the columns of the eq 2 matrix. */
	const double cols[3][4] = {{0, -1, 0, 1}, {1, 0, -1, 0}, {d, d, d, d}};

	for (int c = 0; c < 3; c++) {
		double x[3] = {0, 0, 0}, v[4];

		x[c] = 1.0;
		ik_wheel_speeds(d, x, v);
		for (int j = 0; j < 4; j++)
			assert_near(v[j], cols[c][j], 1e-15);
	}
}

static void test_ik_fk_round_trip_within_1e12(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 42);
	for (int n = 0; n < 10000; n++) {
		const double x[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                     rng_uniform(&g, -20, 20)};
		double v[4], y[3];

		ik_wheel_speeds(d, x, v);
		fk_robot_velocity(d, v, y);
		for (int k = 0; k < 3; k++)
			assert_near(x[k], y[k], 1e-12);
	}
}

static void test_fk_is_least_squares_inverse_of_ik(void **state)
{
	(void)state;
	/* eqs 3-5 equal (G^T G)^-1 G^T for G the eq 2 matrix: G^T G = diag(2, 2, 4 d^2). A wheel
	 * speed vector outside the range of G maps to the x minimising |G x - v|: the residual is
	 * orthogonal to every column of G. */
	struct rng g;

	rng_seed(&g, 7);
	for (int n = 0; n < 1000; n++) {
		double v[4], x[3], vv[4];

		for (int j = 0; j < 4; j++)
			v[j] = rng_uniform(&g, -2, 2);
		fk_robot_velocity(d, v, x);
		ik_wheel_speeds(d, x, vv);
		const double res[4] = {v[0] - vv[0], v[1] - vv[1], v[2] - vv[2], v[3] - vv[3]};

		assert_near(-res[1] + res[3], 0.0, 1e-12);
		assert_near(res[0] - res[2], 0.0, 1e-12);
		assert_near(d * (res[0] + res[1] + res[2] + res[3]), 0.0, 1e-12);
	}
}

static void test_frame_rotation_round_trip_and_closed_form(void **state)
{
	(void)state;
	const double xw[3] = {1.0, 0.0, 0.3};
	double xr[3], back[3];

	/* Heading +90 deg: world +x is the robot's -vn. */
	frame_world_to_robot(M_PI / 2, xw, xr);
	assert_near(xr[0], 0.0, 1e-12);
	assert_near(xr[1], -1.0, 1e-12);
	assert_near(xr[2], 0.3, 0);
	frame_robot_to_world(M_PI / 2, xr, back);
	for (int k = 0; k < 3; k++)
		assert_near(back[k], xw[k], 1e-12);
}

static void test_ik_q16_matches_double_within_12_lsb(void **state)
{
	(void)state;
	struct rng g;
	const q16_t dq = q16_from_double(d);
	double worst = 0;

	rng_seed(&g, 3);
	for (int n = 0; n < 100000; n++) {
		const double x[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                     rng_uniform(&g, -20, 20)};
		const q16_t xq[3] = {q16_from_double(x[0]), q16_from_double(x[1]),
		                     q16_from_double(x[2])};
		double v[4];
		q16_t vq[4];

		ik_wheel_speeds(d, x, v);
		ik_wheel_speeds_q16(dq, xq, vq);
		for (int j = 0; j < 4; j++) {
			const double e = fabs(q16_to_double(vq[j]) - v[j]);

			worst = e > worst ? e : worst;
		}
	}
	/* Quantisation of d (0.5 LSB) times |w| <= 20 plus rounding: < 12 LSB. */
	print_message("ik q16 vs double: max |error| = %.3g m/s (%.1f LSB)\n", worst,
	              worst * Q16_ONE);
	assert_true(worst < 12.0 / Q16_ONE);
}

static void test_fk_q16_matches_double(void **state)
{
	(void)state;
	struct rng g;
	const q16_t inv4d = q16_from_double(1.0 / (4 * d));
	double worst = 0;

	rng_seed(&g, 5);
	for (int n = 0; n < 100000; n++) {
		double v[4], x[3];
		q16_t vq[4], xq[3];

		for (int j = 0; j < 4; j++) {
			v[j] = rng_uniform(&g, -5, 5);
			vq[j] = q16_from_double(v[j]);
			v[j] = q16_to_double(vq[j]);
		}
		fk_robot_velocity(d, v, x);
		fk_robot_velocity_q16(inv4d, vq, xq);
		for (int k = 0; k < 3; k++) {
			const double e = fabs(q16_to_double(xq[k]) - x[k]);

			worst = e > worst ? e : worst;
		}
	}
	print_message("fk q16 vs double: max |error| = %.3g\n", worst);
	/* w: 20 m/s sum x 0.5 LSB of 1/(4d) relative; measured 3.81e-5, bound 2.6x */
	assert_true(worst < 1e-4);
}

static void test_q16_saturates_instead_of_wrapping(void **state)
{
	(void)state;
	const q16_t big = q16_from_double(30000.0);

	assert_int_equal(q16_add(big, big), Q16_MAX);
	assert_int_equal(q16_sub(q16_neg(big), big), Q16_MIN);
	assert_int_equal(q16_mul(big, big), Q16_MAX);
	assert_int_equal(q16_mul(big, q16_neg(big)), Q16_MIN);
	assert_int_equal(q16_neg(Q16_MIN), Q16_MAX);
	assert_int_equal(q16_from_double(NAN), 0);
	assert_int_equal(q16_from_double(1e12), Q16_MAX);

	const q16_t x[3] = {Q16_MAX, Q16_MIN, Q16_MAX};
	q16_t v[4];

	/* Each wheel is the exact sum, saturated once: d*w = 2^30 m/s dominates every row. */
	ik_wheel_speeds_q16(Q16_MAX, x, v);
	for (int j = 0; j < 4; j++)
		assert_int_equal(v[j], Q16_MAX);
	ik_wheel_speeds_q16(Q16_MAX, (q16_t[3]){Q16_MAX, Q16_MIN, Q16_MIN}, v);
	for (int j = 0; j < 4; j++)
		assert_int_equal(v[j], Q16_MIN);
	/* d*w small: the rows saturate only where the exact value is out of range. */
	ik_wheel_speeds_q16(Q16_ONE / 4, (q16_t[3]){Q16_MAX, Q16_MIN, 4 * Q16_ONE}, v);
	assert_int_equal(v[0], Q16_MIN + Q16_ONE); /* -32768 + 1 */
	assert_int_equal(v[1], Q16_ONE - Q16_MAX); /* 1 - 32767.99998 */
	assert_int_equal(v[2], Q16_MAX);           /* 1 + 32768 */
	assert_int_equal(v[3], Q16_MAX);           /* 32767.99998 + 1 */
}

/* The single-precision twins against the double ones (an independent computation in double):
 * within a few float ulps of the result's size (measured: 1 ulp). */
static void test_f32_twins_match_double_within_4_ulp(void **state)
{
	(void)state;
	for (int k = 0; k < 200; k++) {
		const double x[3] = {sin(0.37 * k) * 2.0, cos(0.23 * k) * 1.5,
		                     sin(0.11 * k + 1) * 9.0};
		const float xf[3] = {(float)x[0], (float)x[1], (float)x[2]};
		double v[4], back[3];
		float vf[4], backf[3];

		ik_wheel_speeds(d, (const double[3]){xf[0], xf[1], xf[2]}, v);
		ik_wheel_speeds_f32((float)d, xf, vf);
		for (int j = 0; j < 4; j++)
			assert_near(vf[j], v[j], 4 * FLT_EPSILON * (fabs(v[j]) + 2.0));
		fk_robot_velocity(d, (const double[4]){vf[0], vf[1], vf[2], vf[3]}, back);
		fk_robot_velocity_f32((float)d, vf, backf);
		for (int c = 0; c < 3; c++)
			assert_near(backf[c], back[c],
			            4 * FLT_EPSILON * (fabs(back[c]) + 2.0) / (c == 2 ? d : 1.0));
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_ik_rows_match_eq2),
	    cmocka_unit_test(test_ik_fk_round_trip_within_1e12),
	    cmocka_unit_test(test_fk_is_least_squares_inverse_of_ik),
	    cmocka_unit_test(test_frame_rotation_round_trip_and_closed_form),
	    cmocka_unit_test(test_ik_q16_matches_double_within_12_lsb),
	    cmocka_unit_test(test_fk_q16_matches_double),
	    cmocka_unit_test(test_q16_saturates_instead_of_wrapping),
	    cmocka_unit_test(test_f32_twins_match_double_within_4_ulp),
	};

	return cmocka_run_group_tests_name("kinematics", tests, NULL, NULL);
}
