/*
 * The controller with each drive's own constants ([model] r_j, Kv_j, Kt_j, R_j; docs/model.md):
 * its feedforward is the per-wheel model's (written out here by hand: eqs 9-13, 21 with wheel
 * j's own R_j, r_j, Kt_j, Kv_j), its rim speeds from the encoders use each wheel's own radius,
 * and with no wheel keys (or wheel keys equal to the scalars) its outputs are the scalar
 * Q16.16 feedforward's bit for bit, as before the wheels existed.
 */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/params.h"

#define TICK_US 1000
#define SIGN_BAND_LIN 0.01 /* [m/s], feedforward.h's dead band */
#define SIGN_BAND_ROT 0.1  /* [rad/s] */

static double band_sign(double x, double band)
{
	const double s = x / band;

	return s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s);
}

/* Eq 2: wheel j's rim speed for robot velocity x. */
static double rim(const struct model_params *p, int j, const double x[3])
{
	static const double row[4][2] = {{0, 1}, {-1, 0}, {0, -1}, {1, 0}};

	return row[j][0] * x[0] + row[j][1] * x[1] + p->d * x[2];
}

/*
 * The per-wheel feedforward by hand: the body's forces (Newton with viscous and dead-banded
 * Coulomb friction), shared out as least-squares wheel forces f = IK [Fv/2, Fvn/2, T/(4 d^2)],
 * then wheel j's motor: u_j = R_j i_j + Kv_j w_mj with i_j = f_j r_j / (l Kt_j) (eqs 12-13)
 * and w_mj = l v_j / r_j.
 */
static double ff_by_hand(const struct model_params *p, const struct model_wheels *w, int j,
                         const double x[3], const double a[3], double u_max)
{
	const double F[3] = {
	    p->M * a[0] + p->Bv * x[0] + p->Cv * band_sign(x[0], SIGN_BAND_LIN),
	    p->M * a[1] + p->Bvn * x[1] + p->Cvn * band_sign(x[1], SIGN_BAND_LIN),
	    p->J * a[2] + p->Bw * x[2] + p->Cw * band_sign(x[2], SIGN_BAND_ROT),
	};
	const double share[3] = {F[0] / 2.0, F[1] / 2.0, F[2] / (4.0 * p->d * p->d)};
	const double f = rim(p, j, share);
	const double i = f * w->r[j] / (p->l * w->Kt[j]);
	const double u = w->R[j] * i + w->Kv[j] * p->l * rim(p, j, x) / w->r[j];

	return u > u_max ? u_max : (u < -u_max ? -u_max : u);
}

static const struct ctl_command g_cmd = {
    .utime = 1, .seq = 1, .mode = CTL_VELOCITY, .velocity = {0.6, -0.4, 2.5}};

static void start(struct ctl *c, const struct ctl_settings *s, bool feedback)
{
	struct ctl_settings cfg = *s;

	cfg.control.feedback = feedback;
	assert_int_equal(ctl_init(c, &cfg), 0);
	assert_int_equal(ctl_command(c, &g_cmd, TICK_US), 0);
}

/* Tick n (1 ms each), the command repeated every 100 ms (the watchdog's 200 ms). */
static void tick(struct ctl *c, int n, const float wheel_rad_s[4], struct ctl_output *out)
{
	struct motor_sample s = {.supply_v = 12.0f};

	if (n % 100 == 0)
		assert_int_equal(ctl_command(c, &g_cmd, (int64_t)(n + 1) * TICK_US), 0);

	for (int j = 0; j < 4; j++)
		s.wheel_rad_s[j] = wheel_rad_s ? wheel_rad_s[j] : 0.0f;
	ctl_step(c, (int64_t)(n + 1) * TICK_US, &s, 0, false, out);
}

/* One odd wheel at a time (R_2 +30 %, r_0 -4 %, Kv_3 +8 %, Kt_1 -10 %): every wheel's output
 * within 5 mV of the per-wheel model by hand, the odd wheel far from the scalar model's. */
