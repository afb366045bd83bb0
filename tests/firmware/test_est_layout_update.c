/* The estimator's covariance algebra on wheel layouts other than the paper's (docs/estimator.md,
 * "Other wheel layouts"), one tick at a time against the same step computed here in double:
 * - the coupled prediction's covariance: P <- L P L^T with L = I + Dv on the velocity rows (the
 *   same tick on a copy whose Dv is zeroed gives P before L), every element of P;
 * - the wheel update of four readings (whitened in the filter: three scalar updates for the
 *   four): the batch Kalman update K = P H^T (H P H^T + r I)^-1 with H the layout's eq 2 rows
 *   (layout_by_hand.h), the state and every element of P; and the sequential per-wheel updates
 *   (est.white off) within float rounding of it.
 * Figures printed; tolerances 2-3x the figures measured. 1 tick = 1 ms. */
#include "omni4_test.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "layout_by_hand.h"
#include "omni4/core/est.h"
#include "omni4/model/params.h"
#include "omni4/model/wheels.h"

/* Measured 2026-11-30, float rounding: L P L^T 4.9e-8 (three wheels) and 3.2e-8 (the four) of
 * P's largest element; against the batch update, P 7.7e-8 (whitened) and 4.7e-7 (per wheel) of
 * its largest, the state 1.3e-7 and 1.1e-7 [m, rad, m/s, rad/s] (the update moved it 2.2e-2).
 * Bounds ~3x the larger. */
#define COUPLED_TOL 1.5e-7
#define BATCH_P_TOL 1.5e-6
#define BATCH_S_TOL 4e-7

static const struct model_params *P3 = &model_params_table3;
static struct est E, E2;

static const struct layout THREE = {3, {0.0, 120.0, 240.0}, {0.16, 0.16, 0.19}};
static const struct layout FOUR = {4, {60.0, 135.0, 225.0, 300.0}, {0.078, 0.081, 0.081, 0.078}};

/* Table III's drives on every wheel; accel_noise at its least (Q about 1e-18: negligible). */
static void est_on(const struct layout *L)
{
	struct model_wheels w;
	struct wheel_geom g;
	struct est_settings set;

	est_settings_defaults(&set);
	set.accel_noise_lin = set.accel_noise_rot = 1e-6f;
	model_wheels_from_params(P3, &w);
	assert_int_equal(wheel_geom_angles(L->n, L->angle_deg, L->dist_m, &g), 0);
	assert_int_equal(est_init(&E, &set, P3, 1000.0), 0);
	est_set_model_wheels(&E, P3, &w, &g);
	assert_true(E.layout);
}

/* A covariance of full rank with every element nonzero (A A^T + 1e-4 I, A's elements from a
 * fixed LCG in [-0.1, 0.1]) and a pose; velocities v. */
static void set_state(const float v[3])
{
	double A[6][6];
	uint32_t x = 12345u;

	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++) {
			x = x * 1664525u + 1013904223u;
			A[i][j] = 0.2 * ((double)(x >> 8) / 16777216.0 - 0.5);
		}
	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++) {
			double s = i == j ? 1e-4 : 0.0;

			for (int k = 0; k < 6; k++)
				s += A[i][k] * A[j][k];
			E.P[i][j] = (float)s;
		}
	const float s[6] = {0.3f, -0.2f, 0.7f, v[0], v[1], v[2]};

	memcpy(E.s, s, sizeof(s));
}

/* max |a - b| over P's elements, relative to b's largest. */
static double rel_err(const float a[6][6], const double b[6][6])
{
	double err = 0.0, big = 0.0;

	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++) {
			err = fmax(err, fabs(a[i][j] - b[i][j]));
			big = fmax(big, fabs(b[i][j]));
		}
	return err / big;
}

/* Driven at 0 V from rest: the state stays put, so the copy with Dv = 0 takes the same step
 * less L. */
static void coupled_case(const struct layout *L, const char *name)
{
	static const float rest[3] = {0.0f, 0.0f, 0.0f};
	const struct est_input in = {.utime = 0, .driven = true};
	double Lm[6][6] = {{0}}, LP[6][6] = {{0}}, want[6][6] = {{0}};

	est_on(L);
	set_state(rest);
	E2 = E;
	memset(E2.Dv, 0, sizeof(E2.Dv));
	est_step(&E, &in);
	est_step(&E2, &in);
	for (int i = 0; i < 6; i++)
		Lm[i][i] = 1.0;
	for (int k = 0; k < 3; k++)
		for (int l = 0; l < 3; l++)
			Lm[3 + k][3 + l] += E.Dv[k][l];
	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++)
			for (int k = 0; k < 6; k++)
				LP[i][j] += Lm[i][k] * E2.P[k][j];
	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++)
			for (int k = 0; k < 6; k++)
				want[i][j] += LP[i][k] * Lm[j][k];
	const double err = rel_err((const float (*)[6])E.P, want);

	printf("%s: coupled covariance against L P L^T: %.2e of P's largest\n", name, err);
	assert_true(err < COUPLED_TOL);
}

static void test_coupled_covariance_is_L_P_LT(void **state)
{
	(void)state;
	coupled_case(&THREE, "three wheels");
	coupled_case(&FOUR, "asymmetric four");
}

