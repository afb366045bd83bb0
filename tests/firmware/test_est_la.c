/* The core's small mathematics (core/ la_f32.h) against independent computations: libm's sin,
 * cos and fmod in double, and a 3 x 3 solve by Cramer's rule in double. Figures printed; the
 * tolerances are 2-3x the measured errors. */
#include "omni4_test.h"

#include <errno.h>
#include <stdio.h>

#include "omni4/core/la_f32.h"
#include "omni4/model/consts.h"
#include "omni4/model/rng.h"

#define PI 3.14159265358979323846
#define SINCOS_TOL 1e-6 /* measured 3.7e-7 */
#define WRAP_TOL 2e-6   /* measured 7e-7 */
#define SOLVE_TOL 6e-7  /* relative, measured 2.2e-7 */

static void test_sin_cos_matches_libm_over_the_wrapped_range(void **state)
{
	(void)state;
	double worst = 0.0;

	for (int i = -40000; i <= 40000; i++) {
		const float a = (float)(i * (PI + 0.01) / 40000.0);
		float s, c;

		la_sin_cos_f32(a, &s, &c);
		const double es = fabs(s - sin((double)a)), ec = fabs(c - cos((double)a));

		worst = fmax(worst, fmax(es, ec));
		assert_near(s, sin((double)a), SINCOS_TOL);
		assert_near(c, cos((double)a), SINCOS_TOL);
	}
	printf("sin_cos: worst error %.2g against libm (double) on [-pi-0.01, pi+0.01]\n", worst);
}

static void test_wrap_lands_in_minus_pi_to_pi(void **state)
{
	(void)state;
	double worst = 0.0;

	for (int i = -2000; i <= 2000; i++) {
		const float a = (float)(i * 0.0137);
		const float w = model_wrap_pi_f32(a);
		double want = fmod((double)a + PI, 2.0 * PI);

		want = (want < 0.0 ? want + 2.0 * PI : want) - PI;
		assert_true(w > -(float)PI && w <= (float)PI);
		/* near +-pi both ends name the same angle */
		double err = fabs(w - want);

		err = fmin(err, fabs(fabs(w - want) - 2.0 * PI));
		worst = fmax(worst, err);
		assert_true(err <= WRAP_TOL);
	}
	assert_true(model_wrap_pi_f32((float)PI) == (float)PI);
	assert_true(model_wrap_pi_f32(-(float)PI) == (float)PI); /* -pi is outside (-pi, pi] */
	assert_true(isnan(model_wrap_pi_f32(NAN)));
	printf("wrap: worst error %.2g against fmod (double)\n", worst);
}

/* det of [c0 c1 c2] (columns) in double */
static double det3(const double m[3][3])
{
	return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
	       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
	       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* x = M^-1 b by Cramer's rule. */
static void cramer(const double M[3][3], const double b[3], double x[3])
{
	const double d = det3(M);

	for (int k = 0; k < 3; k++) {
		double Mk[3][3];

		for (int i = 0; i < 3; i++)
			for (int j = 0; j < 3; j++)
				Mk[i][j] = j == k ? b[i] : M[i][j];
		x[k] = det3(Mk) / d;
	}
}

static void test_chol_solve_and_norm_match_cramer(void **state)
{
	(void)state;
	struct rng r;
	double worst = 0.0;

	rng_seed(&r, 7);
	for (int n = 0; n < 2000; n++) {
		double G[3][3], M[3][3], b[3], x[3];
		float A[6], bf[3], xf[3], L[6];
		int m = 0;

		for (int i = 0; i < 3; i++)
			for (int j = 0; j < 3; j++)
				G[i][j] = rng_uniform(&r, -1.0, 1.0);
		for (int i = 0; i < 3; i++) { /* M = G G^T + 0.1 I + ridge: symmetric, definite */
			for (int j = 0; j < 3; j++)
				M[i][j] = G[i][0] * G[j][0] + G[i][1] * G[j][1] +
				          G[i][2] * G[j][2] + (i == j ? 0.1 : 0.0);
			b[i] = rng_uniform(&r, -1.0, 1.0);
			bf[i] = (float)b[i];
		}
		for (int i = 0; i < 3; i++)
			for (int j = i; j < 3; j++)
				A[m++] = (float)M[i][j];
		for (int i = 0; i < 3; i++) /* the ridge: added by la_chol3_f32 */
			M[i][i] += 0.5;
		for (int i = 0; i < 3; i++)
			b[i] = bf[i];
		assert_int_equal(la_chol3_f32(A, 0.5f, L), 0);
		la_chol3_solve_f32(L, bf, xf);
		cramer(M, b, x);
		const double scale = fabs(x[0]) + fabs(x[1]) + fabs(x[2]);
		const double q = b[0] * x[0] + b[1] * x[1] + b[2] * x[2]; /* b^T M^-1 b */

		for (int k = 0; k < 3; k++) {
			worst = fmax(worst, fabs(xf[k] - x[k]) / scale);
			assert_near(xf[k], x[k], SOLVE_TOL * scale);
		}
		assert_near(la_chol3_norm2_f32(L, bf), q, SOLVE_TOL * fabs(q));
	}
	printf("chol3: worst relative error %.2g against Cramer's rule (double)\n", worst);
}

static void test_chol_refuses_an_indefinite_or_nan_matrix(void **state)
{
	(void)state;
	const float indefinite[6] = {1.0f, 2.0f, 0.0f, 1.0f, 0.0f, 1.0f}; /* [[1 2] [2 1]] */
	const float with_nan[6] = {1.0f, 0.0f, 0.0f, NAN, 0.0f, 1.0f};
	const float zero[6] = {0};
	float L[6];

	assert_int_equal(la_chol3_f32(indefinite, 0.0f, L), -EDOM);
	assert_int_equal(la_chol3_f32(with_nan, 0.0f, L), -EDOM);
	assert_int_equal(la_chol3_f32(zero, 0.0f, L), -EDOM);
	assert_int_equal(la_chol3_f32(zero, 1.0f, L), 0); /* the ridge makes it definite */
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_sin_cos_matches_libm_over_the_wrapped_range),
	    cmocka_unit_test(test_wrap_lands_in_minus_pi_to_pi),
	    cmocka_unit_test(test_chol_solve_and_norm_match_cramer),
	    cmocka_unit_test(test_chol_refuses_an_indefinite_or_nan_matrix),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
