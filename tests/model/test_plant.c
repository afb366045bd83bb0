/* Tests for model/src/plant.c against closed forms of eq 23 with Coulomb friction. */
#include "omni4_test.h"

#include <math.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/plant.h"

static const struct model_params *P = &model_params_table3;

/* Closed-form pieces written out from the parameters (not from dyn_state_space). */
static double emf(void)
{
	return P->Kt * P->Kv * P->l * P->l / (P->r * P->r * P->R);
}

static double a_v(void)
{
	return -(2 * emf() + P->Bv) / P->M;
}

static double a_w(void)
{
	return -(4 * P->d * P->d * emf() + P->Bw) / P->J;
}

static void run(struct plant *pl, const double u[4], bool driven, double t, double dt)
{
	const long n = lround(t / dt);

	for (long i = 0; i < n; i++)
		plant_step(pl, u, driven, dt);
}

static void test_steady_speed_under_constant_voltage_matches_closed_form(void **state)
{
	(void)state;
	struct plant pl;
	const double U = 6.0;
	const double b = P->l * P->Kt / (P->r * P->R); /* N/V per wheel */

	/* v: u3 = +U, u1 = -U -> Fv-equivalent drive 2 b U, friction Cv. */
	const double uv[4] = {0, -U, 0, U};
	const double v_ss = (2 * b * U - P->Cv) / (2 * emf() + P->Bv);

	assert_int_equal(plant_init(&pl, P), 0);
	run(&pl, uv, true, 5.0, 1e-3);
	print_message("v steady at %g V: %.6f m/s (closed form %.6f)\n", U, pl.x[0], v_ss);
	assert_near(pl.x[0], v_ss, 1e-6);
	assert_near(pl.x[1], 0, 0);
	assert_near(pl.x[2], 0, 0);

	/* w: all four at +U -> torque 4 d b U against Cw. */
	const double uw[4] = {U, U, U, U};
	const double w_ss = (4 * P->d * b * U - P->Cw) / (4 * P->d * P->d * emf() + P->Bw);

	plant_reset(&pl);
	run(&pl, uw, true, 5.0, 1e-3);
	print_message("w steady at %g V: %.6f rad/s (closed form %.6f)\n", U, pl.x[2], w_ss);
	assert_near(pl.x[2], w_ss, 1e-6);

	/* Currents at steady state satisfy eq 21 with the steady wheel speeds. */
	const double vw = P->d * w_ss;

	for (int j = 0; j < 4; j++)
		assert_near(pl.current_a[j], (U - P->Kv * P->l * vw / P->r) / P->R, 1e-9);

	/* dyn_steady_velocity agrees. */
	double xs[3];

	dyn_steady_velocity(&pl.ss, uw, xs);
	assert_near(xs[2], w_ss, 1e-12);
}

static void test_time_constants_are_minus_one_over_A_ii(void **state)
{
	(void)state;
	struct plant pl;
	const double uv[4] = {0, -8, 0, 8};
	const double uw[4] = {8, 8, 8, 8};
	const double dt = 1e-4;

	assert_int_equal(plant_init(&pl, P), 0);
	double xs[3];

	dyn_steady_velocity(&pl.ss, uv, xs);
	const double tau_v = -1.0 / a_v();

	run(&pl, uv, true, tau_v, dt);
	print_message("tau_v = %.4f s: v/v_ss = %.5f (1 - 1/e = %.5f)\n", tau_v, pl.x[0] / xs[0],
	              1 - exp(-1));
	/* closed form at the time actually run (tau rounded to dt): 1 - exp(-t/tau) */
	assert_near(pl.x[0] / xs[0], 1 - exp(-(double)lround(tau_v / dt) * dt / tau_v), 1e-9);

	plant_reset(&pl);
	dyn_steady_velocity(&pl.ss, uw, xs);
	const double tau_w = -1.0 / a_w();

	run(&pl, uw, true, tau_w, dt);
	print_message("tau_w = %.4f s: w/w_ss = %.5f\n", tau_w, pl.x[2] / xs[2]);
	assert_near(pl.x[2] / xs[2], 1 - exp(-(double)lround(tau_w / dt) * dt / tau_w), 1e-9);
}

