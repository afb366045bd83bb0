/* The model's door and the last guard before the motors.
 * 1. tests/config/model_ranges.txt, the one table of [model] values that the Python reader is
 *    tested against too: each row through the robot's INI (config_load_string: omni4-fw) and
 *    through a live change (config_key_set + config_check: omni4-param set), same verdict.
 * 2. A non-finite output never reaches the HAL: a controller whose wheel radius turned NaN
 *    after its door (a bug) latches FAULT OUTPUT and drives 0 V, bridges off (docs/faults.md). */
#include "omni4_test.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/core/ctl.h"

#define ROWS_MAX 128

struct row {
	char key[16];
	char value[32];
	bool accept;
	int line;
};

static struct row rows[ROWS_MAX];
static int n_rows;

/* Table III, every [model] key written out (docs/design.md). */
static const char *const table3_keys[14][2] = {
    {"d", "0.089"},   {"r", "0.0325"},  {"l", "5"},        {"Kv", "0.0259"}, {"Kt", "0.0259"},
    {"R", "4.3111"},  {"M", "2.34"},    {"J", "0.0228"},   {"Bv", "0.4978"}, {"Bvn", "0.6763"},
    {"Bw", "0.0141"}, {"Cv", "1.8738"}, {"Cvn", "2.2198"}, {"Cw", "0.1385"},
};

static int read_rows(void **state)
{
	(void)state;
	const char *src = getenv("OMNI4_SOURCE_DIR");
	char path[512], line[256];

	snprintf(path, sizeof(path), "%s/tests/config/model_ranges.txt", src ? src : ".");
	FILE *f = fopen(path, "r");

	if (!f) {
		fprintf(stderr, "cannot read %s\n", path);
		return -1;
	}
	for (int no = 1; fgets(line, sizeof(line), f); no++) {
		char verdict[16];

		if (line[0] == '#' || line[0] == '\n')
			continue;
		if (n_rows == ROWS_MAX ||
		    sscanf(line, "%15s %31s %15s", rows[n_rows].key, rows[n_rows].value, verdict) !=
		        3 ||
		    (strcmp(verdict, "accept") && strcmp(verdict, "refuse"))) {
			fprintf(stderr, "%s:%d: key value accept|refuse expected\n", path, no);
			fclose(f);
			return -1;
		}
		rows[n_rows].accept = !strcmp(verdict, "accept");
		rows[n_rows].line = no;
		n_rows++;
	}
	fclose(f);
	return n_rows >= 40 ? 0 : -1; /* the table is whole */
}

/* The robot INI: Table III with the row's key set to its value (a wheel key added). */
static void ini_with(const struct row *r, char *buf, size_t n)
{
	size_t len = (size_t)snprintf(buf, n, "[model]\n");
	bool replaced = false;

	for (int i = 0; i < 14; i++) {
		const bool mine = !strcmp(table3_keys[i][0], r->key);

		len += (size_t)snprintf(buf + len, n - len, "%s = %s\n", table3_keys[i][0],
		                        mine ? r->value : table3_keys[i][1]);
		replaced |= mine;
	}
	if (!replaced)
		snprintf(buf + len, n - len, "%s = %s\n", r->key, r->value);
}

static void test_every_row_has_the_tables_verdict_in_the_robots_ini(void **state)
{
	(void)state;
	for (int i = 0; i < n_rows; i++) {
		struct omni4_config cfg;
		struct config_error err;
		char text[1024];

		ini_with(&rows[i], text, sizeof(text));
		config_defaults(&cfg);
		const int rc = config_load_string(text, "robot.ini", &cfg, &err);

		if ((rc == 0) != rows[i].accept)
			fail_msg("model_ranges.txt:%d: %s = %s %s by the INI (%s)", rows[i].line,
			         rows[i].key, rows[i].value, rc ? "refused" : "taken",
			         rc ? err.msg : "");
		if (rc) /* one line that names the key */
			assert_non_null(strstr(err.msg, rows[i].key));
	}
}

static void test_every_row_has_the_tables_verdict_as_a_live_change(void **state)
{
	(void)state;
	for (int i = 0; i < n_rows; i++) {
		struct omni4_config cfg;
		char dotted[48], why[256] = "";

		config_defaults(&cfg);
		snprintf(dotted, sizeof(dotted), "model.%.15s", rows[i].key);
		const int k = config_key_find(dotted);

		assert_true(k >= 0);
		const int rc = config_key_set(&cfg, k, rows[i].value, why, sizeof(why)) ||
		               config_check(&cfg, why, sizeof(why));

		if ((rc == 0) != rows[i].accept)
			fail_msg("model_ranges.txt:%d: model.%s %s %s by a live change (%s)",
			         rows[i].line, rows[i].key, rows[i].value, rc ? "refused" : "taken",
			         why);
	}
}

/* A healthy reading: the wheels turning as the robot moves at v [m/s] (eq 2, Table III). */
static struct motor_sample moving(double v)
{
	struct motor_sample s = {.supply_v = 12.0f};
	const double rim[4] = {0.0, -v, 0.0, v};

	for (int j = 0; j < 4; j++) {
		s.current_a[j] = 0.1f;
		s.wheel_rad_s[j] = (float)(rim[j] / 0.0325);
	}
	return s;
}

static void test_a_non_finite_output_latches_a_fault_and_writes_zero(void **state)
{
	(void)state;
	struct ctl_settings cfg;
	static struct ctl c;
	struct ctl_output o;
	const struct ctl_command go = {.mode = CTL_VELOCITY, .velocity = {0.3, 0.0, 0.0}};
	int64_t t_us = 0;

	ctl_settings_defaults(&cfg);
	assert_int_equal(ctl_init(&c, &cfg), 0);
	assert_int_equal(ctl_command(&c, &go, t_us), 0);
	for (int i = 0; i < 20; i++) { /* driving, every output finite */
		const struct motor_sample s = moving(0.01 * i);

		t_us += 1000;
		ctl_step(&c, t_us, &s, 0, false, &o);
		assert_true(o.enable);
		assert_int_equal(o.faults & CTL_FAULT_OUTPUT, 0);
	}
	c.t.r[1] = NAN; /* a bug behind the door: wheel 1's rim speed is NaN from now on */
	for (int i = 0; i < 50; i++) {
		const struct motor_sample s = moving(0.2);

		t_us += 1000;
		ctl_step(&c, t_us, &s, 0, false, &o);
		for (int j = 0; j < 4; j++) /* never a NaN toward the motors, not even once */
			assert_true(isfinite(o.volts[j]) && fabsf(o.volts[j]) <= 12.0f);
		assert_true(o.faults & CTL_FAULT_OUTPUT);
		assert_int_equal(o.mode, CTL_FAULT);
		assert_false(o.enable);
		for (int j = 0; j < 4; j++)
			assert_true(o.volts[j] == 0.0f);
	}
	/* Latching: a VELOCITY command is refused until a clear (and the cause is gone). */
	assert_true(ctl_command(&c, &go, t_us) < 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_every_row_has_the_tables_verdict_in_the_robots_ini),
	    cmocka_unit_test(test_every_row_has_the_tables_verdict_as_a_live_change),
	    cmocka_unit_test(test_a_non_finite_output_latches_a_fault_and_writes_zero),
	};

	return cmocka_run_group_tests(tests, read_rows, NULL);
}
