/* Tests for firmware's openers of the vesc and odrive backends (robot_vesc.c, robot_odrive.c)
 * through the composition root, with the OS adapter (sc_os) wrapped: the [vesc] / [odrive]
 * settings reach the drives (ids, pole pairs, mode, nodes), the model's gearbox and drive
 * constants reach the commands, and a parameter change of the model follows at run time. */
#include "../drivers/sc_os_mock.h"

#include <stdio.h>
#include <unistd.h>

#include "omni4/config/config.h"
#include "omni4/firmware/robot.h"

#define TWO_PI 6.28318530717958647692

static struct robot robot; /* large (the log ring) */
static struct omni4_config cfg;

static int reset(void **state)
{
	(void)state;
	mock_reset();
	config_defaults(&cfg);
	cfg.fw.lines = OMNI4_LINES_NONE;
	return 0;
}

static struct robot_spec spec_of(enum omni4_motor_backend motor)
{
	const struct robot_spec spec = {.ctl = &cfg.ctl,
	                                .motor = motor,
	                                .lines = OMNI4_LINES_NONE,
#define SPEC_SETTINGS(member, settings) .member = &cfg.member,
	                                OMNI4_BACKEND_SETTINGS(SPEC_SETTINGS)
#undef SPEC_SETTINGS
	};
	return spec;
}

/* The current command to VESC id in frames from..end (the last one). */
static float vesc_current_to(int from, uint8_t id)
{
	float last = NAN;

	for (int k = from; k < mock_n_sent; k++) {
		uint8_t to;
		float v;

		if (vesc_decode_command(&mock_sent[k], VESC_CMD_SET_CURRENT, &to, &v) == 0 &&
		    to == id)
			last = v;
	}
	return last;
}

static void test_vesc_opener_hands_the_settings_and_the_model_to_the_backend(void **state)
{
	(void)state;
	const int ids[4] = {20, 21, 22, 23};
	const float volts[4] = {3, 3, 3, 3};
	const struct vesc_status1 s1 = {.erpm = 11000, .current_a = 1.0f, .duty = 0};
	const struct vesc_status5 s5 = {.tacho_steps = 0, .input_v = 12.0f};
	struct motor_sample s;
	struct omni4_can_frame f;
	char why[256];

	cfg.fw.motor = OMNI4_MOTOR_VESC;
	snprintf(cfg.vesc.iface, sizeof(cfg.vesc.iface), "can7");
	memcpy(cfg.vesc.id, ids, sizeof(ids));
	cfg.vesc.pole_pairs = 11;
	cfg.vesc.mode = VESC_MODE_CURRENT;
	const struct robot_spec spec = spec_of(OMNI4_MOTOR_VESC);

	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	assert_string_equal(mock_iface, "can7");
	assert_true(mock_filter_passes(VESC_CAN_ID(VESC_CMD_STATUS_1, 22)));
	for (int j = 0; j < 4; j++) {
		assert_int_equal(vesc_encode_status1((uint8_t)ids[j], &s1, &f), 0);
		mock_push(&f);
		assert_int_equal(vesc_encode_status5((uint8_t)ids[j], &s5, &f), 0);
		mock_push(&f);
	}
	assert_int_equal(hal_motor_read(&robot.motor, &s), 0);
	/* 11000 ERPM / 11 pole pairs = 1000 rpm at the motor, / the model's gearbox */
	const double motor_rad_s = 1000.0 * TWO_PI / 60.0;
	const struct model_params *p = &cfg.ctl.model;

	assert_near(s.wheel_rad_s[2], motor_rad_s / p->l, 1e-3);
	assert_int_equal(hal_motor_enable(&robot.motor, true), 0);
	int from = mock_n_sent;

	assert_int_equal(hal_motor_write(&robot.motor, volts), 0);
	assert_near(vesc_current_to(from, 21), (3.0 - p->Kv * motor_rad_s) / p->R, 1e-3);
	/* a parameter change of R reaches the backend through the robot's hook */
	struct ctl_settings changed = cfg.ctl;

	changed.model.R = 2.0 * p->R;
	ctl_settings_wheels_follow(&changed);
	robot.fw.param_hooks.apply(robot.fw.param_hooks.ctx, &changed);
	from = mock_n_sent;
	assert_int_equal(hal_motor_write(&robot.motor, volts), 0);
	assert_near(vesc_current_to(from, 21), (3.0 - p->Kv * motor_rad_s) / (2.0 * p->R), 1e-3);
	robot_close(&robot);
	assert_true(mock_closed);
}

