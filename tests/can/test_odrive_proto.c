/* Tests for drivers/can/odrive_proto.c against frames written by hand from ODrive's "CAN
 * Protocol" documents (CANSimple): ID = node << 5 | command, 11-bit; little-endian, floats IEEE 754
 * binary32 (1.0f = 0x3F800000, -2.0f = 0xC0000000, 0.5f = 0x3F000000, 24.0f = 0x41C00000,
 * 1.5f = 0x3FC00000, -0.25f = 0xBE800000, -0.5f = 0xBF000000). */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/drivers/odrive_proto.h"

static void assert_frame(const struct omni4_can_frame *f, uint32_t id, uint8_t dlc,
                         const uint8_t *data)
{
	assert_int_equal(f->id, id);
	assert_int_equal(f->dlc, dlc);
	if (dlc)
		assert_memory_equal(f->data, data, dlc);
}

static struct omni4_can_frame frame(uint32_t id, const uint8_t data[8])
{
	struct omni4_can_frame f = {.id = id, .dlc = 8};

	memcpy(f.data, data, 8);
	return f;
}

static void test_ids_follow_the_documents_example(void **state)
{
	(void)state;
	/* "an Axis ID of 0x01 with a command of 0x0C would result in 0x2C" */
	assert_int_equal(ODRIVE_CAN_ID(1, 0x0C), 0x2C);
	assert_int_equal(ODRIVE_CAN_ID(63, ODRIVE_CMD_CLEAR_ERRORS), 0x7F8);
}

static void test_commands_have_the_documented_layout(void **state)
{
	(void)state;
	/* Set_Input_Vel (0x0D), node 1 -> 0x2D: 1.0 turn/s, torque feed-forward 0. */
	const uint8_t vel[8] = {0x00, 0x00, 0x80, 0x3F, 0, 0, 0, 0};
	/* Set_Input_Torque (0x0E), node 63 -> 0x7EE: -2.0 Nm. */
	const uint8_t torque[8] = {0x00, 0x00, 0x00, 0xC0, 0, 0, 0, 0};
	/* Set_Axis_State (0x07), node 2 -> 0x47: closed loop control = 8 (uint32). */
	const uint8_t axis[8] = {0x08, 0, 0, 0, 0, 0, 0, 0};
	/* Set_Controller_Mode (0x0B), node 1 -> 0x2B: torque control 1, passthrough 1. */
	const uint8_t mode[8] = {0x01, 0, 0, 0, 0x01, 0, 0, 0};
	/* Clear_Errors (0x18), node 1 -> 0x38: identify 0. */
	const uint8_t clear[1] = {0x00};
	struct omni4_can_frame f;

	assert_int_equal(odrive_encode_set_input_vel(1, 1.0f, 0.0f, &f), 0);
	assert_frame(&f, 0x2D, 8, vel);
	assert_int_equal(odrive_encode_set_input_torque(63, -2.0f, &f), 0);
	assert_frame(&f, 0x7EE, 8, torque);
	assert_int_equal(odrive_encode_set_axis_state(2, ODRIVE_AXIS_STATE_CLOSED_LOOP, &f), 0);
	assert_frame(&f, 0x47, 8, axis);
	assert_int_equal(odrive_encode_set_controller_mode(1, ODRIVE_CONTROL_TORQUE,
	                                                   ODRIVE_INPUT_PASSTHROUGH, &f),
	                 0);
	assert_frame(&f, 0x2B, 8, mode);
	assert_int_equal(odrive_encode_clear_errors(1, &f), 0);
	assert_frame(&f, 0x38, 1, clear);
	assert_int_equal(odrive_encode_estop(1, &f), 0); /* Estop (0x02), no data */
	assert_frame(&f, 0x22, 0, NULL);
	/* Get_Iq (0x14) of node 2 -> 0x54, asked with a remote frame */
	assert_int_equal(odrive_encode_request(2, ODRIVE_CMD_GET_IQ, &f), 0);
	assert_int_equal(f.id, OMNI4_CAN_RTR_FLAG | 0x54u);
	assert_int_equal(f.dlc, 8);
}

/* Heartbeat (0x01) of node 2 -> 0x41: axis error 0x00000201 (initializing, dc_bus_under_voltage)
 * little-endian, state 8, procedure result 0, trajectory done (byte 6) 1. */
