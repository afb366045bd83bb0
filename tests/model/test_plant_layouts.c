/*
 * Tests for the plant with a wheel layout (model/src/plant.c, plant_set_geom), each against a
 * computation written out here from the angles and distances (not wheels.c's maps):
 *   eq 2's row j = [-sin a_j, cos a_j, d_j], contact point d_j (cos a_j, sin a_j);
 *   wheel force f_j = b (u_j - kemf v_j), b = l Kt / (R r), e = b kemf = l^2 Kt Kv / (R r^2);
 *   eq 23 with the axes coupled: m x' = G^T b u - (G^T e G + diag(B)) x - C sgn(x).
 * Objectives: three wheels at 0/120/240 deg under equal volts reach the w where the motors'
 * torque balances back-EMF, viscous and Coulomb friction (and an unequal three the coupled
 * steady state); a least-norm pure-v voltage pattern on an asymmetric four moves the body along
 * v only, on eq 23's v closed form; a push with the bridges off decays as the paper's
 * viscous/Coulomb closed form; the loads carry M g and the tipping moment, and three equal
 * wheels each hold mu M g / 3; the paper's layout
 * given explicitly is the plant without a layout within 1e-12; a bad layout is refused.
 */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "omni4/model/plant.h"

static const struct model_params *P = &model_params_table3;
static const double G_M_S2 = 9.80665;
static const double DT = 1e-3; /* the simulator's step [s] */

/* A layout written out from its angles [deg] and distances [m]. */
struct hand {
	int n;
	double row[4][3];
	double pos[4][2];
};

static void hand_layout(int n, const double a_deg[4], const double dist[4], struct hand *h,
                        struct wheel_geom *g)
{
	memset(h, 0, sizeof(*h));
	h->n = n;
	for (int j = 0; j < n; j++) {
		const double a = a_deg[j] * M_PI / 180.0;

		h->row[j][0] = -sin(a);
		h->row[j][1] = cos(a);
		h->row[j][2] = dist[j];
		h->pos[j][0] = dist[j] * cos(a);
		h->pos[j][1] = dist[j] * sin(a);
	}
	assert_int_equal(wheel_geom_angles(n, a_deg, dist, g), 0);
}

static double drive_gain(void) /* b [N/V] */
{
	return P->l * P->Kt / (P->R * P->r);
}

static double emf_gain(void) /* e [N/(m/s)] */
{
	return P->l * P->l * P->Kt * P->Kv / (P->R * P->r * P->r);
}

/* m x = rhs by Cramer's rule. */
static void solve3(const double m[3][3], const double rhs[3], double x[3])
{
	const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
	                   m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
	                   m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);

	for (int c = 0; c < 3; c++) {
		double t[3][3];

		memcpy(t, m, sizeof(t));
		for (int k = 0; k < 3; k++)
			t[k][c] = rhs[k];
		x[c] = (t[0][0] * (t[1][1] * t[2][2] - t[1][2] * t[2][1]) -
		        t[0][1] * (t[1][0] * t[2][2] - t[1][2] * t[2][0]) +
		        t[0][2] * (t[1][0] * t[2][1] - t[1][1] * t[2][0])) /
		       det;
	}
}

/* The steady velocity of the coupled eq 23 under volts u, every axis moving:
 * (G^T e G + diag(B)) x = G^T b u - C sgn(x), the signs settled by iteration. */
static void hand_steady(const struct hand *h, const double u[4], double x[3])
{
	const double B[3] = {P->Bv, P->Bvn, P->Bw}, C[3] = {P->Cv, P->Cvn, P->Cw};
	double m[3][3] = {{0}}, f[3] = {0}, rhs[3];

	for (int j = 0; j < h->n; j++)
		for (int k = 0; k < 3; k++) {
			f[k] += h->row[j][k] * drive_gain() * u[j];
			for (int c = 0; c < 3; c++)
				m[k][c] += h->row[j][k] * emf_gain() * h->row[j][c];
		}
	for (int k = 0; k < 3; k++)
		m[k][k] += B[k];
	solve3(m, f, x);
	for (int it = 0; it < 10; it++) {
		for (int k = 0; k < 3; k++)
			rhs[k] = f[k] - C[k] * (x[k] > 0 ? 1.0 : -1.0);
		solve3(m, rhs, x);
	}
}

