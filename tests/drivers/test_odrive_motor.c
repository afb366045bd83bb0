/* Tests for drivers/odrive/odrive_motor.c with the OS adapter (sc_os) mocked at link time: the
 * start-up frames, a tick's torques decoded with the codec (Kt (u - Kv l w) / R), the remote
 * requests, reports into the sample, an axis error as a driver fault with its name, silence,
 * stop on close and on halt. Expected numbers are computed here by hand. */
#include "sc_os_mock.h"

#include <stdio.h>

#include "omni4/drivers/odrive_motor.h"

#define TWO_PI 6.28318530717958647692

static const uint8_t nodes[4] = {5, 1, 17, 63};

/* Gear 4; wheel 1 has its own Kt and wheel 2 its own R. */
static struct odrive_motor_config config(void)
{
	struct odrive_motor_config c = {.iface = "can1",
	                                .mode = ODRIVE_MODE_TORQUE,
	                                .status_timeout_ms = 20,
	                                .consts = {.gear = 4.0}};

	for (int j = 0; j < 4; j++) {
		c.node[j] = nodes[j];
		c.consts.w.r[j] = 0.03;
		c.consts.w.Kv[j] = 0.05;
		c.consts.w.Kt[j] = j == 1 ? 0.08 : 0.05;
		c.consts.w.R[j] = j == 2 ? 0.5 : 0.25;
	}
	return c;
}

static int reset(void **state)
{
	(void)state;
	mock_reset();
	return 0;
}

/* Encoder estimate (j + 1) turn/s, Iq j + 0.25 A, bus 24 V (wheel 2: 23 V). */
static void push_reports(void)
{
	for (int j = 0; j < 4; j++) {
		const struct odrive_encoder_estimates e = {.pos_turn = 0, .vel_turn_s = j + 1.0f};
		const struct odrive_iq q = {.setpoint_a = 0, .measured_a = j + 0.25f};
		const struct odrive_bus b = {.voltage_v = j == 2 ? 23.0f : 24.0f, .current_a = 1};
		struct omni4_can_frame f;

		assert_int_equal(odrive_encode_encoder_estimates(nodes[j], &e, &f), 0);
		mock_push(&f);
		assert_int_equal(odrive_encode_iq(nodes[j], &q, &f), 0);
		mock_push(&f);
		assert_int_equal(odrive_encode_bus(nodes[j], &b, &f), 0);
		mock_push(&f);
	}
}

static void push_heartbeat(int j, uint32_t axis_error, uint8_t state)
{
	const struct odrive_heartbeat hb = {.axis_error = axis_error, .axis_state = state};
	struct omni4_can_frame f;

	assert_int_equal(odrive_encode_heartbeat(nodes[j], &hb, &f), 0);
	mock_push(&f);
}

/* The torque sent to nodes[j] in frames from..end. */
static float sent_torque(int from, int j)
{
	for (int k = from; k < mock_n_sent; k++) {
		uint8_t node;
		float nm;

		if (odrive_decode_set_input_torque(&mock_sent[k], &node, &nm) == 0 &&
		    node == nodes[j])
			return nm;
	}
	fail_msg("no torque to node %u", nodes[j]);
	return NAN;
}

static void expect_start(int k, int j)
{
	uint8_t node, cmd;
	uint32_t state, control, input;

	assert_int_equal(odrive_split_id(&mock_sent[k], &node, &cmd), 0);
	assert_int_equal(node, nodes[j]);
	assert_int_equal(cmd, ODRIVE_CMD_CLEAR_ERRORS);
	assert_int_equal(
	    odrive_decode_set_controller_mode(&mock_sent[k + 1], &node, &control, &input), 0);
	assert_int_equal(node, nodes[j]);
	assert_int_equal(control, ODRIVE_CONTROL_TORQUE);
	assert_int_equal(input, ODRIVE_INPUT_PASSTHROUGH);
	assert_int_equal(odrive_decode_set_axis_state(&mock_sent[k + 2], &node, &state), 0);
	assert_int_equal(node, nodes[j]);
	assert_int_equal(state, ODRIVE_AXIS_STATE_CLOSED_LOOP);
}

