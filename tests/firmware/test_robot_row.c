/* Tests for firmware's robot.c over backends.def: a motor backend added as one row
 * (rows/backends_echo.def) plus its own code (below) is opened, started, run, summarised and
 * closed by the unchanged composition root; a backend this build lacks and a value no row names
 * are refused with one line. The robot here is built without Linux: socketcan and gpiod rows
 * exist as enum values only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "omni4/firmware/robot.h"

/* ---- the echo backend's code: what adding a real backend would write ---------------------- */

static int echo_enable(void *ctx, bool on)
{
	((struct echo_motor *)ctx)->enabled = on;
	return 0;
}

static int echo_write(void *ctx, const float volts[4])
{
	struct echo_motor *e = ctx;

	memcpy(e->volts, volts, sizeof(e->volts));
	e->writes++;
	return 0;
}

static int echo_read(void *ctx, struct motor_sample *out)
{
	struct echo_motor *e = ctx;

	e->reads++;
	*out = (struct motor_sample){.supply_v = 12.0f};
	for (int j = 0; j < 4; j++)
		out->wheel_rad_s[j] = e->volts[j];
	return 0;
}

static void echo_close(void *ctx)
{
	((struct echo_motor *)ctx)->closed++;
}

static const struct motor_hal_ops echo_ops = {
    .enable = echo_enable, .write = echo_write, .read = echo_read, .close = echo_close};

static int open_echo(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	(void)spec, (void)why, (void)n;
	r->echo.open = true;
	r->motor = (struct motor_hal){.ops = &echo_ops, .ctx = &r->echo};
	return 0;
}

static void echo_started(struct robot *r, const struct robot_spec *spec)
{
	(void)spec;
	r->echo.started++;
}

static void echo_summary(const struct robot *r)
{
	((struct robot *)r)->echo.summaries++;
}

const struct robot_backend robot_backend_echo = {
    .open = open_echo, .started = echo_started, .summary = echo_summary};

/* ---- the tests ------------------------------------------------------------------------------ */

static struct robot R;
static struct ctl_settings ctl;

static int open_with(enum omni4_motor_backend motor, char *why, size_t n)
{
	const struct robot_spec spec = {.ctl = &ctl, .motor = motor, .lines = OMNI4_LINES_SIM};

	ctl_settings_defaults(&ctl);
	return robot_open(&R, &spec, why, n);
}

static void test_the_row_adds_an_enum_value_after_the_others(void **state)
{
	(void)state;
	assert_int_equal(OMNI4_MOTOR_ODRIVE, 3); /* the last row of backends.def */
	assert_int_equal(OMNI4_MOTOR_ECHO, 4);
	assert_int_equal(OMNI4_MOTOR_COUNT, 5);
}

static void test_the_added_backend_is_opened_run_and_closed_by_the_robot(void **state)
{
	char why[128] = "";

	(void)state;
	assert_int_equal(open_with(OMNI4_MOTOR_ECHO, why, sizeof(why)), 0);
	assert_ptr_equal(R.motor_backend, &robot_backend_echo);
	assert_true(R.echo.open);
	assert_int_equal(R.echo.started, 1);
	for (int k = 0; k < 10; k++)
		fw_tick(&R.fw, 1000000 + 1000 * k);
	assert_int_equal(R.echo.reads, 10);
	robot_summary(&R);
	assert_int_equal(R.echo.summaries, 1);
	robot_close(&R);
	assert_int_equal(R.echo.closed, 1);
	assert_false(R.echo.enabled);
}

static void test_a_backend_this_build_lacks_is_refused_with_one_line(void **state)
{
	char why[128] = "";

	(void)state;
	assert_int_equal(open_with(OMNI4_MOTOR_SOCKETCAN, why, sizeof(why)), -1);
	assert_string_equal(why, "[hal] motor backend 1 is not available in this build");
	assert_int_equal(open_with(OMNI4_MOTOR_COUNT, why, sizeof(why)), -1);
	assert_string_equal(why, "[hal] motor backend 5 is not available in this build");
	assert_int_equal(open_with((enum omni4_motor_backend) - 1, why, sizeof(why)), -1);
	assert_string_equal(why, "[hal] motor backend -1 is not available in this build");
	assert_null(strchr(why, '\n'));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_the_row_adds_an_enum_value_after_the_others),
	    cmocka_unit_test(test_the_added_backend_is_opened_run_and_closed_by_the_robot),
	    cmocka_unit_test(test_a_backend_this_build_lacks_is_refused_with_one_line),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
