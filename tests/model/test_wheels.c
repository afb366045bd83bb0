/*
 * Tests for the per-wheel model (struct model_wheels; docs/model.md): equal wheels give the
 * scalar functions' bits, one odd wheel gives the hand derivation of eq 23, A and B are the
 * finite differences of the force balance, the feedforward inverts the per-wheel model, and the
 * Q16.16 twins stay within their stated bounds of the double ones.
 */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/kinematics.h"
#include "omni4/model/params.h"
#include "omni4/model/rng.h"

#define N_RANDOM 3000
#define LSB_HALF (1.0 / 131072.0) /* half a Q16.16 LSB, 2^-17 */

static void assert_same_bits(double got, double want, const char *what, int n)
{
	if (memcmp(&got, &want, sizeof(got)) != 0)
		fail_msg("%s (draw %d): got %a, want %a", what, n, got, want);
}

/* Table III with every field scaled by a factor in [0.5, 2): Kv != Kt, any shape of robot. */
static void random_params(struct rng *g, struct model_params *p)
{
	*p = model_params_table3;
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		*model_params_field(p, i) *= rng_uniform(g, 0.5, 2.0);
}

/* Each wheel's r, Kv, Kt, R off p's by up to +-spread (relative). */
static void random_wheels(struct rng *g, const struct model_params *p, double spread,
                          struct model_wheels *w)
{
	for (int j = 0; j < 4; j++) {
		w->r[j] = p->r * (1.0 + rng_uniform(g, -spread, spread));
		w->Kv[j] = p->Kv * (1.0 + rng_uniform(g, -spread, spread));
		w->Kt[j] = p->Kt * (1.0 + rng_uniform(g, -spread, spread));
		w->R[j] = p->R * (1.0 + rng_uniform(g, -spread, spread));
	}
}

/* ---- equal wheels: the scalar functions' bits ------------------------------------------- */

static void test_equal_wheels_give_the_scalar_state_space_bit_for_bit(void **state)
{
	(void)state;
	struct rng g;
	const double zero = 0.0;

	rng_seed(&g, 0x5eed01);
	for (int n = 0; n < N_RANDOM; n++) {
		struct model_params p;
		struct model_wheels w;
		struct model_ss ss;
		struct model_ss_wheels sw;

		random_params(&g, &p);
		model_wheels_from_params(&p, &w);
		dyn_state_space(&p, &ss);
		dyn_state_space_wheels(&p, &w, &sw);
		for (int k = 0; k < 3; k++) {
			assert_same_bits(sw.A[k][k], ss.A[k], "A diagonal", n);
			assert_same_bits(sw.A_coast[k], ss.A_coast[k], "A_coast", n);
			assert_same_bits(sw.K[k], ss.K[k], "K", n);
			for (int c = 0; c < 3; c++)
				if (c != k)
					assert_same_bits(sw.A[k][c], zero, "A off-diagonal (+0)",
					                 n);
			for (int j = 0; j < 4; j++)
				assert_same_bits(sw.B[k][j], ss.B[k][j], "B", n);
		}
	}
}

static void test_equal_wheels_give_the_scalar_forces_and_motor_bits(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed02);
	for (int n = 0; n < N_RANDOM; n++) {
		struct model_params p;
		struct model_wheels w;
		double i[4], v[4], u[4], f[4], fw[4], wm[4], uw[4], iw[4];

		random_params(&g, &p);
		model_wheels_from_params(&p, &w);
		for (int j = 0; j < 4; j++) {
			i[j] = rng_uniform(&g, -20, 20);
			v[j] = rng_uniform(&g, -5, 5);
			u[j] = rng_uniform(&g, -24, 24);
		}
		dyn_wheel_forces(&p, i, f);
		dyn_wheel_forces_wheels(&p, &w, i, fw);
		motor_speeds_wheels(&p, &w, v, wm);
		motor_voltages_wheels(&w, i, wm, uw);
		motor_currents_wheels(&w, u, wm, iw);
		for (int j = 0; j < 4; j++) {
			const double wm_s = motor_speed_rad_s(&p, v[j]);

			assert_same_bits(fw[j], f[j], "wheel force", n);
			assert_same_bits(wm[j], wm_s, "motor speed", n);
			assert_same_bits(uw[j], motor_voltage(&p, i[j], wm_s), "motor voltage", n);
			assert_same_bits(iw[j], motor_current(&p, u[j], wm_s), "motor current", n);
		}
	}
}

