/*
 * Tests for the parameter service (firmware/src/param_service.c), the key table it shares with
 * the INI parser (config_key_*), the INI writer and the atomic save (config.c), and the hand-over
 * of a change to the loop between two ticks (fw.c).
 */
#include "omni4_test.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "omni4/config/config.h"
#include "omni4/model/feedforward.h"
#include "omni4/core/fw.h"
#include "omni4/firmware/param_service.h"
#include "omni4/firmware/rtloop.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4_param_changed_t.h"
#include "omni4_param_reply_t.h"
#include "omni4_param_request_t.h"

/* ---- captured output of the service --------------------------------------------------------- */

#define MAX_OUT 64
static struct {
	char channel[32];
	unsigned char *data;
	size_t len;
} g_out[MAX_OUT];
static int g_n_out;

static int capture(void *ctx, const char *channel, const void *data, size_t len)
{
	(void)ctx;
	if (g_n_out >= MAX_OUT)
		return -1;
	snprintf(g_out[g_n_out].channel, sizeof(g_out[0].channel), "%s", channel);
	g_out[g_n_out].data = malloc(len);
	memcpy(g_out[g_n_out].data, data, len);
	g_out[g_n_out].len = len;
	g_n_out++;
	return 0;
}

static void clear_out(void)
{
	for (int i = 0; i < g_n_out; i++)
		free(g_out[i].data);
	g_n_out = 0;
}

/* The last reply; decoded into r (caller cleans up). */
static void last_reply(omni4_param_reply_t *r)
{
	for (int i = g_n_out - 1; i >= 0; i--)
		if (!strcmp(g_out[i].channel, OMNI4_CHANNEL_PARAM_REPLY)) {
			assert_int_equal(
			    omni4_param_reply_t_decode(g_out[i].data, 0, (int)g_out[i].len, r),
			    (int)g_out[i].len);
			return;
		}
	fail_msg("no reply emitted");
}

static int count_channel(const char *channel)
{
	int n = 0;

	for (int i = 0; i < g_n_out; i++)
		n += !strcmp(g_out[i].channel, channel);
	return n;
}

/* ---- a controller on the simulated plant, with or without a loop thread --------------------- */

static struct fw g_fw;
static struct sim_motor g_sim;
static struct param_service g_ps;
static struct omni4_config g_cfg;
static pthread_t g_loop;
static atomic_bool g_loop_stop;
static _Atomic int64_t g_now_us;
static _Atomic uint64_t g_inconsistent, g_model_changes, g_ticks;
static _Atomic int g_mode; /* the controller's mode after the last tick (loop thread writes) */

/* Loop thread: a tick every 200 us; after each tick the controller's precomputed gains must be
 * those of its own configuration (a half-applied model fails this). */
static void *loop_main(void *arg)
{
	const struct timespec nap = {.tv_sec = 0, .tv_nsec = 200000};
	double last_R = g_fw.ctl.set.model.R;

	(void)arg;
	while (!atomic_load(&g_loop_stop)) {
		struct log_entry e;
		struct ff_q16_wheels want;
		struct model_wheels w;

		fw_tick(&g_fw, atomic_fetch_add(&g_now_us, 1000) + 1000);
		while (fw_pop_log(&g_fw, &e))
			;
		ctl_settings_wheels(&g_fw.ctl.set, &w);
		ff_q16_wheels_init(&want, &g_fw.ctl.set.model, &w, g_fw.ctl.set.limits.supply_v);
		if (memcmp(&want, &g_fw.ctl.ff, sizeof(want)) ||
		    g_fw.ctl.lay.kin.inv_4d != q16_from_double(1.0 / (4.0 * g_fw.ctl.set.model.d)))
			atomic_fetch_add(&g_inconsistent, 1);
		if (g_fw.ctl.set.model.R != last_R) {
			atomic_fetch_add(&g_model_changes, 1);
			last_R = g_fw.ctl.set.model.R;
		}
		atomic_store(&g_mode, g_fw.last_out.mode);
		atomic_fetch_add(&g_ticks, 1);
		nanosleep(&nap, NULL);
	}
	return NULL;
}

static void setup_fw(const char *path, const char *secret, bool loop)
{
	struct line_hal lines = {.ops = &line_none_ops, .ctx = NULL};

	config_defaults(&g_cfg);
	snprintf(g_cfg.fw.secret, sizeof(g_cfg.fw.secret), "%s", secret ? secret : "");
	const struct sim_motor_config sc =
	    sim_motor_config_from(&g_cfg.sim, false, &g_cfg.ctl.model, 1.0 / g_cfg.ctl.rate_hz,
	                          g_cfg.ctl.limits.supply_v);

	assert_int_equal(sim_motor_init(&g_sim, &sc), 0);
	assert_int_equal(fw_init(&g_fw, &g_cfg.ctl, sim_motor_hal(&g_sim), lines), 0);
	assert_int_equal(param_service_init(&g_ps, &g_fw, &g_cfg,
	                                    path ? path : "/nonexistent/robot.ini",
	                                    (struct param_out){.emit = capture}),
	                 0);
	g_ps.apply_timeout_us = 200000;
	clear_out();
	atomic_store(&g_loop_stop, false);
	atomic_store(&g_inconsistent, 0);
	atomic_store(&g_model_changes, 0);
	atomic_store(&g_ticks, 0);
	atomic_store(&g_now_us, 1000000);
	if (loop)
		assert_int_equal(pthread_create(&g_loop, NULL, loop_main, NULL), 0);
}

static void teardown_fw(bool loop)
{
	if (loop) {
		atomic_store(&g_loop_stop, true);
		pthread_join(g_loop, NULL);
	}
	param_service_stop(&g_ps);
	clear_out();
}

static int64_t g_next_id = 1000;

/* Encode and handle one request; returns its id. keys/values: n entries (values may be NULL). */
static int64_t request(int8_t op, int n, const char *const *keys, const char *const *values,
                       const char *secret, const char *text)
{
	char *k[PARAM_MAX_KEYS + 1], *v[PARAM_MAX_KEYS + 1];

	for (int i = 0; i < n; i++) {
		k[i] = (char *)keys[i];
		v[i] = (char *)(values ? values[i] : "");
	}
	omni4_param_request_t q = {.utime = 1,
	                           .request_id = ++g_next_id,
	                           .op = op,
	                           .secret = (char *)(secret ? secret : ""),
	                           .n = n,
	                           .keys = k,
	                           .values = v,
	                           .name = "test.ini",
	                           .text = (char *)(text ? text : "")};
	unsigned char buf[8192];
	const int len = omni4_param_request_t_encode(buf, 0, sizeof(buf), &q);

	assert_true(len > 0);
	param_service_handle(&g_ps, buf, (size_t)len);
	return q.request_id;
}

