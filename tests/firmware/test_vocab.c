/* Tests for core's vocab.h and drivers' backends.h: the predicates and enums the rows of
 * vocab.def and backends.def expand to, against the contract written out here (docs/design.md's
 * wire values), and a docking mode and a serial backend added as one row each (rows/). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#define OMNI4_VOCAB_DEF "vocab_dock.def"
#define OMNI4_BACKENDS_DEF "backends_serial.def"
#include "omni4/drivers/backends.h"
#include "omni4/core/vocab.h"

/* One mode as docs/design.md and docs/modes.md state it. */
struct mode_row {
	const char *name;
	bool drives, keep_alive, faulted, command, reported;
};

static const struct mode_row contract[] = {
    {"IDLE", false, false, false, true, true},         {"VELOCITY", true, true, false, true, true},
    {"VOLTAGE", true, true, false, true, true},        {"COAST", false, true, false, true, true},
    {"CLEAR_FAULT", false, false, false, true, false}, {"FAULT", false, false, true, false, true},
    {"ESTOP", false, false, true, false, true},        {"GOAL", true, true, false, false, true},
    {"DOCK", true, true, false, true, true}, /* the row rows/vocab_dock.def adds */
};

static void test_every_mode_answers_as_the_contract_says(void **state)
{
	(void)state;
	for (int m = 0; m < (int)(sizeof(contract) / sizeof(contract[0])); m++) {
		const struct mode_row *r = &contract[m];

		assert_string_equal(mode_name(m), r->name);
		assert_int_equal(mode_drives(m), r->drives);
		assert_int_equal(mode_keep_alive(m), r->keep_alive);
		assert_int_equal(mode_faulted(m), r->faulted);
		assert_int_equal(mode_commandable(m), r->command);
		assert_int_equal(vocab_mode_in(CTL_MODES_REPORTED, m), r->reported);
	}
	assert_int_equal(CTL_GOAL, 7);
	assert_int_equal(CTL_DOCK, 8);
}

static void test_values_without_a_row_are_no_mode(void **state)
{
	(void)state;
	const int none[] = {-1, 9, 31, 32, 127, -128};

	for (size_t i = 0; i < sizeof(none) / sizeof(none[0]); i++) {
		assert_null(mode_name(none[i]));
		assert_false(mode_drives(none[i]) || mode_keep_alive(none[i]) ||
		             mode_faulted(none[i]) || mode_commandable(none[i]));
	}
}

static void test_fault_bits_and_the_latching_set(void **state)
{
	(void)state;
	assert_int_equal(CTL_FAULT_OVERCURRENT, 0x0001);
	assert_int_equal(CTL_FAULT_SUPPLY, 0x0040);
	assert_int_equal(CTL_FAULT_ESTOP, 0x0100);
	assert_int_equal(CTL_FAULT_OVERRUN, 0x1000);
	assert_int_equal(CTL_FAULT_OUTPUT, 0x0080);
	assert_int_equal(CTL_FAULTS_LATCHING, 0x00ff); /* OVERCURRENT .. OUTPUT */
	assert_int_equal(CTL_FAULTS_ALL, 0x1fff);
	assert_string_equal(fault_name(CTL_FAULT_CMD_REJECTED), "CMD_REJECTED");
	assert_string_equal(fault_name(CTL_FAULT_OUTPUT), "OUTPUT");
	assert_null(fault_name(0x2000));
	assert_null(fault_name(0x0003));
	assert_int_equal(EST_FLAG_NO_WHEELS, 0x08);
}

static void test_a_backend_row_is_the_next_enum_value(void **state)
{
	(void)state;
	assert_int_equal(OMNI4_MOTOR_SIM, 0);
	assert_int_equal(OMNI4_MOTOR_SOCKETCAN, 1);
	assert_int_equal(OMNI4_MOTOR_VESC, 2);
	assert_int_equal(OMNI4_MOTOR_ODRIVE, 3);
	assert_int_equal(OMNI4_MOTOR_SERIAL, 4); /* rows/backends_serial.def */
	assert_int_equal(OMNI4_MOTOR_COUNT, 5);
	assert_int_equal(OMNI4_LINES_NONE, 0);
	assert_int_equal(OMNI4_LINES_GPIOD, 2);
	assert_int_equal(OMNI4_LINES_COUNT, 3);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_every_mode_answers_as_the_contract_says),
	    cmocka_unit_test(test_values_without_a_row_are_no_mode),
	    cmocka_unit_test(test_fault_bits_and_the_latching_set),
	    cmocka_unit_test(test_a_backend_row_is_the_next_enum_value),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
