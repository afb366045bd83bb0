/* The motors' resistances estimated online (core/ adapt.h): the RLS against a weighted batch
 * least squares computed here in double on the same samples; a plant whose R steps, estimated
 * and accepted; what freezes it; its bounds and NaN guard; and through the whole loop with the
 * simulated plant (sil/): a wrong acceptance reverted within 5 s, warm windings followed, cold
 * ones left alone. */
#include "omni4_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "config_ini.h"
#include "hil_util.h"
#include "omni4/core/adapt.h"
#include "omni4/core/fw.h"
#include "omni4/lcmtypes/channels.h"
#include "omni4_param_changed_t.h"

#define RATE_HZ 1000.0

static struct ctl_settings settings(void)
{
	struct ctl_settings s;

	ctl_settings_defaults(&s);
	return s;
}

/* A driven VELOCITY tick of motor inputs u, i, w on every motor, tracking error e2. */
static struct adapt_input tick_in(float u, float i, float w, float e2)
{
	struct adapt_input in = {.reading = true,
	                         .driven = true,
	                         .mode = CTL_VELOCITY,
	                         .supply_v = 12.0f,
	                         .tracking = true,
	                         .track_e2 = e2};

	for (int j = 0; j < 4; j++) {
		in.volts[j] = u;
		in.current_a[j] = i;
		in.wheel_rad_s[j] = w;
	}
	return in;
}

/* Deterministic noise in [-1, 1]. */
static double noise(unsigned *state)
{
	*state = *state * 1103515245u + 12345u;
	return ((*state >> 8) & 0xffff) / 32767.5 - 1.0;
}

/* The RLS is the exponentially weighted least squares with the identified R as a prior worth
 * 1 / ADAPT_P0 (closed form: (lambda^N R0 / P0 + sum lambda^(N-k) i y) / (lambda^N / P0 +
 * sum lambda^(N-k) i^2)), and its variance that fit's for the residual's spread. */
static void test_rls_matches_the_weighted_batch_least_squares(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const double R0 = s.model.R, R_true = 1.2 * R0, kvl = s.model.Kv * s.model.l;
	const double lambda = s.adapt.forget, sigma_v = 0.05;
	double num = R0 / ADAPT_P0, den = 1.0 / ADAPT_P0, sw2x2 = 0.0;
	unsigned rng = 7;
	const int N = 6000;

	adapt_init(a, &s);
	/* the tick before: a mode change (not taken), the first sample's output */
	adapt_step(a, &(struct adapt_input){.mode = CTL_IDLE});
	const struct adapt_input first = tick_in((float)(R_true * 0.9), 0.9f, 0.0f, 0.0f);

	adapt_step(a, &first);
	for (int k = 0; k < N; k++) {
		const double i = 0.9 + 0.5 * sin(k * 0.013), w = 20.0 * sin(k * 0.004);
		const double y = R_true * i + sigma_v * noise(&rng);
		const struct adapt_input in =
		    tick_in((float)(y + kvl * w), (float)i, (float)w, 1e-4f);
		const double yf =
		    (double)in.volts[0] - (double)(float)kvl * (double)in.wheel_rad_s[0];

		adapt_step(a, &in);
		num = lambda * num + (double)in.current_a[0] * yf;
		den = lambda * den + (double)in.current_a[0] * in.current_a[0];
		sw2x2 = lambda * lambda * sw2x2 + i * i;
	}
	assert_int_equal(a->m[0].n, N); /* every sample taken */
	const double batch = num / den;
	/* uniform noise on [-sigma, sigma]: variance sigma^2 / 3 */
	const double var = sigma_v * sigma_v / 3.0 * sw2x2 / (den * den);
	struct adapt_report r;

	adapt_report(a, &r);
	printf("RLS %.6f batch %.6f (true %.6f); variance %.3g, batch %.3g\n", r.R_est[0], batch,
	       R_true, r.var[0], var);
	assert_true(fabs(r.R_est[0] - batch) < 2e-6 * batch); /* measured 4e-7 */
	assert_true(r.var[0] > 0.5 * var && r.var[0] < 2.0 * var);
	free(a);
}

/* A plant whose R steps by +30 % at 10 s: 10 s later the estimate and the R in use are within
 * 1 % of it (the forgetting's time constant is about 2 s of samples). */
static void test_an_r_step_is_estimated_and_accepted(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const double R0 = s.model.R, kvl = s.model.Kv * s.model.l;
	unsigned rng = 3, changed = 0;

	adapt_init(a, &s);
	for (int k = 0; k < 20000; k++) {
		const double R = k < 10000 ? R0 : 1.3 * R0;
		const double i = 0.8 + 0.4 * sin(k * 0.01), w = 30.0 * sin(k * 0.003);
		const double u = R * i + kvl * w + 0.1 * noise(&rng);

		const struct adapt_input in = tick_in((float)u, (float)i, (float)w, 1e-4f);

		changed |= adapt_step(a, &in);
	}
	printf("R est %.4f in use %.4f, true %.4f\n", a->m[1].R, adapt_r_in_use(a)[1], 1.3 * R0);
	assert_int_equal(changed, 0xf);
	for (int j = 0; j < 4; j++) {
		assert_true(fabs(a->m[j].R / (1.3 * R0) - 1.0) < 0.01);
		assert_true(fabs(adapt_r_in_use(a)[j] / (1.3 * R0) - 1.0) < 0.01);
	}
	free(a);
}