static void test_heartbeat_written_by_hand_decodes(void **state)
{
	(void)state;
	const uint8_t d[8] = {0x01, 0x02, 0x00, 0x00, 0x08, 0x00, 0x01, 0x00};
	const struct omni4_can_frame f = frame(0x41, d);
	struct odrive_heartbeat h;
	uint8_t node;

	assert_int_equal(odrive_decode_heartbeat(&f, &node, &h), 0);
	assert_int_equal(node, 2);
	assert_int_equal(h.axis_error, 0x201);
	assert_int_equal(h.axis_state, 8);
	assert_int_equal(h.procedure_result, 0);
	assert_true(h.trajectory_done);
	assert_string_equal(odrive_error_name(h.axis_error & 1u), "initializing");
	assert_string_equal(odrive_error_name(h.axis_error & 0x200u), "dc_bus_under_voltage");
	assert_string_equal(odrive_axis_state_name(h.axis_state), "closed_loop_control");
}

static void test_measurements_written_by_hand_decode(void **state)
{
	(void)state;
	/* Get_Encoder_Estimates (0x09), node 0: -2.0 turn, 0.5 turn/s */
	const uint8_t enc[8] = {0x00, 0x00, 0x00, 0xC0, 0x00, 0x00, 0x00, 0x3F};
	/* Get_Iq (0x14), node 5 -> 0xB4: setpoint 1.5 A, measured -0.25 A */
	const uint8_t iq[8] = {0x00, 0x00, 0xC0, 0x3F, 0x00, 0x00, 0x80, 0xBE};
	/* Get_Bus_Voltage_Current (0x17), node 3 -> 0x77: 24.0 V, -0.5 A */
	const uint8_t bus[8] = {0x00, 0x00, 0xC0, 0x41, 0x00, 0x00, 0x00, 0xBF};
	struct omni4_can_frame f = frame(0x009, enc);
	struct odrive_encoder_estimates e;
	struct odrive_iq q;
	struct odrive_bus b;
	uint8_t node;

	assert_int_equal(odrive_decode_encoder_estimates(&f, &node, &e), 0);
	assert_int_equal(node, 0);
	assert_true(e.pos_turn == -2.0f && e.vel_turn_s == 0.5f);
	f = frame(0xB4, iq);
	assert_int_equal(odrive_decode_iq(&f, &node, &q), 0);
	assert_int_equal(node, 5);
	assert_true(q.setpoint_a == 1.5f && q.measured_a == -0.25f);
	f = frame(0x77, bus);
	assert_int_equal(odrive_decode_bus(&f, &node, &b), 0);
	assert_int_equal(node, 3);
	assert_true(b.voltage_v == 24.0f && b.current_a == -0.5f);
}

static void test_every_message_round_trips_exactly(void **state)
{
	(void)state;
	const struct odrive_heartbeat h = {0x02000020u, 1, 3, false};
	const struct odrive_encoder_estimates e = {-1234.5678f, 17.25f};
	struct omni4_can_frame f;
	struct odrive_heartbeat h2;
	struct odrive_encoder_estimates e2;
	uint32_t a, b;
	float v, t;
	uint8_t node, cmd;

	assert_int_equal(odrive_encode_heartbeat(9, &h, &f), 0);
	assert_int_equal(odrive_decode_heartbeat(&f, &node, &h2), 0);
	assert_true(node == 9 && h2.axis_error == h.axis_error && h2.axis_state == 1);
	assert_true(h2.procedure_result == 3 && !h2.trajectory_done);
	assert_int_equal(odrive_encode_encoder_estimates(10, &e, &f), 0);
	assert_int_equal(odrive_decode_encoder_estimates(&f, &node, &e2), 0);
	assert_true(node == 10 && e2.pos_turn == e.pos_turn && e2.vel_turn_s == e.vel_turn_s);
	assert_int_equal(odrive_encode_set_input_vel(11, -3.75f, 0.0625f, &f), 0);
	assert_int_equal(odrive_decode_set_input_vel(&f, &node, &v, &t), 0);
	assert_true(node == 11 && v == -3.75f && t == 0.0625f);
	assert_int_equal(odrive_encode_set_input_torque(12, 0.3f, &f), 0);
	assert_int_equal(odrive_decode_set_input_torque(&f, &node, &t), 0);
	assert_true(node == 12 && t == 0.3f);
	assert_int_equal(odrive_encode_set_axis_state(13, ODRIVE_AXIS_STATE_IDLE, &f), 0);
	assert_int_equal(odrive_decode_set_axis_state(&f, &node, &a), 0);
	assert_true(node == 13 && a == ODRIVE_AXIS_STATE_IDLE);
	assert_int_equal(odrive_encode_set_controller_mode(14, ODRIVE_CONTROL_VELOCITY,
	                                                   ODRIVE_INPUT_VEL_RAMP, &f),
	                 0);
	assert_int_equal(odrive_decode_set_controller_mode(&f, &node, &a, &b), 0);
	assert_true(node == 14 && a == ODRIVE_CONTROL_VELOCITY && b == ODRIVE_INPUT_VEL_RAMP);
	assert_int_equal(odrive_encode_request(15, ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT, &f), 0);
	assert_int_equal(odrive_split_id(&f, &node, &cmd), 0);
	assert_true(node == 15 && cmd == ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT);
}

