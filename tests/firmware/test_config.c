/* Tests for config/src/config.c: the INI file of a robot. */
#include "omni4_test.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "omni4/config/config.h"

static const char *good =
    "; a robot\n"
    "[model]\n"
    "d = 0.1\nr = 0.03\nl = 4\nKv = 0.02\nKt = 0.021\nR = 3.5\nM = 2.5\nJ = 0.03\n"
    "Bv = 0.5\nBvn = 0.6\nBw = 0.01\nCv = 1.5\nCvn = 2.0\nCw = 0.12\n"
    "\n[loop]\nrate_hz = 500\nsched_fifo = yes\npriority = 70\n"
    "[control]\nkp = 10\ncmd_timeout_ms = 150\nfeedforward = false\n"
    "[lcm]\nurl = memq://\n"
    "[hal]\nmotor = socketcan\nlines = gpiod\n"
    "[can]\niface = vcan0\n"
    "[gpio]\nestop_line = 17\nestop_active_low = off\n";

static void expect_error(const char *text, int rc, int line, const char *fragment)
{
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_int_equal(config_load_string(text, "robot.ini", &cfg, &err), rc);
	assert_int_equal(err.line, line);
	if (!strstr(err.msg, fragment))
		fail_msg("message '%s' lacks '%s'", err.msg, fragment);
	char where[32];

	snprintf(where, sizeof(where), "robot.ini:%d: ", line);
	if (line > 0 && strncmp(err.msg, where, strlen(where)))
		fail_msg("message '%s' does not start with '%s'", err.msg, where);
}

static void test_good_file_overrides_defaults(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_int_equal(config_load_string(good, "robot.ini", &cfg, &err), 0);
	assert_near(cfg.ctl.model.d, 0.1, 0);
	assert_near(cfg.ctl.model.Kt, 0.021, 0);
	assert_near(cfg.ctl.model.Cw, 0.12, 0);
	assert_near(cfg.ctl.rate_hz, 500, 0);
	assert_true(cfg.fw.loop.sched_fifo);
	assert_int_equal(cfg.fw.loop.priority, 70);
	assert_int_equal(cfg.ctl.control.cmd_timeout_ms, 150);
	assert_false(cfg.ctl.control.feedforward);
	assert_true(cfg.ctl.control.feedback); /* default kept */
	assert_string_equal(cfg.fw.lcm_url, "memq://");
	assert_int_equal(cfg.fw.motor, OMNI4_MOTOR_SOCKETCAN);
	assert_string_equal(cfg.can.iface, "vcan0");
	assert_int_equal(cfg.gpio.estop_line, 17);
	assert_false(cfg.gpio.estop_active_low);
}

static void test_defaults_are_table3_and_safe(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_near(cfg.ctl.model.R, 4.3111, 0);
	assert_near(cfg.ctl.limits.supply_v, 12.0, 0);
	assert_non_null(strstr(cfg.fw.lcm_url, "ttl=0"));
	/* An empty file is valid: everything at its default. */
	assert_int_equal(config_load_string("", "empty.ini", &cfg, &err), 0);
	assert_near(cfg.ctl.model.M, 2.34, 0);
}

/* The documented defaults: docs/faults.md (fault limits) and docs/design.md (Table III,
 * supply 12 V, 1 kHz loop), written out here, not read from config.c. */
static void test_defaults_are_the_documented_figures(void **state)
{
	(void)state;
	struct omni4_config cfg;
	const double table3[] = {0.089,  0.0325, 5,      0.0259, 0.0259, 4.3111, 2.34,
	                         0.0228, 0.4978, 0.6763, 0.0141, 1.8738, 2.2198, 0.1385};

	config_defaults(&cfg);
	const struct model_params *m = &cfg.ctl.model;
	const double got[] = {m->d, m->r,  m->l,   m->Kv, m->Kt, m->R,   m->M,
	                      m->J, m->Bv, m->Bvn, m->Bw, m->Cv, m->Cvn, m->Cw};

	for (size_t i = 0; i < sizeof(table3) / sizeof(table3[0]); i++)
		assert_near(got[i], table3[i], 0);
	assert_int_equal(cfg.ctl.control.cmd_timeout_ms, 200);
	assert_near(cfg.ctl.control.stop_ramp_s, 0.2, 0);
	assert_near(cfg.ctl.limits.current_max_a, 5.0, 0);
	assert_near(cfg.ctl.limits.current_sensor_max_a, 10.2, 0);
	assert_near(cfg.ctl.limits.supply_min_v, 9.0, 0);
	assert_near(cfg.ctl.limits.supply_v, 12.0, 0);
	assert_near(cfg.ctl.rate_hz, 1000.0, 0);
}