static int8_t set1(const char *key, const char *value, char *message, size_t n)
{
	omni4_param_reply_t r;
	const int64_t id = request(OMNI4_PARAM_REQUEST_T_OP_SET, 1, &key, &value, NULL, NULL);

	last_reply(&r);
	assert_true(r.request_id == id);
	const int8_t result = r.result;

	if (message)
		snprintf(message, n, "%s", r.message);
	omni4_param_reply_t_decode_cleanup(&r);
	return result;
}

/* ---- the key table and validation --------------------------------------------------------------
 */

/* The last reply has this result code (and is released). */
static void expect_result(int8_t result)
{
	omni4_param_reply_t r;

	last_reply(&r);
	assert_int_equal(r.result, result);
	omni4_param_reply_t_decode_cleanup(&r);
}

static void test_table_model_keys_in_order(void **state)
{
	(void)state;
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++) {
		assert_string_equal(config_key_at(i)->section, "model");
		assert_string_equal(config_key_at(i)->name, model_params_names[i]);
	}
	for (int i = 0; i < config_key_count(); i++) {
		const struct config_key *k = config_key_at(i);
		char dotted[64];

		assert_non_null(k->unit);
		assert_non_null(k->doc);
		snprintf(dotted, sizeof(dotted), "%s.%s", k->section, k->name);
		assert_int_equal(config_key_find(dotted), i);
	}
	assert_null(config_key_at(config_key_count()));
	assert_int_equal(config_key_find("control.nope"), -1);
	assert_int_equal(config_key_find("kp"), -1);
	/* the rules the documentation states */
	assert_int_equal(config_key_at(config_key_find("control.kp"))->change, CONFIG_LIVE);
	assert_int_equal(config_key_at(config_key_find("model.R"))->change, CONFIG_LIVE);
	assert_int_equal(config_key_at(config_key_find("model.d"))->change, CONFIG_IDLE);
	assert_int_equal(config_key_at(config_key_find("limits.supply_v"))->change, CONFIG_IDLE);
	assert_int_equal(config_key_at(config_key_find("loop.rate_hz"))->change, CONFIG_RESTART);
	assert_int_equal(config_key_at(config_key_find("lcm.url"))->change, CONFIG_RESTART);
	assert_int_equal(config_key_at(config_key_find("params.secret"))->change, CONFIG_RESTART);
	/* a wheel key has its scalar's rule; the table fits a request */
	assert_int_equal(config_key_at(config_key_find("model.R_3"))->change, CONFIG_LIVE);
	assert_int_equal(config_key_at(config_key_find("model.Kt_0"))->change, CONFIG_LIVE);
	assert_int_equal(config_key_at(config_key_find("model.r_2"))->change, CONFIG_IDLE);
	assert_true(config_key_count() <= PARAM_MAX_KEYS);
}

/* A value is accepted over the bus exactly when the INI parser accepts it. */
static void test_set_validates_like_the_ini_parser(void **state)
{
	(void)state;
	static const char *const extra[] = {"abc",  "",    "1e400", "nan", "inf",   "0x10", "2.5",
	                                    "true", "off", "-1",    "sim", "gpiod", "12abc"};
	int compared = 0, refused = 0;

	for (int i = MODEL_PARAMS_COUNT; i < config_key_count(); i++) {
		const struct config_key *k = config_key_at(i);
		char values[8][64];

		if (!strcmp(k->section, "model"))
			continue; /* a wheel key needs the scalars: test_wheel_keys_validate_... */
		int nv = 0;

		if (k->type == CONFIG_DOUBLE || k->type == CONFIG_INT) {
			const double span = k->max - k->min;

			snprintf(values[nv++], 64, "%.17g", k->min);
			snprintf(values[nv++], 64, "%.17g", k->max);
			snprintf(values[nv++], 64, "%.17g",
			         k->min - (k->type == CONFIG_INT ? 1 : 1e-9 * span + 1e-12));
			snprintf(values[nv++], 64, "%.17g",
			         k->max + (k->type == CONFIG_INT ? 1 : 1e-9 * span + 1e-12));
		}
		for (int j = 0; j < nv + (int)(sizeof(extra) / sizeof(extra[0])); j++) {
			const char *v = j < nv ? values[j] : extra[j - nv];
			struct omni4_config a, b;
			struct config_error err;
			char text[1024], why[320];

			config_defaults(&a);
			config_defaults(&b);
			const int len =
			    snprintf(text, sizeof(text), "[%s]\n%s = %s\n", k->section, k->name, v);

			assert_true(len > 0 && (size_t)len < sizeof(text));
			const int ini = config_load_string(text, "t.ini", &a, &err);
			/* the INI also checks across keys: do the same after the set */
			int bus = config_key_set(&b, i, v, why, sizeof(why));

			if (!bus)
				bus = config_check(&b, why, sizeof(why));
			if ((ini == 0) != (bus == 0))
				fail_msg("%s.%s = '%s': INI %d (%s), bus %d (%s)", k->section,
				         k->name, v, ini, err.msg, bus, why);
			if (bus) {
				char dotted[64];

				snprintf(dotted, sizeof(dotted), "%s.%s", k->section, k->name);
				/* the key, or for a check across keys (supply_min_v < supply_v) the
				 * key it is checked against */
				if (!strstr(why, dotted) && !strstr(why, k->name))
					fail_msg("reason '%s' does not name %s", why, dotted);
				refused++;
			}
			compared++;
		}
	}
	assert_true(compared > 300);
	assert_true(refused > 100);
}