/* A random velocity or acceleration, now and then exactly 0 or inside the sign's band. */
static double random_axis(struct rng *g, double span, double band)
{
	const double pick = rng_uniform(g, 0, 1);

	return pick < 0.1
	           ? 0.0
		   : (pick < 0.3 ? rng_uniform(g, -band, band) : rng_uniform(g, -span, span));
}

static void test_equal_wheels_give_the_scalar_feedforward_bits_double(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed03);
	for (int n = 0; n < N_RANDOM; n++) {
		struct model_params p;
		struct model_wheels w;
		const double band[3] = {FF_SIGN_BAND_LIN, FF_SIGN_BAND_LIN, FF_SIGN_BAND_ROT};
		double vel[3], acc[3], u[4], uw[4];

		random_params(&g, &p);
		model_wheels_from_params(&p, &w);
		for (int k = 0; k < 3; k++) {
			vel[k] = random_axis(&g, k < 2 ? 3.0 : 20.0, band[k]);
			acc[k] = random_axis(&g, 10.0, 1.0);
		}
		const double u_max = rng_uniform(&g, 1.0, 30.0);

		ff_voltages(&p, vel, acc, u_max, u);
		ff_voltages_wheels(&p, &w, vel, acc, u_max, uw);
		for (int j = 0; j < 4; j++)
			assert_same_bits(uw[j], u[j], "feedforward voltage", n);
	}
}

static q16_t random_q16(struct rng *g, double span)
{
	/* One draw in eight anywhere in the int32 range: the saturating clamp is exercised too. */
	if (rng_uniform(g, 0, 1) < 0.125)
		return (q16_t)(uint32_t)rng_u64(g);
	return q16_from_double(rng_uniform(g, -span, span));
}

static void test_equal_wheels_give_the_scalar_feedforward_bits_q16(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed04);
	for (int n = 0; n < N_RANDOM; n++) {
		struct model_params p;
		struct model_wheels w;
		struct ff_q16 ff;
		struct ff_q16_wheels fw;
		q16_t vel[3], acc[3], u[4], uw[4];

		random_params(&g, &p);
		model_wheels_from_params(&p, &w);
		const double u_max = rng_uniform(&g, 1.0, 30.0);

		assert_int_equal(ff_q16_init(&ff, &p, u_max), 0);
		assert_int_equal(ff_q16_wheels_init(&fw, &p, &w, u_max), 0);
		assert_int_equal(fw.d, ff.d);
		assert_int_equal(fw.u_max, ff.u_max);
		for (int k = 0; k < 3; k++) {
			assert_int_equal(fw.sgn_gain[k], ff.sgn_gain[k]);
			for (int j = 0; j < 4; j++) {
				assert_int_equal(fw.k_acc[j][k], ff.k_acc[k]);
				assert_int_equal(fw.k_vel[j][k], ff.k_vel[k]);
				assert_int_equal(fw.k_coul[j][k], ff.k_coul[k]);
			}
		}
		for (int m = 0; m < 10; m++) {
			for (int k = 0; k < 3; k++) {
				vel[k] = random_q16(&g, k < 2 ? 3.0 : 20.0);
				acc[k] = random_q16(&g, 10.0);
			}
			ff_voltages_q16(&ff, vel, acc, u);
			ff_voltages_q16_wheels(&fw, vel, acc, uw);
			assert_memory_equal(uw, u, sizeof(u));
		}
	}
}