static void test_odrive_opener_starts_the_configured_nodes(void **state)
{
	(void)state;
	const int nodes[4] = {9, 10, 11, 12};
	char why[256];

	cfg.fw.motor = OMNI4_MOTOR_ODRIVE;
	memcpy(cfg.odrive.node, nodes, sizeof(nodes));
	const struct robot_spec spec = spec_of(OMNI4_MOTOR_ODRIVE);

	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	assert_string_equal(mock_iface, "can0"); /* the default */
	for (int j = 0; j < 4; j++) {
		uint8_t node;
		uint32_t st;

		assert_int_equal(odrive_decode_set_axis_state(&mock_sent[3 * j + 2], &node, &st),
		                 0);
		assert_int_equal(node, nodes[j]);
		assert_int_equal(st, ODRIVE_AXIS_STATE_CLOSED_LOOP);
	}
	robot_close(&robot);
	assert_true(mock_closed);
}

/* One tick of the controller on the ODrive robot: every axis reports (at rest, bus_v), axis
 * `faulty` with error bits `error` in its heartbeat (-1: none). */
static void odrive_tick_at(int64_t *now_us, int faulty, uint32_t error, float bus_v)
{
	for (int j = 0; j < 4; j++) {
		const uint8_t node = (uint8_t)cfg.odrive.node[j];
		const struct odrive_encoder_estimates e = {0};
		const struct odrive_iq q = {0};
		const struct odrive_bus b = {.voltage_v = bus_v};
		const struct odrive_heartbeat hb = {
		    .axis_error = j == faulty ? error : 0,
		    .axis_state =
		        j == faulty ? ODRIVE_AXIS_STATE_IDLE : ODRIVE_AXIS_STATE_CLOSED_LOOP};
		struct omni4_can_frame f;

		assert_int_equal(odrive_encode_encoder_estimates(node, &e, &f), 0);
		mock_push(&f);
		assert_int_equal(odrive_encode_iq(node, &q, &f), 0);
		mock_push(&f);
		assert_int_equal(odrive_encode_bus(node, &b, &f), 0);
		mock_push(&f);
		assert_int_equal(odrive_encode_heartbeat(node, &hb, &f), 0);
		mock_push(&f);
	}
	*now_us += 1000;
	mock_clock_us = *now_us;
	fw_tick(&robot.fw, *now_us);
}

static void odrive_tick(int64_t *now_us, int faulty, uint32_t error)
{
	odrive_tick_at(now_us, faulty, error, 24.0f);
}

/* One tick of the controller on the VESC robot: every controller reports at rest, input_v its
 * input voltage (STATUS_5). */
static void vesc_tick(int64_t *now_us, float input_v)
{
	for (int j = 0; j < 4; j++) {
		const struct vesc_status1 s1 = {0};
		const struct vesc_status5 s5 = {.tacho_steps = 0, .input_v = input_v};
		struct omni4_can_frame f;

		assert_int_equal(vesc_encode_status1((uint8_t)cfg.vesc.id[j], &s1, &f), 0);
		mock_push(&f);
		assert_int_equal(vesc_encode_status5((uint8_t)cfg.vesc.id[j], &s5, &f), 0);
		mock_push(&f);
	}
	*now_us += 1000;
	mock_clock_us = *now_us;
	fw_tick(&robot.fw, *now_us);
}

/* Frames Clear_Errors to node sent from index from on. */
static int clear_errors_to(int from, uint8_t node)
{
	int n = 0;

	for (int k = from; k < mock_n_sent; k++) {
		uint8_t to, cmd;

		n += odrive_split_id(&mock_sent[k], &to, &cmd) == 0 && to == node &&
		     cmd == ODRIVE_CMD_CLEAR_ERRORS;
	}
	return n;
}