/* A wheel key is accepted over the bus exactly when an INI with the scalars and that key is. */
static void test_wheel_keys_validate_like_the_ini_parser(void **state)
{
	(void)state;
	static const char *const vals[] = {"0.5", "4.3111", "1e-9", "0",     "-1",  "nan",
	                                   "inf", "abc",    "",     "1e400", "0x10"};
	int wheel_keys = 0, refused = 0;

	for (int i = MODEL_PARAMS_COUNT; i < config_key_count(); i++) {
		const struct config_key *k = config_key_at(i);

		if (strcmp(k->section, "model") || !strcmp(k->name, "wheels") ||
		    !strncmp(k->name, "wheel_angle_", 12) || !strncmp(k->name, "d_", 2))
			continue; /* the layout's: test_layout_keys_validate_like_the_ini_parser */
		wheel_keys++;
		for (size_t j = 0; j < sizeof(vals) / sizeof(vals[0]); j++) {
			struct omni4_config a, b;
			struct config_error err;
			char text[2048], why[320], dotted[64];
			int len = snprintf(text, sizeof(text), "[model]\n");

			config_defaults(&a);
			config_defaults(&b);
			for (int m = 0; m < MODEL_PARAMS_COUNT; m++)
				len += snprintf(text + len, sizeof(text) - (size_t)len,
				                "%s = %.17g\n", model_params_names[m],
				                model_params_get(&a.ctl.model, m));
			snprintf(text + len, sizeof(text) - (size_t)len, "%s = %s\n", k->name,
			         vals[j]);
			const int ini = config_load_string(text, "t.ini", &a, &err);
			int bus = config_key_set(&b, i, vals[j], why, sizeof(why));

			if (!bus)
				bus = config_check(&b, why, sizeof(why));
			if ((ini == 0) != (bus == 0))
				fail_msg("%s = '%s': INI %d (%s), bus %d (%s)", k->name, vals[j],
				         ini, err.msg, bus, why);
			snprintf(dotted, sizeof(dotted), "model.%s", k->name);
			if (bus && !strstr(why, dotted))
				fail_msg("reason '%s' does not name %s", why, dotted);
			refused += bus != 0;
		}
	}
	assert_int_equal(wheel_keys, 16);
	/* 0 -1 nan inf abc "" 1e400, 1e-9 (below every range) and 0x10 (not decimal) on every
	 * wheel key; 4.3111 m beyond a wheel radius's 1 m (docs/ini-keys.md) */
	assert_int_equal(refused, 16 * 9 + 4);
}

/* ---- the INI writer and the atomic save ------------------------------------------------------ */

static void distinctive(struct omni4_config *c)
{
	config_defaults(c);
	c->ctl.model = (struct model_params){0.1 / 3, 0.03125, 4.7, 0.021, 0.0215, 3.3, 2.1,
	                                     0.019,   0.3,     0.7, 0.013, 1.7,    2.3, 0.11};
	c->ctl.rate_hz = 777.0;
	c->fw.loop.sched_fifo = true;
	c->fw.loop.priority = 42;
	c->fw.loop.cpu_dma_latency_us = 0;
	c->ctl.control.kp = 1.0 / 7.0;
	c->ctl.control.ki = 1e-5;
	c->ctl.control.feedforward = false;
	c->ctl.control.cmd_timeout_ms = 333;
	c->ctl.limits.supply_v = 24.0;
	c->ctl.limits.supply_min_v = 18.5;
	c->ctl.limits.current_sensor_max_a = 20.25;
	snprintf(c->fw.lcm_url, sizeof(c->fw.lcm_url), "udpm://239.255.76.67:7700?ttl=0");
	c->fw.motor = OMNI4_MOTOR_SOCKETCAN;
	c->fw.lines = OMNI4_LINES_GPIOD;
	c->sim.seed = 2147483647;
	snprintf(c->can.iface, sizeof(c->can.iface), "vcan7");
	snprintf(c->gpio.chip, sizeof(c->gpio.chip), "gpiochip3");
	c->gpio.estop_line = 17;
	c->gpio.estop_active_low = false;
	snprintf(c->fw.secret, sizeof(c->fw.secret), "s3cret-token");
}

static void assert_same_config(const struct omni4_config *a, const struct omni4_config *b)
{
	char va[160], vb[160];

	for (int i = 0; i < config_key_count(); i++) {
		assert_int_equal(config_key_format(a, i, va, sizeof(va)), 0);
		assert_int_equal(config_key_format(b, i, vb, sizeof(vb)), 0);
		if (strcmp(va, vb))
			fail_msg("%s.%s: '%s' != '%s'", config_key_at(i)->section,
			         config_key_at(i)->name, va, vb);
	}
	assert_memory_equal(&a->ctl.model, &b->ctl.model, sizeof(a->ctl.model)); /* bit for bit */
	assert_true(a->ctl.control.kp == b->ctl.control.kp);
}

static void test_writer_round_trip(void **state)
{
	(void)state;
	struct omni4_config c, back;
	struct config_error err;
	char *text = NULL;
	size_t len = 0;
	FILE *f = open_memstream(&text, &len);

	distinctive(&c);
	assert_int_equal(config_write(f, &c, "a header"), 0);
	fclose(f);
	config_defaults(&back);
	if (config_load_string(text, "written.ini", &back, &err))
		fail_msg("%s", err.msg);
	assert_same_config(&c, &back);
	/* and the defaults too */
	config_defaults(&c);
	free(text);
	f = open_memstream(&text, &len);
	assert_int_equal(config_write(f, &c, NULL), 0);
	fclose(f);
	distinctive(&back);
	assert_int_equal(config_load_string(text, "written.ini", &back, &err), 0);
	assert_same_config(&c, &back);
	free(text);
	/* a string an INI file cannot hold unchanged is refused, not written wrongly */
	snprintf(c.can.iface, sizeof(c.can.iface), "can0 ; x");
	f = open_memstream(&text, &len);
	assert_int_equal(config_write(f, &c, NULL), -EINVAL);
	fclose(f);
	free(text);
}

static char g_dir[64];

static void make_dir(void)
{
	snprintf(g_dir, sizeof(g_dir), "/tmp/omni4-param-XXXXXX");
	assert_non_null(mkdtemp(g_dir));
}

static void remove_dir(void)
{
	char cmd[128];

	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", g_dir);
	assert_int_equal(system(cmd), 0);
}

