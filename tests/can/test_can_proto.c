/* Tests for drivers/can/can_proto.c: the motor-driver CAN protocol. */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "omni4/drivers/can_proto.h"

static void test_crc16_matches_the_ccitt_false_check_value(void **state)
{
	(void)state;
	/* The catalogue check value of CRC-16/CCITT-FALSE (IBM-3740) for "123456789" is 0x29B1. */
	assert_int_equal(can_crc16((const uint8_t *)"123456789", 9), 0x29B1);
}

/* A frame as the spec says (can_proto.h): bytes 6-7 = CRC-16 over bytes 0-5 + data ID. */
static void test_frame_layout_follows_the_specification(void **state)
{
	(void)state;
	const float v[4] = {0.04f, 0, 0, 0};
	struct omni4_can_frame f;

	assert_int_equal(can_encode_cmd_voltage(v, true, 0xA, &f), 0);
	assert_int_equal(f.data[0], 0x01); /* voltage_0 = 1 LSB */
	assert_int_equal(f.data[5], 0xA1); /* enable bit 40, counter bits 44-47 */
	const uint8_t crc_in[8] = {f.data[0], f.data[1], f.data[2], f.data[3],
	                           f.data[4], f.data[5], 0x10,      0x4F};
	const uint16_t crc = can_crc16(crc_in, 8);

	assert_int_equal(f.data[6], crc & 0xFF);
	assert_int_equal(f.data[7], crc >> 8);
}

static void test_cmd_voltage_round_trip_within_half_lsb(void **state)
{
	(void)state;
	const float v[4] = {12.0f, -12.0f, 0.015f, -20.48f};
	struct omni4_can_frame f;
	float out[4];
	bool en;
	uint8_t c;

	assert_int_equal(can_encode_cmd_voltage(v, true, 9, &f), 0);
	assert_int_equal(f.id, 0x010);
	assert_int_equal(f.dlc, 8);
	assert_int_equal(can_decode_cmd_voltage(&f, out, &en, &c), 0);
	for (int j = 0; j < 4; j++)
		assert_near(out[j], v[j], 0.02 + 1e-6);
	assert_true(en);
	assert_int_equal(c, 9);
}