static void test_equal_radii_give_the_scalar_kinematics_bits(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed05);
	for (int n = 0; n < N_RANDOM; n++) {
		const double d = rng_uniform(&g, 0.05, 0.3), r = rng_uniform(&g, 0.01, 0.1);
		const double rr[4] = {r, r, r, r};
		const double x[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                     rng_uniform(&g, -20, 20)};
		double rate[4], v[4], wv[4], back[3], want[3];

		ik_wheel_rates(d, rr, x, rate);
		ik_wheel_speeds(d, x, v);
		for (int j = 0; j < 4; j++) {
			assert_same_bits(rate[j], v[j] / r, "wheel rate", n);
			wv[j] = rate[j] * r; /* what a scalar caller does with encoder rates */
		}
		fk_robot_velocity_rates(d, rr, rate, back);
		fk_robot_velocity(d, wv, want);
		for (int k = 0; k < 3; k++)
			assert_same_bits(back[k], want[k], "robot velocity", n);
	}
}

/* ---- one odd wheel: the hand derivation ----------------------------------------------- */

/*
 * Hand-derived A and B (eqs 2, 9-13, 21 on paper, docs/model.md) for Table III with one wheel's
 * constant off. Notation: emf = Kt Kv l^2 / (r^2 R), b = l Kt / (r R), the paper's values.
 */
struct hand {
	double A[3][3], B[3][4];
};

static void check_against_hand(const struct model_wheels *w, const struct hand *h)
{
	const struct model_params *p = &model_params_table3;
	struct model_ss_wheels ss;

	dyn_state_space_wheels(p, w, &ss);
	for (int k = 0; k < 3; k++) {
		for (int c = 0; c < 3; c++)
			assert_near(ss.A[k][c], h->A[k][c], 1e-12 * (1.0 + fabs(h->A[k][c])));
		for (int j = 0; j < 4; j++)
			assert_near(ss.B[k][j], h->B[k][j], 1e-12 * (1.0 + fabs(h->B[k][j])));
	}
}

/* The scalar pieces of the hand derivation. */
#define HAND_SCALARS                                                                               \
	const struct model_params *p = &model_params_table3;                                       \
	const double M = p->M, J = p->J, d = p->d, Bv = p->Bv, Bvn = p->Bvn, Bw = p->Bw;           \
	const double emf = p->Kt * p->Kv * p->l * p->l / (p->r * p->r * p->R);                     \
	const double b = p->l * p->Kt / (p->r * p->R);                                             \
	struct model_wheels w;                                                                     \
	model_wheels_from_params(p, &w)

/* Only R_2 differs, R_2 = R / rho: wheel 2 (rear, pushes -vn) brakes and drives by rho. */
static void test_odd_resistance_R2_matches_the_hand_derivation(void **state)
{
	(void)state;
	HAND_SCALARS;
	const double rho = 1.0 / 1.07;

	w.R[2] = p->R * 1.07;
	const struct hand h = {
	    .A = {{-(2 * emf + Bv) / M, 0, 0},
	          {0, -(emf * (1 + rho) + Bvn) / M, -d * emf * (1 - rho) / M},
	          {0, -d * emf * (1 - rho) / J, -(d * d * emf * (3 + rho) + Bw) / J}},
	    .B = {{0, -b / M, 0, b / M},
	          {b / M, 0, -b * rho / M, 0},
	          {d * b / J, d * b / J, d * b * rho / J, d * b / J}},
	};
	check_against_hand(&w, &h);
}

