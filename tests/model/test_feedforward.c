/* Tests for model/src/feedforward.c and feedforward_q16.c. */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/plant.h"
#include "omni4/model/rng.h"

static const struct model_params *P = &model_params_table3;

/* Bound on |u_q16 - u_double| over the envelope, in volts. */
#define FF_Q16_BOUND_V 2e-3

static double ff_q16_error(const struct ff_q16 *ff, const double vel[3], const double acc[3])
{
	const q16_t vq[3] = {q16_from_double(vel[0]), q16_from_double(vel[1]),
	                     q16_from_double(vel[2])};
	const q16_t aq[3] = {q16_from_double(acc[0]), q16_from_double(acc[1]),
	                     q16_from_double(acc[2])};
	double u[4], worst = 0;
	q16_t uq[4];

	ff_voltages(P, vel, acc, 12.0, u);
	ff_voltages_q16(ff, vq, aq, uq);
	for (int j = 0; j < 4; j++) {
		const double e = fabs(q16_to_double(uq[j]) - u[j]);

		worst = e > worst ? e : worst;
	}
	return worst;
}

static void test_ff_q16_within_bound_of_double_over_envelope(void **state)
{
	(void)state;
	struct ff_q16 ff;
	struct rng g;
	double worst = 0;
	const double lim[6] = {3, 3, 20, 10, 10, 10};

	assert_int_equal(ff_q16_init(&ff, P, 12.0), 0);
	/* Every corner and face centre of the 6-D box. */
	for (int c = 0; c < 729; c++) {
		double z[6];

		for (int k = 0, m = c; k < 6; k++, m /= 3)
			z[k] = (m % 3 - 1) * lim[k];
		const double e = ff_q16_error(&ff, z, z + 3);

		worst = e > worst ? e : worst;
	}
	/* Random points, half of them inside the sign dead band where the slope is steepest. */
	rng_seed(&g, 11);
	for (int n = 0; n < 200000; n++) {
		double z[6];

		for (int k = 0; k < 6; k++) {
			const double s = (k < 3 && (n & 1)) ? (k < 2 ? 0.01 : 0.1) : lim[k];

			z[k] = rng_uniform(&g, -s, s);
		}
		const double e = ff_q16_error(&ff, z, z + 3);

		worst = e > worst ? e : worst;
	}
	print_message("feedforward q16 vs double: max |du| = %.3g V over |v|,|vn|<=3 m/s, "
	              "|w|<=20 rad/s, |a|<=10 (bound %.3g V)\n",
	              worst, FF_Q16_BOUND_V);
	assert_true(worst <= FF_Q16_BOUND_V);
}

/* The same sum in double from the Q16.16 gains: what the integer code must equal within its
 * rounding (3 products per axis, 2 axes per wheel: 3 LSB), clamped once to +-u_max. */
static double ff_q16_reference(const struct ff_q16 *ff, const q16_t vq[3], const q16_t aq[3], int j)
{
	double h[3];

	for (int k = 0; k < 3; k++) {
		double sgn = (double)vq[k] * ff->sgn_gain[k] / Q16_ONE;

		sgn = sgn > 1 ? 1 : (sgn < -1 ? -1 : sgn);
		h[k] = (q16_to_double(ff->k_acc[k]) * q16_to_double(aq[k]) +
		        q16_to_double(ff->k_vel[k]) * q16_to_double(vq[k]) +
		        q16_to_double(ff->k_coul[k]) * sgn);
	}
	const double u[4] = {h[1] + h[2], h[2] - h[0], h[2] - h[1], h[0] + h[2]};
	const double um = q16_to_double(ff->u_max);

	return u[j] > um ? um : (u[j] < -um ? -um : u[j]);
}

/* Any int32 input, up to the format's ends: no intermediate wraps (the sums are int64; UBSan
 * in the asan preset would flag an overflow), and the result is the exact sum clamped once. */
static void test_ff_q16_full_input_range_never_wraps(void **state)
{
	(void)state;
	struct ff_q16 ff;
	struct rng g;
	const q16_t ends[5] = {Q16_MIN, -Q16_ONE, 0, Q16_ONE, Q16_MAX};
	const int p5[6] = {1, 5, 25, 125, 625, 3125}; /* n < 5^6: every corner of the 6-D box */
	double worst = 0;

	assert_int_equal(ff_q16_init(&ff, P, 1000.0), 0); /* wide rail: the clamp rarely hides */
	rng_seed(&g, 5);
	for (int n = 0; n < 200000; n++) {
		q16_t vq[3], aq[3], uq[4];

		for (int k = 0; k < 3; k++) {
			vq[k] = n < 15625 ? ends[(n / p5[k]) % 5]
			                  : (q16_t)(rng_uniform(&g, -2147483648.0, 2147483647.0));
			aq[k] = n < 15625 ? ends[(n / p5[k + 3]) % 5]
			                  : (q16_t)(rng_uniform(&g, -2147483648.0, 2147483647.0));
			if (n >= 15625 && (n & 1)) { /* half of them near the velocity envelope */
				vq[k] >>= 12;
				aq[k] >>= 12;
			}
		}
		ff_voltages_q16(&ff, vq, aq, uq);
		for (int j = 0; j < 4; j++) {
			const double e =
			    fabs(q16_to_double(uq[j]) - ff_q16_reference(&ff, vq, aq, j));

			worst = e > worst ? e : worst;
		}
	}
	print_message("feedforward q16 over the whole int32 input range: max |du| vs exact = %.3g "
	              "LSB\n",
	              worst * Q16_ONE);
	assert_true(worst * Q16_ONE <= 3.0);
}