/* R lies in [0.001, 1000] ohm (docs/ini-keys.md): 0 is refused, the range's low end taken. */
static void test_resistance_boundary_zero_refused_positive_taken(void **state)
{
	(void)state;
	char text[1024];
	struct omni4_config cfg;
	struct config_error err;

	snprintf(text, sizeof(text), "%s", good);
	char *p = strstr(text, "R = 3.5");

	memcpy(p, "R = 0  ", 7);
	expect_error(text, -EINVAL, 8,
	             "out of range value for 'R' in [model]: 0 outside [0.001, 1000]");
	char small[1100];
	const char *rest = strstr(good, "R = 3.5") + strlen("R = 3.5");

	snprintf(small, sizeof(small), "%.*sR = 1e-3%s", (int)(strstr(good, "R = 3.5") - good),
	         good, rest);
	config_defaults(&cfg);
	assert_int_equal(config_load_string(small, "robot.ini", &cfg, &err), 0);
	assert_near(cfg.ctl.model.R, 1e-3, 0);
}

static void test_unknown_key_is_reported_with_its_line(void **state)
{
	(void)state;
	expect_error("[loop]\nrate_hz = 100\nrat_hz = 5\n", -EINVAL, 3,
	             "robot.ini:3: unknown key 'rat_hz' in [loop]");
	expect_error("[motors]\nR = 1\n", -EINVAL, 2, "unknown key 'R' in [motors]");
}

static void test_bad_number_is_reported_with_its_line(void **state)
{
	(void)state;
	expect_error("[loop]\n\nrate_hz = fast\n", -EINVAL, 3, "'fast' is not a finite number");
	expect_error("[loop]\nrate_hz = 1e999\n", -EINVAL, 2, "not a finite number");
	expect_error("[loop]\nrate_hz = nan\n", -EINVAL, 2, "not a finite number");
	expect_error("[loop]\npriority = 3.5\n", -EINVAL, 2, "'3.5' is not an integer");
	expect_error("[loop]\nmlockall = maybe\n", -EINVAL, 2, "is not true/false");
	expect_error("[hal]\nmotor = serial\n", -EINVAL, 2, "'serial' is not one of sim|socketcan");
}

static void test_out_of_range_value_is_rejected(void **state)
{
	(void)state;
	expect_error("[loop]\nrate_hz = 0\n", -EINVAL, 2, "out of range value for 'rate_hz'");
	expect_error("[control]\ncmd_timeout_ms = -5\n", -EINVAL, 2, "out of range");
}

static void test_missing_model_key_is_named(void **state)
{
	(void)state;
	/* at the [model] header: the section that lacks it */
	expect_error("; robot\n[model]\nd = 0.1\nr = 0.03\n", -EINVAL, 2,
	             "missing key 'l' in [model]");
}

static void test_negative_resistance_is_rejected(void **state)
{
	(void)state;
	char text[1024];

	snprintf(text, sizeof(text), "%s", good);
	char *p = strstr(text, "R = 3.5");

	memcpy(p, "R =-3.5", 7);
	expect_error(text, -EINVAL, 8, "out of range value for 'R' in [model]: -3.5 outside");
}

/* The one rule across two keys (supply_min_v < supply_v) blames supply_min_v's line, or
 * supply_v's when supply_min_v is the default. */
static void test_supply_rule_is_reported_with_a_line(void **state)
{
	(void)state;
	expect_error("[limits]\nsupply_v = 12\n\nsupply_min_v = 12\n", -EINVAL, 4,
	             "invalid value for 'supply_min_v' in [limits]: must be below supply_v");
	expect_error("[loop]\nrate_hz = 500\n[limits]\nsupply_v = 5\n", -EINVAL, 4,
	             "invalid value for 'supply_min_v' in [limits]: must be below supply_v");
}

