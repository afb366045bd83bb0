/*
 * Tests for the traction limit of the reference shaping (core/src/traction.c, traction.h),
 * against computations written out here:
 * - along v from rest only wheels 1 and 3 push and neither carries load transfer (they sit on
 *   the vn axis): each needs (M a + Cv) / 2 and holds (1 - margin) mu M g / 4, so the largest
 *   acceleration is a* = ((1 - margin) mu M g / 2 - Cv) / M (the slip back-off b multiplies
 *   mu);
 * - any direction: a brute-force bisection over the scale of the step of the force and load of
 *   each wheel (eqs 9-11 least norm, N_j = M g / 4 - M h (a . p_j) / (2 d^2)) written here;
 * - the controller in VELOCITY on a 1 m/s step along v keeps its reference within a*, and with
 *   traction_mu 0 the shaper alone (acc_lin_max) sets the pace.
 */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/core/traction.h"

static const struct model_params *P = &model_params_table3;
static const double G = 9.80665;
static const double MU = 0.6, MARGIN = 0.05, H = 0.04;

static void set(struct traction *t, double h)
{
	struct model_wheels w;

	model_wheels_from_params(P, &w);
	memset(t, 0, sizeof(*t));
	traction_reset(t);
	traction_set(t, P, &w, NULL, MU, MARGIN, h, 1e-3f);
}

/* The step taken from rest toward a[] (a huge acceleration): the acceleration kept. */
static void step_from_rest(struct traction *t, const float a[3], bool slipping, float out[3])
{
	const float prev[3] = {0, 0, 0};
	float ref[3] = {a[0] * 1e-3f, a[1] * 1e-3f, a[2] * 1e-3f};

	memcpy(out, a, 3 * sizeof(float));
	traction_step(t, prev, ref, out, slipping);
	for (int k = 0; k < 3; k++)
		assert_float_equal(ref[k], out[k] * 1e-3f, 1e-9);
}

static void test_along_v_the_largest_acceleration_is_the_hand_figure(void **state)
{
	(void)state;
	struct traction t;
	const float a[3] = {20.0f, 0, 0};
	float kept[3];
	const double hand = ((1 - MARGIN) * MU * P->M * G / 2 - P->Cv) / P->M;

	set(&t, H);
	step_from_rest(&t, a, false, kept);
	print_message("along v: %.4f m/s^2 (hand %.4f)\n", kept[0], hand);
	assert_float_equal(kept[0], hand, 1e-4 * hand);
	/* A small acceleration passes untouched. */
	const float small[3] = {0.5f, 0, 0};

	step_from_rest(&t, small, false, kept);
	assert_true(kept[0] == 0.5f && t.scale == 1.0f);
}

/* Independent: wheel forces and loads of acceleration s a from rest (friction against a). */
static bool holds(double s, const double a[3], double h)
{
	const double sg[3] = {a[0] > 0 ? 1 : (a[0] < 0 ? -1 : 0),
	                      a[1] > 0 ? 1 : (a[1] < 0 ? -1 : 0),
	                      a[2] > 0 ? 1 : (a[2] < 0 ? -1 : 0)};
	const double Fv = P->M * s * a[0] + P->Cv * sg[0], Fvn = P->M * s * a[1] + P->Cvn * sg[1];
	const double T = P->J * s * a[2] + P->Cw * sg[2];
	const double f[4] = {Fvn / 2 + T / (4 * P->d), -Fv / 2 + T / (4 * P->d),
	                     -Fvn / 2 + T / (4 * P->d), Fv / 2 + T / (4 * P->d)};
	const double px[4] = {P->d, 0, -P->d, 0}, py[4] = {0, P->d, 0, -P->d};

	for (int j = 0; j < 4; j++) {
		const double n =
		    P->M * G / 4 - P->M * h * s * (a[0] * px[j] + a[1] * py[j]) / (2 * P->d * P->d);

		if (fabs(f[j]) > (1 - MARGIN) * MU * n)
			return false;
	}
	return true;
}

static void test_every_direction_matches_a_brute_force_bisection(void **state)
{
	(void)state;
	static const double dirs[][3] = {{10, 10, 0}, {-10, 5, 0}, {0, -10, 0},
	                                 {0, 0, 200}, {8, -8, 60}, {3, 12, -40}};

	for (size_t i = 0; i < sizeof(dirs) / sizeof(dirs[0]); i++) {
		struct traction t;
		const float a[3] = {(float)dirs[i][0], (float)dirs[i][1], (float)dirs[i][2]};
		float kept[3];
		double lo = 0, hi = 1;

		set(&t, H);
		step_from_rest(&t, a, false, kept);
		for (int it = 0; it < 60; it++) {
			const double mid = 0.5 * (lo + hi);

			if (holds(mid, dirs[i], H))
				lo = mid;
			else
				hi = mid;
		}
		print_message("direction %zu: scale %.5f (bisection %.5f)\n", i, t.scale, lo);
		assert_float_equal(t.scale, lo, 2e-4);
	}
}