/* Only r_0 differs, r_0 = r / s: wheel 0 (front, pushes +vn) brakes by s^2, drives by s. */
static void test_odd_radius_r0_matches_the_hand_derivation(void **state)
{
	(void)state;
	HAND_SCALARS;
	const double s = 1.0 / 0.95;

	w.r[0] = p->r * 0.95;
	const struct hand h = {
	    .A = {{-(2 * emf + Bv) / M, 0, 0},
	          {0, -(emf * (1 + s * s) + Bvn) / M, -d * emf * (s * s - 1) / M},
	          {0, -d * emf * (s * s - 1) / J, -(d * d * emf * (3 + s * s) + Bw) / J}},
	    .B = {{0, -b / M, 0, b / M},
	          {b * s / M, 0, -b / M, 0},
	          {d * b * s / J, d * b / J, d * b / J, d * b / J}},
	};
	check_against_hand(&w, &h);
}

/* Only Kv_3 differs by kappa: wheel 3 (right, pushes +v) brakes by kappa, drives as the rest. */
static void test_odd_back_emf_Kv3_matches_the_hand_derivation(void **state)
{
	(void)state;
	HAND_SCALARS;
	const double kappa = 1.04;

	w.Kv[3] = p->Kv * kappa;
	const struct hand h = {
	    .A = {{-(emf * (1 + kappa) + Bv) / M, 0, -d * emf * (kappa - 1) / M},
	          {0, -(2 * emf + Bvn) / M, 0},
	          {-d * emf * (kappa - 1) / J, 0, -(d * d * emf * (3 + kappa) + Bw) / J}},
	    .B = {{0, -b / M, 0, b / M},
	          {b / M, 0, -b / M, 0},
	          {d * b / J, d * b / J, d * b / J, d * b / J}},
	};
	check_against_hand(&w, &h);
}

/* Only Kt_1 differs by tau: wheel 1 (left, pushes -v) brakes and drives by tau. */
static void test_odd_torque_constant_Kt1_matches_the_hand_derivation(void **state)
{
	(void)state;
	HAND_SCALARS;
	const double tau = 0.93;

	w.Kt[1] = p->Kt * tau;
	const struct hand h = {
	    .A = {{-(emf * (1 + tau) + Bv) / M, 0, -d * emf * (1 - tau) / M},
	          {0, -(2 * emf + Bvn) / M, 0},
	          {-d * emf * (1 - tau) / J, 0, -(d * d * emf * (3 + tau) + Bw) / J}},
	    .B = {{0, -b * tau / M, 0, b / M},
	          {b / M, 0, -b / M, 0},
	          {d * b / J, d * b * tau / J, d * b / J, d * b / J}},
	};
	check_against_hand(&w, &h);
}

/* ---- finite differences of the force balance ------------------------------------------ */

/* dx/dt by the equations, written out here: eq 2, 21, 12-13, 9-11 and Newton with friction. */
static void accel_by_hand(const struct model_params *p, const struct model_wheels *w,
                          const double x[3], const double u[4], double a[3])
{
	const double d = p->d, dw = d * x[2];
	const double v[4] = {x[1] + dw, -x[0] + dw, -x[1] + dw, x[0] + dw};
	double f[4];

	for (int j = 0; j < 4; j++) {
		const double wm = p->l * v[j] / w->r[j];
		const double i = (u[j] - w->Kv[j] * wm) / w->R[j];

		f[j] = p->l * w->Kt[j] * i / w->r[j];
	}
	const double sgn[3] = {x[0] > 0 ? 1.0 : -1.0, x[1] > 0 ? 1.0 : -1.0, x[2] > 0 ? 1.0 : -1.0};

	a[0] = (f[3] - f[1] - p->Bv * x[0] - p->Cv * sgn[0]) / p->M;
	a[1] = (f[0] - f[2] - p->Bvn * x[1] - p->Cvn * sgn[1]) / p->M;
	a[2] = (d * (f[0] + f[1] + f[2] + f[3]) - p->Bw * x[2] - p->Cw * sgn[2]) / p->J;
}

/* A state with every component at least 0.5 from 0 (the sign stays put under the steps). */
static double away_from_zero(struct rng *g, double span)
{
	const double m = rng_uniform(g, 0.5, span);

	return rng_uniform(g, 0, 1) < 0.5 ? -m : m;
}

