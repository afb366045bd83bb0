/* Tests for the one door a model comes in by (ctl_settings_check, through config_check): a bad
 * model in a parameter change is refused there, once, with one line, and nothing behind the
 * door runs (the feedforward's preparation, the controller, the estimator); a good one is
 * checked there and not again by fw_param_prepare or the estimator (release builds: the
 * debug builds' MODEL_ASSERT_CHECKED checks again on purpose). The model's checks are counted
 * with the linker's --wrap. */
#include "omni4_test.h"

#include <string.h>

#include "omni4/config/config.h"
#include "omni4/model/feedforward.h"
#include "omni4/core/fw.h"
#include "omni4/firmware/param_service.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4_param_reply_t.h"
#include "omni4_param_request_t.h"

static int n_params_check, n_wheels_check, n_ff_prepare;

int __real_model_params_check(const struct model_params *p, int *bad);
int __real_model_wheels_check(const struct model_wheels *w, int *bad);
int __real_ff_q16_wheels_prepare_layout(struct ff_q16_wheels *ff, const struct model_params *p,
                                        const struct model_wheels *w, const struct wheel_geom *g,
                                        double u_max);
int __wrap_model_params_check(const struct model_params *p, int *bad);
int __wrap_model_wheels_check(const struct model_wheels *w, int *bad);
int __wrap_ff_q16_wheels_prepare_layout(struct ff_q16_wheels *ff, const struct model_params *p,
                                        const struct model_wheels *w, const struct wheel_geom *g,
                                        double u_max);

int __wrap_model_params_check(const struct model_params *p, int *bad)
{
	n_params_check++;
	return __real_model_params_check(p, bad);
}

int __wrap_model_wheels_check(const struct model_wheels *w, int *bad)
{
	n_wheels_check++;
	return __real_model_wheels_check(w, bad);
}

int __wrap_ff_q16_wheels_prepare_layout(struct ff_q16_wheels *ff, const struct model_params *p,
                                        const struct model_wheels *w, const struct wheel_geom *g,
                                        double u_max)
{
	n_ff_prepare++;
	return __real_ff_q16_wheels_prepare_layout(ff, p, w, g, u_max);
}

static struct fw g_fw;
static struct sim_motor g_sim;
static struct param_service g_ps;
static struct omni4_config g_cfg;
static char g_reply[256];
static int8_t g_result = -100;

static int capture(void *ctx, const char *channel, const void *data, size_t len)
{
	omni4_param_reply_t r;

	(void)ctx;
	if (strcmp(channel, OMNI4_CHANNEL_PARAM_REPLY) ||
	    omni4_param_reply_t_decode(data, 0, (int)len, &r) < 0)
		return 0;
	g_result = r.result;
	snprintf(g_reply, sizeof(g_reply), "%s", r.message);
	omni4_param_reply_t_decode_cleanup(&r);
	return 0;
}

static void setup(void)
{
	const struct line_hal lines = {.ops = &line_none_ops, .ctx = NULL};

	config_defaults(&g_cfg);
	const struct sim_motor_config sc =
	    sim_motor_config_from(&g_cfg.sim, false, &g_cfg.ctl.model, 1.0 / g_cfg.ctl.rate_hz,
	                          g_cfg.ctl.limits.supply_v);

	assert_int_equal(sim_motor_init(&g_sim, &sc), 0);
	assert_int_equal(fw_init(&g_fw, &g_cfg.ctl, sim_motor_hal(&g_sim), lines), 0);
	assert_int_equal(param_service_init(&g_ps, &g_fw, &g_cfg, "/nonexistent/robot.ini",
	                                    (struct param_out){.emit = capture}),
	                 0);
	n_params_check = n_wheels_check = n_ff_prepare = 0;
}

/* One SET request of key = value, handled on this thread. */
static void set1(const char *key, const char *value)
{
	char *k = (char *)key, *v = (char *)value;
	omni4_param_request_t q = {.utime = 1,
	                           .request_id = 7,
	                           .op = OMNI4_PARAM_REQUEST_T_OP_SET,
	                           .secret = "",
	                           .n = 1,
	                           .keys = &k,
	                           .values = &v,
	                           .name = "",
	                           .text = ""};
	unsigned char buf[4096];
	const int len = omni4_param_request_t_encode(buf, 0, sizeof(buf), &q);

	assert_true(len > 0);
	param_service_handle(&g_ps, buf, (size_t)len);
}

static void test_a_bad_model_is_refused_once_with_one_line_and_nothing_behind_runs(void **state)
{
	static struct fw before;

	(void)state;
	setup();
	memcpy(&before, &g_fw, sizeof(before));
	set1("model.R", "-1");
	assert_int_equal(g_result, OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_string_equal(g_reply, "model.R: out of range value: -1 outside [0.001, 1000]");
	assert_int_equal(n_params_check, 0); /* the key's own range refuses it first */
	assert_int_equal(n_wheels_check, 0);
	assert_int_equal(n_ff_prepare, 0);
	assert_memory_equal(&g_fw.ctl, &before.ctl, sizeof(before.ctl));
	assert_memory_equal(&g_fw.est, &before.est, sizeof(before.est));
	assert_null(atomic_load(&g_fw.param_pending));
	param_service_stop(&g_ps);
}

static void test_a_bad_wheel_is_refused_at_the_same_door(void **state)
{
	(void)state;
	setup();
	set1("model.Kt_2", "0");
	assert_int_equal(g_result, OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_null(strchr(g_reply, '\n'));
	assert_non_null(strstr(g_reply, "model.Kt_2: out of range value: 0 outside"));
	assert_int_equal(n_params_check, 0);
	assert_int_equal(n_wheels_check, 0);
	assert_int_equal(n_ff_prepare, 0);
	param_service_stop(&g_ps);
}

static void test_a_good_model_is_checked_at_the_door_only(void **state)
{
	static struct omni4_config next;
	static struct fw_param_update u;
	char why[128] = "";

	(void)state;
	setup();
	next = g_cfg;
	next.ctl.model.R = 4.5;
	ctl_settings_wheels_follow(&next.ctl);
	assert_int_equal(config_check(&next, why, sizeof(why)), 0);
	assert_int_equal(n_params_check, 1);
	assert_int_equal(n_wheels_check, 1);
	assert_int_equal(fw_param_prepare(&g_fw, &next.ctl, false, &u, why, sizeof(why)), 0);
	assert_int_equal(n_ff_prepare, 1);
	struct model_wheels w;

	ctl_settings_wheels(&next.ctl, &w);
	est_set_model_wheels(&g_fw.est, &next.ctl.model, &w, NULL);
#ifdef NDEBUG
	assert_int_equal(n_params_check, 1);
	assert_int_equal(n_wheels_check, 1);
#endif
	param_service_stop(&g_ps);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(
	        test_a_bad_model_is_refused_once_with_one_line_and_nothing_behind_runs),
	    cmocka_unit_test(test_a_bad_wheel_is_refused_at_the_same_door),
	    cmocka_unit_test(test_a_good_model_is_checked_at_the_door_only),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