static void run(struct plant *pl, const double u[4], bool driven, double t_s)
{
	const long n = lround(t_s / DT);

	for (long i = 0; i < n; i++)
		plant_step(pl, u, driven, DT);
}

/* Slot 3 of a three-wheel robot: no motor, so 0 V, 0 A and 0 rad/s whatever it is sent. */
static void assert_slot3_empty(const struct plant *pl)
{
	double w[4], n[4], hold[4];

	plant_wheel_speeds(pl, w);
	plant_wheel_loads(pl, n, hold);
	assert_true(pl->voltage_v[3] == 0.0 && pl->current_a[3] == 0.0 && w[3] == 0.0);
	assert_true(n[3] == 0.0 && hold[3] == 0.0);
}

/* Three equal wheels at 0/120/240 deg at 0.12 m (not Table III's d), 6 V each: the torque
 * 3 d b (u - kemf d w) balances Bw w + Cw at w = (3 d b u - Cw) / (3 d^2 e + Bw); v and vn
 * stay 0 (the forces cancel); each wheel turns at d w / r and draws (u - Kv l d w / r) / R.
 * Slot 3 is sent 9 V and has no motor. */
static void test_three_wheels_reach_the_motor_equations_steady_w(void **state)
{
	(void)state;
	const double a[4] = {0, 120, 240, 0}, dist[4] = {0.12, 0.12, 0.12, 0}, U = 6.0;
	const double u[4] = {U, U, U, 9.0}, d = 0.12;
	const double w_ss = (3 * d * drive_gain() * U - P->Cw) / (3 * d * d * emf_gain() + P->Bw);
	struct hand h;
	struct wheel_geom g;
	struct plant pl;
	double ws[4];

	hand_layout(3, a, dist, &h, &g);
	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	run(&pl, u, true, 8.0); /* 8 s: 35 time constants of J / (3 d^2 e + Bw) = 0.23 s */
	/* Rounding alone (measured: 1.1e-14 of w, 1.3e-14 A): bounds at 3x. */
	assert_near(pl.x[2], w_ss, 3e-14 * w_ss);
	assert_true(pl.x[0] == 0.0 && pl.x[1] == 0.0); /* what is left is rounding, below Cv */
	plant_wheel_speeds(&pl, ws);
	for (int j = 0; j < 3; j++) {
		assert_near(ws[j], d * w_ss / P->r, 3e-14 * ws[j]);
		assert_near(pl.current_a[j], (U - P->Kv * P->l * d * w_ss / P->r) / P->R, 4e-14);
		assert_true(pl.voltage_v[j] == U);
	}
	assert_slot3_empty(&pl);
}

/* Three wheels at unequal distances (0.10, 0.12, 0.14 m) couple the axes through back-EMF:
 * unequal volts reach the coupled steady state solved by hand (every axis moving). */
static void test_an_unequal_three_reaches_the_coupled_steady_state(void **state)
{
	(void)state;
	const double a[4] = {0, 120, 240, 0}, dist[4] = {0.10, 0.12, 0.14, 0};
	const double u[4] = {12.0, 2.0, 10.0, -7.0};
	struct hand h;
	struct wheel_geom g;
	struct plant pl;
	double x_ss[3];

	hand_layout(3, a, dist, &h, &g);
	hand_steady(&h, u, x_ss);
	for (int k = 0; k < 3; k++)
		assert_true(fabs(x_ss[k]) > 0.05); /* the case is the coupled one: all moving */
	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	assert_true(pl.coupled);
	run(&pl, u, true, 10.0);
	for (int k = 0; k < 3; k++) /* measured: 4.8e-12 of the speed */
		assert_near(pl.x[k], x_ss[k], 1.5e-11 * fabs(x_ss[k]));
	assert_slot3_empty(&pl);
}