static void test_A_and_B_are_the_finite_differences_of_the_force_balance(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed06);
	for (int n = 0; n < 500; n++) {
		struct model_params p;
		struct model_wheels w;
		struct model_ss_wheels ss;
		double x[3] = {away_from_zero(&g, 3), away_from_zero(&g, 3),
		               away_from_zero(&g, 20)};
		double u[4], ap[3], am[3], a0[3];

		random_params(&g, &p);
		random_wheels(&g, &p, 0.15, &w);
		dyn_state_space_wheels(&p, &w, &ss);
		for (int j = 0; j < 4; j++)
			u[j] = rng_uniform(&g, -12, 12);
		for (int c = 0; c < 3; c++) { /* column c of A */
			const double h = 1e-3, keep = x[c];

			x[c] = keep + h;
			accel_by_hand(&p, &w, x, u, ap);
			x[c] = keep - h;
			accel_by_hand(&p, &w, x, u, am);
			x[c] = keep;
			for (int k = 0; k < 3; k++)
				assert_near(ss.A[k][c], (ap[k] - am[k]) / (2 * h),
				            1e-7 * (1 + fabs(ss.A[k][c])));
		}
		for (int j = 0; j < 4; j++) { /* column j of B */
			const double h = 1e-2, keep = u[j];

			u[j] = keep + h;
			accel_by_hand(&p, &w, x, u, ap);
			u[j] = keep - h;
			accel_by_hand(&p, &w, x, u, am);
			u[j] = keep;
			for (int k = 0; k < 3; k++)
				assert_near(ss.B[k][j], (ap[k] - am[k]) / (2 * h),
				            1e-9 * (1 + fabs(ss.B[k][j])));
		}
		accel_by_hand(&p, &w, x, u, a0); /* and the whole right-hand side at the point */
		for (int k = 0; k < 3; k++) {
			double dx = ss.K[k] * (x[k] > 0 ? 1.0 : -1.0);

			for (int c = 0; c < 3; c++)
				dx += ss.A[k][c] * x[c];
			for (int j = 0; j < 4; j++)
				dx += ss.B[k][j] * u[j];
			assert_near(dx, a0[k], 1e-10 * (1 + fabs(a0[k])));
		}
	}
}

/* The per-wheel forces and motor equation chained give the same dx/dt as accel_by_hand. */
static void test_per_wheel_equation_chain_matches_the_hand_balance(void **state)
{
	(void)state;
	struct rng g;

	rng_seed(&g, 0x5eed07);
	for (int n = 0; n < 500; n++) {
		struct model_params p;
		struct model_wheels w;
		const double x[3] = {away_from_zero(&g, 3), away_from_zero(&g, 3),
		                     away_from_zero(&g, 20)};
		double u[4], v[4], wm[4], i[4], f[4], F[3], a[3];

		random_params(&g, &p);
		random_wheels(&g, &p, 0.15, &w);
		for (int j = 0; j < 4; j++)
			u[j] = rng_uniform(&g, -12, 12);
		ik_wheel_speeds(p.d, x, v);
		motor_speeds_wheels(&p, &w, v, wm);
		motor_currents_wheels(&w, u, wm, i);
		dyn_wheel_forces_wheels(&p, &w, i, f);
		dyn_robot_forces(p.d, f, F);
		accel_by_hand(&p, &w, x, u, a);
		assert_near((F[0] - p.Bv * x[0] - p.Cv * (x[0] > 0 ? 1 : -1)) / p.M, a[0],
		            1e-10 * (1 + fabs(a[0])));
		assert_near((F[1] - p.Bvn * x[1] - p.Cvn * (x[1] > 0 ? 1 : -1)) / p.M, a[1],
		            1e-10 * (1 + fabs(a[1])));
		assert_near((F[2] - p.Bw * x[2] - p.Cw * (x[2] > 0 ? 1 : -1)) / p.J, a[2],
		            1e-10 * (1 + fabs(a[2])));
		double back[4];

		motor_voltages_wheels(&w, i, wm, back);
		for (int j = 0; j < 4; j++)
			assert_near(back[j], u[j], 1e-12 * (1 + fabs(u[j])));
	}
}

