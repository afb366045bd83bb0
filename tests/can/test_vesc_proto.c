/* Tests for drivers/can/vesc_proto.c against frames written by hand from the VESC document
 * ("VESC CAN-Bus Communication", documentation/comm_can.md of github.com/vedderb/bldc): ID =
 * command << 8 | controller ID, 29-bit extended; big-endian int32 / int16 with the document's
 * scales. */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/drivers/vesc_proto.h"

static void assert_frame(const struct omni4_can_frame *f, uint32_t id, uint8_t dlc,
                         const uint8_t *data)
{
	assert_int_equal(f->id, id);
	assert_int_equal(f->dlc, dlc);
	assert_memory_equal(f->data, data, dlc);
}

static struct omni4_can_frame frame(uint32_t id, const uint8_t data[8])
{
	struct omni4_can_frame f = {.id = id, .dlc = 8};

	memcpy(f.data, data, 8);
	return f;
}

/* The document's own example: SET_CURRENT (1, scale 1000), 51 A, VESC ID 23 -> ID 0x0117,
 * data 00 00 C7 38. */
static void test_set_current_is_the_documents_example(void **state)
{
	(void)state;
	const uint8_t want[4] = {0x00, 0x00, 0xC7, 0x38}; /* 51000 = 0xC738 */
	struct omni4_can_frame f;

	assert_int_equal(vesc_encode_set_current(23, 51.0f, &f), 0);
	assert_frame(&f, OMNI4_CAN_EFF_FLAG | 0x0117u, 4, want);
}

static void test_commands_have_the_documented_ids_scales_and_byte_order(void **state)
{
	(void)state;
	/* SET_DUTY (0) to ID 4: -0.25 x 100000 = -25000 = 0xFFFF9E58 (two's complement). */
	const uint8_t duty[4] = {0xFF, 0xFF, 0x9E, 0x58};
	/* SET_CURRENT_BRAKE (2) to ID 0x10: 2.5 A x 1000 = 2500 = 0x000009C4. */
	const uint8_t brake[4] = {0x00, 0x00, 0x09, 0xC4};
	/* SET_RPM (3) to ID 9: 3000 = 0x00000BB8; to ID 200: -123456 = 0xFFFE1DC0. */
	const uint8_t rpm[4] = {0x00, 0x00, 0x0B, 0xB8};
	const uint8_t rpm_neg[4] = {0xFF, 0xFE, 0x1D, 0xC0};
	struct omni4_can_frame f;

	assert_int_equal(vesc_encode_set_duty(4, -0.25f, &f), 0);
	assert_frame(&f, 0x80000004u, 4, duty);
	assert_int_equal(vesc_encode_set_current_brake(0x10, 2.5f, &f), 0);
	assert_frame(&f, 0x80000210u, 4, brake);
	assert_int_equal(vesc_encode_set_rpm(9, 3000.0f, &f), 0);
	assert_frame(&f, 0x80000309u, 4, rpm);
	assert_int_equal(vesc_encode_set_rpm(200, -123456.0f, &f), 0);
	assert_frame(&f, 0x800003C8u, 4, rpm_neg);
}

/* STATUS (9) from ID 1: ERPM 1000 = 0x000003E8, current x 10: 123 = 0x007B -> 12.3 A,
 * duty x 1000: 500 = 0x01F4 -> 0.5. */
static void test_status1_written_by_hand_decodes_to_the_documented_values(void **state)
{
	(void)state;
	const uint8_t d[8] = {0x00, 0x00, 0x03, 0xE8, 0x00, 0x7B, 0x01, 0xF4};
	const struct omni4_can_frame f = frame(OMNI4_CAN_EFF_FLAG | 0x0901u, d);
	struct vesc_status1 s;
	uint8_t id;

	assert_int_equal(vesc_decode_status1(&f, &id, &s), 0);
	assert_int_equal(id, 1);
	assert_int_equal(s.erpm, 1000);
	assert_near(s.current_a, 12.3, 1e-5);
	assert_near(s.duty, 0.5, 1e-6);
}

/* STATUS_4 (16 = 0x10) from ID 2: FET -55 = 0xFFC9 -> -5.5 degC, motor 400 = 0x0190 -> 40 degC,
 * input current -10 = 0xFFF6 -> -1 A, PID position x 50: 4500 = 0x1194 -> 90 deg.
 * STATUS_5 (27 = 0x1B) from ID 3: tachometer -6 = 0xFFFFFFFA, 240 = 0x00F0 -> 24.0 V. */