static void test_coast_down_stops_at_closed_form_time_and_stays(void **state)
{
	(void)state;
	struct plant pl;
	const double u0[4] = {0, 0, 0, 0};
	const double dt = 1e-4;
	/* Null traction (eq 17): v' = -(Bv v + Cv)/M -> t_stop = M/Bv ln(1 + Bv v0/Cv). */
	const double v0 = 1.2;
	const double t_stop = P->M / P->Bv * log(1 + P->Bv * v0 / P->Cv);

	assert_int_equal(plant_init(&pl, P), 0);
	pl.x[0] = v0;
	double t = 0;

	while (pl.x[0] > 0 && t < 10) {
		plant_step(&pl, u0, false, dt);
		t += dt;
		for (int j = 0; j < 4; j++)
			assert_near(pl.current_a[j], 0, 0); /* H-bridges off */
	}
	print_message("coast v0=%.2f: stop after %.4f s (closed form %.4f s)\n", v0, t, t_stop);
	assert_near(t, t_stop, dt);
	run(&pl, u0, false, 1.0, dt);
	assert_near(pl.x[0], 0, 0);

	/* Same about w (eq 19). */
	const double w0 = 15.0;
	const double tw = P->J / P->Bw * log(1 + P->Bw * w0 / P->Cw);

	plant_reset(&pl);
	pl.x[2] = w0;
	t = 0;
	while (pl.x[2] > 0 && t < 10) {
		plant_step(&pl, u0, false, dt);
		t += dt;
	}
	print_message("coast w0=%.1f: stop after %.4f s (closed form %.4f s)\n", w0, t, tw);
	assert_near(t, tw, dt);
}

static void test_stiction_holds_below_coulomb_and_breaks_away_above(void **state)
{
	(void)state;
	struct plant pl;
	const double b = P->l * P->Kt / (P->r * P->R);
	const double U_break = P->Cv / (2 * b); /* drive force equals Cv */
	const double below[4] = {0, -0.95 * U_break, 0, 0.95 * U_break};
	const double above[4] = {0, -1.05 * U_break, 0, 1.05 * U_break};

	assert_int_equal(plant_init(&pl, P), 0);
	run(&pl, below, true, 2.0, 1e-3);
	assert_near(pl.x[0], 0, 0);
	assert_near(pl.pose[0], 0, 0);
	run(&pl, above, true, 2.0, 1e-3);
	assert_true(pl.x[0] > 0);

	/* Opposite drive below breakaway from motion: slows, stops, then stays at zero. */
	const double back[4] = {0, 0.5 * U_break, 0, -0.5 * U_break};

	run(&pl, back, true, 3.0, 1e-3);
	assert_near(pl.x[0], 0, 0);
}

/* Per axis and direction: the drive force (torque) from the voltages alone, at rest, is
 * 2 b U along v (f3 - f1), 2 b U along vn (f0 - f2) and 4 d b U about w, with b = l Kt/(r R)
 * (eqs 9-13, 21 at zero speed). Held at 0.99 of the Coulomb force, breaks away at 1.01 in
 * the direction of the drive, for both signs. */
static void test_stiction_breaks_away_in_both_directions_on_every_axis(void **state)
{
	(void)state;
	const double b = P->l * P->Kt / (P->r * P->R);
	/* unit voltage patterns and their force (torque) per volt */
	const double pattern[3][4] = {{0, -1, 0, 1}, {1, 0, -1, 0}, {1, 1, 1, 1}};
	const double per_volt[3] = {2 * b, 2 * b, 4 * P->d * b};
	const double coulomb[3] = {P->Cv, P->Cvn, P->Cw};
	const double inertia[3] = {P->M, P->M, P->J};
	const double a_vn = -(2 * emf() + P->Bvn) / P->M;
	const double A[3] = {a_v(), a_vn, a_w()};
	struct plant pl;

	assert_int_equal(plant_init(&pl, P), 0);
	for (int k = 0; k < 3; k++) {
		const double U_break = coulomb[k] / per_volt[k];

		for (int sign = -1; sign <= 1; sign += 2) {
			double u[4];

			plant_reset(&pl);
			for (int j = 0; j < 4; j++)
				u[j] = sign * 0.99 * U_break * pattern[k][j];
			run(&pl, u, true, 1.0, 1e-3);
			for (int a = 0; a < 3; a++)
				assert_near(pl.x[a], 0, 0);
			for (int j = 0; j < 4; j++)
				u[j] = sign * 1.01 * U_break * pattern[k][j];
			run(&pl, u, true, 0.05, 1e-3);
			print_message(
			    "axis %d, drive %+d: breakaway at %.4f V, speed after 50 ms at "
			    "1.01x: %+.6e\n",
			    k, sign, U_break, pl.x[k]);
			/* closed form: x' = A x + f, f = 0.01 C / inertia, from rest for 50 ms */
			const double f = sign * 0.01 * coulomb[k] / inertia[k];
			const double want = -f / A[k] * (1 - exp(A[k] * 0.05));

			assert_true(sign * pl.x[k] > 0);
			assert_near(pl.x[k], want, 1e-9 * fabs(want));
			for (int a = 0; a < 3; a++)
				if (a != k)
					assert_near(pl.x[a], 0, 1e-12);
		}
	}
}