static void test_feedforward_is_the_per_wheel_model(void **state)
{
	(void)state;
	for (int odd = 0; odd < 4; odd++) {
		struct ctl_settings s;
		struct ctl c;
		struct ctl_output out;
		struct model_wheels w, eq;
		double far = 0.0;

		ctl_settings_defaults(&s);
		model_wheels_from_params(&s.model, &eq);
		w = eq;
		static const int wheel[4] = {2, 0, 3, 1};
		const int j_odd = wheel[odd];

		switch (odd) {
		case 0:
			w.R[2] = s.wheels.R[2] = 1.3 * s.model.R;
			s.wheel_keys = CTL_WHEEL_KEY(3, 2);
			break;
		case 1:
			w.r[0] = s.wheels.r[0] = 0.96 * s.model.r;
			s.wheel_keys = CTL_WHEEL_KEY(0, 0);
			break;
		case 2:
			w.Kv[3] = s.wheels.Kv[3] = 1.08 * s.model.Kv;
			s.wheel_keys = CTL_WHEEL_KEY(1, 3);
			break;
		default:
			w.Kt[1] = s.wheels.Kt[1] = 0.9 * s.model.Kt;
			s.wheel_keys = CTL_WHEEL_KEY(2, 1);
			break;
		}
		start(&c, &s, false);
		for (int n = 1; n <= 400; n++) {
			tick(&c, n, NULL, &out);
			const double x[3] = {c.shaper.ref[0], c.shaper.ref[1], c.shaper.ref[2]};
			const double a[3] = {c.shaper.acc[0], c.shaper.acc[1], c.shaper.acc[2]};

			for (int j = 0; j < 4; j++) {
				const double want = ff_by_hand(&s.model, &w, j, x, a, 12.0);

				if (fabs(out.volts[j] - want) > 5e-3)
					fail_msg("odd %d tick %d wheel %d: %.6f V, by hand %.6f V",
					         odd, n, j, (double)out.volts[j], want);
			}
			far = fmax(far, fabs(out.volts[j_odd] -
			                     ff_by_hand(&s.model, &eq, j_odd, x, a, 12.0)));
		}
		if (!(far > 0.05))
			fail_msg("odd %d: the scalar model is within %.4f V of the per-wheel one",
			         odd, far);
	}
}

/* No wheel keys, and all sixteen wheel keys equal to the scalars: the scalar Q16.16
 * feedforward (ff_q16_init, ff_voltages_q16) bit for bit, tick by tick. */
static void test_equal_wheels_give_the_scalar_bits(void **state)
{
	(void)state;
	struct ctl_settings s;
	struct ff_q16 ff;

	ctl_settings_defaults(&s);
	s.model.R = 3.9; /* not only the defaults: wheels follow a changed scalar */
	s.model.r = 0.0331;
	assert_int_equal(ff_q16_init(&ff, &s.model, s.limits.supply_v), 0);
	for (int variant = 0; variant < 2; variant++) {
		struct ctl c;
		struct ctl_output out;

		if (variant) { /* every wheel key given, equal to its scalar */
			model_wheels_from_params(&s.model, &s.wheels);
			s.wheel_keys = 0xffff;
		}
		start(&c, &s, false);
		for (int n = 1; n <= 600; n++) {
			q16_t ref_q[3], acc_q[3], u[4];

			tick(&c, n, NULL, &out);
			for (int k = 0; k < 3; k++) {
				ref_q[k] = q16_from_float(c.shaper.ref[k]);
				acc_q[k] = q16_from_float(c.shaper.acc[k]);
			}
			ff_voltages_q16(&ff, ref_q, acc_q, u);
			for (int j = 0; j < 4; j++) {
				float want = q16_to_float(u[j]);

				want = want > 12.0f ? 12.0f : (want < -12.0f ? -12.0f : want);
				if (memcmp(&want, &out.volts[j], sizeof(want)))
					fail_msg(
					    "variant %d tick %d wheel %d: %.9g V, scalar %.9g V",
					    variant, n, j, (double)out.volts[j], (double)want);
			}
		}
	}
}

/* The encoders' wheel rates [rad/s] become rim speeds with each wheel's own radius: a robot
 * moving at x with wheel 0 4 % smaller reads x (eqs 3-5), not x skewed by wheel 0. */
static void test_rim_speeds_use_each_wheels_radius(void **state)
{
	(void)state;
	struct ctl_settings s;
	struct ctl c;
	struct ctl_output out;
	const double x[3] = {0.5, 0.2, 1.0};
	float rate[4];

	ctl_settings_defaults(&s);
	s.wheels.r[0] = 0.96 * s.model.r;
	s.wheel_keys = CTL_WHEEL_KEY(0, 0);
	for (int j = 0; j < 4; j++)
		rate[j] = (float)(rim(&s.model, j, x) / (j == 0 ? s.wheels.r[0] : s.model.r));
	start(&c, &s, true);
	tick(&c, 1, rate, &out);
	for (int k = 0; k < 3; k++)
		if (fabs(c.x_est[k] - x[k]) > 1e-3)
			fail_msg("axis %d: %.6f, moving at %.6f", k, (double)c.x_est[k], x[k]);
	/* The PI's error is on rim speeds too: feedforward off, P only, the reference at rest
	 * (first tick from rest), so wheel j's output is -kp r_j rate_j. */
	struct ctl c1;

	s.control.feedforward = false;
	s.control.ki = 0.0;
	start(&c1, &s, true);
	c1.vel_target[0] = c1.vel_target[1] = c1.vel_target[2] = 0.0f;
	tick(&c1, 1, rate, &out);
	for (int j = 0; j < 4; j++) {
		const double want = -s.control.kp * rim(&s.model, j, x);

		if (fabs(out.volts[j] - want) > 1e-3)
			fail_msg("wheel %d: %.6f V, P on its rim speed %.6f V", j,
			         (double)out.volts[j], want);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_feedforward_is_the_per_wheel_model),
	    cmocka_unit_test(test_equal_wheels_give_the_scalar_bits),
	    cmocka_unit_test(test_rim_speeds_use_each_wheels_radius),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