static void test_open_clears_sets_torque_control_and_closes_the_loop(void **state)
{
	(void)state;
	struct odrive_motor m;
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	assert_string_equal(mock_iface, "can1");
	assert_int_equal(mock_n_sent, 12);
	for (int j = 0; j < 4; j++)
		expect_start(3 * j, j);
	for (int j = 0; j < 4; j++)
		assert_true(mock_filter_passes(ODRIVE_CAN_ID(nodes[j], ODRIVE_CMD_HEARTBEAT)));
	/* another node's heartbeat and estimates (to name a drive on a wrong node), not its rest */
	assert_true(mock_filter_passes(ODRIVE_CAN_ID(6, ODRIVE_CMD_HEARTBEAT)));
	assert_true(mock_filter_passes(ODRIVE_CAN_ID(6, ODRIVE_CMD_GET_ENCODER_ESTIMATES)));
	assert_false(mock_filter_passes(ODRIVE_CAN_ID(6, ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT)));
	assert_false(
	    mock_filter_passes(ODRIVE_CAN_ID(6, ODRIVE_CMD_HEARTBEAT) | OMNI4_CAN_RTR_FLAG));
	assert_false(mock_filter_passes(ODRIVE_CAN_ID(5, ODRIVE_CMD_GET_IQ) | OMNI4_CAN_RTR_FLAG));
	hal_motor_close(&(struct motor_hal){&odrive_motor_ops, &m});
}

static void test_reports_become_the_sample(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	assert_int_equal(hal_motor_read(&h, &s), -EAGAIN);
	push_reports();
	push_heartbeat(0, 0, ODRIVE_AXIS_STATE_CLOSED_LOOP);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	for (int j = 0; j < 4; j++) {
		assert_near(s.wheel_rad_s[j], (j + 1) * TWO_PI / 4.0, 1e-5); /* turn/s / gear */
		assert_near(s.current_a[j], j + 0.25, 1e-6);
	}
	assert_near(s.supply_v, 23.0, 1e-6);
	assert_int_equal(s.faults, 0);
	hal_motor_close(&h);
}

/* A read 4 ms after the last takes the frames of those 4 ms and more (the reports of a late
 * tick): 192 queued frames of older estimates, then the newest, reach the sample. */
static void test_a_late_read_reaches_the_newest_reports(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	for (int k = 0; k < 48; k++) /* 192 frames of older estimates */
		for (int j = 0; j < 4; j++) {
			const struct odrive_encoder_estimates e = {.vel_turn_s = -10.0f - k};
			struct omni4_can_frame f;

			assert_int_equal(odrive_encode_encoder_estimates(nodes[j], &e, &f), 0);
			mock_push(&f);
		}
	push_reports();
	push_heartbeat(0, 0, ODRIVE_AXIS_STATE_CLOSED_LOOP);
	mock_clock_us += 4000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	for (int j = 0; j < 4; j++)
		assert_near(s.wheel_rad_s[j], (j + 1) * TWO_PI / 4.0, 1e-5);
	hal_motor_close(&h);
}

static void test_torque_is_kt_times_eq21_current_and_one_request_a_tick(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const struct odrive_motor_config c = config();
	const float volts[4] = {6.0f, -3.0f, 12.0f, 0.5f};

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	push_reports();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	int from = mock_n_sent;

	assert_int_equal(hal_motor_write(&h, volts), 0); /* not enabled: 0 Nm */
	for (int j = 0; j < 4; j++)
		assert_near(sent_torque(from, j), 0.0, 0.0);
	assert_int_equal(hal_motor_enable(&h, true), 0);
	from = mock_n_sent;
	assert_int_equal(hal_motor_write(&h, volts), 0);
	assert_int_equal(mock_n_sent - from, 5);
	for (int j = 0; j < 4; j++) {
		const double wm = (j + 1) * TWO_PI; /* motor rad/s: the encoder is on the motor */
		const double i = (volts[j] - 0.05 * wm) / (j == 2 ? 0.5 : 0.25);

		assert_near(sent_torque(from, j), (j == 1 ? 0.08 : 0.05) * i, 1e-5);
	}
	/* the fifth frame: a remote request; eight ticks ask each node for Iq and bus once */
	int asked[4][2] = {{0}};

	for (int t = 0; t < 8; t++) {
		const struct omni4_can_frame *f = &mock_sent[mock_n_sent - 1];
		uint8_t node, cmd;

		assert_true(f->id & OMNI4_CAN_RTR_FLAG);
		assert_int_equal(odrive_split_id(f, &node, &cmd), 0);
		for (int j = 0; j < 4; j++)
			if (node == nodes[j])
				asked[j][cmd == ODRIVE_CMD_GET_IQ ? 0 : 1]++;
		assert_int_equal(hal_motor_write(&h, volts), 0);
	}
	for (int j = 0; j < 4; j++)
		assert_true(asked[j][0] == 1 && asked[j][1] == 1);
	hal_motor_close(&h);
}