/* A reversal inside one integration step: moving at +0.05 m/s along v with the drive reversed
 * to 3x the Coulomb force. Closed form per phase of x' = A x + f: first f1 = (-3 Cv - Cv) / M
 * until the speed reaches 0 at t0, then from rest f2 = (-3 Cv + Cv) / M (friction now opposes
 * the negative motion) for the rest of the step. */
static void test_reversal_through_zero_inside_one_step(void **state)
{
	(void)state;
	const double b = P->l * P->Kt / (P->r * P->R);
	const double U = 3 * P->Cv / (2 * b);
	const double u[4] = {0, U, 0, -U}; /* f3 - f1 = -2 b U = -3 Cv */
	const double A = a_v(), x0 = 0.05, dt = 0.05;
	const double f1 = -4 * P->Cv / P->M, f2 = -2 * P->Cv / P->M;
	const double t0 = log((f1 / A) / (x0 + f1 / A)) / A;
	const double want = -f2 / A * (1 - exp(A * (dt - t0)));
	struct plant pl;

	assert_int_equal(plant_init(&pl, P), 0);
	pl.x[0] = x0;
	plant_step(&pl, u, true, dt);
	print_message("reversal: stops at %.4f s, speed after the %.2f s step %+.6f m/s (closed "
	              "form %+.6f)\n",
	              t0, dt, pl.x[0], want);
	assert_true(t0 > 0 && t0 < dt);
	assert_near(pl.x[0], want, 1e-9 * fabs(want));
}

static void test_pose_integrates_rotation_and_translation(void **state)
{
	(void)state;
	struct plant pl;
	const double u0[4] = {0, 0, 0, 0};

	assert_int_equal(plant_init(&pl, P), 0);
	/* Frictionless and EMF-free coast (null traction, no friction) keeps speed constant. */
	pl.p.Bv = pl.p.Bvn = pl.p.Bw = pl.p.Cv = pl.p.Cvn = pl.p.Cw = 0;
	dyn_state_space(&pl.p, &pl.ss);
	pl.x[0] = 1.0;
	pl.x[2] = 1.0;                           /* a circle of radius 1 m */
	run(&pl, u0, false, M_PI, M_PI / 31416); /* a whole number of steps */
	/* After half a turn, starting at the origin heading +x: at (0, 2), heading pi. */
	assert_near(pl.pose[0], 0.0, 1e-6);
	assert_near(pl.pose[1], 2.0, 1e-6);
	assert_near(pl.pose[2], M_PI, 1e-9);
}

static void test_init_rejects_bad_params(void **state)
{
	(void)state;
	struct plant pl;
	struct model_params p = model_params_table3;

	p.R = -4.3;
	assert_int_not_equal(plant_init(&pl, &p), 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_steady_speed_under_constant_voltage_matches_closed_form),
	    cmocka_unit_test(test_time_constants_are_minus_one_over_A_ii),
	    cmocka_unit_test(test_coast_down_stops_at_closed_form_time_and_stays),
	    cmocka_unit_test(test_stiction_holds_below_coulomb_and_breaks_away_above),
	    cmocka_unit_test(test_stiction_breaks_away_in_both_directions_on_every_axis),
	    cmocka_unit_test(test_reversal_through_zero_inside_one_step),
	    cmocka_unit_test(test_pose_integrates_rotation_and_translation),
	    cmocka_unit_test(test_init_rejects_bad_params),
	};

	return cmocka_run_group_tests_name("plant", tests, NULL, NULL);
}