/* A UTF-8 BOM is skipped (inih does; so does omni4.ini), also by the repeated-section check. */
static void test_a_utf8_bom_is_skipped(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_int_equal(
	    config_load_string("\xEF\xBB\xBF[loop]\nrate_hz = 500\n", "robot.ini", &cfg, &err), 0);
	assert_near(cfg.ctl.rate_hz, 500.0, 0);
	expect_error("\xEF\xBB\xBF[loop]\n[loop]\n", -EINVAL, 2, "duplicate section [loop]");
}

/* The first error in the file is the one reported, whichever kind it is. */
static void test_first_error_in_the_file_is_reported(void **state)
{
	(void)state;
	expect_error("[loop]\nrate_hz 500\nnope = 1\n", -EINVAL, 2, "syntax error");
	expect_error("[loop]\nnope = 1\nrate_hz 500\n", -EINVAL, 2, "unknown key 'nope'");
}

/* A directory given as the file is refused (fopen takes it; its read fails), not read as an
 * empty file with the defaults. */
static void test_directory_is_refused(void **state)
{
	(void)state;
	char dir[] = "/tmp/omni4_test_config_dir_XXXXXX";
	struct omni4_config cfg;
	struct config_error err;

	assert_non_null(mkdtemp(dir));
	config_defaults(&cfg);
	assert_int_equal(config_load(dir, &cfg, &err), -EISDIR);
	assert_non_null(strstr(err.msg, ": cannot read: Is a directory"));
	assert_int_equal(config_load_partial(dir, &cfg, &(uint32_t){0}, &err), -EISDIR);
	rmdir(dir);
}

/* One case of tests/config/ini_cases.txt: its text, and what the reader must say. */
struct ini_case {
	int at; /* line of its "===" in the table */
	bool accept;
	int line;
	char text_expected[96]; /* refuse: in the message; accept: "section.key value" */
	char ini[1024];
};

/* The next case of the table from f into c; false at its end. */
static bool next_case(FILE *f, int *table_line, struct ini_case *c)
{
	char buf[256];
	long start;

	do {
		if (!fgets(buf, sizeof(buf), f))
			return false;
		++*table_line;
	} while (strncmp(buf, "=== ", 4));
	memset(c, 0, sizeof(*c));
	c->at = *table_line;
	buf[strcspn(buf, "\n")] = '\0';
	int used = 0;

	c->accept = !strncmp(buf, "=== accept", 10) && (!buf[10] || buf[10] == ' ');
	if (c->accept)
		used = buf[10] ? 11 : 0;
	else if (sscanf(buf, "=== refuse %d %n", &c->line, &used) != 1)
		fail_msg("ini_cases.txt:%d: neither accept nor refuse LINE", c->at);
	if (used)
		snprintf(c->text_expected, sizeof(c->text_expected), "%s", buf + used);
	for (;;) {
		start = ftell(f);
		if (!fgets(buf, sizeof(buf), f) || !strncmp(buf, "=== ", 4))
			break;
		++*table_line;
		assert_true(strlen(c->ini) + strlen(buf) < sizeof(c->ini));
		strcat(c->ini, buf);
	}
	fseek(f, start, SEEK_SET);
	return true;
}

/* An accepted case's "section.key value": the key as the loader read it. */
static void expect_case_value(const struct ini_case *c, const struct omni4_config *cfg)
{
	char dotted[64], value[CONFIG_VALUE_MAX];
	const char *space = strchr(c->text_expected, ' ');

	assert_non_null(space);
	snprintf(dotted, sizeof(dotted), "%.*s", (int)(space - c->text_expected), c->text_expected);
	const int k = config_key_find(dotted);

	if (k < 0)
		fail_msg("ini_cases.txt:%d: no key %s", c->at, dotted);
	/* a string as read (config_key_format refuses one the writer could not write back) */
	if (config_key_at(k)->type == CONFIG_STRING)
		snprintf(value, sizeof(value), "%s", (const char *)cfg + config_key_at(k)->offset);
	else if (config_key_format(cfg, k, value, sizeof(value)))
		fail_msg("ini_cases.txt:%d: %s cannot be formatted", c->at, dotted);
	if (strcmp(value, space + 1))
		fail_msg("ini_cases.txt:%d: %s is '%s', expected '%s'", c->at, dotted, value,
		         space + 1);
}

