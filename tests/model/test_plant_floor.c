/*
 * Tests for the floor of model/src/plant.c (plant.h): the traction limit with the wheels on
 * their own inertia, the radius errors, the creep, an external force and a blocked body,
 * against closed forms written out here from the parameters (not from plant.c's helpers).
 *
 * Closed forms used (Table III, F = mu M g / 4 the kinetic friction of a slipping wheel):
 * - A slipping wheel: J_w w' = l Kt i - r F sgn(slip), i = (u - Kv l w) / R (eq 21 at the
 *   wheel's own speed). With s = r w: s' = -s / tau_w + r l Kt u / (J_w R) - r^2 F / J_w, so
 *   s(t) = s_ss (1 - exp(-t / tau_w)) from rest, tau_w = J_w R / (l^2 Kt Kv),
 *   s_ss = r u / (l Kv) - r^2 R F / (l^2 Kt Kv) (the no-load speed r u / (l Kv) as F -> 0).
 * - The body with slipping wheels: eq 23 with each slipping wheel's force F summed as eqs 9-11,
 *   e.g. along v with wheels 1 and 3 slipping: M v' = 2 F - Bv v - Cv, and about w with all
 *   four slipping: J w' = 4 d F - Bw w - Cw: first-order, closed form from rest.
 */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/kinematics.h"
#include "omni4/model/plant.h"

static const struct model_params *P = &model_params_table3;
static const double G = 9.80665;

static double fk(double mu)
{
	return mu * P->M * G / 4.0;
}

static struct plant_floor floor_mu(double mu, double jw)
{
	return (struct plant_floor){.traction_mu = mu, .wheel_inertia = jw};
}

static void run(struct plant *pl, const double u[4], bool driven, double t, double dt)
{
	const long n = lround(t / dt);

	for (long i = 0; i < n; i++)
		plant_step(pl, u, driven, dt);
}

/* x(t) of x' = a x + f from x0 (a < 0). */
static double first_order(double a, double f, double x0, double t)
{
	return -f / a + (x0 + f / a) * exp(a * t);
}

/* Under the traction limit the plant is the paper's, to the last bit: a random drive (steps,
 * reversals, coasting) whose wheel forces l Kt i / r (measured on the plant without a limit,
 * back-EMF included) stay below mu M g / 4 gives the very same doubles as that plant. */
static void test_under_the_limit_identical_to_the_plant_without_one(void **state)
{
	(void)state;
	struct plant a, b;
	const double mu = 2.0, umax = 5.0;
	const struct plant_floor f = floor_mu(mu, 1e-4);
	struct rng g;
	double u[4] = {0, 0, 0, 0}, fmax_n = 0;

	assert_int_equal(plant_init(&a, P), 0);
	assert_int_equal(plant_init(&b, P), 0);
	assert_int_equal(plant_set_floor(&b, &f), 0);
	rng_seed(&g, 42);
	for (int i = 0; i < 20000; i++) {
		if (i % 250 == 0)
			for (int j = 0; j < 4; j++)
				u[j] = rng_uniform(&g, -umax, umax);
		const bool driven = (i / 1000) % 4 != 3;

		plant_step(&a, u, driven, 1e-3);
		plant_step(&b, u, driven, 1e-3);
		for (int j = 0; j < 4; j++)
			fmax_n = fmax(fmax_n, fabs(P->l * P->Kt * a.current_a[j] / P->r));
		assert_memory_equal(a.x, b.x, sizeof(a.x));
		assert_memory_equal(a.pose, b.pose, sizeof(a.pose));
		assert_memory_equal(a.current_a, b.current_a, sizeof(a.current_a));
		double wa[4], wb[4];

		plant_wheel_speeds(&a, wa);
		plant_wheel_speeds(&b, wb);
		assert_memory_equal(wa, wb, sizeof(wa));
		assert_int_equal(plant_slip_flags(&b), 0);
	}
	print_message("largest wheel force %.3f N, limit %.3f N\n", fmax_n, fk(mu));
	assert_true(fmax_n < fk(mu) && fmax_n > 0.5 * fk(mu));
	assert_true(fabs(a.pose[0]) + fabs(a.pose[1]) > 0.05); /* it did move */
}

/* The body blocked, wheel 0 driven at 6 V: it breaks loose at once and spins up on its own
 * inertia with tau_w and s_ss of the header; its current follows eq 21 at its own speed. The
 * other wheels (0 V) stay gripping at rest. With a negligible mu the final speed is the
 * no-load speed r u / (l Kv). */