static void test_save_replaces_atomically_and_keeps_bak(void **state)
{
	(void)state;
	char path[128], bak[160], tmp[160];
	struct omni4_config c, back;
	struct config_error err;
	struct stat st;
	char why[320];

	make_dir();
	snprintf(path, sizeof(path), "%s/robot.ini", g_dir);
	snprintf(bak, sizeof(bak), "%s.bak", path);
	snprintf(tmp, sizeof(tmp), "%s.tmp", path);
	FILE *f = fopen(path, "w");

	fputs("[control]\nkp = 3\n", f);
	fclose(f);
	chmod(path, 0600);
	distinctive(&c);
	assert_int_equal(config_save(path, &c, "saved", why, sizeof(why)), 0);
	config_defaults(&back);
	assert_int_equal(config_load(path, &back, &err), 0);
	assert_same_config(&c, &back);
	assert_int_equal(stat(path, &st), 0);
	assert_int_equal(st.st_mode & 0777, 0600); /* permissions kept (the secret) */
	assert_int_equal(stat(tmp, &st), -1);      /* no temporary left */
	config_defaults(&back);
	assert_int_equal(config_load(bak, &back, &err), 0);
	assert_near(back.ctl.control.kp, 3.0, 0);
	/* A second save: .bak is the first saved file. */
	c.ctl.control.kp = 9.5;
	assert_int_equal(config_save(path, &c, NULL, why, sizeof(why)), 0);
	config_defaults(&back);
	assert_int_equal(config_load(bak, &back, &err), 0);
	assert_near(back.ctl.control.kp, 1.0 / 7.0, 0);
	/* A directory it cannot write: an error with the reason, the file untouched. */
	assert_true(config_save("/nonexistent-dir/robot.ini", &c, NULL, why, sizeof(why)) < 0);
	assert_non_null(strstr(why, "/nonexistent-dir/robot.ini.tmp"));
	config_defaults(&back);
	assert_int_equal(config_load(path, &back, &err), 0);
	assert_near(back.ctl.control.kp, 9.5, 0);
	remove_dir();
}

/* ---- the service --------------------------------------------------------------------------------
 */