/* The table both readers run (python/tests/test_ini.py runs it on omni4.ini). */
static void test_shared_ini_cases(void **state)
{
	(void)state;
	const char *src = getenv("OMNI4_SOURCE_DIR");
	char path[512];

	assert_non_null(src);
	snprintf(path, sizeof(path), "%s/tests/config/ini_cases.txt", src);
	FILE *f = fopen(path, "r");
	struct ini_case c;
	int table_line = 0, n = 0;

	assert_non_null(f);
	while (next_case(f, &table_line, &c)) {
		struct omni4_config cfg;
		struct config_error err;
		char where[32];

		config_defaults(&cfg);
		const int rc = config_load_string(c.ini, "case.ini", &cfg, &err);

		n++;
		snprintf(where, sizeof(where), "case.ini:%d: ", c.line);
		if (c.accept && rc)
			fail_msg("ini_cases.txt:%d: refused: %s", c.at, err.msg);
		if (c.accept && c.text_expected[0])
			expect_case_value(&c, &cfg);
		if (!c.accept &&
		    (!rc || err.line != c.line || strncmp(err.msg, where, strlen(where)) ||
		     !strstr(err.msg + strlen(where), c.text_expected)))
			fail_msg("ini_cases.txt:%d: expected line %d '%s', got %d: '%s'", c.at,
			         c.line, c.text_expected, rc ? err.line : 0,
			         rc ? err.msg : "accepted");
	}
	fclose(f);
	assert_true(n >= 10);
}

static void test_duplicate_key_and_syntax_error(void **state)
{
	(void)state;
	expect_error("[loop]\nrate_hz = 100\nrate_hz = 200\n", -EINVAL, 3,
	             "duplicate key 'rate_hz'");
	expect_error("[loop]\nrate_hz 100\n", -EINVAL, 2, "robot.ini:2: syntax error");
	expect_error("[loop\n", -EINVAL, 1, "syntax error");
	/* a section that comes back after another: refused at its second header, as the Python
	 * reader (omni4.ini) does */
	expect_error("[loop]\npriority = 50\n[sim]\nseed = 3\n[loop]\nmlockall = 1\n", -EINVAL, 5,
	             "robot.ini:5: duplicate section [loop]");
}

static void test_missing_file_is_enoent(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_int_equal(config_load("/nonexistent/omni4.ini", &cfg, &err), -ENOENT);
	assert_non_null(strstr(err.msg, "/nonexistent/omni4.ini: cannot open"));
}

static void test_written_model_section_reads_back_exactly(void **state)
{
	(void)state;
	char path[] = "/tmp/omni4_test_config_XXXXXX";
	const int fd = mkstemp(path);
	struct omni4_config cfg;
	struct config_error err;
	struct model_params p = model_params_table3;

	assert_true(fd >= 0);
	FILE *f = fdopen(fd, "w");

	p.J = 0.1 / 3.0; /* not representable in few digits */
	assert_int_equal(config_write_model(f, &p), 0);
	fclose(f);
	config_defaults(&cfg);
	assert_int_equal(config_load(path, &cfg, &err), 0);
	/* Table III's figures as written in the paper, not as %.17g prints them
	 * (0.088999999999999996). */
	char text[1024] = "";
	FILE *g = fopen(path, "r");

	assert_non_null(g);
	const size_t got = fread(text, 1, sizeof(text) - 1, g);

	fclose(g);
	text[got] = '\0';
	assert_non_null(strstr(text, "\nd = 0.089\n"));
	assert_non_null(strstr(text, "\nR = 4.3111\n"));
	unlink(path);
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		assert_near(model_params_get(&cfg.ctl.model, i), model_params_get(&p, i), 0);
}

/* The [model] of `good` with extra lines after it (wheel keys), the rest of `good` after. */
static void good_with(char *buf, size_t n, const char *extra)
{
	const char *split = strstr(good, "\n[loop]");

	snprintf(buf, n, "%.*s%s%s", (int)(split - good), good, extra, split);
}