static void test_blocked_wheel_spins_up_with_tau_w_to_its_closed_form_speed(void **state)
{
	(void)state;
	const double mu = 0.3, jw = 1e-4, U = 6.0, dt = 1e-3;
	const double tau = jw * P->R / (P->l * P->l * P->Kt * P->Kv);
	const double s_ss =
	    P->r * U / (P->l * P->Kv) - P->r * P->r * P->R * fk(mu) / (P->l * P->l * P->Kt * P->Kv);
	const double u[4] = {U, 0, 0, 0};
	struct plant pl;
	struct plant_floor f = floor_mu(mu, jw);
	double w[4];

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	pl.blocked = true;
	const long n_tau = lround(tau / dt);

	run(&pl, u, true, (double)n_tau * dt, dt);
	plant_wheel_speeds(&pl, w);
	const double want = s_ss * (1 - exp(-(double)n_tau * dt / tau));

	print_message("tau_w = %.4f s, s_ss = %.5f m/s; rim after %ld ms %.6f m/s (closed form "
	              "%.6f)\n",
	              tau, s_ss, n_tau, w[0] * P->r, want);
	assert_near(w[0] * P->r, want, 1e-9);
	assert_int_equal(plant_slip_flags(&pl), 0x1);
	for (int j = 1; j < 4; j++)
		assert_true(w[j] == 0.0);
	for (int k = 0; k < 3; k++)
		assert_true(pl.x[k] == 0.0 && pl.pose[k] == 0.0);
	assert_near(pl.current_a[0], (U - P->Kv * P->l * w[0]) / P->R, 1e-12);
	double slip[4];

	plant_wheel_slip(&pl, slip);
	assert_near(slip[0], w[0] * P->r, 1e-15);
	run(&pl, u, true, (double)(10 * n_tau) * dt, dt);
	plant_wheel_speeds(&pl, w);
	assert_near(w[0] * P->r, s_ss * (1 - exp(-(double)(11 * n_tau) * dt / tau)), 1e-9);

	/* mu -> 0: the no-load speed. */
	f = floor_mu(1e-9, jw);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	pl.blocked = true;
	run(&pl, u, true, 12 * tau, dt);
	plant_wheel_speeds(&pl, w);
	print_message("no-load: %.6f rad/s (u / (l Kv) = %.6f)\n", w[0], U / (P->l * P->Kv));
	assert_near(w[0], U / (P->l * P->Kv), 1e-3);
}

/* Along v, wheels 1 and 3 at -U/+U far beyond the limit: both slip, the body follows
 * M v' = 2 F - Bv v - Cv exactly; wheels 0 and 2 (no drive, no motion along their axis) grip. */
static void test_slipping_drive_accelerates_the_body_with_the_kinetic_force(void **state)
{
	(void)state;
	const double mu = 0.3, U = 6.0, t = 0.3;
	const double uv[4] = {0, -U, 0, U};
	struct plant pl;
	const struct plant_floor f = floor_mu(mu, 1e-4);

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	plant_step(&pl, uv, true, 1e-3);
	const double a0 = (2 * fk(mu) - P->Cv) / P->M;

	print_message("v: slip flags 0x%x, accel %.6f m/s^2 ((2 F - Cv)/M = %.6f)\n",
	              plant_slip_flags(&pl), pl.x[0] / 1e-3, a0);
	assert_int_equal(plant_slip_flags(&pl), 0xa);
	run(&pl, uv, true, t - 1e-3, 1e-3);
	const double want = first_order(-P->Bv / P->M, (2 * fk(mu) - P->Cv) / P->M, 0.0, t);

	print_message("v after %.1f s: %.12f m/s (closed form %.12f)\n", t, pl.x[0], want);
	assert_int_equal(plant_slip_flags(&pl), 0xa);
	assert_near(pl.x[0], want, 3e-12); /* measured 1e-12 (rounding over 3000 substeps) */
	assert_true(pl.x[1] == 0.0 && pl.x[2] == 0.0);
	/* The readings follow the slipping wheels: faster than the ground. */
	double w[4], vg[4];

	plant_wheel_speeds(&pl, w);
	ik_wheel_speeds(P->d, pl.x, vg);
	assert_true(w[3] * P->r > vg[3] + 0.5 && -w[1] * P->r > -vg[1] + 0.5);

	/* About w, all four slipping: J w' = 4 d F - Bw w - Cw. */
	const double uw[4] = {U, U, U, U};

	plant_reset(&pl);
	run(&pl, uw, true, t, 1e-3);
	const double want_w =
	    first_order(-P->Bw / P->J, (4 * P->d * fk(mu) - P->Cw) / P->J, 0.0, t);

	print_message("w after %.1f s: %.12f rad/s (closed form %.12f)\n", t, pl.x[2], want_w);
	assert_int_equal(plant_slip_flags(&pl), 0xf);
	assert_near(pl.x[2], want_w, 3e-12 * want_w); /* measured 0.9e-12 x */
}

