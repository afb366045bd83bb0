/* libFuzzer target: raw LCM bytes -> command decoding -> validation -> mode logic -> ticks.
 * The input is split into messages (1 length byte + payload) and, for bytes that do not form
 * a command_t, into structured commands (so the controller sees valid encodings too).
 * Properties: no crash/UB; every output is finite, within the supply, and 0 when disabled. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/firmware/lcmcodec.h"
#include "omni4_command_t.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(const struct ctl *c, const struct ctl_output *o)
{
	for (int j = 0; j < 4; j++) {
		if (!isfinite(o->volts[j]) || fabsf(o->volts[j]) > c->set.limits.supply_v + 1e-3f)
			__builtin_trap();
		if (!o->enable && o->volts[j] != 0.0f)
			__builtin_trap();
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct ctl c;
	struct ctl_settings cfg;
	struct ctl_output out;
	int64_t now = 1000000;

	ctl_settings_defaults(&cfg);
	if (ctl_init(&c, &cfg))
		__builtin_trap();
	struct motor_sample s = {{0.1f, 0.1f, 0.1f, 0.1f}, {1, 1, 1, 1}, 12.0f, 0};

	while (size > 1) {
		const size_t n = data[0] < size - 1 ? data[0] : size - 1;
		struct ctl_command cmd;

		if (lcmio_decode_command(data + 1, n, &cmd) != 0 && n >= 8) {
			/* Not a command_t: build one from the bytes, values of every magnitude. */
			omni4_command_t m = {
			    .utime = now, .seq = data[1], .mode = (int8_t)(data[2] % 8 - 1)};
			const double scale[4] = {0.001, 1.0, 100.0, 1e12};

			for (int k = 0; k < 3; k++)
				m.velocity[k] =
				    (int8_t)data[1 + (k + 3) % n] * scale[data[1 + k] & 3];
			for (int k = 0; k < 4; k++)
				m.voltage[k] =
				    (int8_t)data[1 + (k + 4) % n] * scale[data[2 + k % 3] & 3] / 8;
			m.ramp_s = data[1 + 7 % n] == 0xFF ? NAN : data[1 + 7 % n] / 64.0;
			uint8_t buf[256];
			const int len = omni4_command_t_encode(buf, 0, sizeof(buf), &m);

			if (len <= 0 || lcmio_decode_command(buf, (size_t)len, &cmd) != 0)
				__builtin_trap();
		} else if (n < 8) {
			break;
		}
		ctl_command(&c, &cmd, now);
		for (int t = 0; t < 5; t++) {
			now += 1000;
			s.current_a[0] = (float)(data[0] & 0x1F) * 0.3f;
			ctl_step(&c, now, &s, 0, data[n] == 0xEE, &out);
			check(&c, &out);
		}
		data += n + 1;
		size -= n + 1;
	}
	for (int t = 0; t < 300; t++) { /* watchdog and stop ramps run to their end */
		now += 1000;
		ctl_step(&c, now, &s, 0, false, &out);
		check(&c, &out);
	}
	return 0;
}