static void test_an_axis_error_is_a_driver_fault_once_and_again_after_a_clear(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	char text[256];
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	push_reports();
	push_heartbeat(2, 0x00000200u | 0x00002000u, ODRIVE_AXIS_STATE_IDLE);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	odrive_motor_fault_text(&m, text, sizeof(text));
	assert_non_null(strstr(text, "wheel 2 (node 17, error 0x00002200)"));
	assert_non_null(strstr(text, "dc_bus_under_voltage"));
	assert_non_null(strstr(text, "motor_over_temp"));

	/* reported once (the controller latches it), so the controller's clear is not refused */
	push_reports();
	push_heartbeat(2, 0x00000200u | 0x00002000u, ODRIVE_AXIS_STATE_IDLE);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	const int from = mock_n_sent;

	assert_int_equal(hal_motor_clear_faults(&h), 0); /* the start sequence again */
	assert_int_equal(mock_n_sent - from, 12);
	expect_start(from + 6, 2);
	push_reports();
	push_heartbeat(2, 0x00000200u, ODRIVE_AXIS_STATE_IDLE); /* still there after the clear */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	push_reports();
	push_heartbeat(2, 0, ODRIVE_AXIS_STATE_CLOSED_LOOP);
	push_heartbeat(2, 0x00000200u, ODRIVE_AXIS_STATE_IDLE); /* gone, then back: new again */
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER);
	/* the summary keeps what was seen since start */
	assert_non_null(strstr(odrive_motor_fault_text(&m, text, sizeof(text)), "motor_over_temp"));
	hal_motor_close(&h);
}

static void test_a_silent_axis_is_a_driver_timeout(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	char text[16];
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	push_reports();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_string_equal(odrive_motor_fault_text(&m, text, sizeof(text)), "none");
	mock_clock_us += 19000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	mock_clock_us += 2000;
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_DRIVER_TIMEOUT);
	hal_motor_close(&h);
}

/* Close (and halt): 0 Nm to every axis, then IDLE to every axis; nothing after a halt. */
static void expect_stop(int from)
{
	for (int j = 0; j < 4; j++) {
		uint8_t node;
		float nm;

		assert_int_equal(odrive_decode_set_input_torque(&mock_sent[from + j], &node, &nm),
		                 0);
		assert_int_equal(node, nodes[j]);
		assert_near(nm, 0.0, 0.0);
	}
	for (int j = 0; j < 4; j++) {
		uint8_t node;
		uint32_t st;

		assert_int_equal(odrive_decode_set_axis_state(&mock_sent[from + 4 + j], &node, &st),
		                 0);
		assert_int_equal(node, nodes[j]);
		assert_int_equal(st, ODRIVE_AXIS_STATE_IDLE);
	}
}

static void test_close_zeroes_the_torque_then_idles_every_axis(void **state)
{
	(void)state;
	struct odrive_motor m;
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	hal_motor_close(&h);
	assert_int_equal(mock_n_sent, 12 + 8);
	expect_stop(12);
	assert_true(mock_closed);
}

static void test_halt_stops_and_drops_later_writes(void **state)
{
	(void)state;
	struct odrive_motor m;
	const struct odrive_motor_config c = config();
	const float volts[4] = {6, 6, 6, 6};

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	assert_int_equal(odrive_motor_halt(&m), 8);
	expect_stop(12);
	assert_int_equal(hal_motor_enable(&h, true), 0);
	assert_int_equal(hal_motor_write(&h, volts), 0);
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	hal_motor_close(&h);
	assert_int_equal(mock_n_sent, 12 + 8);
}

/* Set_Axis_State CLOSED_LOOP frames to nodes[j] in frames from..end. */
static int closed_loop_requests(int from, int j)
{
	int n = 0;

	for (int k = from; k < mock_n_sent; k++) {
		uint8_t node;
		uint32_t st;

		n += odrive_decode_set_axis_state(&mock_sent[k], &node, &st) == 0 &&
		     node == nodes[j] && st == ODRIVE_AXIS_STATE_CLOSED_LOOP;
	}
	return n;
}

/* An axis that came up after the start (heartbeat IDLE, no error) is started again: torque
 * control and closed loop, at most every 100 ms while its heartbeat says IDLE; none for an axis
 * in closed loop or one with an error (that waits for a clear). */
static void test_an_idle_axis_without_error_is_started_again_at_a_bounded_rate(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const float volts[4] = {0, 0, 0, 0};
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);
	const int from = mock_n_sent;

	for (int t = 0; t < 250; t++) { /* 250 ticks of 1 ms */
		push_reports();
		push_heartbeat(0, 0, ODRIVE_AXIS_STATE_CLOSED_LOOP);
		push_heartbeat(1, 0, ODRIVE_AXIS_STATE_IDLE);
		push_heartbeat(2, 0x00000200u, ODRIVE_AXIS_STATE_IDLE);
		push_heartbeat(3, 0, ODRIVE_AXIS_STATE_CLOSED_LOOP);
		assert_int_equal(hal_motor_read(&h, &s), 0);
		assert_int_equal(hal_motor_write(&h, volts), 0);
		mock_clock_us += 1000;
	}
	assert_int_equal(closed_loop_requests(from, 0), 0);
	assert_int_equal(closed_loop_requests(from, 1), 3); /* at 0, 100, 200 ms */
	assert_int_equal(closed_loop_requests(from, 2), 0);
	assert_int_equal(closed_loop_requests(from, 3), 0);
	hal_motor_close(&h);
}

