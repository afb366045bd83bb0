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
#include "wheel_use.h"

#define DT 1e-3

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

/* Start pose/velocity (world) -> goal pose: from rest along each axis and turning, a turn in
 * place, moving toward the goal and across it. */
static const float moves[][9] = {
    {0, 0, 0, 0, 0, 0, 1.0f, 0, 0},         {0, 0, 0, 0, 0, 0, 0, 1.2f, 0},
    {0, 0, 0, 0, 0, 0, 0.7f, 0.7f, 0},      {0, 0, 0, 0, 0, 0, 1.5f, 0.5f, 2.0f},
    {0, 0, 0, 0, 0, 0, 0, 0, 3.0f},         {0, 0, 0, 0, 0, 0, 0.3f, 0.1f, 0.4f},
    {0, 0, 0, 0.8f, 0, 0, 2.0f, 0, 0},      {0, 0, 0.5f, 0.5f, 0.3f, 0, 0, 1.0f, -0.5f},
    {0, 0, 0, 0, 0, 2.0f, 0.5f, 0.5f, 0.5f}};

#define N_MOVES (sizeof(moves) / sizeof(moves[0]))

/* The stop of a start moving at (vx, vy) without turning at a constant deceleration, the
 * largest that keeps every wheel within its limits at every speed on the way (the model of
 * wheel_use.h, bisected here): its duration [s]. */
static double constant_stop_s(const struct layout *lay, const struct traj_limits *l,
                              const float pose[3], double vx, double vy)
{
	const double sp = hypot(vx, vy), e[2] = {vx / sp, vy / sp};
	double lo = 0.0, hi = 20.0;

	for (int it = 0; it < 30; it++) {
		const double A = 0.5 * (lo + hi);
		bool ok = true;
		for (int q = 0; q <= 200 && ok; q++) {
			const double t = sp / A * q / 200.0, v = sp - A * t;
			const struct traj_ref r = {
			    {pose[0] + (float)(e[0] * (sp * t - 0.5 * A * t * t)),
			     pose[1] + (float)(e[1] * (sp * t - 0.5 * A * t * t)), pose[2]},
			    {(float)(e[0] * v), (float)(e[1] * v), 0.0f},
			    {(float)(-e[0] * A), (float)(-e[1] * A), 0.0f}};
			ok = use_of_limits(&r, l, lay) <= 1.0;
		}
		if (ok)
			lo = A;
		else
			hi = A;
	}
	return sp / lo;
}

/* When the reference's translation first comes to rest (the brake prelude's stop: below 5 mm/s,
 * sampled every 0.1 ms) [s]. */
static double first_rest_s(const struct traj *tr)
{
	struct traj_ref r;

	for (double t = 0.0; t < tr->duration_s; t += 1e-4) {
		traj_eval(tr, (float)t, &r);
		if (hypot(r.vel[0], r.vel[1]) < 5e-3)
			return t;
	}
	return tr->duration_s;
}

/* Every plan of every move on a floor of friction mu: every wheel within its limits all the
 * way, the reference without a jump, at the goal at rest at the end; a start that moves
 * without turning and brakes first stops no later than 1.25 times the stop at the largest
 * constant deceleration every wheel allows (speed steps may stop sooner). */
static void plans_stay_within_every_wheel(const struct layout *lay, double mu, const float (*ms)[9],
                                          size_t n_moves)
{
	struct wheel_geom g;
	struct traj_limits l = limits(lay, &g);
	static struct traj tr;

	l.mu = mu;

	assert_int_equal(traj_init(&tr, &l), 0);
	for (size_t m = 0; m < n_moves; m++) {
		const float *k = ms[m];
		const struct traj_ref from = {{k[0], k[1], k[2]}, {k[3], k[4], k[5]}, {0, 0, 0}};

		assert_int_equal(traj_reset(&tr, from.pose), 0);
		assert_int_equal(traj_plan(&tr, &from, k + 6), 0);
		assert_true(tr.duration_s > 0.0f && tr.duration_s < 30.0f);
		const double worst = plan_worst_use(&tr, &l, lay, k + 6);
		printf("%s, mu %.2f, move %zu: %.3f s (%.3f s to rest first), largest use of a "
		       "wheel's limit %.4f\n",
		       lay->name, mu, m, tr.duration_s, tr.pre_s, worst);
		assert_true(worst <= 1.01);
		if (tr.pre_s > 0.0f && k[5] == 0.0f && hypot(k[3], k[4]) > 0.0) {
			const double t_stop = first_rest_s(&tr),
			             t_const = constant_stop_s(lay, &l, from.pose, k[3], k[4]);
			printf(
			    "  at rest after %.3f s, at the largest constant deceleration %.3f s\n",
			    t_stop, t_const);
			assert_true(isfinite(t_const) && t_stop <= 1.25 * t_const);
		}
	}
}

static void test_three_wheels_plan_within_every_wheel(void **state)
{
	(void)state;
	plans_stay_within_every_wheel(&three, test_traj_limits().mu, moves, N_MOVES);
}

static void test_asymmetric_four_plan_within_every_wheel(void **state)
{
	(void)state;
	plans_stay_within_every_wheel(&robocup, test_traj_limits().mu, moves, N_MOVES);
}

/* A floor too slippery to turn and move at once (a turn's and a translation's Coulomb friction
 * together beyond traction: mu 0.25 for the three wheels, 0.35 for the asymmetric four, which
 * cannot start in every direction at 0.3), on both layouts: moves from rest with and without a
 * turn, starts moving along several directions and one turning (each inside what the floor
 * allows), each inside every wheel's limits all the way. */
static const float slippery_moves[][9] = {{0, 0, 0, 0, 0, 0, 1.0f, 0, 0},
                                          {0, 0, 0, 0, 0, 0, 1.5f, 0.5f, 2.0f},
                                          {0, 0, 0, 0, 0, 0, 0.3f, 0.1f, 0.4f},
                                          {0, 0, 0, 0, 0, 0, 0, 0, 3.0f},
                                          {0, 0, 0, 0.3f, 0, 0, 0.5f, 0.5f, 1.0f},
                                          {0, 0, 0.5f, 0, 0, -1.0f, 0, 1.0f, -0.5f},
                                          {0, 0, 0, 0, 0.3f, 0, 1.0f, 0.5f, 1.0f},
                                          {0, 0, 0, -0.08f, 0.08f, 0, 0.5f, 1.0f, -1.0f},
                                          {0, 0, 0.3f, 0.06f, -0.08f, 0, 1.0f, -1.0f, 1.5f}};

static void test_a_slippery_floor_plans_within_every_wheel(void **state)
{
	(void)state;
	const size_t n = sizeof(slippery_moves) / sizeof(slippery_moves[0]);

	plans_stay_within_every_wheel(&three, 0.25, slippery_moves, n);
	plans_stay_within_every_wheel(&robocup, 0.35, slippery_moves, n);
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
	    cmocka_unit_test(test_a_slippery_floor_plans_within_every_wheel),
	    cmocka_unit_test(test_paper_layout_as_angles_plans_the_same),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