/* An estimate is taken into use only once its relative variance is below variance_gate: not
 * after 200 noisy samples of a 50 % higher R, but after 10 s of them. */
static void test_only_a_certain_estimate_is_taken(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const double R0 = s.model.R;
	unsigned rng = 11;
	struct adapt_report r;

	adapt_init(a, &s);
	for (int k = 0; k < 2000; k++) /* a window of tracking behind, nothing taken */
		adapt_step(a, &(struct adapt_input){.reading = true,
		                                    .driven = true,
		                                    .mode = CTL_VELOCITY,
		                                    .tracking = true,
		                                    .track_e2 = 1e-4f});
	for (int k = 0; k < 10000; k++) {
		const double i = 0.6 + 0.3 * sin(k * 0.01);
		const struct adapt_input in =
		    tick_in((float)(1.5 * R0 * i + 0.4 * noise(&rng)), (float)i, 0.0f, 1e-4f);

		adapt_step(a, &in);
		if (k != 200)
			continue;
		adapt_report(a, &r);
		printf("after 200 samples: estimate %.3f, relative variance %.2g\n", r.R_est[0],
		       r.var[0] / (r.R_est[0] * r.R_est[0]));
		assert_true(r.var[0] > s.adapt.variance_gate * r.R_est[0] * r.R_est[0]);
		assert_true(adapt_r_in_use(a)[0] == (float)R0);
	}
	assert_true(fabs(adapt_r_in_use(a)[0] / (1.5 * R0) - 1.0) < 0.01);
	free(a);
}

/* No sample is taken on a slip, a collision, a fault, a mode change, a motor that does not
 * drive, a small current, an output at the supply or a step of the output. */
static void test_what_freezes_it(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	struct adapt_input in = tick_in(5.0f, 1.0f, 10.0f, 0.0f);
	struct adapt_report r;

	adapt_init(a, &s);
	adapt_step(a, &in);
	adapt_step(a, &in);
	assert_int_equal(a->m[0].n, 1); /* the first tick is a mode change (from none) */
	const uint32_t before = a->m[0].n;
	struct adapt_input bad[9];

	for (int k = 0; k < 9; k++)
		bad[k] = in;
	bad[0].est_flags = EST_FLAG_SLIP | EST_FLAG_SLIP_2;
	bad[1].est_flags = EST_FLAG_COLLISION;
	bad[2].faulted = true;
	bad[3].driven = false;
	bad[4].current_a[0] = 0.1f;
	bad[5].volts[0] = 11.5f;
	bad[6].volts[0] = 6.5f; /* 1.5 V from the tick before */
	bad[7].current_a[0] = NAN;
	bad[8].mode = CTL_GOAL; /* a mode change */
	for (int k = 0; k < 9; k++) {
		adapt_step(a, &bad[k]);
		adapt_step(a, &in); /* back to the mode and the output of the tick before */
		adapt_step(a, &in);
	}
	/* the bad ticks none; after each, both good ticks, except after an output at the supply
	 * or a step (the first good tick is a step back) and a mode change (the first is one) */
	assert_int_equal(a->m[0].n - before, 6 * 2 + 3 * 1);
	adapt_report(a, &r);
	assert_true(r.flags & ADAPT_FLAG_FROZEN);
	free(a);
}

/* Held within [0.5, 2] x the identified R; a sample that makes it non-finite restarts it from
 * the R in use; off, nothing is taken. */
static void test_bounds_and_non_finite_values(void **state)
{
	(void)state;
	struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const float R0 = (float)s.model.R;
	struct adapt_report r;

	adapt_init(a, &s);
	for (int k = 0; k < 3000; k++) {
		struct adapt_input in = tick_in(10.0f, 0.5f, 0.0f, 0.0f);

		adapt_step(a, &in); /* y = 20 R0 i */
	}
	assert_true(a->m[0].R <= 2.0f * R0 && a->m[0].R >= 2.0f * R0 * 0.999f);
	struct adapt_input huge = tick_in(10.0f, 3e19f, 0.0f, 0.0f);

	adapt_step(a, &huge);
	adapt_report(a, &r);
	assert_true(r.flags & ADAPT_FLAG_RESTART);
	assert_true(isfinite(r.R_est[0]) && r.R_est[0] == r.R[0]);
	s.adapt.enable = false;
	struct adapt *fresh = calloc(1, sizeof(*fresh));

	adapt_init(fresh, &s);
	assert_int_equal(adapt_retune(a, fresh), 0);
	free(fresh);
	for (int j = 0; j < 4; j++)
		assert_true(adapt_r_in_use(a)[j] == R0);
	const uint32_t n = a->m[1].n;

	adapt_step(a, &(struct adapt_input){.reading = true, .driven = true, .mode = CTL_VELOCITY});
	assert_int_equal(a->m[1].n, n);
	free(a);
}

