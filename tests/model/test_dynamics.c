/* Tests for model/src/dynamics.c and params.c: eqs 9-13, 21, 25-27 and the paper's numbers. */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/kinematics.h"
#include "omni4/model/params.h"

static void assert_rel(double got, double want, double rel)
{
	if (fabs(got - want) > rel * fabs(want))
		fail_msg("got %.6g, want %.6g (rel tol %.2g)", got, want, rel);
}

/* Section V-D: with the initial estimates R = 3.7007, Bv = 0.477 the paper prints
 * 2 Kt^2 l^2/(r^2 R M) = 3.6676, Bv/M = 0.2041, 12 l Kt/(r R M) = 5.5227 (4 digits). */
static void test_sensitivity_numbers_of_section_V_D(void **state)
{
	(void)state;
	struct model_params p = model_params_table3;
	struct model_ss ss;

	p.R = 3.7007;
	p.Bv = 0.477;
	dyn_state_space(&p, &ss);
	assert_rel(-ss.A_coast[0], 0.2041, 2e-3);
	assert_rel(-(ss.A[0] - ss.A_coast[0]), 3.6676, 2e-3);
	assert_rel(12.0 * ss.B[0][3], 5.5227, 2e-3);
}

static void test_state_space_signs_are_the_derived_ones(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_ss ss;
	const double emf = p->Kt * p->Kv * p->l * p->l / (p->r * p->r * p->R);

	dyn_state_space(p, &ss);
	/* Back-EMF decelerates: every A_ii is more negative than the friction-only term. */
	for (int k = 0; k < 3; k++) {
		assert_true(ss.A[k] < ss.A_coast[k]);
		assert_true(ss.A_coast[k] < 0);
		assert_true(ss.K[k] < 0);
	}
	assert_rel(ss.A[2], -(4 * p->d * p->d * emf / p->J + p->Bw / p->J), 1e-12);
	/* eq 26 layout: v driven by u3 - u1, vn by u0 - u2, w by the sum. */
	assert_true(ss.B[0][3] > 0 && ss.B[0][1] < 0 && ss.B[0][0] == 0 && ss.B[0][2] == 0);
	assert_true(ss.B[1][0] > 0 && ss.B[1][2] < 0 && ss.B[1][1] == 0 && ss.B[1][3] == 0);
	for (int j = 0; j < 4; j++)
		assert_rel(ss.B[2][j], p->l * p->Kt * p->d / (p->r * p->R * p->J), 1e-12);
}

/* The state-space model must equal the chain eqs 21 -> 13 -> 12 -> 9-11 -> 6-8 evaluated
 * step by step at any state and input (an independent path through the equations). */
static void test_state_space_equals_equation_chain(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_ss ss;
	const double x[3] = {0.7, -0.4, 3.0};
	const double u[4] = {5.0, -2.0, 7.5, 11.0};
	double vw[4], i[4], f[4], F[3];

	dyn_state_space(p, &ss);
	ik_wheel_speeds(p->d, x, vw);
	for (int j = 0; j < 4; j++)
		i[j] = motor_current(p, u[j], motor_speed_rad_s(p, vw[j]));
	dyn_wheel_forces(p, i, f);
	dyn_robot_forces(p->d, f, F);
	const double want[3] = {
	    (F[0] - p->Bv * x[0] - p->Cv) / p->M,
	    (F[1] - p->Bvn * x[1] + p->Cvn) / p->M,
	    (F[2] - p->Bw * x[2] - p->Cw) / p->J,
	};
	const double sgn[3] = {1, -1, 1};

	for (int k = 0; k < 3; k++) {
		double dx = ss.A[k] * x[k] + ss.K[k] * sgn[k];

		for (int j = 0; j < 4; j++)
			dx += ss.B[k][j] * u[j];
		assert_rel(dx, want[k], 1e-12);
	}
}

static void test_motor_equation_round_trip(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	const double wm = motor_speed_rad_s(p, 1.3);

	assert_near(wm, 5 * 1.3 / 0.0325, 1e-12);
	assert_near(motor_current(p, motor_voltage(p, 0.8, wm), wm), 0.8, 1e-12);
}

static void test_params_check_rejects_nonsense(void **state)
{
	(void)state;
	int bad = -1;

	assert_int_equal(model_params_check(&model_params_table3, &bad), 0);
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++) {
		const double wrong[] = {NAN, INFINITY, -1.0, i < 8 ? 0.0 : -1e-9};

		for (unsigned w = 0; w < sizeof(wrong) / sizeof(wrong[0]); w++) {
			struct model_params p = model_params_table3;

			*model_params_field(&p, i) = wrong[w];
			bad = -1;
			assert_int_equal(model_params_check(&p, &bad), -EINVAL);
			assert_int_equal(bad, i);
		}
	}
	struct model_params frictionless = model_params_table3;

	frictionless.Cv = 0.0;
	assert_int_equal(model_params_check(&frictionless, NULL), 0);
}

static void test_table3_defaults_are_the_paper_values(void **state)
{
	(void)state;
	const double want[MODEL_PARAMS_COUNT] = {0.089,  0.0325, 5,      0.0259, 0.0259,
	                                         4.3111, 2.34,   0.0228, 0.4978, 0.6763,
	                                         0.0141, 1.8738, 2.2198, 0.1385};

	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		assert_near(model_params_get(&model_params_table3, i), want[i], 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_sensitivity_numbers_of_section_V_D),
	    cmocka_unit_test(test_state_space_signs_are_the_derived_ones),
	    cmocka_unit_test(test_state_space_equals_equation_chain),
	    cmocka_unit_test(test_motor_equation_round_trip),
	    cmocka_unit_test(test_params_check_rejects_nonsense),
	    cmocka_unit_test(test_table3_defaults_are_the_paper_values),
	};

	return cmocka_run_group_tests_name("dynamics", tests, NULL, NULL);
}