static void test_set_applies_between_ticks(void **state)
{
	(void)state;
	omni4_param_reply_t r;
	char msg[320];

	setup_fw(NULL, NULL, true);
	assert_int_equal(set1("control.kp", "40", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	last_reply(&r);
	assert_true(r.seq >= 0);
	assert_int_equal(r.n, 1);
	assert_string_equal(r.params[0].key, "control.kp");
	assert_string_equal(r.params[0].value, "40");
	omni4_param_reply_t_decode_cleanup(&r);
	assert_near(g_ps.running.ctl.control.kp, 40.0, 0);
	/* one change notice with old and new values and the tick */
	assert_int_equal(count_channel(OMNI4_CHANNEL_PARAM_CHANGED), 1);
	for (int i = 0; i < g_n_out; i++)
		if (!strcmp(g_out[i].channel, OMNI4_CHANNEL_PARAM_CHANGED)) {
			omni4_param_changed_t m;

			assert_true(omni4_param_changed_t_decode(g_out[i].data, 0,
			                                         (int)g_out[i].len, &m) > 0);
			assert_string_equal(m.source, "set");
			assert_int_equal(m.n, 1);
			assert_string_equal(m.old_values[0], "20");
			assert_string_equal(m.values[0], "40");
			assert_true(m.seq >= 0);
			omni4_param_changed_t_decode_cleanup(&m);
		}
	teardown_fw(true);
	assert_near(g_fw.ctl.set.control.kp, 40.0, 0);
}

/* At start every value in force goes out once (source "start"), so a log that begins with the
 * controller says what it ran on from its first tick. Read back through the INI parser: the
 * values are the configuration, and the secret is never in them. */
static void test_start_announces_every_value(void **state)
{
	(void)state;
	struct omni4_config want, back;
	struct config_error err;
	omni4_param_changed_t m;
	char *text = NULL;
	size_t len = 0;

	setup_fw("/etc/omni4/robot.ini", NULL, false);
	distinctive(&want);
	g_ps.running = want;
	param_service_announce(&g_ps, 17, 123456789);
	assert_int_equal(g_n_out, 1);
	assert_string_equal(g_out[0].channel, OMNI4_CHANNEL_PARAM_CHANGED);
	for (size_t i = 0; i + 12 <= g_out[0].len; i++) /* the secret is nowhere in the bytes */
		assert_memory_not_equal(g_out[0].data + i, "s3cret-token", 12);
	assert_int_equal(omni4_param_changed_t_decode(g_out[0].data, 0, (int)g_out[0].len, &m),
	                 (int)g_out[0].len);
	assert_string_equal(m.source, "start");
	assert_string_equal(m.path, "/etc/omni4/robot.ini");
	assert_int_equal(m.seq, 17);
	assert_int_equal(m.utime, 123456789);
	assert_int_equal(m.request_id, 0);
	assert_int_equal(m.n, config_key_count());
	FILE *f = open_memstream(&text, &len);

	/* back to an INI: each section once (its keys need not be together in the message) */
	for (int i = 0; i < m.n; i++) {
		const char *dot = strchr(m.keys[i], '.');
		const int sl = (int)(dot ? dot - m.keys[i] : 0);
		bool done = false;

		assert_non_null(dot);
		assert_string_equal(m.old_values[i], "");
		for (int j = 0; j < i && !done; j++)
			done = !strncmp(m.keys[j], m.keys[i], (size_t)sl + 1);
		if (done)
			continue;
		fprintf(f, "[%.*s]\n", sl, m.keys[i]);
		for (int j = i; j < m.n; j++) {
			if (strncmp(m.keys[j], m.keys[i], (size_t)sl + 1))
				continue;
			if (!strcmp(m.keys[j], "params.secret")) {
				assert_string_equal(m.values[j], "(set)");
				continue;
			}
			fprintf(f, "%s = %s\n", m.keys[j] + sl + 1, m.values[j]);
		}
	}
	fclose(f);
	config_defaults(&back);
	snprintf(back.fw.secret, sizeof(back.fw.secret), "%s", want.fw.secret);
	if (config_load_string(text, "start.ini", &back, &err))
		fail_msg("%s", err.msg);
	assert_same_config(&want, &back);
	free(text);
	omni4_param_changed_t_decode_cleanup(&m);
	teardown_fw(false);
}

/* The loop must not see a change before a tick boundary, and then all of it. */
static void test_nothing_changes_without_a_tick(void **state)
{
	(void)state;
	char msg[320];

	setup_fw(NULL, NULL, false); /* no loop thread */
	const struct ff_q16_wheels ff0 = g_fw.ctl.ff;

	assert_int_equal(set1("model.R", "8.6222", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_FAILED);
	if (!strstr(msg, "nothing changed"))
		fail_msg("'%s'", msg);
	/* withdrawn: neither the running copy nor the controller changed, and a later tick
	 * does not pick it up */
	assert_near(g_ps.running.ctl.model.R, 4.3111, 0);
	fw_tick(&g_fw, 2000000);
	assert_near(g_fw.ctl.set.model.R, 4.3111, 0);
	assert_memory_equal(&ff0, &g_fw.ctl.ff, sizeof(ff0));

	/* Prepared and offered by hand: before the tick nothing, after it everything. */
	struct fw_param_update u;
	struct omni4_config next = g_ps.running;
	char why[320];

	next.ctl.model.R = 8.6222;
	next.ctl.model.M = 3.0;
	assert_int_equal(fw_param_prepare(&g_fw, &next.ctl, false, &u, why, sizeof(why)), 0);
	fw_param_offer(&g_fw, &u);
	assert_near(g_fw.ctl.set.model.R, 4.3111, 0);
	assert_memory_equal(&ff0, &g_fw.ctl.ff, sizeof(ff0));
	const int64_t seq = g_fw.seq;

	fw_tick(&g_fw, 2001000);
	assert_near(g_fw.ctl.set.model.R, 8.6222, 0);
	assert_near(g_fw.ctl.set.model.M, 3.0, 0);
	assert_memory_equal(&u.ff, &g_fw.ctl.ff, sizeof(u.ff));
	struct fw_param_result r;

	assert_true(fw_param_done(&g_fw, &u, &r));
	assert_int_equal(r.rc, 0);
	assert_true(r.seq == seq);
	teardown_fw(false);
}

/* Many multi-key model changes while the loop runs: after every tick the precomputed
 * feedforward gains are those of the model the controller holds. */
static void test_model_swap_is_atomic_under_load(void **state)
{
	(void)state;
	static const char *const keys[] = {"model.R", "model.M", "model.Kt", "model.Cv"};
	static const char *const a[] = {"4.3111", "2.34", "0.0259", "1.8738"};
	static const char *const b[] = {"6.5", "3.1", "0.031", "2.5"};
	int ok = 0;

	setup_fw(NULL, NULL, true);
	for (int i = 0; i < 200; i++) {
		omni4_param_reply_t r;

		request(OMNI4_PARAM_REQUEST_T_OP_SET, 4, keys, i % 2 ? a : b, NULL, NULL);
		last_reply(&r);
		ok += r.result == OMNI4_PARAM_REPLY_T_RESULT_OK;
		omni4_param_reply_t_decode_cleanup(&r);
		clear_out();
	}
	teardown_fw(true);
	assert_int_equal(ok, 200);
	assert_int_equal(atomic_load(&g_inconsistent), 0);
	assert_true(atomic_load(&g_model_changes) >= 150); /* the loop ran on most of them */
	assert_near(g_fw.ctl.set.model.R, 4.3111, 0);      /* the last one (i = 199: a) */
}

static void test_refusals_say_why_and_change_nothing(void **state)
{
	(void)state;
	char msg[320];

	setup_fw(NULL, NULL, true);
	const double kp = g_ps.running.ctl.control.kp;

	assert_int_equal(set1("control.kp", "1e9", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "control.kp: out of range value: 1e+09 outside [0, 10000]"));
	assert_int_equal(set1("model.R", "-1", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "model.R: out of range value: -1 outside [0.001, 1000]"));
	assert_int_equal(set1("model.Bv", "-0.1", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "model.Bv: out of range value: -0.1 outside [0, 10000]"));
	assert_int_equal(set1("limits.supply_min_v", "13", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "must be below supply_v"));
	assert_int_equal(set1("loop.rate_hz", "500", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "loop.rate_hz: restart only"));
	assert_int_equal(set1("params.secret", "x", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	/* the same value as in force is no change, even for a restart-only key */
	assert_int_equal(set1("loop.rate_hz", "1000", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_non_null(strstr(msg, "no change"));
	/* a multi-key set with one bad value changes none of them */
	static const char *const keys[] = {"control.kp", "model.R", "control.ki"};
	static const char *const vals[] = {"33", "5", "-1"};
	omni4_param_reply_t r;

	request(OMNI4_PARAM_REQUEST_T_OP_SET, 3, keys, vals, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(r.message, "control.ki"));
	omni4_param_reply_t_decode_cleanup(&r);
	assert_int_equal(count_channel(OMNI4_CHANNEL_PARAM_CHANGED), 0);
	teardown_fw(true);
	assert_near(g_fw.ctl.set.control.kp, kp, 0);
	assert_near(g_fw.ctl.set.model.R, 4.3111, 0);
}

static void test_idle_only_keys_wait_for_idle(void **state)
{
	(void)state;
	char msg[320];
	const struct ctl_command go = {
	    .utime = 1, .seq = 1, .mode = CTL_VELOCITY, .velocity = {0.2, 0, 0}};

	setup_fw(NULL, NULL, true);
	/* no keep-alive here: a watchdog longer than the test */
	assert_int_equal(set1("control.cmd_timeout_ms", "600000", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_OK);
	fw_post_command(&g_fw, &go);
	for (int i = 0; i < 2000 && atomic_load(&g_mode) != CTL_VELOCITY; i++)
		usleep(1000);
	assert_int_equal(atomic_load(&g_mode), CTL_VELOCITY);
	assert_int_equal(set1("model.d", "0.1", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	if (!strstr(msg, "model.d: only while the bridges are not driven") ||
	    !strstr(msg, "VELOCITY"))
		fail_msg("'%s'", msg);
	/* live keys go through while driving */
	assert_int_equal(set1("model.R", "5", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_int_equal(set1("control.kp", "25", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	/* and the idle-only one once the robot is idle */
	const struct ctl_command stop = {.utime = 2, .seq = 2, .mode = CTL_IDLE};

	fw_post_command(&g_fw, &stop);
	for (int i = 0; i < 2000 && atomic_load(&g_mode) != CTL_IDLE; i++)
		usleep(1000);
	assert_int_equal(atomic_load(&g_mode), CTL_IDLE);
	assert_int_equal(set1("model.d", "0.1", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	teardown_fw(true);
	assert_near(g_fw.ctl.set.model.d, 0.1, 0);
	assert_near(g_fw.ctl.set.model.R, 5, 0);
}

static void test_load_merges_a_partial_model(void **state)
{
	(void)state;
	omni4_param_reply_t r;

	setup_fw(NULL, NULL, true);
	/* identified keys only (as omni4-ident writes when data is partial) */
	request(OMNI4_PARAM_REQUEST_T_OP_LOAD, 0, NULL, NULL, NULL,
	        "; identified\n[model]\nBv = 0.61\nCv = 1.5 ; comment\n");
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_int_equal(r.n, 2);
	omni4_param_reply_t_decode_cleanup(&r);
	assert_near(g_ps.running.ctl.model.Bv, 0.61, 0);
	assert_near(g_ps.running.ctl.model.Cv, 1.5, 0);
	assert_near(g_ps.running.ctl.model.R, 4.3111, 0); /* kept */
	/* a file that would make the merged model invalid: refused whole */
	request(OMNI4_PARAM_REQUEST_T_OP_LOAD, 0, NULL, NULL, NULL, "[model]\nBvn = 0.9\nJ = 0\n");
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(r.message, "model.J"));
	omni4_param_reply_t_decode_cleanup(&r);
	assert_near(g_ps.running.ctl.model.Bvn, 0.6763, 0);
	/* what the INI parser rejects, LOAD rejects with the file's name and line */
	request(OMNI4_PARAM_REQUEST_T_OP_LOAD, 0, NULL, NULL, NULL, "[model]\nBv = 1\nBv = 2\n");
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_non_null(strstr(r.message, "test.ini:3: duplicate key 'Bv' in [model]"));
	omni4_param_reply_t_decode_cleanup(&r);
	request(OMNI4_PARAM_REQUEST_T_OP_LOAD, 0, NULL, NULL, NULL, "[model]\nBq = 1\n");
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_non_null(strstr(r.message, "unknown key 'Bq'"));
	omni4_param_reply_t_decode_cleanup(&r);
	request(OMNI4_PARAM_REQUEST_T_OP_LOAD, 0, NULL, NULL, NULL, "; nothing\n");
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	teardown_fw(true);
}

static void test_broken_requests(void **state)
{
	(void)state;
	static const char *const key[] = {"control.kp"};
	static const char *const val[] = {"30"};
	char *k[1] = {(char *)key[0]}, *v[1] = {(char *)val[0]};
	omni4_param_request_t q = {.request_id = 77,
	                           .op = OMNI4_PARAM_REQUEST_T_OP_SET,
	                           .secret = "",
	                           .n = 1,
	                           .keys = k,
	                           .values = v,
	                           .name = "",
	                           .text = ""};
	unsigned char buf[512];
	const int len = omni4_param_request_t_encode(buf, 0, sizeof(buf), &q);
	omni4_param_reply_t r;

	setup_fw(NULL, NULL, true);
	/* every truncation, and trailing garbage: one BAD_REQUEST reply each, nothing applied */
	for (int cut = 0; cut < len; cut++) {
		param_service_handle(&g_ps, buf, (size_t)cut);
		last_reply(&r);
		assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
		assert_true(r.request_id == 0);
		assert_non_null(strstr(r.message, "undecodable param_request_t"));
		omni4_param_reply_t_decode_cleanup(&r);
		clear_out();
	}
	/* n as sent decides what lcm-gen's decoder allocates: a negative or huge n, or strings
	 * whose lengths run past the end, are refused before any decoding */
	{
		unsigned char bad[512];
		/* offset of n: fingerprint 8, utime 8, request_id 8, op 1, secret (4 + 1) */
		const size_t at_n = 8 + 8 + 8 + 1 + 4 + 1;
		const uint32_t ns[] = {0xFFFFFFFFu, 0x7FFFFFFFu, 0x80000000u, 2};

		for (size_t j = 0; j < sizeof(ns) / sizeof(ns[0]); j++) {
			memcpy(bad, buf, (size_t)len);
			bad[at_n] = (unsigned char)(ns[j] >> 24);
			bad[at_n + 1] = (unsigned char)(ns[j] >> 16);
			bad[at_n + 2] = (unsigned char)(ns[j] >> 8);
			bad[at_n + 3] = (unsigned char)ns[j];
			param_service_handle(&g_ps, bad, (size_t)len);
			expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
			clear_out();
		}
		/* n = -1 and nothing after it: only the n check refuses it (the strings that
		 * follow are 2 n + 2 = 0), before lcm-gen's decoder allocates -1 pointers */
		memcpy(bad, buf, at_n);
		memset(bad + at_n, 0xFF, 4);
		param_service_handle(&g_ps, bad, at_n + 4);
		last_reply(&r);
		assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
		if (!strstr(r.message, "n = -1 outside"))
			fail_msg("n = -1: refused as '%s', not for n", r.message);
		omni4_param_reply_t_decode_cleanup(&r);
		clear_out();
		/* a string length that runs past the end */
		memcpy(bad, buf, (size_t)len);
		bad[at_n + 4] = 0x7F;
		param_service_handle(&g_ps, bad, (size_t)len);
		expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
		clear_out();
	}
	unsigned char longer[520];

	memcpy(longer, buf, (size_t)len);
	longer[len] = 0;
	param_service_handle(&g_ps, longer, (size_t)len + 1);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	/* a wrong fingerprint (another type on the channel) */
	memcpy(longer, buf, (size_t)len);
	longer[0] ^= 0x40;
	param_service_handle(&g_ps, longer, (size_t)len);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_near(g_ps.running.ctl.control.kp, 20.0, 0);
	assert_true(atomic_load(&g_ps.n.bad) ==
	            (uint64_t)len + 2 + 6); /* + the 6 bad n and lengths */
	/* decodable but wrong: unknown op, unknown key, a key twice, too many keys */
	static const char *const two[] = {"control.kp", "control.kp"};
	static const char *const unknown[] = {"control.kq"};

	request(42, 0, NULL, NULL, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_non_null(strstr(r.message, "unknown op 42"));
	omni4_param_reply_t_decode_cleanup(&r);
	request(OMNI4_PARAM_REQUEST_T_OP_SET, 1, unknown, val, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_non_null(strstr(r.message, "unknown key 'control.kq'"));
	omni4_param_reply_t_decode_cleanup(&r);
	static const char *const two_vals[] = {"30", "31"};

	request(OMNI4_PARAM_REQUEST_T_OP_SET, 2, two, two_vals, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	request(OMNI4_PARAM_REQUEST_T_OP_SET, 0, NULL, NULL, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	const char *many[PARAM_MAX_KEYS + 1];

	for (int i = 0; i <= PARAM_MAX_KEYS; i++)
		many[i] = "control.kp";
	request(OMNI4_PARAM_REQUEST_T_OP_GET, PARAM_MAX_KEYS + 1, many, NULL, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	teardown_fw(true);
	assert_near(g_fw.ctl.set.control.kp, 20.0, 0);
}

static void test_secret_and_repeated_ids(void **state)
{
	(void)state;
	static const char *const key[] = {"control.kp"};
	static const char *const val[] = {"31"};
	omni4_param_reply_t r;

	setup_fw(NULL, "tok3n", true);
	request(OMNI4_PARAM_REQUEST_T_OP_SET, 1, key, val, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_DENIED);
	request(OMNI4_PARAM_REQUEST_T_OP_SET, 1, key, val, "tok3", NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_DENIED);
	request(OMNI4_PARAM_REQUEST_T_OP_SAVE, 0, NULL, NULL, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_DENIED);
	assert_near(g_ps.running.ctl.control.kp, 20.0, 0);
	/* reads need no secret, and never show it */
	request(OMNI4_PARAM_REQUEST_T_OP_LIST, 0, NULL, NULL, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_int_equal(r.n, config_key_count());
	for (int i = 0; i < r.n; i++) {
		assert_null(strstr(r.params[i].value, "tok3n"));
		if (!strcmp(r.params[i].key, "params.secret"))
			assert_string_equal(r.params[i].value, "(set)");
	}
	omni4_param_reply_t_decode_cleanup(&r);
	/* with it: applied once, even if the request arrives twice (a retry) */
	char *k[1] = {(char *)key[0]}, *v[1] = {(char *)val[0]};
	omni4_param_request_t q = {.request_id = 9001,
	                           .op = OMNI4_PARAM_REQUEST_T_OP_SET,
	                           .secret = "tok3n",
	                           .n = 1,
	                           .keys = k,
	                           .values = v,
	                           .name = "",
	                           .text = ""};
	unsigned char buf[512];
	const int len = omni4_param_request_t_encode(buf, 0, sizeof(buf), &q);

	clear_out();
	param_service_handle(&g_ps, buf, (size_t)len);
	param_service_handle(&g_ps, buf, (size_t)len);
	assert_int_equal(count_channel(OMNI4_CHANNEL_PARAM_REPLY), 2);
	assert_int_equal(count_channel(OMNI4_CHANNEL_PARAM_CHANGED), 1);
	assert_int_equal(g_out[g_n_out - 1].len, g_out[g_n_out - 2].len);
	assert_memory_equal(g_out[g_n_out - 1].data, g_out[g_n_out - 2].data,
	                    g_out[g_n_out - 1].len);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_true(atomic_load(&g_ps.n.applied) == 1);
	assert_near(g_ps.running.ctl.control.kp, 31.0, 0);
	/* a bad request sent twice (its reply lost): the same answer, counted bad once */
	static const char *const nope[] = {"control.nope"};
	char *kn[1] = {(char *)nope[0]};

	q.request_id = 9002;
	q.op = OMNI4_PARAM_REQUEST_T_OP_GET;
	q.keys = kn;
	q.values = v;
	const int len_bad = omni4_param_request_t_encode(buf, 0, sizeof(buf), &q);
	const uint64_t bad_before = atomic_load(&g_ps.n.bad);

	clear_out();
	param_service_handle(&g_ps, buf, (size_t)len_bad);
	param_service_handle(&g_ps, buf, (size_t)len_bad);
	assert_int_equal(count_channel(OMNI4_CHANNEL_PARAM_REPLY), 2);
	assert_memory_equal(g_out[g_n_out - 1].data, g_out[g_n_out - 2].data,
	                    g_out[g_n_out - 1].len);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_BAD_REQUEST);
	assert_true(atomic_load(&g_ps.n.bad) == bad_before + 1);
	teardown_fw(true);
}

static void test_save_writes_what_is_in_force(void **state)
{
	(void)state;
	char path[128], msg[320];
	struct omni4_config back;
	struct config_error err;
	omni4_param_reply_t r;

	make_dir();
	snprintf(path, sizeof(path), "%s/robot.ini", g_dir);
	FILE *f = fopen(path, "w");

	fputs("[hal]\nmotor = sim\n", f);
	fclose(f);
	setup_fw(path, NULL, true);
	assert_int_equal(set1("control.kp", "44.5", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_int_equal(set1("model.Cw", "0.2", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	request(OMNI4_PARAM_REQUEST_T_OP_SAVE, 0, NULL, NULL, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_string_equal(r.path, path);
	char bak_said[600];

	snprintf(bak_said, sizeof(bak_said), "saved; previous kept as %s.bak", path);
	assert_string_equal(r.message, bak_said);
	omni4_param_reply_t_decode_cleanup(&r);
	teardown_fw(true);
	config_defaults(&back);
	assert_int_equal(config_load(path, &back, &err), 0);
	assert_near(back.ctl.control.kp, 44.5, 0);
	assert_near(back.ctl.model.Cw, 0.2, 0);
	remove_dir();
}

/* GET of one key: its value in force into buf. */
static void get1(const char *key, char *buf, size_t n)
{
	omni4_param_reply_t r;

	request(OMNI4_PARAM_REQUEST_T_OP_GET, 1, &key, NULL, NULL, NULL);
	last_reply(&r);
	assert_int_equal(r.result, OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_int_equal(r.n, 1);
	snprintf(buf, n, "%s", r.params[0].value);
	omni4_param_reply_t_decode_cleanup(&r);
}

static void expect_param(const char *key, const char *want)
{
	char got[160];

	get1(key, got, sizeof(got));
	if (strcmp(got, want))
		fail_msg("%s = '%s', not '%s'", key, got, want);
}

/* The controller runs on the feedforward of these wheels: the scalar model's, R_2 and R_3
 * as given (built here from the scalars, independently of the settings' wheel keys). */
static void expect_controller_wheels(double R, double R2, double R3)
{
	struct model_params p = g_fw.ctl.set.model;
	struct model_wheels w;
	struct ff_q16_wheels want;

	p.R = R;
	model_wheels_from_params(&p, &w);
	w.R[2] = R2;
	w.R[3] = R3;
	assert_int_equal(ff_q16_wheels_init(&want, &p, &w, g_fw.ctl.set.limits.supply_v), 0);
	assert_memory_equal(&want, &g_fw.ctl.ff, sizeof(want));
}

/* The layout's keys ([model] wheels, wheel_angle_j, d_j) are taken over the bus exactly when an
 * INI with them is; a layout that cannot drive the body (two wheels on one line leave an axis
 * undriven) is refused by both, naming [model] wheels. */
static void test_layout_keys_validate_like_the_ini_parser(void **state)
{
	(void)state;
	static const struct {
		const char *text; /* [model] lines */
		bool ok;
	} cases[] = {
	    {"wheels = 3\n", true},
	    {"wheels = 5\n", false},
	    {"wheels = 2\n", false},
	    {"wheel_angle_1 = 135\n", true},
	    {"wheel_angle_0 = 400\n", false},
	    {"wheel_angle_1 = 0\nwheel_angle_2 = 0\nwheel_angle_3 = 0\n", false},
	    {"wheels = 3\nwheel_angle_1 = 180\nwheel_angle_2 = 0\n", false},
	    {"wheels = 3\nwheel_angle_1 = 120\nwheel_angle_2 = 240\n", true},
	    {"wheel_angle_0 = nan\n", false},
	};
	int refused = 0;

	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct omni4_config a, b;
		struct config_error err;
		char text[512], line[128], why[320];

		config_defaults(&a);
		config_defaults(&b);
		snprintf(text, sizeof(text), "[model]\n%s", cases[c].text);
		const int ini = config_load_string(text, "t.ini", &a, &err);
		int bus = 0;

		for (const char *p = cases[c].text; *p && !bus;) {
			const char *eol = strchr(p, '\n');
			char key[64], value[64];

			snprintf(line, sizeof(line), "%.*s", (int)(eol - p), p);
			assert_int_equal(sscanf(line, "%63s = %63s", key, value), 2);
			snprintf(line, sizeof(line), "model.%s", key);
			bus = config_key_set(&b, config_key_find(line), value, why, sizeof(why));
			p = eol + 1;
		}
		if (!bus)
			bus = config_check(&b, why, sizeof(why));
		if ((ini == 0) != cases[c].ok || (bus == 0) != cases[c].ok)
			fail_msg("'%s': INI %d (%s), bus %d (%s), expected %s", cases[c].text, ini,
			         err.msg, bus, why, cases[c].ok ? "taken" : "refused");
		if (!cases[c].ok && !strstr(why, "model."))
			fail_msg("reason '%s' names no [model] key", why);
		refused += !cases[c].ok;
	}
	assert_int_equal(refused, 6);
}

/* The wheel keys over the bus: set (a wheel's own), GET, a scalar set moves only the wheels
 * without their own key, refusals name the key, and SAVE writes the own ones only. */
static void test_wheel_keys_over_the_bus(void **state)
{
	(void)state;
	char path[128], msg[320];
	omni4_param_reply_t r;

	make_dir();
	snprintf(path, sizeof(path), "%s/robot.ini", g_dir);
	setup_fw(path, NULL, true);
	expect_param("model.R_2", "4.3111"); /* no key of its own: the scalar */
	assert_int_equal(set1("model.R_2", "5.25", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_OK);
	expect_param("model.R_2", "5.25");
	expect_param("model.R_1", "4.3111");
	expect_param("model.R", "4.3111");
	expect_controller_wheels(4.3111, 5.25, 4.3111);
	/* a wheel key set to the value it follows: its own from now on */
	assert_int_equal(set1("model.R_3", "4.3111", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_OK);
	assert_non_null(strstr(msg, "no change"));
	/* the scalar: the wheels without a key of their own follow it, in the same change */
	assert_int_equal(set1("model.R", "4", msg, sizeof(msg)), OMNI4_PARAM_REPLY_T_RESULT_OK);
	last_reply(&r);
	assert_int_equal(r.n, 3);
	assert_string_equal(r.params[0].key, "model.R");
	assert_string_equal(r.params[1].key, "model.R_0");
	assert_string_equal(r.params[2].key, "model.R_1");
	omni4_param_reply_t_decode_cleanup(&r);
	expect_param("model.R_0", "4");
	expect_param("model.R_2", "5.25");
	expect_param("model.R_3", "4.3111");
	expect_controller_wheels(4.0, 5.25, 4.3111);
	/* refused whole, the key named, nothing changed */
	assert_int_equal(set1("model.R_1", "0", msg, sizeof(msg)),
	                 OMNI4_PARAM_REPLY_T_RESULT_REFUSED);
	assert_non_null(strstr(msg, "model.R_1"));
	expect_param("model.R_1", "4");
	/* SAVE: the scalars as in force and the wheels' own keys, nothing else */
	request(OMNI4_PARAM_REQUEST_T_OP_SAVE, 0, NULL, NULL, NULL, NULL);
	expect_result(OMNI4_PARAM_REPLY_T_RESULT_OK);
	const struct omni4_config running = g_ps.running;

	teardown_fw(true);
	char text[16384];
	FILE *f = fopen(path, "r");

	assert_non_null(f);
	text[fread(text, 1, sizeof(text) - 1, f)] = '\0';
	fclose(f);
	assert_non_null(strstr(text, "\nR = 4\n"));
	assert_non_null(strstr(text, "\nR_2 = 5.25\n"));
	assert_non_null(strstr(text, "\nR_3 = 4.3111\n"));
	assert_null(strstr(text, "\nR_0 ="));
	assert_null(strstr(text, "\nR_1 ="));
	assert_null(strstr(text, "\nKv_0 ="));
	struct omni4_config back;
	struct config_error err;

	config_defaults(&back);
	assert_int_equal(config_load(path, &back, &err), 0);
	assert_same_config(&running, &back);
	assert_int_equal(back.ctl.wheel_keys, CTL_WHEEL_KEY(3, 2) | CTL_WHEEL_KEY(3, 3));
	remove_dir();
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_table_model_keys_in_order),
	    cmocka_unit_test(test_set_validates_like_the_ini_parser),
	    cmocka_unit_test(test_writer_round_trip),
	    cmocka_unit_test(test_save_replaces_atomically_and_keeps_bak),
	    cmocka_unit_test(test_start_announces_every_value),
	    cmocka_unit_test(test_set_applies_between_ticks),
	    cmocka_unit_test(test_nothing_changes_without_a_tick),
	    cmocka_unit_test(test_model_swap_is_atomic_under_load),
	    cmocka_unit_test(test_refusals_say_why_and_change_nothing),
	    cmocka_unit_test(test_idle_only_keys_wait_for_idle),
	    cmocka_unit_test(test_load_merges_a_partial_model),
	    cmocka_unit_test(test_broken_requests),
	    cmocka_unit_test(test_secret_and_repeated_ids),
	    cmocka_unit_test(test_save_writes_what_is_in_force),
	    cmocka_unit_test(test_wheel_keys_validate_like_the_ini_parser),
	    cmocka_unit_test(test_layout_keys_validate_like_the_ini_parser),
	    cmocka_unit_test(test_wheel_keys_over_the_bus),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