static void test_status4_and_5_written_by_hand_decode_to_the_documented_values(void **state)
{
	(void)state;
	const uint8_t d4[8] = {0xFF, 0xC9, 0x01, 0x90, 0xFF, 0xF6, 0x11, 0x94};
	const uint8_t d5[8] = {0xFF, 0xFF, 0xFF, 0xFA, 0x00, 0xF0, 0x00, 0x00};
	const struct omni4_can_frame f4 = frame(OMNI4_CAN_EFF_FLAG | 0x1002u, d4);
	const struct omni4_can_frame f5 = frame(OMNI4_CAN_EFF_FLAG | 0x1B03u, d5);
	struct vesc_status4 s4;
	struct vesc_status5 s5;
	uint8_t id;

	assert_int_equal(vesc_decode_status4(&f4, &id, &s4), 0);
	assert_int_equal(id, 2);
	assert_near(s4.temp_fet_c, -5.5, 1e-5);
	assert_near(s4.temp_motor_c, 40.0, 1e-5);
	assert_near(s4.current_in_a, -1.0, 1e-5);
	assert_near(s4.pid_pos_deg, 90.0, 1e-5);
	assert_int_equal(vesc_decode_status5(&f5, &id, &s5), 0);
	assert_int_equal(id, 3);
	assert_int_equal(s5.tacho_steps, -6);
	assert_near(s5.input_v, 24.0, 1e-5);
}

static void test_commands_round_trip_within_half_an_lsb(void **state)
{
	(void)state;
	struct omni4_can_frame f;
	uint8_t id;
	float v;

	assert_int_equal(vesc_encode_set_duty(12, 0.123456f, &f), 0);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_SET_DUTY, &id, &v), 0);
	assert_int_equal(id, 12);
	assert_near(v, 0.123456, 0.5e-5 + 1e-7);
	assert_int_equal(vesc_encode_set_current(VESC_ID_BROADCAST, -37.1234f, &f), 0);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_SET_CURRENT, &id, &v), 0);
	assert_int_equal(id, 255);
	assert_near(v, -37.1234, 0.5e-3 + 1e-5);
	assert_int_equal(vesc_encode_set_current_brake(0, 8.0f, &f), 0);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_SET_CURRENT_BRAKE, &id, &v), 0);
	assert_near(v, 8.0, 1e-6);
	assert_int_equal(vesc_encode_set_rpm(1, 25000.4f, &f), 0);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_SET_RPM, &id, &v), 0);
	assert_near(v, 25000.0, 1e-3);
	/* a brake frame is not a current command */
	assert_int_equal(vesc_encode_set_current_brake(0, 8.0f, &f), 0);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_SET_CURRENT, &id, &v), -EINVAL);
}

static void test_status_round_trips_within_half_an_lsb(void **state)
{
	(void)state;
	const struct vesc_status1 s1 = {-54321, -87.64f, 0.9876f};
	const struct vesc_status4 s4 = {85.04f, -20.06f, 31.55f, -359.99f};
	const struct vesc_status5 s5 = {2000000000, 50.35f};
	struct omni4_can_frame f;
	struct vesc_status1 o1;
	struct vesc_status4 o4;
	struct vesc_status5 o5;
	uint8_t id;

	assert_int_equal(vesc_encode_status1(42, &s1, &f), 0);
	assert_int_equal(vesc_decode_status1(&f, &id, &o1), 0);
	assert_int_equal(id, 42);
	assert_int_equal(o1.erpm, s1.erpm);
	assert_near(o1.current_a, s1.current_a, 0.05 + 1e-5);
	assert_near(o1.duty, s1.duty, 0.0005 + 1e-6);
	assert_int_equal(vesc_encode_status4(43, &s4, &f), 0);
	assert_int_equal(vesc_decode_status4(&f, &id, &o4), 0);
	assert_near(o4.temp_fet_c, s4.temp_fet_c, 0.05 + 1e-5);
	assert_near(o4.temp_motor_c, s4.temp_motor_c, 0.05 + 1e-5);
	assert_near(o4.current_in_a, s4.current_in_a, 0.05 + 1e-5);
	assert_near(o4.pid_pos_deg, s4.pid_pos_deg, 0.01 + 1e-5);
	assert_int_equal(vesc_encode_status5(44, &s5, &f), 0);
	assert_int_equal(f.data[6] | f.data[7], 0); /* reserved */
	assert_int_equal(vesc_decode_status5(&f, &id, &o5), 0);
	assert_int_equal(o5.tacho_steps, s5.tacho_steps);
	assert_near(o5.input_v, s5.input_v, 0.05 + 1e-5);
}