/* A wheel's gains for R from their parts per ohm are the double path's (ff_q16_wheels_prepare
 * with that R_j) within a Q16.16 LSB, the other wheels' untouched. */
static void test_gains_per_ohm_match_the_prepared_ones(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct model_wheels w;
	struct ff_q16_wheels ff, want;
	struct ff_wheels_per_ohm o;

	ctl_settings_wheels(&s, &w);
	assert_int_equal(ff_q16_wheels_prepare(&ff, &s.model, &w, 12.0), 0);
	ff_wheels_per_ohm_prepare(&o, &s.model, &w);
	for (int j = 0; j < 4; j++) {
		const float R = (float)(s.model.R * (0.6 + 0.4 * j));
		const struct ff_q16_wheels before = ff;

		ff_q16_wheels_set_resistance(&ff, &o, j, R);
		w.R[j] = R;
		assert_int_equal(ff_q16_wheels_prepare(&want, &s.model, &w, 12.0), 0);
		for (int k = 0; k < 3; k++) {
			assert_true(abs(ff.k_acc[j][k] - want.k_acc[j][k]) <= 1);
			assert_true(abs(ff.k_vel[j][k] - want.k_vel[j][k]) <= 1);
			assert_true(abs(ff.k_coul[j][k] - want.k_coul[j][k]) <= 1);
			for (int q = 0; q < 4; q++)
				if (q != j)
					assert_int_equal(ff.k_vel[q][k], before.k_vel[q][k]);
		}
	}
}

/* ---- friction (eq 23 at steady motion) ------------------------------------------------------ */

/* A driven VELOCITY tick at body velocity x whose wheels' currents give body force F, by the
 * paper's layout written out here (eqs 2, 9-13: rims v0 = vn + d w, v1 = -v + d w, v2 = -vn +
 * d w, v3 = v + d w; Fv = f3 - f1, Fvn = f0 - f2, T = d (f0 + f1 + f2 + f3), f = l Kt i / r). */
static struct adapt_input body_tick(const struct ctl_settings *s, const double x[3],
                                    const double F[3])
{
	const struct model_params *p = &s->model;
	const double d = p->d, k = p->l * p->Kt / p->r, t = F[2] / (4.0 * d);
	const double rim[4] = {x[1] + d * x[2], -x[0] + d * x[2], -x[1] + d * x[2],
	                       x[0] + d * x[2]};
	const double f[4] = {F[1] / 2 + t, -F[0] / 2 + t, -F[1] / 2 + t, F[0] / 2 + t};
	struct adapt_input in = tick_in(1.0f, 0.0f, 0.0f, 1e-4f);

	for (int j = 0; j < 4; j++) {
		in.current_a[j] = (float)(f[j] / k);
		in.wheel_rad_s[j] = (float)(rim[j] / p->r);
	}
	return in;
}

/* Friction [B, C] of axis k of the model. */
static void model_friction(const struct ctl_settings *s, int k, double *B, double *C)
{
	const struct model_params *p = &s->model;

	*B = k == 0 ? p->Bv : k == 1 ? p->Bvn : p->Bw;
	*C = k == 0 ? p->Cv : k == 1 ? p->Cvn : p->Cw;
}

/* Holds x for seconds on a floor whose friction is (scale_B, scale_C) x the model's: each
 * axis's force F_k = B_k x_k + C_k sgn(x_k) (eq 23 at rest of the acceleration). Returns the
 * step's mask, ORed. */
static uint32_t hold(struct adapt *a, const struct ctl_settings *s, const double x[3],
                     double scale_B, double scale_C, double seconds, uint32_t est_flags)
{
	uint32_t mask = 0;
	double F[3];

	for (int k = 0; k < 3; k++) {
		double B, C;

		model_friction(s, k, &B, &C);
		F[k] = scale_B * B * x[k] + scale_C * C * (x[k] > 0 ? 1.0 : -1.0);
	}
	struct adapt_input in = body_tick(s, x, F);

	in.est_flags = est_flags;
	for (int n = 0; n < (int)lround(seconds * RATE_HZ); n++)
		mask |= adapt_step(a, &in);
	return mask;
}

/* Two speeds per axis make B and C apart observable: on a floor with B x 1.3, C x 1.6 (not one
 * common scale) the fit is the exponentially weighted least squares with the prior (closed
 * form, in double: (I0 + sum lambda^(N-k) phi phi^T)^-1 (I0 theta_id + sum lambda^(N-k) phi
 * F), I0 = C^2 (theta theta^T + eps diag(theta^2))^-1); its C within 10 % of the floor's (the
 * prior holds B near the common scale); it is taken into use. */