/* A wheel key overrides its scalar for that wheel only; the other wheels, and the other
 * quantities of the same wheel, are the scalar's (docs/configuration.md, "Per-wheel drives"). */
static void test_wheel_key_overrides_its_scalar_for_that_wheel_only(void **state)
{
	(void)state;
	static const struct {
		const char *key;
		int q, j; /* 0 r, 1 Kv, 2 Kt, 3 R; wheel */
	} cases[] = {{"r_0", 0, 0},  {"r_3", 0, 3},  {"Kv_1", 1, 1}, {"Kv_2", 1, 2},
	             {"Kt_0", 2, 0}, {"Kt_3", 2, 3}, {"R_1", 3, 1},  {"R_2", 3, 2}};
	const double scalar[4] = {0.03, 0.02, 0.021, 3.5}; /* good's r Kv Kt R */

	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct omni4_config cfg;
		struct config_error err;
		struct model_wheels w;
		char text[2048], line[64];

		snprintf(line, sizeof(line), "%s = 0.777\n", cases[c].key);
		good_with(text, sizeof(text), line);
		config_defaults(&cfg);
		if (config_load_string(text, "robot.ini", &cfg, &err))
			fail_msg("%s", err.msg);
		ctl_settings_wheels(&cfg.ctl, &w);
		const double *const got[4] = {w.r, w.Kv, w.Kt, w.R};

		for (int q = 0; q < 4; q++)
			for (int j = 0; j < 4; j++) {
				const double want =
				    q == cases[c].q && j == cases[c].j ? 0.777 : scalar[q];

				if (got[q][j] != want)
					fail_msg("%s: quantity %d wheel %d is %.17g, not %.17g",
					         cases[c].key, q, j, got[q][j], want);
			}
		assert_near(cfg.ctl.model.R, 3.5, 0); /* the scalar itself stays */
		assert_int_equal(cfg.ctl.wheel_keys, CTL_WHEEL_KEY(cases[c].q, cases[c].j));
	}
}

/* No wheel keys: the scalar model's four equal wheels, bit for bit. */
static void test_no_wheel_keys_are_the_scalar_model(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;
	struct model_wheels got, want;

	config_defaults(&cfg);
	assert_int_equal(config_load_string(good, "robot.ini", &cfg, &err), 0);
	ctl_settings_wheels(&cfg.ctl, &got);
	model_wheels_from_params(&cfg.ctl.model, &want);
	assert_memory_equal(&got, &want, sizeof(got));
	assert_memory_equal(&cfg.ctl.wheels, &want, sizeof(want)); /* the keys read the same */
	assert_int_equal(cfg.ctl.wheel_keys, 0);
}

/* A wheel key is checked like its scalar (its range), named in the error; it needs the
 * scalars. */
static void test_wheel_key_errors(void **state)
{
	(void)state;
	char text[2048];

	good_with(text, sizeof(text), "R_3 = 0\n");
	expect_error(text, -EINVAL, 17, "out of range value for 'R_3' in [model]: 0 outside");
	good_with(text, sizeof(text), "Kv_0 = -0.02\n");
	expect_error(text, -EINVAL, 17, "out of range value for 'Kv_0' in [model]: -0.02 outside");
	good_with(text, sizeof(text), "r_2 = abc\n");
	expect_error(text, -EINVAL, 17, "bad value for 'r_2' in [model]");
	good_with(text, sizeof(text), "R_1 = 3\nR_1 = 3\n");
	expect_error(text, -EINVAL, 18, "duplicate key 'R_1' in [model]");
	expect_error("[model]\nR_0 = 3\n", -EINVAL, 1, "missing key 'd' in [model]");
	expect_error("[model]\nR_4 = 3\n", -EINVAL, 2, "unknown key 'R_4' in [model]");
}

/* Key i of cfg set to a valid value other than its present one (the range's ends, a step, the
 * other choice, a string longer by one): true if one was found. */
