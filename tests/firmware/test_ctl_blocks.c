/* Tests for core/src/ctl_blocks.c on their own: the PI, the ramp and the reference shaper,
 * against closed forms computed here in double. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "omni4/core/ctl_blocks.h"

#define near(a, b, tol) assert_true(fabs((double)(a) - (double)(b)) <= (tol))

/* Constant error e below saturation: u_n = ff + kp e + n ki dt e (the integral after n steps). */
static void test_pi_is_p_plus_integral(void **state)
{
	(void)state;
	struct ctl_pi pi;
	const double kp = 20, ki = 200, dt = 1e-3, e = 0.01, ff = 1.5;

	ctl_pi_init(&pi, (float)kp, (float)ki, (float)dt, 12.0f);
	for (int n = 1; n <= 1000; n++) {
		const float u = ctl_pi_step(&pi, (float)ff, (float)e);

		near(u, ff + kp * e + n * ki * dt * e, 1e-5 * n);
	}
	near(pi.integ, 1000 * ki * dt * e, 1e-3); /* 2 V */
	ctl_pi_reset(&pi);
	assert_true(pi.integ == 0.0f);
	near(ctl_pi_step(&pi, 0, (float)-e), -kp * e - ki * dt * e, 1e-6);
	/* New gains keep the integral. */
	const float integ = pi.integ;

	ctl_pi_set_gains(&pi, 40.0f, 0.0f, (float)dt, 12.0f);
	near(ctl_pi_step(&pi, 0, (float)e), 40 * e + integ, 1e-6);
	assert_true(pi.integ == integ);
}

/* Saturated in the direction of the error: the output holds at the limit and the integral
 * stops; it integrates again as soon as the error turns. */
static void test_pi_antiwindup_and_clamp(void **state)
{
	(void)state;
	struct ctl_pi pi;

	ctl_pi_init(&pi, 20.0f, 200.0f, 1e-3f, 12.0f);
	float u = 0;

	for (int n = 0; n < 5000; n++)
		u = ctl_pi_step(&pi, 10.0f,
		                0.3f); /* ff 10 V + 6 V: saturated from the first step */
	assert_true(u == 12.0f);
	near(pi.integ, 0.0, 1e-6); /* never integrated: saturated from the start */
	u = ctl_pi_step(&pi, 10.0f, -0.05f);
	near(u, 10.0 - 1.0 - 200 * 1e-3 * 0.05, 1e-5);
	near(pi.integ, -0.01, 1e-6);
	/* The integral itself stays within the limit. */
	ctl_pi_init(&pi, 0.0f, 1e6f, 1e-3f, 12.0f);
	for (int n = 0; n < 10; n++)
		ctl_pi_step(&pi, 0.0f, -1.0f);
	assert_true(pi.integ == -12.0f);
}

/* Linear from `from` to `to`: at t0 + k/len of the way, exactly `to` from len on. */
static void test_ramp_is_linear_and_ends_on_time(void **state)
{
	(void)state;
	struct ctl_ramp r;
	const float from[4] = {0, 1, -2, 3}, to[4] = {6, -1, 2, 3};
	float out[4];

	ctl_ramp_start(&r, from, to, 0.2f, 1000000);
	assert_false(ctl_ramp_step(&r, 1000000, out));
	for (int j = 0; j < 4; j++)
		assert_true(out[j] == from[j]);
	assert_false(ctl_ramp_step(&r, 1050000, out));
	for (int j = 0; j < 4; j++)
		near(out[j], from[j] + 0.25 * (to[j] - from[j]), 1e-6);
	assert_false(ctl_ramp_step(&r, 1199000, out)); /* one tick before the end */
	assert_true(ctl_ramp_step(&r, 1200000, out));  /* the end, 200 ms after the start */
	for (int j = 0; j < 4; j++)
		assert_true(out[j] == to[j]);
	ctl_ramp_start(&r, from, to, 0.0f, 5); /* zero length: there at once */
	assert_true(ctl_ramp_step(&r, 5, out));
	assert_true(out[0] == 6.0f);
	ctl_ramp_start(&r, from, to, 0.2f, 1000000); /* reset in the middle of a ramp */
	ctl_ramp_reset(&r, from);
	for (int64_t t = 0; t <= 2000000; t += 1000000) {
		assert_true(ctl_ramp_step(&r, t, out)); /* done at any time, holding `from` */
		for (int j = 0; j < 4; j++)
			assert_true(out[j] == from[j]);
	}
}

/* A step of the target is followed at acc_max: |delta| / (acc_max dt) steps, the last one
 * partial, with acc = step / dt; bumpless reset starts from the given reference. */
static void test_shaper_follows_at_the_rate_limit(void **state)
{
	(void)state;
	struct ctl_shaper s;
	const float acc_max[3] = {3.0f, 3.0f, 30.0f}, target[3] = {1.0f, -0.5f, 4.0f};

	ctl_shaper_init(&s, acc_max, 1e-3f);
	int steps[3] = {0, 0, 0};

	for (int n = 1; n <= 1000; n++) {
		ctl_shaper_step(&s, target);
		for (int k = 0; k < 3; k++) {
			if (!steps[k] && s.ref[k] == target[k])
				steps[k] = n;
			if (n == 1)
				near(s.acc[k], copysign(acc_max[k], target[k]), 1e-3);
		}
	}
	/* 1 / 0.003 = 333.3 -> 334 steps; 0.5 / 0.003 -> 167; 4 / 0.03 = 133.3 -> 134 */
	assert_in_range(steps[0], 333, 335);
	assert_in_range(steps[1], 166, 168);
	assert_in_range(steps[2], 133, 135);
	for (int k = 0; k < 3; k++)
		assert_true(s.acc[k] == 0.0f);
	const float start[3] = {0.2f, 0.0f, -1.0f};

	ctl_shaper_reset(&s, start);
	assert_true(s.ref[0] == 0.2f && s.ref[2] == -1.0f && s.acc[0] == 0.0f);
	ctl_shaper_step(&s, start);
	assert_true(s.ref[0] == 0.2f && s.acc[0] == 0.0f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_pi_is_p_plus_integral),
	    cmocka_unit_test(test_pi_antiwindup_and_clamp),
	    cmocka_unit_test(test_ramp_is_linear_and_ends_on_time),
	    cmocka_unit_test(test_shaper_follows_at_the_rate_limit),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