static void test_friction_fit_matches_the_weighted_batch(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const double lambda = s.adapt.friction_forget;
	double S[3][3] = {{0}}, sy[3][2] = {{0}};
	uint32_t mask = 0;

	adapt_init(a, &s);
	for (int n = 0; n < 40; n++) {
		const double f = n % 2 ? 0.5 : 1.0, sg = (n / 2) % 2 ? -1.0 : 1.0;
		const double x[3] = {sg * 1.2 * f, -sg * 0.9 * f, sg * 4.0 * f};
		uint32_t before[3];

		for (int k = 0; k < 3; k++)
			before[k] = a->f[k].n;
		mask |= hold(a, &s, x, 1.3, 1.6, 1.0, 0);
		for (int k = 0; k < 3; k++) {
			double B, C;

			model_friction(&s, k, &B, &C);
			const double sgn = x[k] > 0 ? 1.0 : -1.0,
			             F = 1.3 * B * x[k] + 1.6 * C * sgn;

			for (uint32_t q = before[k]; q < a->f[k].n; q++) {
				S[k][0] = lambda * S[k][0] + x[k] * x[k];
				S[k][1] = lambda * S[k][1] + x[k] * sgn;
				S[k][2] = lambda * S[k][2] + 1.0;
				sy[k][0] = lambda * sy[k][0] + x[k] * F;
				sy[k][1] = lambda * sy[k][1] + sgn * F;
			}
		}
	}
	assert_true(mask & ADAPT_CHANGED_FRICTION);
	for (int k = 0; k < 3; k++) {
		double B, C;

		model_friction(&s, k, &B, &C);
		const double eps = ADAPT_FRIC_EPS, p00 = B * B * (1 + eps), p01 = B * C,
		             p11 = C * C * (1 + eps), w = C * C / (p00 * p11 - p01 * p01);
		const double i00 = w * p11 + S[k][0], i01 = -w * p01 + S[k][1],
		             i11 = w * p00 + S[k][2];
		const double b0 = w * (p11 * B - p01 * C) + sy[k][0],
		             b1 = w * (p00 * C - p01 * B) + sy[k][1], det = i00 * i11 - i01 * i01;
		const double Bb = (i11 * b0 - i01 * b1) / det, Cb = (i00 * b1 - i01 * b0) / det;

		printf(
		    "axis %d: B %.5f C %.5f, batch %.5f %.5f, floor %.5f %.5f; in use %.5f %.5f\n",
		    k, (double)a->f[k].th[0], (double)a->f[k].th[1], Bb, Cb, 1.3 * B, 1.6 * C,
		    (double)adapt_b_in_use(a)[k], (double)adapt_c_in_use(a)[k]);
		assert_true(a->f[k].n > 1000);
		assert_true(fabs(a->f[k].th[0] / Bb - 1.0) < 1e-3);
		assert_true(fabs(a->f[k].th[1] / Cb - 1.0) < 1e-3);
		/* C within the specification's 10 %; B apart from the common scale only as far as
		 * the prior lets it (its 10 %) */
		assert_true(fabs(Cb / (1.6 * C) - 1.0) < 0.10);
		assert_true(fabs(adapt_c_in_use(a)[k] / Cb - 1.0) < 0.05);
	}
	free(a);
}

/* One speed per axis (the hard drive's cruises): B and C are not apart observable, and a floor
 * that scales both by 1.5 is found along the prior's common scale: C within 10 % (the
 * specification's bound) in 30 s. The same robot on its own floor keeps every value within 1 %. */
static void test_one_speed_follows_a_common_scale(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));

	for (int floor = 0; floor < 2; floor++) {
		const double scale = floor ? 1.5 : 1.0;

		adapt_init(a, &s);
		for (int k = 0; k < 30; k++) {
			const double sg = k % 2 ? -1.0 : 1.0;

			hold(a, &s, (const double[3]){1.2 * sg, 1.2 * sg, 3.0 * sg}, scale, scale,
			     1.0, 0);
		}
		for (int k = 0; k < 3; k++) {
			double B, C;

			model_friction(&s, k, &B, &C);
			printf("scale %.1f axis %d: B %.4f C %.4f in use (floor's %.4f %.4f)\n",
			       scale, k, (double)adapt_b_in_use(a)[k], (double)adapt_c_in_use(a)[k],
			       scale * B, scale * C);
			assert_true(fabs(adapt_c_in_use(a)[k] / (scale * C) - 1.0) <
			            (floor ? 0.10 : 0.01));
			if (!floor)
				assert_true(fabs(adapt_b_in_use(a)[k] / B - 1.0) < 0.01);
		}
	}
	free(a);
}

/* A slip or a collision flagged freezes the friction's estimation: no sample, nothing taken,
 * while the floor's friction is twice the model's. */
static void test_friction_frozen_on_slip_and_collision(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const uint32_t flags[2] = {EST_FLAG_SLIP, EST_FLAG_COLLISION};

	for (int f = 0; f < 2; f++) {
		adapt_init(a, &s);
		assert_int_equal(
		    hold(a, &s, (const double[3]){1.0, 0.8, 2.0}, 2.0, 2.0, 10.0, flags[f]), 0);
		for (int k = 0; k < 3; k++)
			assert_int_equal(a->f[k].n, 0);
	}
	/* the same ticks unflagged: sampled and taken */
	adapt_init(a, &s);
	assert_true(hold(a, &s, (const double[3]){1.0, 0.8, 2.0}, 2.0, 2.0, 10.0, 0) &
	            ADAPT_CHANGED_FRICTION);
	free(a);
}

