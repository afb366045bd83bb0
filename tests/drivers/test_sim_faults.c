/* The sim backend's sensor faults ([sim] current_offset_a0..a3, encoder_eccentricity;
 * docs/ini-keys.md): read from the INI, added to the current readings with the bridges off and
 * on, and the eccentric motor-shaft encoder's once-per-motor-turn speed ripple, against closed
 * forms. Off (0) they change nothing: the readings are those of the sim without them. */
#include "omni4_test.h"

#include <string.h>

#include "omni4/config/config.h"
#include "omni4/drivers/sim_motor.h"

#define TWO_PI 6.283185307179586477

static const double OFF[4] = {0.05, -0.05, 0.03, -0.02};

static struct omni4_config faulty_config(double ecc)
{
	struct omni4_config cfg;
	struct config_error err;
	char ini[512];

	snprintf(ini, sizeof(ini),
	         "[sim]\ncurrent_offset_a0 = %g\ncurrent_offset_a1 = %g\ncurrent_offset_a2 = %g\n"
	         "current_offset_a3 = %g\nencoder_eccentricity = %g\n",
	         OFF[0], OFF[1], OFF[2], OFF[3], ecc);
	config_defaults(&cfg);
	if (config_load_string(ini, "test.ini", &cfg, &err))
		fail_msg("%s", err.msg);
	return cfg;
}

static void start(struct sim_motor *s, const struct omni4_config *cfg, bool noise)
{
	const struct sim_motor_config sc = sim_motor_config_from(
	    &cfg->sim, noise, &cfg->ctl.model, 1.0 / cfg->ctl.rate_hz, cfg->ctl.limits.supply_v);

	assert_int_equal(sim_motor_init(s, &sc), 0);
}

static void test_keys_ranges_and_defaults(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;
	char why[256];

	config_defaults(&cfg);
	for (int j = 0; j < 4; j++)
		assert_true(cfg.sim.current_offset_a[j] == 0.0);
	assert_true(cfg.sim.encoder_eccentricity == 0.0);
	cfg = faulty_config(0.05);
	for (int j = 0; j < 4; j++)
		assert_true(cfg.sim.current_offset_a[j] == OFF[j]);
	assert_true(cfg.sim.encoder_eccentricity == 0.05);
	const int k = config_key_find("sim.current_offset_a2");

	assert_true(k >= 0);
	assert_int_equal(config_key_set(&cfg, k, "1.0", why, sizeof(why)), 0);
	assert_true(cfg.sim.current_offset_a[2] == 1.0);
	assert_int_not_equal(config_key_set(&cfg, k, "-1.01", why, sizeof(why)), 0);
	const int e = config_key_find("sim.encoder_eccentricity");

	assert_int_equal(config_key_set(&cfg, e, "0.1", why, sizeof(why)), 0);
	assert_int_not_equal(config_key_set(&cfg, e, "0.11", why, sizeof(why)), 0);
	assert_int_not_equal(config_key_set(&cfg, e, "-0.01", why, sizeof(why)), 0);
	assert_int_not_equal(
	    config_load_string("[sim]\ncurrent_offset_a3 = 2\n", "bad.ini", &cfg, &err), 0);
	assert_non_null(strstr(err.msg, "current_offset_a3"));
}

/* Bridges off (true current 0): every reading is the channel's offset, exactly (the sim draws
 * no current noise then). Bridges on at 0 V, robot at rest: the mean of 4000 noisy readings
 * within 3 standard errors of the offset. Exact sensors (noise = false): no offsets. */
static void test_current_offsets_bridges_off_and_on(void **state)
{
	(void)state;
	const struct omni4_config cfg = faulty_config(0.0);
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static struct sim_motor s;
	struct motor_sample m;
	static const float zero[4] = {0, 0, 0, 0};
	const int n = 4000;
	double sum[4] = {0, 0, 0, 0};

	start(&s, &cfg, true);
	for (int k = 0; k < 100; k++) {
		assert_int_equal(ops->read(&s, &m), 0);
		for (int j = 0; j < 4; j++)
			assert_true(m.current_a[j] == (float)OFF[j]);
	}
	ops->enable(&s, true);
	ops->write(&s, zero);
	for (int k = 0; k < n; k++) {
		ops->read(&s, &m);
		for (int j = 0; j < 4; j++)
			sum[j] += m.current_a[j];
	}
	for (int j = 0; j < 4; j++)
		assert_near(sum[j] / n, OFF[j], 3 * cfg.sim.current_noise_a / sqrt(n));

	start(&s, &cfg, false);
	ops->read(&s, &m);
	for (int j = 0; j < 4; j++)
		assert_true(m.current_a[j] == 0.0f);
}

struct ripple {
	double mean[4];      /* mean speed reading [rad/s] */
	double amp[4];       /* fitted relative amplitude at once per motor turn */
	double phase[4];     /* its phase [rad]: reading ~ 1 + amp cos(theta_m - phase) */
	double amp_wheel[4]; /* the same fit at once per wheel turn (none expected) */
	double phi[4];       /* the sim's phases phi_j */
	float current[200][4];
};