/* ---- the feedforward inverts the per-wheel model ------------------------------------------ */

static void test_feedforward_wheels_gives_the_wanted_acceleration(void **state)
{
	(void)state;
	struct rng g;
	double worst_scalar = 0;

	rng_seed(&g, 0x5eed08);
	for (int n = 0; n < 500; n++) {
		struct model_params p;
		struct model_wheels w;
		struct model_ss_wheels ss;
		/* outside the sign's band: sgn is +-1 in both the feedforward and the model */
		const double x[3] = {away_from_zero(&g, 3), away_from_zero(&g, 3),
		                     away_from_zero(&g, 20)};
		const double acc[3] = {rng_uniform(&g, -5, 5), rng_uniform(&g, -5, 5),
		                       rng_uniform(&g, -20, 20)};
		double u[4], us[4];

		random_params(&g, &p);
		random_wheels(&g, &p, 0.15, &w);
		dyn_state_space_wheels(&p, &w, &ss);
		ff_voltages_wheels(&p, &w, x, acc, 1e9, u);
		ff_voltages(&p, x, acc, 1e9, us); /* the scalar one, blind to the differences */
		for (int k = 0; k < 3; k++) {
			double dx = ss.K[k] * (x[k] > 0 ? 1.0 : -1.0), dxs = dx;

			for (int c = 0; c < 3; c++) {
				dx += ss.A[k][c] * x[c];
				dxs += ss.A[k][c] * x[c];
			}
			for (int j = 0; j < 4; j++) {
				dx += ss.B[k][j] * u[j];
				dxs += ss.B[k][j] * us[j];
			}
			assert_near(dx, acc[k],
			            1e-9 * (1 + fabs(acc[k]) + fabs(ss.A[k][k] * x[k])));
			worst_scalar = fmax(worst_scalar, fabs(dxs - acc[k]));
		}
	}
	assert_true(worst_scalar > 0.1); /* the differences matter: the scalar one misses */
}

/* ---- Q16.16 against double, within the stated bounds -------------------------------------- */

/*
 * Bound per wheel (each term half an LSB, 2^-17, times what it scales), summed over the two
 * axes k that move the wheel: gains rounded (x |a_k| + |v_k| + 1), inputs rounded (x |k_acc| +
 * |k_vel| + sgn_gain |k_coul|), three products rounded (3); plus u_max rounded (1).
 */
static double ff_bound(const struct ff_q16_wheels *fw, int j, const int ax[2], const double v[3],
                       const double a[3])
{
	double s = 1.0;

	for (int m = 0; m < 2; m++) {
		const int k = ax[m];

		s += fabs(a[k]) + fabs(v[k]) + 1.0 + 3.0;
		s += fabs(q16_to_double(fw->k_acc[j][k])) + fabs(q16_to_double(fw->k_vel[j][k])) +
		     fw->sgn_gain[k] * fabs(q16_to_double(fw->k_coul[j][k]));
	}
	return s * LSB_HALF * 1.001 + 1e-12;
}

