/* Tests for the one-curve plan (traj_plan_curve, core/src/planner/traj_curve.c): on the paper's
 * layout, three wheels and an asymmetric four, from rest and from moving starts (toward the
 * goal, away from it, across it, turning), each plan sampled every millisecond against every
 * wheel's voltage, traction on its own load and rim speed (the tests' own model, wheel_use.h);
 * it starts at the start's pose and velocity, ends at rest at the goal; bad input refused. */
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
#include "wheel_use.h"

#define DT 1e-3
#define EVALS 40 /* the search's timings */

static const struct layout paper = {
    "paper", 4, {0, 90, 180, 270}, {0.089, 0.089, 0.089, 0.089}, 0.04};
static const struct layout three = {
    "three at 120 deg", 3, {60, 180, 300, 0}, {0.089, 0.089, 0.089, 0}, 0.0};
static const struct layout robocup = {
    "asymmetric four", 4, {60, 135, 225, 300}, {0.080, 0.089, 0.089, 0.080}, 0.04};

/* Start pose and world velocity -> goal pose. */
static const float moves[][9] = {
    {0, 0, 0, 0, 0, 0, 1.0f, 0, 0},           {0, 0, 0, 0, 0, 0, 0.7f, 0.7f, 0},
    {0, 0, 0, 0, 0, 0, 1.5f, 0.5f, 2.0f},     {0, 0, 0, 0, 0, 0, 0, 0, 3.0f},
    {0, 0, 0, 0, 0, 0, 1.0f, 1.0f, 1.0f},     {0, 0, 0.7f, 0, 0, 0, -0.5f, 3.0f, 0.7f},
    {0, 0, 0, 0.8f, 0, 0, 2.0f, 0, 0},        {0, 0, 0, 1.0f, 0, 0, -1.0f, 0, 0},
    {0, 0, 0, 0.5f, 0.5f, 0, 1.0f, -1.0f, 0}, {0, 0, 0.5f, 0.5f, 0.3f, 0, 0, 1.0f, -0.5f},
    {0, 0, 0, 0, 0, 2.0f, 0.5f, 0.5f, 0.5f}};

static void curves_stay_within_every_wheel(const struct layout *lay)
{
	struct wheel_geom g;
	struct traj_limits l = test_traj_limits();
	static struct traj tr;

	l.com_height_m = lay->com_height;
	assert_int_equal(wheel_geom_angles(lay->n, lay->deg, lay->dist, &g), 0);
	l.geom = &g;
	assert_int_equal(traj_init(&tr, &l), 0);
	for (size_t m = 0; m < sizeof(moves) / sizeof(moves[0]); m++) {
		const float *k = moves[m];
		const struct traj_ref from = {{k[0], k[1], k[2]}, {k[3], k[4], k[5]}, {0, 0, 0}};
		struct traj_ref r;

		assert_int_equal(traj_plan_curve(&tr, &from, k + 6, EVALS), 0);
		assert_true(tr.duration_s > 0.0f && tr.duration_s < 30.0f);
		traj_eval(&tr, 0.0f, &r);
		for (int i = 0; i < 3; i++) {
			assert_true(fabsf(r.pose[i] - from.pose[i]) < 1e-5f);
			assert_true(fabsf(r.vel[i] - from.vel[i]) < 1e-3f);
		}
		const double worst = plan_worst_use(&tr, &l, lay, k + 6);
		printf("%s, move %zu: %.3f s (braked first %.3f s), largest use of a wheel's "
		       "limit %.4f\n",
		       lay->name, m, (double)tr.duration_s, (double)tr.pre_s, worst);
		assert_true(worst <= 1.01);
	}
}

static void test_paper_layout_curves_within_every_wheel(void **state)
{
	(void)state;
	curves_stay_within_every_wheel(&paper);
}

static void test_three_wheels_curves_within_every_wheel(void **state)
{
	(void)state;
	curves_stay_within_every_wheel(&three);
}

static void test_asymmetric_four_curves_within_every_wheel(void **state)
{
	(void)state;
	curves_stay_within_every_wheel(&robocup);
}

/* The reference is continuous in pose and velocity: no step between two milliseconds larger
 * than the largest speed (and acceleration) of the wheels allows. */
static void test_curve_reference_is_continuous(void **state)
{
	(void)state;
	const struct traj_limits l = test_traj_limits();
	static struct traj tr;
	const struct traj_ref from = {{0, 0, 0}, {0.5f, 0.5f, 0}, {0, 0, 0}};
	const float goal[3] = {1.0f, -1.0f, 1.0f};
	struct traj_ref a, b;

	assert_int_equal(traj_init(&tr, &l), 0);
	assert_int_equal(traj_plan_curve(&tr, &from, goal, EVALS), 0);
	traj_eval(&tr, 0.0f, &a);
	for (double t = DT; t < tr.duration_s + DT; t += DT) {
		traj_eval(&tr, (float)t, &b);
		for (int i = 0; i < 3; i++) {
			/* 5 m/s, 50 rad/s, 50 m/s^2: far above Table III's drives */
			assert_true(fabsf(b.pose[i] - a.pose[i]) < (i < 2 ? 5.0f : 50.0f) * DT);
			assert_true(fabsf(b.vel[i] - a.vel[i]) < 50.0f * DT);
		}
		a = b;
	}
}