/* An axis that stops reporting: no fault up to the timeout (20 ms), DRIVER_TIMEOUT within 3
 * ticks (1 ms) after it. */
static void test_driver_timeout_within_three_ticks_of_the_timeout(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const struct odrive_motor_config c = config();
	int fault_tick = -1;

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	push_reports(); /* the last estimate of axis 3 */
	for (int t = 1; t <= 30 && fault_tick < 0; t++) {
		mock_clock_us += 1000;
		for (int j = 0; j < 3; j++) {
			const struct odrive_encoder_estimates e = {.pos_turn = 0,
			                                           .vel_turn_s = 1.0f};
			struct omni4_can_frame f;

			assert_int_equal(odrive_encode_encoder_estimates(nodes[j], &e, &f), 0);
			mock_push(&f);
		}
		assert_int_equal(hal_motor_read(&h, &s), 0);
		if (s.faults & HAL_FAULT_DRIVER_TIMEOUT)
			fault_tick = t;
	}
	assert_true(fault_tick > 20 && fault_tick <= 23);
	hal_motor_close(&h);
}

/* Start-up with axis 2 on a wrong node (18): one missing, named with the node heard. */
static void test_an_axis_on_a_wrong_node_is_named_with_the_node_heard(void **state)
{
	(void)state;
	struct odrive_motor m;
	char text[256];
	const struct odrive_motor_config c = config();
	const struct odrive_encoder_estimates e = {.pos_turn = 0, .vel_turn_s = 0};
	struct omni4_can_frame f;

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	for (int j = 0; j < 4; j++)
		if (j != 2) {
			assert_int_equal(odrive_encode_encoder_estimates(nodes[j], &e, &f), 0);
			mock_push(&f);
		}
	assert_int_equal(odrive_encode_encoder_estimates(18, &e, &f), 0);
	mock_push(&f);
	assert_int_equal(odrive_motor_poll_missing(&m), 1);
	assert_string_equal(odrive_motor_missing_text(&m, text, sizeof(text)),
	                    "no encoder estimate from node 17 (wheel 2); heard instead: node 18");
	hal_motor_close(&h);
}

static void test_bus_off_is_a_bus_fault_until_cleared(void **state)
{
	(void)state;
	struct odrive_motor m;
	struct motor_sample s;
	const struct odrive_motor_config c = config();

	assert_int_equal(odrive_motor_open(&m, &c), 0);
	const struct motor_hal h = odrive_motor_hal(&m);

	push_reports();
	mock_push_error(SC_ERR_BUSOFF);
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_BUS);
	push_reports();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, HAL_FAULT_BUS); /* latched until a clear */
	assert_int_equal(hal_motor_clear_faults(&h), 0);
	push_reports();
	assert_int_equal(hal_motor_read(&h, &s), 0);
	assert_int_equal(s.faults, 0);
	hal_motor_close(&h);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test_setup(test_open_clears_sets_torque_control_and_closes_the_loop, reset),
	    cmocka_unit_test_setup(test_reports_become_the_sample, reset),
	    cmocka_unit_test_setup(test_a_late_read_reaches_the_newest_reports, reset),
	    cmocka_unit_test_setup(test_torque_is_kt_times_eq21_current_and_one_request_a_tick,
	                           reset),
	    cmocka_unit_test_setup(
	        test_an_axis_error_is_a_driver_fault_once_and_again_after_a_clear, reset),
	    cmocka_unit_test_setup(test_a_silent_axis_is_a_driver_timeout, reset),
	    cmocka_unit_test_setup(test_close_zeroes_the_torque_then_idles_every_axis, reset),
	    cmocka_unit_test_setup(test_halt_stops_and_drops_later_writes, reset),
	    cmocka_unit_test_setup(
	        test_an_idle_axis_without_error_is_started_again_at_a_bounded_rate, reset),
	    cmocka_unit_test_setup(test_driver_timeout_within_three_ticks_of_the_timeout, reset),
	    cmocka_unit_test_setup(test_bus_off_is_a_bus_fault_until_cleared, reset),
	    cmocka_unit_test_setup(test_an_axis_on_a_wrong_node_is_named_with_the_node_heard,
	                           reset),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