/* The asymmetric four: 60/135/225/300 deg, the front pair nearer (mirror images across v). */
static void asym_four(struct hand *h, struct wheel_geom *g)
{
	const double a[4] = {60, 135, 225, 300}, dist[4] = {0.078, 0.081, 0.081, 0.078};

	hand_layout(4, a, dist, h, g);
}

/* Volts of the least-norm wheel forces f = G (G^T G)^-1 F at rest (f = b u there). */
static void least_norm_volts(const struct hand *h, const double F[3], double u[4])
{
	double m[3][3] = {{0}}, y[3];

	for (int j = 0; j < h->n; j++)
		for (int k = 0; k < 3; k++)
			for (int c = 0; c < 3; c++)
				m[k][c] += h->row[j][k] * h->row[j][c];
	solve3(m, F, y);
	for (int j = 0; j < 4; j++)
		u[j] = (h->row[j][0] * y[0] + h->row[j][1] * y[1] + h->row[j][2] * y[2]) /
		       drive_gain();
}

/* From rest, the pure-v pattern for Fv = 8 N with the body's friction scaled by s: v follows
 * m v' = Fv - (sum e gx_j^2 + s Bv) v - s Cv (the layout is symmetric across v, so back-EMF
 * along v pushes along v only) and vn, w stay 0 to rounding. */
static void pure_v_run(double s)
{
	const double F[3] = {8.0, 0.0, 0.0};
	struct hand h;
	struct wheel_geom g;
	struct plant pl;
	double u[4], ev = 0.0;

	asym_four(&h, &g);
	least_norm_volts(&h, F, u);
	for (int j = 0; j < 4; j++)
		ev += emf_gain() * h.row[j][0] * h.row[j][0];
	const double a = -(ev + s * P->Bv) / P->M, v_ss = (F[0] - s * P->Cv) / (ev + s * P->Bv);

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	plant_set_friction_scale(&pl, s);
	assert_true(pl.coupled); /* vn and w couple: the substep path */
	for (int i = 1; i <= 2000; i++) {
		plant_step(&pl, u, true, DT);
		/* Rounding (measured: 3.4e-14 of v_ss; vn 1.0e-16 m/s, w 4.7e-16 rad/s): v at 3x,
		 * vn and w at 1e-15 m/s (w at the wheels' arm, 0.08 m), where only rounding fits.
		 */
		assert_near(pl.x[0], v_ss * (1.0 - exp(a * i * DT)), 1e-13 * v_ss);
		assert_near(pl.x[1], 0.0, 1e-15);
		assert_near(pl.x[2], 0.0, 1e-15 / 0.08);
	}
	assert_true(pl.x[0] > 0.8 * v_ss);
}

static void test_a_pure_v_pattern_on_an_asymmetric_four_moves_along_v_only(void **state)
{
	(void)state;
	pure_v_run(1.0); /* Table III's friction: v's closed form with Coulomb */
	pure_v_run(0.0); /* no friction: no stiction hides a leak into vn or w */
}

/* Closed form of one axis coasting: m x' = -B x - C sgn(x) from x0, at rest after
 * t* = (m / B) ln(1 + B |x0| / C). */
static double coast(double x0, double m, double B, double C, double t)
{
	const double s = x0 > 0 ? 1.0 : -1.0, k = C / B;

	if (t >= m / B * log(1.0 + fabs(x0) / k))
		return 0.0;
	return s * ((fabs(x0) + k) * exp(-B * t / m) - k);
}