/* Each slipping tick multiplies the traction by TRACTION_BACKOFF down to its floor; gripping,
 * it grows back by dt / TRACTION_RECOVER_S. */
static void test_a_slip_backs_the_limit_off_until_the_wheels_grip(void **state)
{
	(void)state;
	struct traction t;
	const float a[3] = {20.0f, 0, 0};
	float kept[3];

	set(&t, 0.0);
	for (int i = 0; i < 5; i++)
		step_from_rest(&t, a, true, kept);
	double b = pow(0.9, 5);

	assert_float_equal(kept[0], ((1 - MARGIN) * b * MU * P->M * G / 2 - P->Cv) / P->M, 1e-3);
	for (int i = 0; i < 100; i++)
		step_from_rest(&t, a, true, kept);
	assert_float_equal(t.backoff, TRACTION_BACKOFF_MIN, 1e-6);
	step_from_rest(&t, a, false, kept);
	assert_float_equal(t.backoff, TRACTION_BACKOFF_MIN + 1e-3 / TRACTION_RECOVER_S, 1e-6);
	for (int i = 0; i < 400; i++)
		step_from_rest(&t, a, false, kept);
	assert_float_equal(t.backoff, 1.0, 1e-6);
}

/* The voltage clamp: at rim speed s a wheel's motor pushes l Kt (u - Kv l s / r) / (R r)
 * (eqs 12-13, 21): the clamp keeps that within the hold, (1 - margin) mu M g / 4 at rest. */
static void test_the_voltage_clamp_keeps_each_motor_force_within_the_hold(void **state)
{
	(void)state;
	struct traction t;
	const float zero[3] = {0, 0, 0}, rim[4] = {0.0f, 0.5f, -1.0f, 0.1f};
	float u[4] = {12, 12, -12, 0.5f}, taken[4];
	const double hold = (1 - MARGIN) * MU * P->M * G / 4;

	set(&t, 0.0);
	traction_clamp_volts(&t, zero, zero, rim, u, taken);
	for (int j = 0; j < 3; j++) {
		const double f =
		    P->l * P->Kt * (u[j] - P->Kv * P->l * rim[j] / P->r) / (P->R * P->r);

		assert_float_equal(fabs(f), hold, 1e-4 * hold);
		assert_true(taken[j] != 0.0f);
	}
	assert_true(u[3] == 0.5f && taken[3] == 0.0f); /* within: untouched */
}

/* The controller: a 1 m/s VELOCITY step along v ramps its reference at a* (traction_mu set),
 * or at acc_lin_max (traction_mu 0, the limit off). */
static double reference_rate(double mu)
{
	struct ctl_settings s;
	static struct ctl c;
	struct ctl_output out;
	const struct motor_sample m = {.supply_v = 12};
	const struct ctl_command cmd = {.mode = CTL_VELOCITY, .velocity = {1, 0, 0}};

	ctl_settings_defaults(&s);
	s.limits.acc_lin_max = 20;
	s.limits.traction_mu = mu;
	s.limits.traction_margin = MARGIN;
	assert_int_equal(ctl_init(&c, &s), 0);
	assert_int_equal(ctl_command(&c, &cmd, 0), 0);
	for (int i = 1; i <= 50; i++)
		ctl_step(&c, i * 1000, &m, 0, false, &out);
	return c.shaper.ref[0] / 0.05;
}

static void test_the_controller_ramps_at_the_limit_and_can_switch_it_off(void **state)
{
	(void)state;
	/* v' = a0 - (Bv / M) v from rest: v(T) = a0 M / Bv (1 - exp(-Bv T / M)), T = 50 ms. */
	const double a0 = ((1 - MARGIN) * MU * P->M * G / 2 - P->Cv) / P->M;
	const double hand = a0 * P->M / P->Bv * (1 - exp(-P->Bv * 0.05 / P->M)) / 0.05;

	assert_float_equal(reference_rate(MU), hand, 1e-3 * hand);
	assert_float_equal(reference_rate(0.0), 20.0, 1e-3);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_along_v_the_largest_acceleration_is_the_hand_figure),
	    cmocka_unit_test(test_every_direction_matches_a_brute_force_bisection),
	    cmocka_unit_test(test_a_slip_backs_the_limit_off_until_the_wheels_grip),
	    cmocka_unit_test(test_the_voltage_clamp_keeps_each_motor_force_within_the_hold),
	    cmocka_unit_test(test_the_controller_ramps_at_the_limit_and_can_switch_it_off),
	};

	return cmocka_run_group_tests_name("traction", tests, NULL, NULL);
}
