/* libFuzzer target: raw bytes -> CAN frame -> every decoder of the omni4 protocol.
 * Properties: no crash/UB; a frame that decodes re-encodes to the identical bytes. */
#include <stdint.h>
#include <string.h>

#include "omni4/can_proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

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
	int node;

	if (can_decode_cmd_voltage(&f, v, &en, &c) == 0) {
		if (can_encode_cmd_voltage(v, en, c, &g) != 0 || memcmp(g.data, f.data, 7))
			__builtin_trap();
	}
	if (can_decode_control(&f, &cmd, &c) == 0 && can_encode_control(cmd, c, &g) != 0)
		__builtin_trap();
	if (can_decode_status(&f, &node, &s, &c) == 0) {
		if (can_encode_status(node, &s, c, &g) != 0 || memcmp(g.data, f.data, 7))
			__builtin_trap();
	}
	if (can_decode_health(&f, &node, &h, &c) == 0 && h.state <= CAN_STATE_FAULT) {
		if (can_encode_health(node, &h, c, &g) != 0)
			__builtin_trap();
	}
	(void)can_counter_gap(data[0], data[1]);
	return 0;
}