static void test_feedforward_wheels_q16_within_bound_of_double(void **state)
{
	(void)state;
	static const int axes[4][2] = {{1, 2}, {2, 0}, {2, 1}, {0, 2}};
	struct rng g;
	double worst = 0, worst_bound = 0;

	rng_seed(&g, 0x5eed09);
	for (int n = 0; n < N_RANDOM; n++) {
		struct model_params p;
		struct model_wheels w;
		struct ff_q16_wheels fw;
		const double vel[3] = {rng_uniform(&g, -3, 3), rng_uniform(&g, -3, 3),
		                       rng_uniform(&g, -20, 20)};
		const double acc[3] = {rng_uniform(&g, -10, 10), rng_uniform(&g, -10, 10),
		                       rng_uniform(&g, -30, 30)};
		double u[4], vq[3], aq[3];
		q16_t vel_q[3], acc_q[3], uq[4];

		random_params(&g, &p);
		random_wheels(&g, &p, 0.15, &w);
		assert_int_equal(ff_q16_wheels_init(&fw, &p, &w, 24.0), 0);
		for (int k = 0; k < 3; k++) {
			vel_q[k] = q16_from_double(vel[k]);
			acc_q[k] = q16_from_double(acc[k]);
			vq[k] = vel[k];
			aq[k] = acc[k];
		}
		ff_voltages_wheels(&p, &w, vel, acc, 24.0, u);
		ff_voltages_q16_wheels(&fw, vel_q, acc_q, uq);
		for (int j = 0; j < 4; j++) {
			const double e = fabs(q16_to_double(uq[j]) - u[j]);

			const double bound = ff_bound(&fw, j, axes[j], vq, aq);

			worst = fmax(worst, e);
			worst_bound = fmax(worst_bound, bound);
			assert_near(q16_to_double(uq[j]), u[j], bound);
		}
	}
	print_message(
	    "feedforward q16 vs double, %d draws: max |du| = %.3g mV, largest bound %.3g mV\n",
	    N_RANDOM, worst * 1e3, worst_bound * 1e3);
}

static void test_kinematics_rates_q16_within_bound_of_double(void **state)
{
	(void)state;
	struct rng g;
	double worst_ik = 0, worst_fk = 0;

	rng_seed(&g, 0x5eed0a);
	for (int n = 0; n < N_RANDOM; n++) {
		const double d = rng_uniform(&g, 0.05, 0.3);
		double r[4], rate[4], x[3], back[3];
		q16_t xq[3], rq[4], bq[3];
		struct kin_wheels_q16 k;

		for (int j = 0; j < 4; j++)
			r[j] = rng_uniform(&g, 0.02, 0.06);
		assert_int_equal(kin_wheels_q16_init(&k, d, r), 0);
		for (int c = 0; c < 3; c++) {
			x[c] = rng_uniform(&g, -3, 3) * (c == 2 ? 10 : 1);
			xq[c] = q16_from_double(x[c]);
		}
		/* ik: rim error 2^-17 (2 + d + |w|) (x, d, d w rounded), then times 1/r_j, plus
		 * 2^-17 (|v_j| + 1) (1/r_j rounded, product rounded). */
		ik_wheel_rates(d, r, x, rate);
		ik_wheel_rates_q16(&k, xq, rq);
		for (int j = 0; j < 4; j++) {
			const double bound =
			    LSB_HALF * ((2 + d + fabs(x[2])) / r[j] + fabs(rate[j] * r[j]) + 1);

			assert_near(q16_to_double(rq[j]), rate[j], bound * 1.01);
			worst_ik = fmax(worst_ik, fabs(q16_to_double(rq[j]) - rate[j]));
		}
		/* fk from the double rates rounded: rim error er = 2^-17 (r + 1) + 2^-32 |w|; v, vn
		 * er + 2^-17; w 4 er / (4 d) + 2^-17 (|sum| + 1) (1/(4d) and product rounded). */
		for (int j = 0; j < 4; j++)
			rq[j] = q16_from_double(rate[j]);
		fk_robot_velocity_rates_q16(&k, rq, bq);
		fk_robot_velocity_rates(d, r, rate, back);
		const double er =
		    LSB_HALF * 1.06 +
		    (fabs(rate[0]) + fabs(rate[1]) + fabs(rate[2]) + fabs(rate[3])) * 0x1p-32;
		const double sum = fabs(4 * d * back[2]);

		assert_near(q16_to_double(bq[0]), back[0], (er + LSB_HALF) * 1.01);
		assert_near(q16_to_double(bq[1]), back[1], (er + LSB_HALF) * 1.01);
		assert_near(q16_to_double(bq[2]), back[2], (er / d + LSB_HALF * (sum + 1)) * 1.01);
		for (int c = 0; c < 3; c++)
			worst_fk = fmax(worst_fk, fabs(q16_to_double(bq[c]) - back[c]));
	}
	print_message("wheel rates q16 vs double, %d draws: ik max %.3g rad/s, fk max %.3g (m/s, "
	              "rad/s)\n",
	              N_RANDOM, worst_ik, worst_fk);
}