/* An estimate is taken only below [adapt] friction_variance_gate: on a floor of twice the
 * model's friction, each 1 s hold's Coulomb friction 10 % off it either way (a floor that is not
 * one), the default gate (1e-4) takes it, the smallest the key allows (1e-9) never. */
static void test_friction_taken_only_below_its_variance_gate(void **state)
{
	(void)state;
	struct adapt *a = calloc(1, sizeof(*a));

	for (int q = 0; q < 2; q++) {
		struct ctl_settings s = settings();
		uint32_t mask = 0;

		if (q)
			s.adapt.friction_variance_gate = 1e-9;
		adapt_init(a, &s);
		for (int n = 0; n < 40; n++) {
			const double f = n % 2 ? 0.5 : 1.0, sg = (n / 2) % 2 ? -1.0 : 1.0;
			const double off = 0.1 * (((n * 7) % 5) - 2) / 2.0; /* -10 .. +10 % */

			mask |= hold(a, &s,
			             (const double[3]){sg * 1.2 * f, -sg * 0.9 * f, sg * 4.0 * f},
			             2.0, 2.0 * (1.0 + off), 1.0, 0);
		}
		printf("gate %g: friction %s\n", s.adapt.friction_variance_gate,
		       mask & ADAPT_CHANGED_FRICTION ? "taken" : "not taken");
		assert_int_equal(!!(mask & ADAPT_CHANGED_FRICTION), !q);
	}
	free(a);
}

/* Steady means the whole body's velocity changed by less than ADAPT_FRIC_STEADY C / M per
 * second (adapt.h): axis v ramped at 3x that rate under a steady force gives no axis a sample,
 * at a third of it every axis its samples. */
static void test_friction_sampled_only_while_steady(void **state)
{
	(void)state;
	const struct ctl_settings s = settings();
	struct adapt *a = calloc(1, sizeof(*a));
	const double bound = ADAPT_FRIC_STEADY * s.model.Cv / s.model.M; /* [m/s^2] */

	for (int q = 0; q < 2; q++) {
		const double rate = q ? bound / 3.0 : 3.0 * bound, x0[3] = {0.8, 0.6, 2.0};
		double F[3];

		for (int k = 0; k < 3; k++) {
			double B, C;

			model_friction(&s, k, &B, &C);
			F[k] = B * x0[k] + C;
		}
		adapt_init(a, &s);
		for (int n = 0; n < (int)lround(5.0 * RATE_HZ); n++) {
			const double x[3] = {x0[0] + rate * n / RATE_HZ, x0[1], x0[2]};
			struct adapt_input in = body_tick(&s, x, F);

			adapt_step(a, &in);
		}
		printf("v ramped at %.4f m/s^2 (the steady bound %.4f): samples %u %u %u\n", rate,
		       bound, a->f[0].n, a->f[1].n, a->f[2].n);
		for (int k = 0; k < 3; k++)
			assert_true(q ? a->f[k].n > 100 : a->f[k].n == 0);
	}
	free(a);
}

/* The controller's gains for friction B, C (ctl_set_friction) are the double path's
 * (ff_q16_wheels_prepare with the model's B, C so) within a Q16.16 LSB, with a wheel's R in use
 * kept. */
static void test_friction_gains_match_the_prepared_ones(void **state)
{
	(void)state;
	struct ctl_settings s = settings();
	struct ctl *c = calloc(1, sizeof(*c));
	struct model_wheels w;
	struct ff_q16_wheels want;
	const float B[3] = {0.6f, 0.9f, 0.02f}, C[3] = {2.5f, 3.0f, 0.2f};
	const float R1 = (float)(1.2 * s.model.R);

	assert_int_equal(ctl_init(c, &s), 0);
	ctl_set_resistance(c, 1, R1);
	ctl_set_friction(c, B, C);
	s.model.Bv = B[0];
	s.model.Bvn = B[1];
	s.model.Bw = B[2];
	s.model.Cv = C[0];
	s.model.Cvn = C[1];
	s.model.Cw = C[2];
	ctl_settings_wheels(&s, &w);
	w.R[1] = R1;
	assert_int_equal(ff_q16_wheels_prepare(&want, &s.model, &w, s.limits.supply_v), 0);
	for (int j = 0; j < 4; j++)
		for (int k = 0; k < 3; k++) {
			assert_true(abs(c->ff.k_vel[j][k] - want.k_vel[j][k]) <= 1);
			assert_true(abs(c->ff.k_coul[j][k] - want.k_coul[j][k]) <= 1);
			assert_true(abs(c->ff.k_acc[j][k] - want.k_acc[j][k]) <= 1);
		}
	assert_true(c->trac.C[1] == C[1] && c->trac.B[2] == B[2]);
	free(c);
}

/* ---- through the loop with the simulated plant (sil/) -------------------------------------- */

static struct simrun *sim(const char *ini, const char *log)
{
	struct omni4_config cfg = config_ini(ini);
	char err[256];
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, true, log, err, sizeof(err));

	if (!sr)
		fail_msg("%s", err);
	return sr;
}

