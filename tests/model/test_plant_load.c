/*
 * Tests for the floor's normal loads and creep (model/src/plant.c, plant.h): the force a wheel
 * holds, mu N_j, with the load transfer of the body's acceleration, against a hand
 * computation written out here (not plant.c's helpers):
 *   N_j = M g / 4 - M h (a . p_j) / (2 d^2), p_0 = (d, 0), p_1 = (0, d), p_2 = -p_0, p_3 = -p_1
 * (a rigid body on four wheels: the pitch and roll moments M h a balanced by the wheels'
 * lever arms, symmetric). The acceleration is read off the plant's velocity by finite
 * difference; the wheel force at a stand-still wheel is l Kt u / (R r) (eqs 12-13, 21).
 */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/model/kinematics.h"
#include "omni4/model/plant.h"

static const struct model_params *P = &model_params_table3;
static const double G = 9.80665;
static const double MU = 0.5, H = 0.05, DT = 1e-3;

/* Hand computation: the normal load of wheel j at body acceleration (av, avn), at rest. */
static double hand_load(int j, double av, double avn)
{
	const double px[4] = {P->d, 0, -P->d, 0}, py[4] = {0, P->d, 0, -P->d};

	return P->M * G / 4.0 - P->M * H * (av * px[j] + avn * py[j]) / (2.0 * P->d * P->d);
}

/* Volts on a stand-still wheel for a drive force f (eqs 12-13 with eq 21 at speed 0). */
static double volts_for(double f)
{
	return f * P->R * P->r / (P->l * P->Kt);
}

/* Accelerate along v with sign s (wheels 1 and 3, under the limit) for 20 ms; returns the
 * acceleration of the last step by finite difference. */
static double push_along_v(struct plant *pl, double s)
{
	const struct plant_floor f = {.traction_mu = MU, .wheel_inertia = 1e-4, .com_height = H};
	const double u[4] = {0, -2.5 * s, 0, 2.5 * s};
	double before = 0;

	assert_int_equal(plant_init(pl, P), 0);
	assert_int_equal(plant_set_floor(pl, &f), 0);
	for (int i = 0; i < 20; i++) {
		before = pl->x[0];
		plant_step(pl, u, true, DT);
	}
	assert_int_equal(plant_slip_flags(pl), 0);
	return (pl->x[0] - before) / DT;
}

/* Then push along vn with wheels 0 and 2 at a share k of the hand limit of wheel `weak` (the
 * one the acceleration unloads); returns the slip flags after one step. */
static uint32_t push_across(double s, int weak, double k, double *av_out)
{
	struct plant pl;
	const double av = push_along_v(&pl, s);
	const double f = k * MU * hand_load(weak, av, 0.0);
	const double u[4] = {volts_for(f), -2.5 * s, -volts_for(f), 2.5 * s};

	*av_out = av;
	plant_step(&pl, u, true, DT);
	return plant_slip_flags(&pl);
}

/* Accelerating along +v unloads wheel 0 (ahead) and loads wheel 2 (behind): with wheels 0 and
 * 2 pushing alike along vn, wheel 0 holds 92 % of its hand limit and slips at 108 %, alone;
 * braking (along -v) the other way round. (108 % of the unloaded wheel's limit is below the
 * limit at rest, mu M g / 4: without load transfer nothing would slip. Closer to the limit a
 * slipping wheel's rim, on its own inertia, gains on the ground more slowly than the body
 * accelerates: it grips again, as the wheel inertia's share of the force says it should.) */
static void test_the_wheel_ahead_of_the_acceleration_holds_mu_times_its_load(void **state)
{
	(void)state;
	double av;

	assert_int_equal(push_across(1.0, 0, 0.92, &av), 0);
	assert_true(av > 0.5);
	assert_int_equal(push_across(1.0, 0, 1.08, &av), 0x1);
	assert_int_equal(push_across(-1.0, 2, 0.92, &av), 0);
	assert_true(av < -0.5);
	assert_int_equal(push_across(-1.0, 2, 1.08, &av), 0x4);
	print_message("a_v %.3f m/s^2: wheel 0 holds %.3f N, wheel 2 %.3f N (at rest %.3f N)\n",
	              -av, MU * hand_load(0, -av, 0), MU * hand_load(2, -av, 0),
	              MU * P->M * G / 4.0);
}

/* plant_wheel_loads against the hand computation at a diagonal acceleration, and the loads
 * sum to M g. */
static void test_wheel_loads_match_the_hand_computation(void **state)
{
	(void)state;
	struct plant pl;
	const struct plant_floor f = {.traction_mu = MU, .wheel_inertia = 1e-4, .com_height = H};
	const double u[4] = {2.0, -2.0, -2.0, 2.0};
	double x0[3], n[4], hold[4], sum = 0;

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	for (int i = 0; i < 30; i++) {
		memcpy(x0, pl.x, sizeof(x0));
		plant_step(&pl, u, true, DT);
	}
	const double av = (pl.x[0] - x0[0]) / DT, avn = (pl.x[1] - x0[1]) / DT;
	const double cv = av - pl.x[2] * pl.x[1], cvn = avn + pl.x[2] * pl.x[0];

	assert_true(av > 0.5 && avn > 0.5);
	plant_wheel_loads(&pl, n, hold);
	for (int j = 0; j < 4; j++) {
		assert_near(n[j], hand_load(j, cv, cvn), 1e-9);
		assert_near(hold[j], MU * n[j], 1e-9);
		sum += n[j];
	}
	assert_near(sum, P->M * G, 1e-9);
}

/* The creep scales with the ground speed: at rest the wheels read exactly 0 (the old constant
 * creep read ~4 mm/s), at a steady speed the slip is a share of it. */
static void test_creep_is_zero_at_rest_and_scales_with_speed(void **state)
{
	(void)state;
	struct plant pl;
	const struct plant_floor f = {.slip_noise = 0.004, .seed = 3};
	const double zero[4] = {0, 0, 0, 0};
	double w[4], s[4], vg[4];

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	for (int i = 0; i < 1000; i++)
		plant_step(&pl, zero, true, DT);
	plant_wheel_speeds(&pl, w);
	plant_wheel_slip(&pl, s);
	for (int j = 0; j < 4; j++) {
		assert_true(w[j] == 0.0 && s[j] == 0.0);
		assert_true(pl.creep[j] != 0.0); /* the process runs; the speed scales it away */
	}
	const double u[4] = {0, -6, 0, 6};

	for (int i = 0; i < 3000; i++)
		plant_step(&pl, u, true, DT);
	plant_wheel_slip(&pl, s);
	ik_wheel_speeds(P->d, pl.x, vg);
	for (int j = 1; j < 4; j += 2)
		assert_near(s[j], pl.creep[j] * fabs(vg[j]), 1e-12);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_the_wheel_ahead_of_the_acceleration_holds_mu_times_its_load),
	    cmocka_unit_test(test_wheel_loads_match_the_hand_computation),
	    cmocka_unit_test(test_creep_is_zero_at_rest_and_scales_with_speed),
	};

	return cmocka_run_group_tests_name("plant_load", tests, NULL, NULL);
}