/* ---- set-up checks ---------------------------------------------------------------------- */

static void test_bad_wheels_are_refused(void **state)
{
	(void)state;
	const double wrong[] = {NAN, INFINITY, -1.0, 0.0};
	struct model_wheels w;
	struct ff_q16_wheels fw;
	struct kin_wheels_q16 k;
	int bad = -1;

	model_wheels_from_params(&model_params_table3, &w);
	assert_int_equal(model_wheels_check(&w, &bad), 0);
	for (int i = 0; i < 16; i++)
		for (unsigned m = 0; m < sizeof(wrong) / sizeof(wrong[0]); m++) {
			struct model_wheels b = w;
			double *const f[4] = {b.r, b.Kv, b.Kt, b.R};

			f[i / 4][i % 4] = wrong[m];
			bad = -1;
			assert_int_equal(model_wheels_check(&b, &bad), -EINVAL);
			assert_int_equal(bad, i);
			assert_int_equal(ff_q16_wheels_init(&fw, &model_params_table3, &b, 12.0),
			                 -EINVAL);
		}
	assert_int_equal(ff_q16_wheels_init(&fw, &model_params_table3, &w, 0.0), -EINVAL);
	const double ok[4] = {0.0325, 0.0325, 0.0325, 0.0325};
	const double big[4] = {0.0325, 1.0, 0.0325, 0.0325},
	             tiny[4] = {0.0325, 0.0325, 1e-5, 0.0325};

	assert_int_equal(kin_wheels_q16_init(&k, 0.089, ok), 0);
	assert_int_equal(kin_wheels_q16_init(&k, 0.089, big), -EINVAL);
	assert_int_equal(kin_wheels_q16_init(&k, 0.089, tiny), -EINVAL);
	assert_int_equal(kin_wheels_q16_init(&k, 0.0, ok), -EINVAL);
	assert_int_equal(kin_wheels_q16_init(&k, NAN, ok), -EINVAL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_equal_wheels_give_the_scalar_state_space_bit_for_bit),
	    cmocka_unit_test(test_equal_wheels_give_the_scalar_forces_and_motor_bits),
	    cmocka_unit_test(test_equal_wheels_give_the_scalar_feedforward_bits_double),
	    cmocka_unit_test(test_equal_wheels_give_the_scalar_feedforward_bits_q16),
	    cmocka_unit_test(test_equal_radii_give_the_scalar_kinematics_bits),
	    cmocka_unit_test(test_odd_resistance_R2_matches_the_hand_derivation),
	    cmocka_unit_test(test_odd_radius_r0_matches_the_hand_derivation),
	    cmocka_unit_test(test_odd_back_emf_Kv3_matches_the_hand_derivation),
	    cmocka_unit_test(test_odd_torque_constant_Kt1_matches_the_hand_derivation),
	    cmocka_unit_test(test_A_and_B_are_the_finite_differences_of_the_force_balance),
	    cmocka_unit_test(test_per_wheel_equation_chain_matches_the_hand_balance),
	    cmocka_unit_test(test_feedforward_wheels_gives_the_wanted_acceleration),
	    cmocka_unit_test(test_feedforward_wheels_q16_within_bound_of_double),
	    cmocka_unit_test(test_kinematics_rates_q16_within_bound_of_double),
	    cmocka_unit_test(test_bad_wheels_are_refused),
	};

	return cmocka_run_group_tests_name("wheels", tests, NULL, NULL);
}