/* The drive keeps its error until Clear_Errors, the controller refuses a clear while a fault is
 * present: the error latches DRIVER, the clear is accepted and restarts the axes, an error
 * still there latches again. */
static void test_odrive_error_latches_driver_and_a_clear_restarts_the_axes(void **state)
{
	(void)state;
	int64_t now = mock_clock_us;
	char why[256];

	cfg.fw.motor = OMNI4_MOTOR_ODRIVE;
	const struct robot_spec spec = spec_of(OMNI4_MOTOR_ODRIVE);

	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	for (int t = 0; t < 20; t++)
		odrive_tick(&now, -1, 0);
	assert_false(robot.fw.ctl.latched & CTL_FAULT_DRIVER);
	for (int t = 0; t < 5; t++)
		odrive_tick(&now, 1, 0x00000020u); /* drv_fault, heartbeat after heartbeat */
	assert_true(mode_faulted(robot.fw.ctl.mode));
	assert_true(robot.fw.ctl.latched & CTL_FAULT_DRIVER);
	const struct ctl_command clear = {.utime = now, .seq = 1, .mode = CTL_CLEAR_FAULT};
	const int from = mock_n_sent;

	assert_true(fw_post_command(&robot.fw, &clear));
	odrive_tick(&now, -1, 0); /* the drive has not seen the clear yet when this frame left */
	assert_false(mode_faulted(robot.fw.ctl.mode));
	assert_int_equal(clear_errors_to(from, (uint8_t)cfg.odrive.node[1]), 1);
	odrive_tick(&now, 1, 0x00000020u); /* still there after the clear */
	assert_true(mode_faulted(robot.fw.ctl.mode));
	robot_close(&robot);
}

static void test_duplicate_ids_are_refused_with_the_reason(void **state)
{
	(void)state;
	char why[256];

	cfg.odrive.node[3] = cfg.odrive.node[0];
	const struct robot_spec spec = spec_of(OMNI4_MOTOR_ODRIVE);

	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), -1);
	assert_string_equal(why, "[odrive] node_0..node_3 must differ");
	assert_false(mock_open);
}

/* Each drive reports once, at the mock's clock; wheel 3's drive on id (VESC) or node id3. */
static void report_all_with(bool odrive, int id3)
{
	for (int j = 0; j < 4; j++) {
		const struct vesc_status1 s1 = {.erpm = 700};
		const struct odrive_encoder_estimates e = {.vel_turn_s = 1.0f};
		const struct odrive_iq q = {0};
		const int id = j == 3 ? id3 : odrive ? cfg.odrive.node[j] : cfg.vesc.id[j];
		struct omni4_can_frame f;

		if (odrive) {
			assert_int_equal(odrive_encode_encoder_estimates((uint8_t)id, &e, &f), 0);
			mock_push(&f);
			assert_int_equal(odrive_encode_iq((uint8_t)id, &q, &f), 0);
		} else {
			assert_int_equal(vesc_encode_status1((uint8_t)id, &s1, &f), 0);
		}
		mock_push(&f);
	}
}

/* Each drive reports once, at the mock's clock. */
static void report_all(bool odrive)
{
	report_all_with(odrive, odrive ? cfg.odrive.node[3] : cfg.vesc.id[3]);
}

/* [vesc] / [odrive] status_timeout_ms: drives silent for less than it are no fault, for more
 * they are DRIVER_TIMEOUT (the CAN test VM runs with 1500 ms, a robot with the default). */