static void test_status_and_health_round_trip(void **state)
{
	(void)state;
	const struct can_status s = {{1.234f, -10.2f}, {92.3f, -127.9f}};
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
		assert_near(s2.current_a[k], s.current_a[k], 0.01 + 1e-6);
		assert_near(s2.speed_rad_s[k], s.speed_rad_s[k], 0.0625 + 1e-5);
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
	const struct can_status fast = {{0, 0}, {0, 128.0f}};

	assert_int_equal(can_encode_cmd_voltage(big, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_cmd_voltage(nan_v, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_status(0, &s, 0, &f), -ERANGE);
	assert_int_equal(can_encode_status(0, &fast, 0, &f), -ERANGE);
	assert_int_equal(can_encode_status(2, &s, 0, &f), -EINVAL);
	/* The most negative raw value is in range (it decodes, so it must encode). */
	const float low[4] = {-20.48f, 20.44f, 0, 0};
	const float over[4] = {20.48f, 0, 0, 0};

	assert_int_equal(can_encode_cmd_voltage(low, true, 0, &f), 0);
	assert_int_equal(can_encode_cmd_voltage(over, true, 0, &f), -ERANGE);
	assert_int_equal(can_encode_control((enum can_control)7, 0, &f), -ERANGE);
}

/* CRC-16/CCITT has Hamming distance 4 at this length: every pattern of 1, 2 or 3 flipped bits
 * in the 64-bit frame is detected (all 43744 of them, for a command and a status frame). */
static bool crc_ok(const struct omni4_can_frame *g)
{
	const uint16_t crc = can_frame_crc(g);

	return g->data[6] == (crc & 0xFF) && g->data[7] == (crc >> 8);
}

static void flip(struct omni4_can_frame *g, int bit)
{
	g->data[bit / 8] ^= (uint8_t)(1u << (bit % 8));
}

static int flips_undetected(const struct omni4_can_frame *f, int *patterns)
{
	int undetected = 0;

	*patterns = 0;
	for (int a = 0; a < 64; a++) {
		struct omni4_can_frame g1 = *f;

		flip(&g1, a);
		undetected += crc_ok(&g1);
		++*patterns;
		for (int b = a + 1; b < 64; b++) {
			struct omni4_can_frame g2 = g1;

			flip(&g2, b);
			undetected += crc_ok(&g2);
			++*patterns;
			for (int c = b + 1; c < 64; c++) {
				struct omni4_can_frame g3 = g2;

				flip(&g3, c);
				undetected += crc_ok(&g3);
				++*patterns;
			}
		}
	}
	return undetected;
}

static void test_every_one_two_and_three_bit_error_is_detected(void **state)
{
	(void)state;
	const float v[4] = {1, 2, 3, 4};
	const struct can_status st = {{1.5f, -2.0f}, {30.0f, -12.5f}};
	struct omni4_can_frame f, g;
	float out[4];
	bool en;
	uint8_t c;

	int patterns;

	assert_int_equal(can_encode_cmd_voltage(v, false, 1, &f), 0);
	assert_int_equal(flips_undetected(&f, &patterns), 0);
	assert_int_equal(patterns, 64 + 2016 + 41664);
	for (int bit = 0; bit < 64; bit++) {
		g = f;
		g.data[bit / 8] ^= (uint8_t)(1u << (bit % 8));
		assert_int_equal(can_decode_cmd_voltage(&g, out, &en, &c), -EBADMSG);
	}
	assert_int_equal(can_encode_status(1, &st, 7, &g), 0);
	assert_int_equal(flips_undetected(&g, &patterns), 0);

	/* The data ID is covered: the same bytes under another ID are refused, even STATUS_0's
	 * under STATUS_1's ID (a frame of one node taken for the other's). */
	struct can_status s;
	int node;

	g = f;
	g.id = CAN_ID_STATUS(0);
	assert_int_equal(can_decode_status(&g, &node, &s, &c), -EBADMSG);
	assert_int_equal(can_encode_status(0, &st, 7, &g), 0);
	g.id = CAN_ID_STATUS(1);
	assert_int_equal(can_decode_status(&g, &node, &s, &c), -EBADMSG);
	g = f;
	g.dlc = 7;
	assert_int_equal(can_decode_cmd_voltage(&g, out, &en, &c), -EINVAL);
}

/* A frame with a correct CRC but a reserved bit set, or an undefined HEALTH state, is not ours. */
static void test_reserved_bits_are_checked(void **state)
{
	(void)state;
	const struct can_status st = {{1.5f, -2.0f}, {30.0f, -12.5f}};
	const struct can_health h = {0, 12.0f, 30, CAN_STATE_ENABLED};
	struct omni4_can_frame f;
	struct can_status s;
	struct can_health h2;
	int node;
	uint8_t c;

	assert_int_equal(can_encode_status(0, &st, 7, &f), 0);
	f.data[5] |= 0x04; /* bit 42 */
	const uint16_t crc = can_frame_crc(&f);

	f.data[6] = (uint8_t)crc;
	f.data[7] = (uint8_t)(crc >> 8);
	assert_int_equal(can_decode_status(&f, &node, &s, &c), -EBADMSG);
	assert_int_equal(can_encode_health(1, &h, 2, &f), 0);
	f.data[4] |= 0x03; /* state 3 */
	const uint16_t crc2 = can_frame_crc(&f);

	f.data[6] = (uint8_t)crc2;
	f.data[7] = (uint8_t)(crc2 >> 8);
	assert_int_equal(can_decode_health(&f, &node, &h2, &c), -EBADMSG);
}

static void test_counter_gap_finds_replays_and_losses(void **state)
{
	(void)state;
	assert_int_equal(can_counter_gap(3, 4), 0);
	assert_int_equal(can_counter_gap(15, 0), 0);
	assert_int_equal(can_counter_gap(7, 7), -EALREADY);
	assert_int_equal(can_counter_gap(7, 10), 2);
	assert_int_equal(can_counter_gap(7, 6), 14); /* one behind */
}

static void test_bus_load_at_1khz_is_below_half_of_1_mbit(void **state)
{
	(void)state;
	const double load = can_bus_load_1khz(1e6);

	assert_int_equal(can_frame_bits_worst(8), 135);
	/* The former CRC-8 format had the same frames (8 bytes each): 3 per tick + 2 HEALTH at
	 * 100 Hz = 3 x 135 + 0.2 x 135 = 432 bits per ms. */
	const double old_load = (3 * 135 + 0.2 * 135) * 1000.0 / 1e6;

	print_message("CAN bus load at 1 kHz, worst-case stuffing: %.1f %% of 1 Mbit/s "
	              "(CRC-16 E2E format; former CRC-8 format %.1f %%)\n",
	              100 * load, 100 * old_load);
	assert_near(load, 0.432, 0.0005);
	assert_true(load <= 0.5);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_crc16_matches_the_ccitt_false_check_value),
	    cmocka_unit_test(test_frame_layout_follows_the_specification),
	    cmocka_unit_test(test_cmd_voltage_round_trip_within_half_lsb),
	    cmocka_unit_test(test_status_and_health_round_trip),
	    cmocka_unit_test(test_out_of_range_values_are_refused_not_clipped),
	    cmocka_unit_test(test_every_one_two_and_three_bit_error_is_detected),
	    cmocka_unit_test(test_reserved_bits_are_checked),
	    cmocka_unit_test(test_counter_gap_finds_replays_and_losses),
	    cmocka_unit_test(test_bus_load_at_1khz_is_below_half_of_1_mbit),
	};

	return cmocka_run_group_tests_name("can_proto", tests, NULL, NULL);
}