/* The optional caps on speed and turn rate hold on a curve (its progress is not its speed), and
 * the speed cap is reached, not undercut. */
static void test_curve_holds_the_caps(void **state)
{
	(void)state;
	struct traj_limits l = test_traj_limits();
	static struct traj tr;
	const struct traj_ref from = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
	const float goal[3] = {1.5f, 0.5f, 2.0f};
	struct traj_ref r;
	double v_max = 0.0, w_max = 0.0;

	l.speed_cap_m_s = 0.5;
	l.omega_cap_rad_s = 1.0;
	assert_int_equal(traj_init(&tr, &l), 0);
	assert_int_equal(traj_plan_curve(&tr, &from, goal, EVALS), 0);
	for (double t = 0.0; t < tr.duration_s + DT; t += DT) {
		traj_eval(&tr, (float)t, &r);
		v_max = fmax(v_max, hypot(r.vel[0], r.vel[1]));
		w_max = fmax(w_max, fabs(r.vel[2]));
	}
	printf("caps 0.5 m/s, 1 rad/s: %.3f s, largest speed %.4f m/s, turn rate %.4f rad/s\n",
	       (double)tr.duration_s, v_max, w_max);
	assert_true(v_max <= 0.5 * 1.001 && w_max <= 1.0 * 1.001);
	/* the cap reached, not undercut: at least the straight line's time at the cap, at most a
	 * trapezoid's on it at 1 m/s^2 (below what the wheels allow along any direction) */
	const float dist = hypotf(goal[0], goal[1]);
	assert_true(tr.duration_s >= dist / 0.5f);
	assert_true(tr.duration_s <= dist / 0.5f + 0.5f / 1.0f);
	/* from rest and moving across, toward three goals: within the caps, and at the speed cap
	 * over the middle half of the move (its progress s' is not the speed: held at cap /
	 * |dp/ds|) */
	const float goals[3][3] = {{1.5f, 0.5f, 2.0f}, {2.0f, 0.0f, 0.0f}, {0.5f, 1.5f, -1.0f}};
	const struct traj_ref across = {{0, 0, 0}, {0, 0.4f, 0}, {0, 0, 0}};
	for (int k = 0; k < 6; k++) {
		assert_int_equal(traj_plan_curve(&tr, k < 3 ? &from : &across, goals[k % 3], EVALS),
		                 0);
		double slow = INFINITY;
		v_max = w_max = 0.0;
		for (double t = 0.0; t < tr.duration_s + DT; t += DT) {
			traj_eval(&tr, (float)t, &r);
			const double v = hypot(r.vel[0], r.vel[1]);
			v_max = fmax(v_max, v);
			w_max = fmax(w_max, fabs(r.vel[2]));
			if (t > 0.25 * tr.duration_s && t < 0.75 * tr.duration_s)
				slow = fmin(slow, v);
		}
		printf("  %s to goal %d: %.3f s, speed %.4f to %.4f m/s over its middle half, turn "
		       "rate %.4f rad/s at most\n",
		       k < 3 ? "from rest" : "moving across", k % 3, (double)tr.duration_s, slow,
		       v_max, w_max);
		assert_true(v_max <= 0.5 * 1.001 && w_max <= 1.0 * 1.001);
		assert_true(slow >= 0.98 * 0.5);
	}
}

static void test_curve_bad_input_is_refused(void **state)
{
	(void)state;
	const struct traj_limits l = test_traj_limits();
	static struct traj tr;
	const struct traj_ref from = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
	struct traj_ref nan_from = from;
	const float goal[3] = {1.0f, 0, 0}, bad_goal[3] = {NAN, 0, 0};

	assert_int_equal(traj_init(&tr, &l), 0);
	assert_int_equal(traj_plan_curve(&tr, &from, goal, EVALS), 0);
	const float before = tr.duration_s;
	nan_from.vel[1] = INFINITY;
	assert_int_equal(traj_plan_curve(&tr, &nan_from, goal, EVALS), -EINVAL);
	assert_int_equal(traj_plan_curve(&tr, &from, bad_goal, EVALS), -EINVAL);
	assert_int_equal(traj_plan_curve(&tr, &from, goal, CURVE_EVALS_MIN - 1), -EINVAL);
	assert_int_equal(traj_plan_curve(&tr, &from, goal, CURVE_EVALS_MAX + 1), -EINVAL);
	assert_true(tr.duration_s == before);
	/* already there: held, no plan */
	assert_int_equal(traj_plan_curve(&tr, &from, from.pose, EVALS), 0);
	assert_true(tr.duration_s == 0.0f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_paper_layout_curves_within_every_wheel),
	    cmocka_unit_test(test_three_wheels_curves_within_every_wheel),
	    cmocka_unit_test(test_asymmetric_four_curves_within_every_wheel),
	    cmocka_unit_test(test_curve_reference_is_continuous),
	    cmocka_unit_test(test_curve_holds_the_caps),
	    cmocka_unit_test(test_curve_bad_input_is_refused),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