static bool set_other_value(struct omni4_config *cfg, int i)
{
	const struct config_key *k = config_key_at(i);
	char now[CONFIG_VALUE_MAX], try[CONFIG_VALUE_MAX], after[CONFIG_VALUE_MAX], why[160];
	const char *fixed[] = {"true", "false", "x",     "0",         "1",      "7",
	                       "sim",  "none",  "gpiod", "socketcan", "current"};

	assert_int_equal(config_key_format(cfg, i, now, sizeof(now)), 0);
	for (int c = 0; c < 4 + (int)(sizeof(fixed) / sizeof(fixed[0])); c++) {
		const double v = atof(now);

		if (c == 0 && k->type == CONFIG_STRING) { /* the same start, one longer */
			snprintf(try, sizeof(try), "%.*sx", (int)(sizeof(try) - 2), now);
		} else if (c < 4) {
			const double cand[] = {k->min, k->max, v * 1.5, v + 1.0};

			snprintf(try, sizeof(try), "%.17g", cand[c]);
		} else {
			snprintf(try, sizeof(try), "%s", fixed[c - 4]);
		}
		struct omni4_config other = *cfg;

		if (config_key_set(&other, i, try, why, sizeof(why)) ||
		    config_key_format(&other, i, after, sizeof(after)) || !strcmp(after, now))
			continue;
		*cfg = other;
		return true;
	}
	return false;
}

/* config_key_equal against the keys' INI text (an independent comparison): one key changed at a
 * time, every key compared; a wheel key that follows its scalar changes with it. */
static void test_key_equal_agrees_with_the_text(void **state)
{
	(void)state;
	struct omni4_config base, cfg;
	char ta[CONFIG_VALUE_MAX], tb[CONFIG_VALUE_MAX];
	int tried = 0;

	config_defaults(&base);
	for (int i = 0; i < config_key_count(); i++) {
		cfg = base;
		if (!set_other_value(&cfg, i))
			continue;
		tried++;
		for (int j = 0; j < config_key_count(); j++) {
			if (config_key_format(&base, j, ta, sizeof(ta)) ||
			    config_key_format(&cfg, j, tb, sizeof(tb)))
				continue;
			if (config_key_equal(&base, &cfg, j) != !strcmp(ta, tb))
				fail_msg("key %d changed: key %d '%s' -> '%s' but equal says %d", i,
				         j, ta, tb, config_key_equal(&base, &cfg, j));
		}
		assert_false(config_key_equal(&base, &cfg, i));
	}
	/* every key but a fixed one or two and a one-word choice ([odrive] mode) */
	assert_true(tried >= config_key_count() - 3);
	assert_int_equal(config_key_find("model.R_0") >= 0, 1);
	cfg = base; /* the scalar moves the wheels that follow it */
	assert_true(set_other_value(&cfg, config_key_find("model.R")));
	assert_false(config_key_equal(&base, &cfg, config_key_find("model.R_2")));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_good_file_overrides_defaults),
	    cmocka_unit_test(test_key_equal_agrees_with_the_text),
	    cmocka_unit_test(test_defaults_are_table3_and_safe),
	    cmocka_unit_test(test_defaults_are_the_documented_figures),
	    cmocka_unit_test(test_resistance_boundary_zero_refused_positive_taken),
	    cmocka_unit_test(test_unknown_key_is_reported_with_its_line),
	    cmocka_unit_test(test_bad_number_is_reported_with_its_line),
	    cmocka_unit_test(test_out_of_range_value_is_rejected),
	    cmocka_unit_test(test_missing_model_key_is_named),
	    cmocka_unit_test(test_negative_resistance_is_rejected),
	    cmocka_unit_test(test_duplicate_key_and_syntax_error),
	    cmocka_unit_test(test_supply_rule_is_reported_with_a_line),
	    cmocka_unit_test(test_first_error_in_the_file_is_reported),
	    cmocka_unit_test(test_a_utf8_bom_is_skipped),
	    cmocka_unit_test(test_directory_is_refused),
	    cmocka_unit_test(test_shared_ini_cases),
	    cmocka_unit_test(test_missing_file_is_enoent),
	    cmocka_unit_test(test_written_model_section_reads_back_exactly),
	    cmocka_unit_test(test_wheel_key_overrides_its_scalar_for_that_wheel_only),
	    cmocka_unit_test(test_no_wheel_keys_are_the_scalar_model),
	    cmocka_unit_test(test_wheel_key_errors),
	};

	return cmocka_run_group_tests_name("config", tests, NULL, NULL);
}