/* A parameter change through the loop (fw_param_prepare / offer): one that leaves the drives
 * keeps the R and the friction in use and their gains; one that changes a drive's R starts
 * again from it. */
static void change(struct fw *fw, struct simrun *sr, const struct ctl_settings *cfg)
{
	static struct fw_param_update u;
	struct fw_param_result r;
	char why[128];

	assert_int_equal(fw_param_prepare(fw, cfg, false, &u, why, sizeof(why)), 0);
	fw_param_offer(fw, &u);
	simrun_tick(sr);
	assert_true(fw_param_done(fw, &u, &r) && r.rc == 0);
}

static void test_a_parameter_change_keeps_or_restarts_it(void **state)
{
	(void)state;
	struct simrun *sr = sim("[sim]\nseed = 2\n", NULL);
	struct fw *fw = simrun_fw(sr);
	struct ctl_settings cfg = fw->ctl.set;
	const float R = 1.1f * fw->adapt.R_id[0];
	struct ff_q16_wheels want = fw->ctl.ff;

	adapt_accept(&fw->adapt, (const float[4]){R, R, R, R});
	for (int j = 0; j < 4; j++) {
		ctl_set_resistance(&fw->ctl, j, R);
		ff_q16_wheels_set_resistance(&want, &fw->ctl.ff_ohm, j, R);
	}
	const float B[3] = {0.6f, 0.8f, 0.02f}, C[3] = {2.4f, 2.6f, 0.2f};

	adapt_accept_friction(&fw->adapt, B, C);
	ctl_set_friction(&fw->ctl, B, C);
	want = fw->ctl.ff;
	cfg.control.kp = 25.0;
	change(fw, sr, &cfg);
	assert_true(adapt_r_in_use(&fw->adapt)[2] == R);
	assert_true(adapt_c_in_use(&fw->adapt)[1] == C[1] && fw->ctl.trac.C[1] == C[1]);
	assert_memory_equal(fw->ctl.ff.k_vel, want.k_vel, sizeof(want.k_vel));
	assert_memory_equal(fw->ctl.ff.k_coul, want.k_coul, sizeof(want.k_coul));
	cfg.model.R = 5.0;
	ctl_settings_wheels_follow(&cfg);
	change(fw, sr, &cfg);
	assert_true(adapt_r_in_use(&fw->adapt)[2] == 5.0f);
	assert_true(fw->adapt.m[2].R == 5.0f && !fw->adapt.watch);
	simrun_destroy(sr);
}

/* docs/hard-drive.csv's pattern, one row per second: +-1.2 m/s on v and vn, +-3 rad/s. */
static void drive_row(struct simrun *sr, int row)
{
	const double v = row % 2 ? -1.2 : 1.2, w = (row / 2) % 2 ? -3.0 : 3.0;

	hil_send(sr, CTL_VELOCITY, (const double[3]){v, v, w}, NULL, 0.0);
}

/* Runs the drive for seconds from row0 on (commands every 100 ms); the mean square of the
 * robot's true velocity minus the controller's reference (v, vn, d w) over it, and the ticks. */
static double drive(struct simrun *sr, int *row, double seconds, double *worst_R, bool plant_R)
{
	const int ticks = (int)lround(seconds * RATE_HZ);
	const double d = simrun_fw(sr)->ctl.set.model.d;
	double e2 = 0.0;

	for (int k = 0; k < ticks; k++) {
		if (k % 100 == 0)
			drive_row(sr, *row + k / 1000);
		simrun_tick(sr);
		double x[3], pose[3], ref[3], R[4];

		simrun_truth(sr, x, pose);
		simrun_reference(sr, ref);
		e2 += pow(x[0] - ref[0], 2) + pow(x[1] - ref[1], 2) + pow(d * (x[2] - ref[2]), 2);
		if (!worst_R || k % 100)
			continue;
		if (plant_R)
			simrun_plant_resistance(sr, R);
		else
			for (int j = 0; j < 4; j++)
				R[j] = simrun_fw(sr)->adapt.R_id[j];
		for (int j = 0; j < 4; j++)
			*worst_R = fmax(
			    *worst_R, fabs(adapt_r_in_use(&simrun_fw(sr)->adapt)[j] / R[j] - 1.0));
	}
	*row += ticks / 1000;
	return e2 / ticks;
}

/* A wrong value planted into use (twice the identified R on every motor, the plant cold) is put
 * back within 5 s, with REVERTED in the next adapt_t and a param_changed_t "adapt" "reverted"
 * in the log; the right value planted stays. */
