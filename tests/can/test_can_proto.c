/* Tests for drivers/can/can_proto.c: the motor-driver CAN protocol. */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/can_proto.h"

static void test_crc8_matches_the_sae_j1850_check_value(void **state)
{
	(void)state;
	/* The catalogue check value of CRC-8/SAE-J1850 for "123456789" is 0x4B. */
	assert_int_equal(can_crc8((const uint8_t *)"123456789", 9), 0x4B);
}

static void test_cmd_voltage_round_trip_within_half_lsb(void **state)
{
	(void)state;
	const float v[4] = {12.0f, -12.0f, 0.004f, -20.47f};
	struct omni4_can_frame f;
	float out[4];
	bool en;
	uint8_t c;

	assert_int_equal(can_encode_cmd_voltage(v, true, 9, &f), 0);
	assert_int_equal(f.id, 0x010);
	assert_int_equal(f.dlc, 8);
	assert_int_equal(can_decode_cmd_voltage(&f, out, &en, &c), 0);
	for (int j = 0; j < 4; j++)
		assert_near(out[j], v[j], 0.005 + 1e-6);
	assert_true(en);
	assert_int_equal(c, 9);
}

static void test_status_and_health_round_trip(void **state)
{
	(void)state;
	const struct can_status s = {{1.234f, -10.2f}, {92.3f, -409.5f}};
	const struct can_health h = {CAN_DRV_OVERTEMP, 11.87f, -5, CAN_STATE_FAULT};
	struct omni4_can_frame f;
	struct can_status s2;
	struct can_health h2;
	int node;
	uint8_t c;

	assert_int_equal(can_encode_status(1, &s, 15, &f), 0);
	assert_int_equal(f.id, 0x021);
	assert_int_equal(can_decode_status(&f, &node, &s2, &c), 0);
	assert_int_equal(node, 1);
	assert_int_equal(c, 15);
	for (int k = 0; k < 2; k++) {
		assert_near(s2.current_a[k], s.current_a[k], 0.0025 + 1e-6);
		assert_near(s2.speed_rad_s[k], s.speed_rad_s[k], 0.025 + 1e-5);
	}
	assert_int_equal(can_encode_health(0, &h, 3, &f), 0);
	assert_int_equal(can_decode_health(&f, &node, &h2, &c), 0);
	assert_int_equal(node, 0);
	assert_int_equal(h2.faults, CAN_DRV_OVERTEMP);
	assert_near(h2.supply_v, 11.87, 0.005);
	assert_int_equal(h2.temp_c, -5);
	assert_int_equal(h2.state, CAN_STATE_FAULT);
}

static void test_out_of_range_values_are_refused_not_clipped(void **state)
{
	(void)state;
	struct omni4_can_frame f;
	const float big[4] = {0, 0, 21.0f, 0};
	const float nan_v[4] = {NAN, 0, 0, 0};
	const struct can_status s = {{11.0f, 0}, {0, 0}};

	assert_int_equal(can_encode_cmd_voltage(big, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_cmd_voltage(nan_v, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_status(0, &s, 0, &f), -ERANGE);
	assert_int_equal(can_encode_status(2, &s, 0, &f), -EINVAL);
	/* The most negative raw value is in range (it decodes, so it must encode). */
	const float low[4] = {-20.48f, 20.47f, 0, 0};
	const float over[4] = {20.48f, 0, 0, 0};

	assert_int_equal(can_encode_cmd_voltage(low, true, 0, &f), 0);
	assert_int_equal(can_encode_cmd_voltage(over, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_control((enum can_control)7, 0, &f), -ERANGE);
}

static void test_every_single_bit_flip_is_detected(void **state)
{
	(void)state;
	const float v[4] = {1, 2, 3, 4};
	struct omni4_can_frame f, g;
	float out[4];
	bool en;
	uint8_t c;

	assert_int_equal(can_encode_cmd_voltage(v, false, 1, &f), 0);
	for (int bit = 0; bit < 64; bit++) {
		g = f;
		g.data[bit / 8] ^= (uint8_t)(1u << (bit % 8));
		assert_int_equal(can_decode_cmd_voltage(&g, out, &en, &c), -EBADMSG);
	}
	/* The ID is covered too: the same payload under another ID is refused. */
	g = f;
	g.id = CAN_ID_STATUS(0);
	struct can_status s;
	int node;

	assert_int_equal(can_decode_status(&g, &node, &s, &c), -EBADMSG);
	g.dlc = 7;
	g.id = f.id;
	assert_int_equal(can_decode_cmd_voltage(&g, out, &en, &c), -EINVAL);
}

static void test_counter_gap_finds_replays_and_losses(void **state)
{
	(void)state;
	assert_int_equal(can_counter_gap(3, 4), 0);
	assert_int_equal(can_counter_gap(15, 0), 0);
	assert_int_equal(can_counter_gap(7, 7), -EALREADY);
	assert_int_equal(can_counter_gap(7, 10), 2);
}

static void test_bus_load_at_1khz_is_below_half_of_1_mbit(void **state)
{
	(void)state;
	const double load = can_bus_load_1khz(1e6);

	assert_int_equal(can_frame_bits_worst(8), 135);
	print_message("CAN bus load at 1 kHz, worst-case stuffing: %.1f %% of 1 Mbit/s\n",
		      100 * load);
	assert_true(load <= 0.5);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_crc8_matches_the_sae_j1850_check_value),
		cmocka_unit_test(test_cmd_voltage_round_trip_within_half_lsb),
		cmocka_unit_test(test_status_and_health_round_trip),
		cmocka_unit_test(test_out_of_range_values_are_refused_not_clipped),
		cmocka_unit_test(test_every_single_bit_flip_is_detected),
		cmocka_unit_test(test_counter_gap_finds_replays_and_losses),
		cmocka_unit_test(test_bus_load_at_1khz_is_below_half_of_1_mbit),
	};

	return cmocka_run_group_tests_name("can_proto", tests, NULL, NULL);
}