/* A slip ends: the drive cut (bridges off) after 0.1 s of slipping, each wheel decelerates on
 * its inertia by r^2 F / J_w until its rim meets the ground, then grips (flags clear, readings
 * = ground speed / r). The time to grip is bounded by the closed form of the rim alone. */
static void test_slip_ends_when_the_rim_meets_the_ground(void **state)
{
	(void)state;
	const double mu = 0.3, jw = 1e-4, U = 6.0, dt = 1e-3;
	const double uv[4] = {0, -U, 0, U}, u0[4] = {0, 0, 0, 0};
	struct plant pl;
	const struct plant_floor f = floor_mu(mu, jw);
	double w[4], vg[4];

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	run(&pl, uv, true, 0.1, dt);
	assert_int_equal(plant_slip_flags(&pl), 0xa);
	plant_wheel_speeds(&pl, w);
	ik_wheel_speeds(P->d, pl.x, vg);
	const double sig0 = w[3] * P->r - vg[3];
	/* slip velocity shrinks at least at r^2 F / J_w (the body also slows) */
	const double t_max = sig0 / (P->r * P->r * fk(mu) / jw);
	int steps = 0;

	while (plant_slip_flags(&pl) && steps < 1000) {
		plant_step(&pl, u0, false, dt);
		steps++;
	}
	print_message("slip %.4f m/s gone after %d ms (rim alone: %.2f ms)\n", sig0, steps,
	              t_max * 1e3);
	assert_true(steps > 0 && steps * dt <= t_max + dt);
	plant_wheel_speeds(&pl, w);
	ik_wheel_speeds(P->d, pl.x, vg);
	for (int j = 0; j < 4; j++)
		assert_near(w[j], vg[j] / P->r, 1e-15);
	assert_true(pl.x[0] > 0);
}

/* The substepped integrator against the exact one: with a radius error of 1e-9 (the floor path
 * on every step) and no slip, a drive on all three axes for 1.5 s, then coasting: velocities
 * within 1e-8 (measured 2.3e-9: the cross-axis terms held over a substep), poses within 6e-6
 * (measured 1.8e-6: the exact plant's pose takes one mid-step heading per 1 ms step). */
static void test_substeps_agree_with_the_exact_plant_when_nothing_slips(void **state)
{
	(void)state;
	struct plant a, b;
	const struct plant_floor f = {.wheel_inertia = 1e-4,
	                              .radius_error = {1e-9, 1e-9, 1e-9, 1e-9}};
	const double u[4] = {3.0, -1.0, 2.5, 4.0};
	double worst = 0;

	assert_int_equal(plant_init(&a, P), 0);
	assert_int_equal(plant_init(&b, P), 0);
	assert_int_equal(plant_set_floor(&b, &f), 0);
	for (int i = 0; i < 2000; i++) {
		plant_step(&a, u, i < 1500, 1e-3);
		plant_step(&b, u, i < 1500, 1e-3);
		for (int k = 0; k < 3; k++)
			worst = fmax(worst, fabs(a.x[k] - b.x[k]));
	}
	print_message("substeps vs exact: worst velocity difference %.3g\n", worst);
	assert_true(worst < 1e-8);
	assert_true(fabs(a.x[2]) + fabs(a.pose[0]) > 0.1);
	for (int k = 0; k < 3; k++)
		assert_near(a.pose[k], b.pose[k], 6e-6);
}

