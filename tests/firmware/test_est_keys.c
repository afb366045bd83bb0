/* The estimator's settings as INI keys ([estimator], core/ est_keys.def): the defaults are the
 * figures docs/estimator.md states, written here as numbers; a key in the INI reaches the
 * filter's settings; a live change takes effect between two ticks and a bad set is refused. */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/core/est.h"

static struct est E;

static void test_defaults_are_the_documented_figures(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct est_settings s;

	config_defaults(&cfg);
	est_settings_from_keys(&cfg.ctl.est, &s);
	/* docs/estimator.md, "Noise figures and thresholds" */
	assert_true(s.accel_noise_lin == 1.0f && s.accel_noise_rot == 10.0f);
	assert_true(s.wheel_noise == 0.0065f);
	assert_true(s.cam_pos_noise == 0.01f && s.cam_theta_noise == 0.0524f);
	assert_true(s.gate_sigmas == 5.0f);
	assert_true(s.slip_threshold == 0.08f && s.slip_ticks == 3);
	assert_true(s.collision_threshold == 0.02f && s.collision_ticks == 5);
	assert_true(s.calibrate && s.replay);
	assert_int_equal(est_settings_check(&s), 0);
}

static void test_ini_keys_reach_the_filter(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;
	struct est_settings s;

	config_defaults(&cfg);
	assert_int_equal(config_load_string("[estimator]\nslip_threshold = 0.5\nslip_ticks = 7\n"
	                                    "replay = false\nwheel_noise = 0.01\n",
	                                    "t.ini", &cfg, &err),
	                 0);
	est_settings_from_keys(&cfg.ctl.est, &s);
	assert_true(s.slip_threshold == 0.5f && s.slip_ticks == 7 && !s.replay);
	assert_true(s.wheel_noise == 0.01f);
	config_defaults(&cfg); /* outside the range: one clear line */
	assert_int_not_equal(
	    config_load_string("[estimator]\nslip_ticks = 0\n", "t.ini", &cfg, &err), 0);
	assert_non_null(strstr(err.msg, "slip_ticks"));
}

/* One tick whose wheel 0 reads 0.2 m/s off a rigid body at rest: null residual 0.2 m/s. */
static uint32_t odd_tick(int n)
{
	struct est_input in = {.utime = (int64_t)n * 1000, .have_wheels = true};

	in.wheel_rad_s[0] = 0.2f / (float)model_params_table3.r;
	est_step(&E, &in);
	return est_get(&E)->flags;
}

static void test_a_live_change_applies_between_ticks(void **state)
{
	(void)state;
	struct est_settings s;
	int n = 0;

	est_settings_defaults(&s);
	assert_int_equal(est_init(&E, &s, &model_params_table3, 1000.0), 0);
	for (; n < 3; n++)
		odd_tick(n);
	assert_true(odd_tick(n++) & EST_FLAG_SLIP); /* 0.2 > 0.08 for 3 ticks */
	s.slip_threshold = 0.3f;
	assert_int_equal(est_set_settings(&E, &s), 0);
	assert_false(odd_tick(n++) & EST_FLAG_SLIP);
	s.slip_threshold = -1.0f; /* refused: the one in force stays */
	assert_int_equal(est_set_settings(&E, &s), -EINVAL);
	assert_true(E.set.slip_threshold == 0.3f);
	s.slip_threshold = 0.08f;
	s.slip_ticks = 0;
	assert_int_equal(est_set_settings(&E, &s), -EINVAL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_defaults_are_the_documented_figures),
	    cmocka_unit_test(test_ini_keys_reach_the_filter),
	    cmocka_unit_test(test_a_live_change_applies_between_ticks),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