static void status_timeout_from_the_ini(enum omni4_motor_backend motor)
{
	const bool odrive = motor == OMNI4_MOTOR_ODRIVE;
	struct motor_sample s;
	char why[256];

	cfg.fw.motor = motor;
	cfg.vesc.status_timeout_ms = cfg.odrive.status_timeout_ms = 300;
	const struct robot_spec spec = spec_of(motor);

	mock_clock_us = 1000000;
	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	report_all(odrive);
	assert_int_equal(hal_motor_read(&robot.motor, &s), 0);
	assert_false(s.faults & HAL_FAULT_DRIVER_TIMEOUT);
	mock_clock_us += 299000;
	assert_int_equal(hal_motor_read(&robot.motor, &s), 0);
	assert_false(s.faults & HAL_FAULT_DRIVER_TIMEOUT);
	mock_clock_us += 2000;
	assert_int_equal(hal_motor_read(&robot.motor, &s), 0);
	assert_true(s.faults & HAL_FAULT_DRIVER_TIMEOUT);
	robot_close(&robot);
}

static void test_vesc_status_timeout_is_the_ini_key(void **state)
{
	(void)state;
	status_timeout_from_the_ini(OMNI4_MOTOR_VESC);
}

static void test_odrive_status_timeout_is_the_ini_key(void **state)
{
	(void)state;
	status_timeout_from_the_ini(OMNI4_MOTOR_ODRIVE);
}

/* The supply each drive measures (VESC STATUS_5, ODrive Get_Bus_Voltage_Current) against
 * [limits] supply_min_v (9 V): 12 V runs, 8 V latches FAULT_SUPPLY (outputs off). */
static void supply_below_the_minimum(enum omni4_motor_backend motor)
{
	int64_t now = mock_clock_us;
	char why[256];

	cfg.fw.motor = motor;
	const struct robot_spec spec = spec_of(motor);

	assert_true(cfg.ctl.limits.supply_min_v == 9.0);
	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	for (int t = 0; t < 10; t++)
		if (motor == OMNI4_MOTOR_VESC)
			vesc_tick(&now, 12.0f);
		else
			odrive_tick_at(&now, -1, 0, 12.0f);
	assert_false(robot.fw.ctl.latched & CTL_FAULT_SUPPLY);
	for (int t = 0; t < 10; t++) /* ODrive: one bus request per axis every 8 ticks */
		if (motor == OMNI4_MOTOR_VESC)
			vesc_tick(&now, 8.0f);
		else
			odrive_tick_at(&now, -1, 0, 8.0f);
	assert_true(robot.fw.ctl.latched & CTL_FAULT_SUPPLY);
	assert_true(mode_faulted(robot.fw.ctl.mode));
	robot_close(&robot);
}

static void test_vesc_supply_below_the_minimum_is_fault_supply(void **state)
{
	(void)state;
	supply_below_the_minimum(OMNI4_MOTOR_VESC);
}

static void test_odrive_supply_below_the_minimum_is_fault_supply(void **state)
{
	(void)state;
	supply_below_the_minimum(OMNI4_MOTOR_ODRIVE);
}

/* robot_open with stderr into a file: what it wrote, in err. */
static int open_capturing_stderr(const struct robot_spec *spec, char *err, size_t n)
{
	char why[256];
	FILE *tmp = tmpfile();
	const int saved = dup(2);

	assert_non_null(tmp);
	fflush(stderr);
	assert_true(dup2(fileno(tmp), 2) == 2);
	const int rc = robot_open(&robot, spec, why, sizeof(why));

	fflush(stderr);
	dup2(saved, 2);
	close(saved);
	rewind(tmp);
	const size_t k = fread(err, 1, n - 1, tmp);

	err[k] = '\0';
	fclose(tmp);
	return rc;
}

/* A drive on a wrong id: exactly one line at start-up naming the id that did not report and
 * the one heard instead; the robot runs and its DRIVER_TIMEOUT latches (no crash). All four
 * there: nothing said. */