/* A push (external force, bridges off) and release: each axis decays as the closed form,
 * for three wheels, the asymmetric four and no layout alike (no drive, no back-EMF: the
 * layout does not enter). */
static void push_and_coast(struct plant *pl)
{
	const double push[3] = {9.0, -7.0, 1.2}, m[3] = {P->M, P->M, P->J};
	const double B[3] = {P->Bv, P->Bvn, P->Bw}, C[3] = {P->Cv, P->Cvn, P->Cw};
	const double u[4] = {5, 5, 5, 5};

	memcpy(pl->ext_force, push, sizeof(push));
	run(pl, u, false, 0.3);
	memset(pl->ext_force, 0, sizeof(pl->ext_force));
	const double x0[3] = {pl->x[0], pl->x[1], pl->x[2]};

	assert_true(x0[0] > 0.2 && x0[1] < -0.1 && x0[2] > 3.0);
	for (int i = 1; i <= 1500; i++) {
		plant_step(pl, u, false, DT);
		for (int k = 0; k < 3; k++)
			assert_near(pl->x[k], coast(x0[k], m[k], B[k], C[k], i * DT),
			            1.5e-12); /* measured 4.7e-13 */
		assert_true(pl->current_a[0] == 0.0 && pl->voltage_v[1] == 0.0);
	}
	for (int k = 0; k < 3; k++)
		assert_true(pl->x[k] == 0.0); /* all three stopped inside 1.5 s, and stay */
}

static void test_a_push_with_the_bridges_off_decays_as_the_papers(void **state)
{
	(void)state;
	const double a3[4] = {0, 120, 240, 0}, dist3[4] = {0.1, 0.12, 0.14, 0};
	struct hand h;
	struct wheel_geom g;
	struct plant pl;

	assert_int_equal(plant_init(&pl, P), 0);
	push_and_coast(&pl);
	asym_four(&h, &g);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	push_and_coast(&pl);
	hand_layout(3, a3, dist3, &h, &g);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	push_and_coast(&pl);
	assert_slot3_empty(&pl);
}

/* While the body accelerates and turns, the loads carry the weight (sum N_j = M g) and the
 * tipping moment of the centre of mass at height h (sum N_j p_j = -M h a_c, a_c = (a_v - w vn,
 * a_vn + w v)), each holding mu N_j; with three wheels these fix the loads. */
static void loads_run(const struct hand *hd, const struct wheel_geom *g, const double u[4])
{
	const struct plant_floor f = {
	    .traction_mu = 3.0, .wheel_inertia = 1e-4, .com_height = 0.03};
	struct plant pl;
	double n[4], hold[4];

	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0); /* either order: floor, then layout ... */
	assert_int_equal(plant_set_geom(&pl, g), 0);
	for (int i = 0; i < 300; i++) {
		plant_step(&pl, u, true, DT);
		plant_wheel_loads(&pl, n, hold);
		const double ac[2] = {pl.acc[0] - pl.x[2] * pl.x[1], pl.acc[1] + pl.x[2] * pl.x[0]};
		double sum = 0.0, mom[2] = {0.0, 0.0};

		assert_true(hypot(ac[0], ac[1]) > 0.1);
		for (int j = 0; j < 4; j++) {
			assert_true(j >= hd->n || n[j] > 0.0); /* none lifts: the moment is whole */
			assert_true(hold[j] == f.traction_mu * n[j]);
			sum += n[j];
			mom[0] += n[j] * hd->pos[j][0];
			mom[1] += n[j] * hd->pos[j][1];
		}
		/* measured: 3.6e-15 N, 7.8e-16 N m (of 23 N, 0.1 N m) */
		assert_near(sum, P->M * G_M_S2, 1e-14);
		assert_near(mom[0], -P->M * f.com_height * ac[0], 2.5e-15);
		assert_near(mom[1], -P->M * f.com_height * ac[1], 2.5e-15);
	}
	assert_int_equal(plant_slip_flags(&pl), 0);
}