static void test_bad_arguments_are_refused(void **state)
{
	(void)state;
	struct omni4_can_frame f;

	assert_int_equal(odrive_encode_set_input_vel(64, 1.0f, 0.0f, &f), -EINVAL);
	assert_int_equal(odrive_encode_estop(64, &f), -EINVAL);
	assert_int_equal(odrive_encode_set_input_vel(1, NAN, 0.0f, &f), -EINVAL);
	assert_int_equal(odrive_encode_set_input_vel(1, 0.0f, INFINITY, &f), -EINVAL);
	assert_int_equal(odrive_encode_set_input_torque(1, -INFINITY, &f), -EINVAL);
	assert_int_equal(odrive_encode_set_axis_state(1, ODRIVE_AXIS_STATE_MAX + 1, &f), -EINVAL);
	assert_int_equal(odrive_encode_set_controller_mode(1, (enum odrive_control_mode)4,
	                                                   ODRIVE_INPUT_PASSTHROUGH, &f),
	                 -EINVAL);
	assert_int_equal(odrive_encode_set_controller_mode(1, ODRIVE_CONTROL_TORQUE,
	                                                   (enum odrive_input_mode)9, &f),
	                 -EINVAL);
	assert_int_equal(odrive_encode_request(1, ODRIVE_CMD_SET_INPUT_VEL, &f), -EINVAL);
}

static void test_foreign_frames_are_refused_and_outputs_untouched(void **state)
{
	(void)state;
	const uint8_t d[8] = {0x00, 0x00, 0xC0, 0x41, 0x00, 0x00, 0x00, 0xBF};
	struct odrive_bus b = {7.0f, 7.0f};
	uint8_t node = 99, cmd;
	struct omni4_can_frame f = frame(OMNI4_CAN_EFF_FLAG | 0x77u, d);

	assert_int_equal(odrive_decode_bus(&f, &node, &b), -EINVAL);
	assert_int_equal(odrive_split_id(&f, &node, &cmd), -EINVAL);
	f = frame(OMNI4_CAN_RTR_FLAG | 0x77u, d); /* a request, not the answer */
	assert_int_equal(odrive_decode_bus(&f, &node, &b), -EINVAL);
	f = frame(0x74u, d); /* Get_Iq of node 3 */
	assert_int_equal(odrive_decode_bus(&f, &node, &b), -EINVAL);
	f = frame(0x77u, d);
	f.dlc = 7;
	assert_int_equal(odrive_decode_bus(&f, &node, &b), -EINVAL);
	assert_true(node == 99 && b.voltage_v == 7.0f && b.current_a == 7.0f);
}

/* A drive without an estimate may send NaN: passed through for the caller to judge. */
static void test_a_nan_from_the_drive_is_passed_through(void **state)
{
	(void)state;
	const uint8_t d[8] = {0x00, 0x00, 0xC0, 0x7F, 0x00, 0x00, 0x00, 0x00}; /* quiet NaN, 0 */
	const struct omni4_can_frame f = frame(0x009, d);
	struct odrive_encoder_estimates e;
	uint8_t node;

	assert_int_equal(odrive_decode_encoder_estimates(&f, &node, &e), 0);
	assert_true(isnan(e.pos_turn) && e.vel_turn_s == 0.0f);
}

static void test_error_bits_and_states_have_their_names(void **state)
{
	(void)state;
	assert_string_equal(odrive_error_name(0x02000000u), "estop_requested");
	assert_string_equal(odrive_error_name(0x01000000u), "watchdog_timer_expired");
	assert_string_equal(odrive_error_name(0x00000080u), "unknown");
	assert_string_equal(odrive_axis_state_name(1), "idle");
	assert_string_equal(odrive_axis_state_name(15), "unknown");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_ids_follow_the_documents_example),
	    cmocka_unit_test(test_commands_have_the_documented_layout),
	    cmocka_unit_test(test_heartbeat_written_by_hand_decodes),
	    cmocka_unit_test(test_measurements_written_by_hand_decode),
	    cmocka_unit_test(test_every_message_round_trips_exactly),
	    cmocka_unit_test(test_bad_arguments_are_refused),
	    cmocka_unit_test(test_foreign_frames_are_refused_and_outputs_untouched),
	    cmocka_unit_test(test_a_nan_from_the_drive_is_passed_through),
	    cmocka_unit_test(test_error_bits_and_states_have_their_names),
	};

	return cmocka_run_group_tests_name("odrive_proto", tests, NULL, NULL);
}