/* 6 V on every channel (the robot turns about w) for 2 s, then 1 s of speed readings fitted
 * against the true motor angle: y = w_read / mean - 1 = a cos(l theta) + b sin(l theta). */
static struct ripple spin(const struct omni4_config *cfg)
{
	static struct sim_motor s;
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static const float six[4] = {6, 6, 6, 6};
	struct motor_sample m;
	struct ripple r;
	static double w[1000][4], th[1000][4];

	memset(&r, 0, sizeof(r));
	start(&s, cfg, true);
	memcpy(r.phi, s.ecc_phase, sizeof(r.phi));
	ops->enable(&s, true);
	ops->write(&s, six);
	for (int k = 0; k < 3000; k++) {
		ops->read(&s, &m);
		if (k < 200)
			memcpy(r.current[k], m.current_a, sizeof(r.current[k]));
		if (k < 2000)
			continue;
		for (int j = 0; j < 4; j++) {
			w[k - 2000][j] = m.wheel_rad_s[j];
			th[k - 2000][j] = s.wheel_angle[j];
			r.mean[j] += m.wheel_rad_s[j] / 1000.0;
		}
	}
	for (int j = 0; j < 4; j++) {
		for (int pass = 0; pass < 2; pass++) {
			const double l = pass == 0 ? cfg->ctl.model.l : 1.0;
			double cc = 0, ss = 0, cs = 0, yc = 0, ys = 0;

			for (int k = 0; k < 1000; k++) {
				/* the speed over the last period: the angle half a period back */
				const double t = l * (th[k][j] - 0.5e-3 * w[k][j]);
				const double y = w[k][j] / r.mean[j] - 1.0;

				cc += cos(t) * cos(t);
				ss += sin(t) * sin(t);
				cs += cos(t) * sin(t);
				yc += y * cos(t);
				ys += y * sin(t);
			}
			const double det = cc * ss - cs * cs;
			const double a = (yc * ss - ys * cs) / det, b = (ys * cc - yc * cs) / det;

			if (pass == 0) {
				r.amp[j] = hypot(a, b);
				r.phase[j] = atan2(b, a);
			} else {
				r.amp_wheel[j] = hypot(a, b);
			}
		}
	}
	return r;
}

/* The eccentric encoder's reading theta + e sin(theta - phi) has the speed
 * w (1 + e cos(theta - phi)): a ripple of relative amplitude e once per motor turn, with the
 * phases phi_j of the sim seed; the mean speed and the current noise stream are unchanged. */
static void test_encoder_eccentricity_ripple(void **state)
{
	(void)state;
	const double ecc = 0.05;

	for (int cpr_case = 0; cpr_case < 2; cpr_case++) {
		struct omni4_config plain = faulty_config(0.0), ecc_cfg = faulty_config(ecc);

		if (cpr_case == 0) /* exact encoders, then the default 10240 counts */
			plain.sim.encoder_cpr = ecc_cfg.sim.encoder_cpr = 0;
		const struct ripple r0 = spin(&plain), r1 = spin(&ecc_cfg);
		/* exact: the fit is exact to O(e^2); quantised: +-1 count of ~60 per tick */
		const double tol = cpr_case == 0 ? 0.02 * ecc : 0.1 * ecc;

		for (int j = 0; j < 4; j++) {
			print_message(
			    "cpr %d channel %d: mean %.4f rad/s (without %.4f), ripple %.5f "
			    "at phase %.3f rad (once per wheel turn %.5f; without: %.5f)\n",
			    ecc_cfg.sim.encoder_cpr, j, r1.mean[j], r0.mean[j], r1.amp[j],
			    r1.phase[j], r1.amp_wheel[j], r0.amp[j]);
			assert_true(fabs(r1.mean[j]) > 20.0);
			assert_near(r1.mean[j], r0.mean[j], 0.005 * fabs(r0.mean[j]));
			assert_near(r1.amp[j], ecc, tol);
			assert_near(remainder(r1.phase[j] - r1.phi[j], TWO_PI), 0.0, 0.05);
			assert_true(r1.amp_wheel[j] < 0.1 * ecc);
			assert_true(r0.amp[j] < 0.1 * ecc);
			assert_true(memcmp(r0.current, r1.current, sizeof(r0.current)) == 0);
		}
		/* Each motor its own phase. */
		for (int j = 1; j < 4; j++)
			assert_true(fabs(remainder(r1.phase[j] - r1.phase[0], TWO_PI)) > 0.05);
	}
	/* Another seed, other phases. */
	struct omni4_config other = faulty_config(ecc);

	other.sim.encoder_cpr = 0;
	const struct ripple a = spin(&other);

	other.sim.seed = 2;
	const struct ripple b = spin(&other);

	assert_true(fabs(remainder(a.phase[0] - b.phase[0], TWO_PI)) > 0.05);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_keys_ranges_and_defaults),
	    cmocka_unit_test(test_current_offsets_bridges_off_and_on),
	    cmocka_unit_test(test_encoder_eccentricity_ripple),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