/* x (n x n, n <= 4) solved in place for A x = b, columns of b: Gauss-Jordan with pivoting. */
static void solve4(double A[4][4], double b[4][6], int n, int m)
{
	for (int c = 0; c < n; c++) {
		int p = c;

		for (int r = c + 1; r < n; r++)
			if (fabs(A[r][c]) > fabs(A[p][c]))
				p = r;
		for (int k = 0; k < 4; k++) {
			const double t = A[c][k];

			A[c][k] = A[p][k], A[p][k] = t;
		}
		for (int k = 0; k < m; k++) {
			const double t = b[c][k];

			b[c][k] = b[p][k], b[p][k] = t;
		}
		for (int r = 0; r < n; r++) {
			const double f = A[r][c] / A[c][c];

			if (r == c)
				continue;
			for (int k = 0; k < n; k++)
				A[r][k] -= f * A[c][k];
			for (int k = 0; k < m; k++)
				b[r][k] -= f * b[c][k];
		}
	}
	for (int r = 0; r < n; r++)
		for (int k = 0; k < m; k++)
			b[r][k] /= A[r][r];
}

/* The batch update of the predicted s, P (double) with readings z [m/s]: s, P updated. */
static void batch_update(const double H[4][3], const double z[4], double r, double s[6],
                         double P[6][6])
{
	double S[4][4], X[4][6], PH[6][4], nu[4];

	for (int a = 0; a < 4; a++) {
		nu[a] = z[a];
		for (int k = 0; k < 3; k++)
			nu[a] -= H[a][k] * s[3 + k];
		for (int i = 0; i < 6; i++) {
			PH[i][a] = 0.0;
			for (int k = 0; k < 3; k++)
				PH[i][a] += P[i][3 + k] * H[a][k];
			X[a][i] = PH[i][a]; /* (H P)'s row a */
		}
	}
	for (int a = 0; a < 4; a++)
		for (int b = 0; b < 4; b++) {
			S[a][b] = a == b ? r : 0.0;
			for (int k = 0; k < 3; k++)
				S[a][b] += H[a][k] * PH[3 + k][b];
		}
	double Sn[4][6] = {{0}}; /* S^-1 nu in column 0 */

	for (int a = 0; a < 4; a++)
		Sn[a][0] = nu[a];
	double S2[4][4];

	memcpy(S2, S, sizeof(S2));
	solve4(S, X, 4, 6); /* S^-1 H P */
	solve4(S2, Sn, 4, 1);
	for (int i = 0; i < 6; i++)
		for (int a = 0; a < 4; a++) {
			s[i] += PH[i][a] * Sn[a][0];
			for (int j = 0; j < 6; j++)
				P[i][j] -= PH[i][a] * X[a][j];
		}
}

/* One tick coasting (no voltage) with the four readings of a rigid body's velocity x. */
static double update_case(bool white, const float wheel_rad_s[4], float s_out[6], float P_out[6][6])
{
	const float v0[3] = {0.3f, -0.2f, 1.0f};
	struct est_input in = {.utime = 0, .driven = false, .have_wheels = false};

	est_on(&FOUR);
	E.white = white;
	set_state(v0);
	E2 = E;
	est_step(&E2, &in); /* the prediction alone */
	in.have_wheels = true;
	memcpy(in.wheel_rad_s, wheel_rad_s, sizeof(in.wheel_rad_s));
	est_step(&E, &in);
	memcpy(s_out, E.s, sizeof(E.s));
	memcpy(P_out, E.P, sizeof(E.P));
	return (double)E.set.wheel_noise * E.set.wheel_noise;
}

static void test_four_wheel_update_is_the_batch_update(void **state)
{
	static const double x[3] = {0.31, -0.19, 1.02}; /* the body's velocity [m/s, rad/s] */
	double G[4][3], inv[3][3], z[4], s[6], P[6][6];
	float wheel[4], sw[6], Pw[6][6], sq[6], Pq[6][6];

	(void)state;
	layout_by_hand(&FOUR, G, inv);
	est_on(&FOUR);
	for (int j = 0; j < 4; j++) {
		wheel[j] = (float)((G[j][0] * x[0] + G[j][1] * x[1] + G[j][2] * x[2]) / E.r[j]);
		z[j] = (double)(wheel[j] * E.r[j]); /* the filter's reading [m/s], to its bits */
	}
	const double r = update_case(false, wheel, sq, Pq);

	update_case(true, wheel, sw, Pw);
	assert_true(E.white);
	for (int i = 0; i < 6; i++) {
		s[i] = E2.s[i];
		for (int j = 0; j < 6; j++)
			P[i][j] = E2.P[i][j];
	}
	batch_update((const double (*)[3])G, z, r, s, P);
	double es = 0.0, eq = 0.0, step = 0.0;

	for (int i = 0; i < 6; i++) {
		es = fmax(es, fabs(sw[i] - s[i]));
		eq = fmax(eq, fabs(sq[i] - s[i]));
		step = fmax(step, fabs(s[i] - E2.s[i]));
	}
	const double ep = rel_err((const float (*)[6])Pw, P),
	             epq = rel_err((const float (*)[6])Pq, P);

	printf("four wheels against the batch update (the update moved the state %.3e): whitened P "
	       "%.2e of its largest, state %.2e; per-wheel P %.2e, state %.2e\n",
	       step, ep, es, epq, eq);
	assert_true(step > 1e-3); /* the readings moved the state */
	assert_true(ep < BATCH_P_TOL && es < BATCH_S_TOL);
	assert_true(epq < BATCH_P_TOL && eq < BATCH_S_TOL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_coupled_covariance_is_L_P_LT),
	    cmocka_unit_test(test_four_wheel_update_is_the_batch_update),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