static void wrong_id_named_at_start(enum omni4_motor_backend motor, int wrong_id, const char *want)
{
	const bool odrive = motor == OMNI4_MOTOR_ODRIVE;
	int64_t now = mock_clock_us;
	char err[1024];

	cfg.fw.motor = motor;
	const struct robot_spec spec = spec_of(motor);

	report_all(odrive);
	assert_int_equal(open_capturing_stderr(&spec, err, sizeof(err)), 0);
	assert_string_equal(err, "");
	robot_close(&robot);
	mock_reset();
	report_all_with(odrive, wrong_id);
	assert_int_equal(open_capturing_stderr(&spec, err, sizeof(err)), 0);
	assert_string_equal(err, want);
	for (int t = 0; t < 25; t++) { /* the drive goes on reporting on its wrong id */
		report_all_with(odrive, wrong_id);
		now += 1000;
		mock_clock_us = now;
		fw_tick(&robot.fw, now);
	}
	assert_true(robot.fw.ctl.latched & CTL_FAULT_DRIVER_TIMEOUT);
	robot_close(&robot);
}

static void test_vesc_on_a_wrong_id_is_one_line_at_start(void **state)
{
	(void)state;
	wrong_id_named_at_start(OMNI4_MOTOR_VESC, 13,
	                        "omni4-fw: vesc: after 20 ms at start-up: no STATUS_1 from id 3 "
	                        "(wheel 3); heard instead: id 13\n");
}

static void test_odrive_on_a_wrong_node_is_one_line_at_start(void **state)
{
	(void)state;
	wrong_id_named_at_start(OMNI4_MOTOR_ODRIVE, 13,
	                        "omni4-fw: odrive: after 20 ms at start-up: no encoder estimate "
	                        "from node 3 (wheel 3); heard instead: node 13\n");
}

/* Bus-off on either drive bus: the controller latches FAULT_BUS (outputs off). */
static void bus_off_latches_bus(enum omni4_motor_backend motor)
{
	int64_t now = mock_clock_us;
	char why[256];

	cfg.fw.motor = motor;
	const struct robot_spec spec = spec_of(motor);

	assert_int_equal(robot_open(&robot, &spec, why, sizeof(why)), 0);
	for (int t = 0; t < 5; t++)
		if (motor == OMNI4_MOTOR_VESC)
			vesc_tick(&now, 12.0f);
		else
			odrive_tick(&now, -1, 0);
	assert_false(robot.fw.ctl.latched & CTL_FAULT_BUS);
	mock_push_error(SC_ERR_BUSOFF);
	if (motor == OMNI4_MOTOR_VESC)
		vesc_tick(&now, 12.0f);
	else
		odrive_tick(&now, -1, 0);
	assert_true(robot.fw.ctl.latched & CTL_FAULT_BUS);
	assert_true(mode_faulted(robot.fw.ctl.mode));
	robot_close(&robot);
}

static void test_vesc_bus_off_is_fault_bus(void **state)
{
	(void)state;
	bus_off_latches_bus(OMNI4_MOTOR_VESC);
}

static void test_odrive_bus_off_is_fault_bus(void **state)
{
	(void)state;
	bus_off_latches_bus(OMNI4_MOTOR_ODRIVE);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test_setup(test_vesc_opener_hands_the_settings_and_the_model_to_the_backend,
	                           reset),
	    cmocka_unit_test_setup(test_odrive_opener_starts_the_configured_nodes, reset),
	    cmocka_unit_test_setup(test_odrive_error_latches_driver_and_a_clear_restarts_the_axes,
	                           reset),
	    cmocka_unit_test_setup(test_duplicate_ids_are_refused_with_the_reason, reset),
	    cmocka_unit_test_setup(test_vesc_status_timeout_is_the_ini_key, reset),
	    cmocka_unit_test_setup(test_odrive_status_timeout_is_the_ini_key, reset),
	    cmocka_unit_test_setup(test_vesc_supply_below_the_minimum_is_fault_supply, reset),
	    cmocka_unit_test_setup(test_odrive_supply_below_the_minimum_is_fault_supply, reset),
	    cmocka_unit_test_setup(test_vesc_on_a_wrong_id_is_one_line_at_start, reset),
	    cmocka_unit_test_setup(test_vesc_bus_off_is_fault_bus, reset),
	    cmocka_unit_test_setup(test_odrive_bus_off_is_fault_bus, reset),
	    cmocka_unit_test_setup(test_odrive_on_a_wrong_node_is_one_line_at_start, reset),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