static void test_the_loads_carry_the_weight_and_the_tipping_moment(void **state)
{
	(void)state;
	const double a3[4] = {0, 120, 240, 0}, dist3[4] = {0.1, 0.12, 0.14, 0};
	const double u4[4] = {8, -4, 6, 9}, u3[4] = {12, 2, 10, 5};
	struct hand h;
	struct wheel_geom g;

	asym_four(&h, &g);
	loads_run(&h, &g, u4);
	hand_layout(3, a3, dist3, &h, &g);
	loads_run(&h, &g, u3);
}

/* Three equal wheels at rest each carry M g / 3 (not the paper's quarter) and hold
 * mu M g / 3: a wheel force of 95 % of it (b u at rest) grips, 120 % slips. (Just above the
 * limit the excess spins the wheel's own inertia no faster than the body turns under it: the
 * rim stays with the ground, as the floor's wheel inertia says; test_plant_load.c.) */
static uint32_t three_wheels_pushed(double share)
{
	const double a[4] = {0, 120, 240, 0}, dist[4] = {0.1, 0.1, 0.1, 0};
	const struct plant_floor f = {.traction_mu = 0.1, .wheel_inertia = 1e-4};
	const double U = share * f.traction_mu * P->M * G_M_S2 / 3.0 / drive_gain();
	const double u[4] = {U, U, U, U};
	struct hand h;
	struct wheel_geom g;
	struct plant pl;

	hand_layout(3, a, dist, &h, &g);
	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	assert_int_equal(plant_set_floor(&pl, &f), 0);
	plant_step(&pl, u, true, DT);
	return plant_slip_flags(&pl);
}

static void test_three_wheels_hold_a_third_of_the_weight_times_mu(void **state)
{
	(void)state;
	assert_int_equal(three_wheels_pushed(0.95), 0);
	assert_int_equal(three_wheels_pushed(1.2), 7); /* wheels 0-2; slot 3 never */
}

/* Everything a caller reads, plant a against plant b within rel of each value (at least of 1;
 * the loads of M g: they take the acceleration by finite difference over a substep). */
static void assert_same_plant(const struct plant *a, const struct plant *b, double rel)
{
	double wa[4], wb[4], na[4], nb[4], ha[4], hb[4];
	const double load_tol = rel * P->M * G_M_S2;

	plant_wheel_speeds(a, wa);
	plant_wheel_speeds(b, wb);
	plant_wheel_loads(a, na, ha);
	plant_wheel_loads(b, nb, hb);
	for (int k = 0; k < 3; k++) {
		assert_near(a->x[k], b->x[k], rel * fmax(1.0, fabs(b->x[k])));
		assert_near(a->pose[k], b->pose[k], rel * fmax(1.0, fabs(b->pose[k])));
	}
	for (int j = 0; j < 4; j++) {
		assert_near(a->current_a[j], b->current_a[j],
		            rel * fmax(1.0, fabs(b->current_a[j])));
		assert_true(a->voltage_v[j] == b->voltage_v[j]);
		assert_near(wa[j], wb[j], rel * fmax(1.0, fabs(wb[j])));
		assert_near(na[j], nb[j], load_tol);
		assert_near(ha[j], hb[j], load_tol);
	}
	assert_int_equal(plant_slip_flags(a), plant_slip_flags(b));
}

/* 1 s of changing volts, then 0.5 s off, on floor f: the plant given the paper's layout
 * (wheel_geom_angles 0/90/180/270 at d) and the plant without a layout agree within 1e-12
 * (measured: 1e-14 of the velocity, 6e-14 of M g in the loads). */