/* Duty to the document's [-1, 1]; the others to their integer fields. */
static void test_out_of_range_commands_saturate_to_the_field(void **state)
{
	(void)state;
	const uint8_t duty_max[4] = {0x00, 0x01, 0x86, 0xA0}; /* 100000 */
	const uint8_t duty_min[4] = {0xFF, 0xFE, 0x79, 0x60}; /* -100000 */
	const uint8_t i32_max[4] = {0x7F, 0xFF, 0xFF, 0xFF};
	const uint8_t i32_min[4] = {0x80, 0x00, 0x00, 0x00};
	const struct vesc_status1 s1 = {0, 5000.0f, -40.0f};
	struct omni4_can_frame f;

	assert_int_equal(vesc_encode_set_duty(0, 1.5f, &f), 0);
	assert_memory_equal(f.data, duty_max, 4);
	assert_int_equal(vesc_encode_set_duty(0, -7.0f, &f), 0);
	assert_memory_equal(f.data, duty_min, 4);
	assert_int_equal(vesc_encode_set_current(0, 3.0e6f, &f), 0);
	assert_memory_equal(f.data, i32_max, 4);
	assert_int_equal(vesc_encode_set_current_brake(0, -1.0e12f, &f), 0);
	assert_memory_equal(f.data, i32_min, 4);
	assert_int_equal(vesc_encode_set_rpm(0, 1.0e10f, &f), 0);
	assert_memory_equal(f.data, i32_max, 4);
	assert_int_equal(vesc_encode_status1(0, &s1, &f), 0);
	assert_int_equal(f.data[4] << 8 | f.data[5], 0x7FFF);
	assert_int_equal(f.data[6] << 8 | f.data[7], 0x8000);
}

static void test_non_finite_values_and_foreign_frames_are_refused(void **state)
{
	(void)state;
	const uint8_t d[8] = {0x00, 0x00, 0x03, 0xE8, 0x00, 0x7B, 0x01, 0xF4};
	struct omni4_can_frame f = frame(OMNI4_CAN_EFF_FLAG | 0x0901u, d);
	struct vesc_status1 s = {7, 7.0f, 7.0f};
	uint8_t id = 99;

	assert_int_equal(vesc_encode_set_duty(0, NAN, &f), -EINVAL);
	assert_int_equal(vesc_encode_set_current(0, INFINITY, &f), -EINVAL);
	assert_int_equal(vesc_encode_set_rpm(0, -INFINITY, &f), -EINVAL);
	f = frame(0x0901u, d); /* standard ID */
	assert_int_equal(vesc_decode_status1(&f, &id, &s), -EINVAL);
	f = frame(OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG | 0x0901u, d);
	assert_int_equal(vesc_decode_status1(&f, &id, &s), -EINVAL);
	f = frame(OMNI4_CAN_EFF_FLAG | 0x10901u, d); /* bit 16: unused bits set */
	assert_int_equal(vesc_decode_status1(&f, &id, &s), -EINVAL);
	f = frame(OMNI4_CAN_EFF_FLAG | 0x1001u, d); /* STATUS_4 */
	assert_int_equal(vesc_decode_status1(&f, &id, &s), -EINVAL);
	f = frame(OMNI4_CAN_EFF_FLAG | 0x0901u, d);
	f.dlc = 6;
	assert_int_equal(vesc_decode_status1(&f, &id, &s), -EINVAL);
	assert_int_equal(vesc_decode_command(&f, VESC_CMD_STATUS_1, &id, &s.current_a), -EINVAL);
	assert_int_equal(id, 99); /* outputs untouched */
	assert_int_equal(s.erpm, 7);
}

/* mc_fault_code in the firmware's datatypes.h: NONE = 0, then in order. */
static void test_fault_codes_have_their_names(void **state)
{
	(void)state;
	assert_string_equal(vesc_fault_name(0), "none");
	assert_string_equal(vesc_fault_name(2), "under_voltage");
	assert_string_equal(vesc_fault_name(5), "over_temp_fet");
	assert_string_equal(vesc_fault_name(33), "abs_overspeed");
	assert_string_equal(vesc_fault_name(34), "unknown");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_set_current_is_the_documents_example),
	    cmocka_unit_test(test_commands_have_the_documented_ids_scales_and_byte_order),
	    cmocka_unit_test(test_status1_written_by_hand_decodes_to_the_documented_values),
	    cmocka_unit_test(test_status4_and_5_written_by_hand_decode_to_the_documented_values),
	    cmocka_unit_test(test_commands_round_trip_within_half_an_lsb),
	    cmocka_unit_test(test_status_round_trips_within_half_an_lsb),
	    cmocka_unit_test(test_out_of_range_commands_saturate_to_the_field),
	    cmocka_unit_test(test_non_finite_values_and_foreign_frames_are_refused),
	    cmocka_unit_test(test_fault_codes_have_their_names),
	};

	return cmocka_run_group_tests_name("vesc_proto", tests, NULL, NULL);
}