static void test_a_wrong_acceptance_is_reverted_within_5_s(void **state)
{
	(void)state;
	char path[] = "/tmp/omni4_adapt_XXXXXX";
	const int fd = mkstemp(path);

	assert_true(fd >= 0);
	close(fd);
	struct simrun *sr = sim("[sim]\nseed = 5\n", path);
	struct fw *fw = simrun_fw(sr);
	const float R0 = fw->adapt.R_id[0];
	int row = 0;

	drive(sr, &row, 4.0, NULL, false);
	/* planted as adapt_step's acceptance is applied (fw.c) */
	uint32_t m = adapt_accept(&fw->adapt, (const float[4]){2 * R0, 2 * R0, 2 * R0, 2 * R0});

	for (int j = 0; j < 4; j++)
		if (m & (1u << j))
			ctl_set_resistance(&fw->ctl, j, adapt_r_in_use(&fw->adapt)[j]);
	assert_int_equal(m, 0xf);
	int t_ms = 0;

	while (adapt_r_in_use(&fw->adapt)[0] != R0 && t_ms < 5000) {
		drive(sr, &row, 0.001, NULL, false);
		t_ms++;
	}
	printf("reverted after %d ms\n", t_ms);
	assert_true(t_ms < 5000);
	assert_int_equal(fw->adapt.reverted, 1);
	drive(sr, &row, 0.2, NULL, false);
	const float right = R0 * 1.001f;

	m = adapt_accept(&fw->adapt, (const float[4]){right, right, right, right});
	for (int j = 0; j < 4; j++)
		ctl_set_resistance(&fw->ctl, j, adapt_r_in_use(&fw->adapt)[j]);
	drive(sr, &row, 5.0, NULL, false);
	assert_int_equal(fw->adapt.reverted, 1); /* the right one stays */
	assert_true(adapt_r_in_use(&fw->adapt)[0] == right);
	assert_int_equal(simrun_flush_log(sr), 0);
	simrun_destroy(sr);

	lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
	lcm_eventlog_event_t *ev;
	int notices = 0;

	while ((ev = lcm_eventlog_read_next_event(log))) {
		omni4_param_changed_t p;

		if (!strcmp(ev->channel, OMNI4_CHANNEL_PARAM_CHANGED) &&
		    omni4_param_changed_t_decode(ev->data, 0, (int)ev->datalen, &p) > 0) {
			if (!strcmp(p.source, "adapt") && !strcmp(p.values[4], "reverted")) {
				notices++;
				assert_true(fabs(atof(p.values[0]) - R0) < 1e-5);
				assert_true(fabs(atof(p.old_values[0]) - 2.0 * R0) < 1e-5);
			}
			omni4_param_changed_t_decode_cleanup(&p);
		}
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	unlink(path);
	assert_int_equal(notices, 1);
}

/* Warm windings (a small heat capacity: R +20 % within 60 s of the hard drive's pattern): the
 * R in use within 3 % of the plant's after the first 20 s, and the velocity tracking's mean
 * square over the last 10 s at most a quarter with [adapt] on of off (RMS at most half). Cold
 * windings: every R in use within 1 % of the identified for the whole run. */
static void test_warm_windings_followed_and_cold_ones_left_alone(void **state)
{
	(void)state;
	static const char warm[] = "[sim]\nthermal = true\nthermal_capacity = 2\nseed = 9\n";
	static const char warm_off[] =
	    "[sim]\nthermal = true\nthermal_capacity = 2\nseed = 9\n[adapt]\nenable = false\n";
	double ms[2], worst = 0.0, cold_worst = 0.0, R[4];

	for (int on = 0; on < 2; on++) {
		struct simrun *sr = sim(on ? warm : warm_off, NULL);
		int row = 0;

		drive(sr, &row, 20.0, NULL, true);
		drive(sr, &row, 30.0, on ? &worst : NULL, true);
		ms[on] = drive(sr, &row, 10.0, on ? &worst : NULL, true);
		simrun_plant_resistance(sr, R);
		printf("adapt %s: plant R_0 %.3f (identified %.3f), in use %.3f; tracking RMS "
		       "%.4f m/s\n",
		       on ? "on" : "off", R[0], (double)simrun_fw(sr)->adapt.R_id[0],
		       (double)adapt_r_in_use(&simrun_fw(sr)->adapt)[0], sqrt(ms[on]));
		assert_true(R[0] > 1.2 * simrun_fw(sr)->adapt.R_id[0]);
		simrun_destroy(sr);
	}
	printf("worst R in use against the plant's after 20 s: %.4f; RMS on / off %.3f\n", worst,
	       sqrt(ms[1] / ms[0]));
	assert_true(worst < 0.03);
	assert_true(ms[1] <= 0.25 * ms[0]);

	struct simrun *sr = sim("[sim]\nseed = 9\n", NULL);
	int row = 0;

	drive(sr, &row, 60.0, &cold_worst, false);
	printf("cold: worst R in use against the identified %.4f\n", cold_worst);
	assert_true(cold_worst < 0.01);
	simrun_destroy(sr);
}

/* The largest |C in use / plant's - 1| over the three axes (the plant's: the model's x its
 * friction scale). */
static double friction_error(struct simrun *sr)
{
	const struct fw *fw = simrun_fw(sr);
	const double scale = simrun_plant_friction_scale(sr);
	double worst = 0.0;

	for (int k = 0; k < 3; k++) {
		double B, C;

		model_friction(&fw->ctl.set, k, &B, &C);
		worst = fmax(worst, fabs(adapt_c_in_use(&fw->adapt)[k] / (scale * C) - 1.0));
		/* and the controller's traction limit uses the same */
		assert_true(fw->ctl.trac.C[k] == adapt_c_in_use(&fw->adapt)[k]);
	}
	return worst;
}

/* The floor's friction x 1.5 at 10 s of the hard drive's pattern: before, the friction in use
 * within 1 % of the identified (a robot that does not change); after, all three Coulomb terms
 * within 10 % of the plant's within 60 s and from then on (the specification's bounds). */
static void test_a_new_floor_is_followed(void **state)
{
	(void)state;
	struct simrun *sr =
	    sim("[sim]\nfloor_change_s = 10\nfloor_friction_scale = 1.5\nseed = 4\n", NULL);
	int row = 0;
	double before = 0.0, settled = -1.0, after = 0.0;

	for (int t = 0; t < 10; t++) {
		drive(sr, &row, 1.0, NULL, false);
		before = fmax(before, friction_error(sr));
	}
	for (int t = 1; t <= 70; t++) {
		drive(sr, &row, 1.0, NULL, false);
		const double e = friction_error(sr);

		if (e > 0.10)
			settled = -1.0;
		else if (settled < 0.0)
			settled = t;
		if (t >= 60)
			after = fmax(after, e);
	}
	printf("floor x 1.5: before it the Coulomb in use within %.4f of the identified; within "
	       "10 %% of the plant's from %.0f s after it; %.4f from 60 s to 70 s\n",
	       before, settled, after);
	assert_true(before < 0.01);
	assert_true(settled > 0.0 && settled <= 60.0);
	assert_true(after < 0.10);
	simrun_destroy(sr);
}

/* A wrong friction planted into use (three times the identified B and C, the floor the model's)
 * is put back within 5 s, with the controller's gains and traction limit back on the
 * identified. */
static void test_a_wrong_friction_acceptance_is_reverted(void **state)
{
	(void)state;
	struct simrun *sr = sim("[sim]\nseed = 6\n", NULL);
	struct fw *fw = simrun_fw(sr);
	const struct ff_q16_wheels ident = fw->ctl.ff;
	float B[3], C[3];
	int row = 0, t_ms = 0;

	drive(sr, &row, 4.0, NULL, false);
	for (int k = 0; k < 3; k++) {
		B[k] = 3.0f * fw->adapt.B_id[k];
		C[k] = 3.0f * fw->adapt.C_id[k];
	}
	/* planted as adapt_step's acceptance is applied (fw.c) */
	assert_int_equal(adapt_accept_friction(&fw->adapt, B, C), ADAPT_CHANGED_FRICTION);
	ctl_set_friction(&fw->ctl, adapt_b_in_use(&fw->adapt), adapt_c_in_use(&fw->adapt));
	assert_true(fw->ctl.ff.k_coul[0][1] != ident.k_coul[0][1]);
	while (adapt_c_in_use(&fw->adapt)[0] != fw->adapt.C_id[0] && t_ms < 5000) {
		drive(sr, &row, 0.001, NULL, false);
		t_ms++;
	}
	printf("friction reverted after %d ms\n", t_ms);
	assert_true(t_ms < 5000);
	assert_int_equal(fw->adapt.reverted, 1);
	for (int k = 0; k < 3; k++)
		assert_true(adapt_b_in_use(&fw->adapt)[k] == fw->adapt.B_id[k]);
	assert_memory_equal(fw->ctl.ff.k_coul, ident.k_coul, sizeof(ident.k_coul));
	assert_memory_equal(fw->ctl.ff.k_vel, ident.k_vel, sizeof(ident.k_vel));
	assert_true(fw->ctl.trac.C[2] == fw->adapt.C_id[2]);
	simrun_destroy(sr);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_rls_matches_the_weighted_batch_least_squares),
	    cmocka_unit_test(test_an_r_step_is_estimated_and_accepted),
	    cmocka_unit_test(test_only_a_certain_estimate_is_taken),
	    cmocka_unit_test(test_what_freezes_it),
	    cmocka_unit_test(test_bounds_and_non_finite_values),
	    cmocka_unit_test(test_gains_per_ohm_match_the_prepared_ones),
	    cmocka_unit_test(test_a_parameter_change_keeps_or_restarts_it),
	    cmocka_unit_test(test_a_wrong_acceptance_is_reverted_within_5_s),
	    cmocka_unit_test(test_warm_windings_followed_and_cold_ones_left_alone),
	    cmocka_unit_test(test_friction_fit_matches_the_weighted_batch),
	    cmocka_unit_test(test_one_speed_follows_a_common_scale),
	    cmocka_unit_test(test_friction_frozen_on_slip_and_collision),
	    cmocka_unit_test(test_friction_sampled_only_while_steady),
	    cmocka_unit_test(test_friction_taken_only_below_its_variance_gate),
	    cmocka_unit_test(test_friction_gains_match_the_prepared_ones),
	    cmocka_unit_test(test_a_new_floor_is_followed),
	    cmocka_unit_test(test_a_wrong_friction_acceptance_is_reverted),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
