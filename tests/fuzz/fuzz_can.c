/* libFuzzer target: raw bytes -> CAN frame -> every decoder of the omni4 protocol.
 * Properties: no crash/UB; a frame that decodes carries the E2E CRC-16 of its data ID and
 * re-encodes to the identical 8 bytes (CRC included); decoded values lie in their signal
 * ranges; a frame whose CRC bytes are changed never decodes. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "omni4/drivers/can_proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void same_bytes(const struct omni4_can_frame *a, const struct omni4_can_frame *b)
{
	if (a->id != b->id || a->dlc != 8 || b->dlc != 8 || memcmp(a->data, b->data, 8))
		__builtin_trap();
}

static void crc_is_checked(const struct omni4_can_frame *f)
{
	const uint16_t crc = can_frame_crc(f);

	if (f->data[6] != (crc & 0xFF) || f->data[7] != (crc >> 8))
		__builtin_trap();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct omni4_can_frame f = {0}, g;

	if (size < 3)
		return 0;
	f.id = (uint32_t)(data[0] | (data[1] & 0x07) << 8);
	f.dlc = data[2] % 9;
	memcpy(f.data, data + 3, size - 3 > 8 ? 8 : size - 3);

	float v[4];
	bool en;
	uint8_t c;
	enum can_control cmd;
	struct can_status s;
	struct can_health h;
	int node, decoded = 0;

	if (can_decode_cmd_voltage(&f, v, &en, &c) == 0) {
		decoded++;
		for (int j = 0; j < 4; j++)
			if (!(fabsf(v[j]) <= 20.48f + 1e-3f))
				__builtin_trap();
		if (can_encode_cmd_voltage(v, en, c, &g) != 0)
			__builtin_trap();
		same_bytes(&f, &g);
	}
	if (can_decode_control(&f, &cmd, &c) == 0) {
		decoded++;
		if (can_encode_control(cmd, c, &g) != 0)
			__builtin_trap();
		same_bytes(&f, &g);
	}
	if (can_decode_status(&f, &node, &s, &c) == 0) {
		decoded++;
		for (int k = 0; k < 2; k++)
			if (!(fabsf(s.current_a[k]) <= 10.24f + 1e-3f) ||
			    !(fabsf(s.speed_rad_s[k]) <= 128.0f + 1e-3f))
				__builtin_trap();
		if (can_encode_status(node, &s, c, &g) != 0)
			__builtin_trap();
		same_bytes(&f, &g);
	}
	if (can_decode_health(&f, &node, &h, &c) == 0) {
		decoded++;
		if (h.state > CAN_STATE_FAULT || can_encode_health(node, &h, c, &g) != 0)
			__builtin_trap();
		same_bytes(&f, &g);
	}
	if (decoded) {
		if (decoded != 1)
			__builtin_trap(); /* one ID, one meaning */
		crc_is_checked(&f);
		g = f;
		g.data[6 + (data[0] & 1)] ^= (uint8_t)(1u << (data[1] % 8));
		if (can_decode_cmd_voltage(&g, v, &en, &c) == 0 ||
		    can_decode_control(&g, &cmd, &c) == 0 ||
		    can_decode_status(&g, &node, &s, &c) == 0 ||
		    can_decode_health(&g, &node, &h, &c) == 0)
			__builtin_trap();
	}
	(void)can_counter_gap(data[0], data[1]);
	return 0;
}