static uint32_t paper_explicit_run(const struct plant_floor *f)
{
	const double a[4] = {0, 90, 180, 270}, dist[4] = {P->d, P->d, P->d, P->d};
	struct wheel_geom g;
	struct plant ref, lay;
	uint32_t slipped = 0;

	assert_int_equal(wheel_geom_angles(4, a, dist, &g), 0);
	assert_int_equal(plant_init(&ref, P), 0);
	assert_int_equal(plant_init(&lay, P), 0);
	assert_int_equal(plant_set_geom(&lay, &g), 0);
	assert_false(lay.coupled);
	assert_int_equal(plant_set_floor(&ref, f), 0);
	assert_int_equal(plant_set_floor(&lay, f), 0); /* ... or layout, then floor */
	for (int i = 0; i < 1500; i++) {
		const double t = i * DT, on = i < 1000;
		const double u[4] = {9 * sin(7 * t), 12 * cos(3 * t), -6 + 4 * t, 10 * sin(11 * t)};

		plant_step(&ref, u, on, DT);
		plant_step(&lay, u, on, DT);
		assert_same_plant(&lay, &ref, 1e-12);
		slipped |= plant_slip_flags(&ref);
	}
	return slipped;
}

static void test_the_papers_layout_given_is_the_plant_without_one(void **state)
{
	(void)state;
	const struct plant_floor off = {0};
	const struct plant_floor slip = {.traction_mu = 0.25,
	                                 .wheel_inertia = 2e-4,
	                                 .com_height = 0.05,
	                                 .radius_error = {0.02, -0.01, 0, 0.03}};

	assert_int_equal(paper_explicit_run(&off), 0);
	assert_int_not_equal(paper_explicit_run(&slip), 0); /* the slip path, too */
}

/* A layout the wheels' physics refuses is refused whole: -EINVAL, and the plant runs on as
 * before; NULL gives the paper's closed forms back, to the last bit. */
static void test_a_bad_layout_is_refused_and_null_restores_the_paper(void **state)
{
	(void)state;
	const double a[4] = {60, 135, 225, 300}, dist[4] = {0.078, 0.081, 0.081, 0.078};
	const double u[4] = {3, -2, 5, 1};
	struct wheel_geom g, bad;
	struct plant ref, pl;

	assert_int_equal(wheel_geom_angles(4, a, dist, &g), 0);
	bad = g;
	bad.n = 5;
	assert_int_equal(plant_init(&ref, P), 0);
	assert_int_equal(plant_init(&pl, P), 0);
	assert_int_equal(plant_set_geom(&pl, &bad), -EINVAL);
	assert_false(pl.has_geom);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	bad.row[1][2] = -0.081;
	assert_int_equal(plant_set_geom(&pl, &bad), -EINVAL);
	assert_true(pl.has_geom && pl.ph.n == 4 && pl.ph.row[1][2] == 0.081);
	assert_int_equal(plant_set_geom(&pl, NULL), 0);
	run(&ref, u, true, 0.5);
	run(&pl, u, true, 0.5);
	assert_memory_equal(pl.x, ref.x, sizeof(ref.x));
	assert_memory_equal(pl.current_a, ref.current_a, sizeof(ref.current_a));
	assert_memory_equal(&pl.ss, &ref.ss, sizeof(ref.ss));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_three_wheels_reach_the_motor_equations_steady_w),
	    cmocka_unit_test(test_an_unequal_three_reaches_the_coupled_steady_state),
	    cmocka_unit_test(test_a_pure_v_pattern_on_an_asymmetric_four_moves_along_v_only),
	    cmocka_unit_test(test_a_push_with_the_bridges_off_decays_as_the_papers),
	    cmocka_unit_test(test_the_loads_carry_the_weight_and_the_tipping_moment),
	    cmocka_unit_test(test_three_wheels_hold_a_third_of_the_weight_times_mu),
	    cmocka_unit_test(test_the_papers_layout_given_is_the_plant_without_one),
	    cmocka_unit_test(test_a_bad_layout_is_refused_and_null_restores_the_paper),
	};

	return cmocka_run_group_tests_name("plant_layouts", tests, NULL, NULL);
}