/* Radius errors: each wheel's reading is its ground speed / (r (1 + e_j)). */
static void test_radius_error_scales_each_wheel_reading(void **state)
{
	(void)state;
	const double e[4] = {0.01, -0.02, 0.005, 0.03};
	const struct plant_floor f = {.radius_error = {e[0], e[1], e[2], e[3]}};
	const double u[4] = {2.0, -3.0, 1.0, 4.0};
	struct plant pl;
	double w[4], vg[4];

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	run(&pl, u, true, 0.5, 1e-3);
	plant_wheel_speeds(&pl, w);
	ik_wheel_speeds(P->d, pl.x, vg);
	for (int j = 0; j < 4; j++) {
		assert_true(fabs(vg[j]) > 0.05);
		assert_near(w[j] * P->r * (1 + e[j]), vg[j], 1e-14);
	}
}

/* 3x3 determinant (Cramer's rule below). */
static double det3(const double m[3][3])
{
	return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
	       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
	       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* Motor errors: each wheel's force and current use its own R (1 + e_R) and Kv, Kt (1 + e_Kv)
 * (and radius): at constant voltages the plant settles where the per-wheel model
 * (dyn_state_space_wheels, docs/model.md) is at rest, A x + B u + K sgn(x) = 0, and each
 * current is eq 21 with that wheel's own constants. */
static void test_motor_errors_settle_where_the_per_wheel_model_does(void **state)
{
	(void)state;
	const struct plant_floor f = {.radius_error = {0.01, -0.01, 0.0, 0.0},
	                              .R_error = {0.05, -0.05, 0.03, -0.02},
	                              .Kv_error = {-0.04, 0.05, 0.02, -0.05}};
	const double u[4] = {6.0, -2.0, 1.0, 5.0}; /* every axis well beyond its stiction */
	struct plant pl;
	struct model_wheels w;
	struct model_ss_wheels ss;

	model_wheels_from_params(P, &w);
	for (int j = 0; j < 4; j++) {
		w.r[j] *= 1.0 + f.radius_error[j];
		w.R[j] *= 1.0 + f.R_error[j];
		w.Kv[j] *= 1.0 + f.Kv_error[j];
		w.Kt[j] *= 1.0 + f.Kv_error[j];
	}
	dyn_state_space_wheels(P, &w, &ss);
	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	run(&pl, u, true, 12.0, 1e-3);
	double rhs[3], x[3];

	for (int k = 0; k < 3; k++) {
		rhs[k] = ss.K[k] * (pl.x[k] > 0 ? 1.0 : -1.0);
		for (int j = 0; j < 4; j++)
			rhs[k] += ss.B[k][j] * u[j];
		rhs[k] = -rhs[k];
	}
	for (int c = 0; c < 3; c++) { /* A x = rhs */
		double m[3][3];

		memcpy(m, ss.A, sizeof(m));
		for (int k = 0; k < 3; k++)
			m[k][c] = rhs[k];
		x[c] = det3(m) / det3(ss.A);
	}
	for (int k = 0; k < 3; k++) {
		assert_true(fabs(x[k]) > 0.05);
		if (fabs(pl.x[k] - x[k]) > 1e-6 * fabs(x[k]))
			fail_msg("axis %d: plant %.9f, per-wheel model at rest %.9f", k, pl.x[k],
			         x[k]);
	}
	double vw[4], wm[4], cur[4];

	ik_wheel_speeds(P->d, pl.x, vw);
	motor_speeds_wheels(P, &w, vw, wm);
	motor_currents_wheels(&w, u, wm, cur);
	for (int j = 0; j < 4; j++)
		assert_near(pl.current_a[j], cur[j], 1e-9);
}

/* The creep: stationary std dev slip_noise per m/s of ground speed (200 s, correlated over
 * 0.2 s: ~500 independent samples, 3 standard errors of the variance ~ 20 %), mean ~0; the
 * body does not see it. */
static void test_creep_has_its_std_dev_and_leaves_the_body_alone(void **state)
{
	(void)state;
	const double sigma = 0.004;
	const struct plant_floor f = {.slip_noise = sigma, .seed = 7};
	const double u[4] = {1.0, -2.0, 3.0, 2.0};
	struct plant a, b;
	double sum = 0, sum2 = 0;
	long n = 0;

	assert_int_equal(plant_init(&a, P), 0);
	assert_int_equal(plant_init(&b, P), 0);
	assert_int_equal(plant_set_floor(&b, &f), 0);
	for (int i = 0; i < 200000; i++) {
		plant_step(&a, u, true, 1e-3);
		plant_step(&b, u, true, 1e-3);
		if (i % 100 == 0) {
			double s[4], vg[4];

			plant_wheel_slip(&b, s);
			ik_wheel_speeds(P->d, b.x, vg); /* the independent ground speed (eq 2) */
			for (int j = 0; j < 4; j++) {
				if (fabs(vg[j]) < 0.05)
					continue;
				sum += s[j] / fabs(vg[j]);
				sum2 += s[j] * s[j] / (vg[j] * vg[j]);
				n++;
			}
		}
	}
	assert_memory_equal(a.x, b.x, sizeof(a.x));
	assert_memory_equal(a.pose, b.pose, sizeof(a.pose));
	const double sd = sqrt(sum2 / n - (sum / n) * (sum / n));

	print_message("creep: std dev %.5f per m/s (set %.5f), mean %+.5f\n", sd, sigma, sum / n);
	assert_near(sd, sigma, 0.2 * sigma);
	assert_near(sum / n, 0, 0.3 * sigma);
	assert_int_equal(plant_slip_flags(&b), 0);
}

/* An external force along v on a coasting robot: M v' = Fext - Bv v - Cv; a blocked robot
 * with its motors driven and no traction limit stalls (i = u / R, no motion). */
static void test_external_force_and_blocked_body(void **state)
{
	(void)state;
	const double u0[4] = {0, 0, 0, 0}, F = 5.0;
	struct plant pl;

	assert_int_equal(plant_init(&pl, P), 0);
	pl.ext_force[0] = F;
	run(&pl, u0, false, 0.5, 1e-3);
	const double want = first_order(-P->Bv / P->M, (F - P->Cv) / P->M, 0, 0.5);

	print_message("pushed with %.1f N for 0.5 s: %.9f m/s (closed form %.9f)\n", F, pl.x[0],
	              want);
	assert_near(pl.x[0], want, 1e-12);

	const double u[4] = {6, 6, 6, 6};

	pl.ext_force[0] = 0;
	pl.blocked = true;
	const double pose[3] = {pl.pose[0], pl.pose[1], pl.pose[2]};

	run(&pl, u, true, 0.2, 1e-3);
	for (int k = 0; k < 3; k++) {
		assert_true(pl.x[k] == 0.0);
		assert_true(pl.pose[k] == pose[k]);
	}
	for (int j = 0; j < 4; j++)
		assert_near(pl.current_a[j], 6.0 / P->R, 1e-15);
	pl.blocked = false;
	run(&pl, u, true, 0.2, 1e-3);
	assert_true(pl.x[2] > 0);
}

static void test_set_floor_rejects_bad_values(void **state)
{
	(void)state;
	struct plant pl;
	struct plant_floor f = floor_mu(0.5, 0.0);

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_not_equal(plant_set_floor(&pl, &f), 0); /* slipping needs an inertia */
	f = floor_mu(-0.1, 1e-4);
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = floor_mu(NAN, 1e-4);
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = (struct plant_floor){.radius_error = {0, 0, 0.5, 0}};
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = (struct plant_floor){.R_error = {0, -0.5, 0, 0}};
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = (struct plant_floor){.Kv_error = {0, 0, 0, NAN}};
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = (struct plant_floor){.slip_noise = -1};
	assert_int_not_equal(plant_set_floor(&pl, &f), 0);
	f = floor_mu(0.5, 1e-4);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_under_the_limit_identical_to_the_plant_without_one),
	    cmocka_unit_test(test_blocked_wheel_spins_up_with_tau_w_to_its_closed_form_speed),
	    cmocka_unit_test(test_slipping_drive_accelerates_the_body_with_the_kinetic_force),
	    cmocka_unit_test(test_slip_ends_when_the_rim_meets_the_ground),
	    cmocka_unit_test(test_substeps_agree_with_the_exact_plant_when_nothing_slips),
	    cmocka_unit_test(test_radius_error_scales_each_wheel_reading),
	    cmocka_unit_test(test_motor_errors_settle_where_the_per_wheel_model_does),
	    cmocka_unit_test(test_creep_has_its_std_dev_and_leaves_the_body_alone),
	    cmocka_unit_test(test_external_force_and_blocked_body),
	    cmocka_unit_test(test_set_floor_rejects_bad_values),
	};

	return cmocka_run_group_tests_name("plant_floor", tests, NULL, NULL);
}