static void test_ff_clamps_to_supply(void **state)
{
	(void)state;
	struct ff_q16 ff;
	const double vel[3] = {3, 0, 20}, acc[3] = {10, 0, 10};
	double u[4];
	q16_t uq[4];
	const q16_t vq[3] = {q16_from_double(3), 0, q16_from_double(20)};
	const q16_t aq[3] = {q16_from_double(10), 0, q16_from_double(10)};

	assert_int_equal(ff_q16_init(&ff, P, 12.0), 0);
	ff_voltages(P, vel, acc, 12.0, u);
	ff_voltages_q16(&ff, vq, aq, uq);
	assert_near(u[3], 12.0, 0);
	assert_int_equal(uq[3], q16_from_double(12.0));
	assert_int_equal(ff_q16_init(&ff, P, 0.0), -EINVAL);
	assert_int_equal(ff_q16_init(&ff, P, NAN), -EINVAL);
}

/* Constant desired velocity: the ff voltages make x a fixed point of eq 23 (derived signs). */
static void test_ff_steady_velocity_is_an_equilibrium_of_eq23(void **state)
{
	(void)state;
	struct model_ss ss;
	const double vel[3] = {0.8, -0.5, 4.0}, acc[3] = {0, 0, 0};
	double u[4];

	dyn_state_space(P, &ss);
	ff_voltages(P, vel, acc, 100.0, u);
	for (int k = 0; k < 3; k++) {
		double dx = ss.A[k] * vel[k] + ss.K[k] * (vel[k] > 0 ? 1 : -1);

		for (int j = 0; j < 4; j++)
			dx += ss.B[k][j] * u[j];
		assert_near(dx, 0.0, 1e-12);
	}
}

/* Desired profile: smooth ramps up, cruise, reverse (all three axes at once). */
static void profile(double t, double vel[3], double acc[3])
{
	const double amp[3] = {1.0, 0.6, 6.0};
	const double wn = 2 * M_PI * 0.25;

	for (int k = 0; k < 3; k++) {
		vel[k] = amp[k] * sin(wn * t + k);
		acc[k] = amp[k] * wn * cos(wn * t + k);
	}
}

static void test_ff_alone_makes_the_plant_follow_a_profile(void **state)
{
	(void)state;
	struct plant pl;
	struct ff_q16 ff;
	const double dt = 1e-3, T = 8.0;
	double sq[3] = {0}, worst[3] = {0};
	long n = 0;

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(ff_q16_init(&ff, P, 12.0), 0);
	profile(0, pl.x, (double[3]){0});
	for (double t = 0; t < T; t += dt, n++) {
		double vel[3], acc[3], u[4];
		q16_t vq[3], aq[3], uq[4];

		/* Zero-order hold: aim at the mid-step state. */
		profile(t + dt / 2, vel, acc);
		for (int k = 0; k < 3; k++) {
			vq[k] = q16_from_double(vel[k]);
			aq[k] = q16_from_double(acc[k]);
		}
		ff_voltages_q16(&ff, vq, aq, uq);
		for (int j = 0; j < 4; j++)
			u[j] = q16_to_double(uq[j]);
		plant_step(&pl, u, true, dt);
		profile(t + dt, vel, acc);
		for (int k = 0; k < 3; k++) {
			const double e = fabs(pl.x[k] - vel[k]);

			sq[k] += e * e;
			worst[k] = e > worst[k] ? e : worst[k];
		}
	}
	print_message("feedforward only, open loop, %.0f s: RMS error v %.4f m/s, vn %.4f m/s, "
	              "w %.4f rad/s; max %.4f, %.4f, %.4f\n",
	              T, sqrt(sq[0] / n), sqrt(sq[1] / n), sqrt(sq[2] / n), worst[0], worst[1],
	              worst[2]);
	/* 2.5x the measured RMS 0.0005, 0.0014, 0.0056 and max 0.0025, 0.0049, 0.0257 */
	assert_true(sqrt(sq[0] / n) < 0.0013 && sqrt(sq[1] / n) < 0.0035 &&
	            sqrt(sq[2] / n) < 0.014);
	assert_true(worst[0] < 0.0065 && worst[1] < 0.0125 && worst[2] < 0.065);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_ff_q16_within_bound_of_double_over_envelope),
	    cmocka_unit_test(test_ff_q16_full_input_range_never_wraps),
	    cmocka_unit_test(test_ff_clamps_to_supply),
	    cmocka_unit_test(test_ff_steady_velocity_is_an_equilibrium_of_eq23),
	    cmocka_unit_test(test_ff_alone_makes_the_plant_follow_a_profile),
	};

	return cmocka_run_group_tests_name("feedforward", tests, NULL, NULL);
}
