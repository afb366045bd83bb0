/* can_proto.c - pack/unpack of the omni4 CAN frames (see can_proto.h and omni4.dbc). */
#include "omni4/can_proto.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define COUNTER_BIT 52
#define CRC_BYTE 7

uint8_t can_crc8(const uint8_t *p, size_t n)
{
	uint8_t crc = 0xFF;

	for (size_t i = 0; i < n; i++) {
		crc ^= p[i];
		for (int b = 0; b < 8; b++)
			crc = (uint8_t)(crc & 0x80 ? (crc << 1) ^ 0x1D : crc << 1);
	}
	return crc ^ 0xFF;
}

static uint64_t load(const uint8_t d[8])
{
	uint64_t v = 0;

	for (int i = 7; i >= 0; i--)
		v = (v << 8) | d[i];
	return v;
}

static void store(uint64_t v, uint8_t d[8])
{
	for (int i = 0; i < 8; i++)
		d[i] = (uint8_t)(v >> (8 * i));
}

static void put(uint64_t *w, unsigned start, unsigned len, uint64_t raw)
{
	const uint64_t mask = (len == 64 ? ~0ull : ((1ull << len) - 1)) << start;

	*w = (*w & ~mask) | ((raw << start) & mask);
}

static uint64_t get(uint64_t w, unsigned start, unsigned len)
{
	return (w >> start) & ((1ull << len) - 1);
}

static int64_t sign_extend(uint64_t raw, unsigned len)
{
	const uint64_t sign = 1ull << (len - 1);

	return (int64_t)((raw ^ sign) - sign);
}

/* Scale a physical value to a signed raw field of len bits; -ERANGE if it does not fit
 * [-2^(len-1), 2^(len-1) - 1] LSB (the range every raw value decodes to) or is NaN. */
static int to_raw(float value, float lsb, unsigned len, uint64_t *raw)
{
	const float lim = (float)(1l << (len - 1));

	if (!(fabsf(value / lsb) <= lim + 0.5f))
		return -ERANGE;
	const long r = lroundf(value / lsb);

	if (r < -(1l << (len - 1)) || r > (1l << (len - 1)) - 1)
		return -ERANGE;
	*raw = (uint64_t)r & ((1ull << len) - 1);
	return 0;
}

static uint8_t frame_crc(uint32_t id, const uint8_t d[8])
{
	uint8_t buf[9] = {(uint8_t)id, (uint8_t)(id >> 8)};

	memcpy(buf + 2, d, 7);
	return can_crc8(buf, 9);
}

static void finish(uint32_t id, uint64_t w, uint8_t counter, struct omni4_can_frame *f)
{
	put(&w, COUNTER_BIT, 4, counter & 0xF);
	f->id = id;
	f->dlc = 8;
	store(w, f->data);
	f->data[CRC_BYTE] = frame_crc(id, f->data);
}

/* Reserved bits per frame (must be 0: a frame that sets them is not one of ours). */
#define RESERVED_CMD_VOLTAGE (0x7ull << 49)
#define RESERVED_CMD_CONTROL (((1ull << 44) - 1) << 8)
#define RESERVED_STATUS 0ull
#define RESERVED_HEALTH (((1ull << 12) - 1) << 40)

static int check(const struct omni4_can_frame *f, uint32_t id, uint64_t reserved, uint64_t *w,
		 uint8_t *counter)
{
	if (f->id != id || f->dlc != 8)
		return -EINVAL;
	if (f->data[CRC_BYTE] != frame_crc(f->id, f->data))
		return -EBADMSG;
	*w = load(f->data);
	if (*w & reserved)
		return -EINVAL;
	if (counter)
		*counter = (uint8_t)get(*w, COUNTER_BIT, 4);
	return 0;
}

int can_encode_cmd_voltage(const float volts[4], bool enable, uint8_t counter,
			   struct omni4_can_frame *f)
{
	uint64_t w = 0, raw;

	for (unsigned j = 0; j < 4; j++) {
		if (to_raw(volts[j], CAN_VOLT_LSB, 12, &raw))
			return -ERANGE;
		put(&w, 12 * j, 12, raw);
	}
	put(&w, 48, 1, enable);
	finish(CAN_ID_CMD_VOLTAGE, w, counter, f);
	return 0;
}

int can_decode_cmd_voltage(const struct omni4_can_frame *f, float volts[4], bool *enable,
			   uint8_t *counter)
{
	uint64_t w;
	const int rc = check(f, CAN_ID_CMD_VOLTAGE, RESERVED_CMD_VOLTAGE, &w, counter);

	if (rc)
		return rc;
	for (unsigned j = 0; j < 4; j++)
		volts[j] = (float)sign_extend(get(w, 12 * j, 12), 12) * CAN_VOLT_LSB;
	*enable = get(w, 48, 1);
	return 0;
}

int can_encode_control(enum can_control cmd, uint8_t counter, struct omni4_can_frame *f)
{
	if (cmd < CAN_CTL_ENABLE || cmd > CAN_CTL_CLEAR_FAULTS)
		return -ERANGE;
	finish(CAN_ID_CMD_CONTROL, (uint64_t)cmd, counter, f);
	return 0;
}

int can_decode_control(const struct omni4_can_frame *f, enum can_control *cmd, uint8_t *counter)
{
	uint64_t w;
	const int rc = check(f, CAN_ID_CMD_CONTROL, RESERVED_CMD_CONTROL, &w, counter);

	if (rc)
		return rc;
	const unsigned c = (unsigned)get(w, 0, 8);

	if (c < CAN_CTL_ENABLE || c > CAN_CTL_CLEAR_FAULTS)
		return -EINVAL;
	*cmd = (enum can_control)c;
	return 0;
}

int can_encode_status(int node, const struct can_status *s, uint8_t counter,
		      struct omni4_can_frame *f)
{
	uint64_t w = 0, raw;

	if (node < 0 || node >= CAN_NODES)
		return -EINVAL;
	for (unsigned k = 0; k < 2; k++) {
		if (to_raw(s->current_a[k], CAN_CURR_LSB, 12, &raw))
			return -ERANGE;
		put(&w, 12 * k, 12, raw);
		if (to_raw(s->speed_rad_s[k], CAN_SPEED_LSB, 14, &raw))
			return -ERANGE;
		put(&w, 24 + 14 * k, 14, raw);
	}
	finish(CAN_ID_STATUS(node), w, counter, f);
	return 0;
}

int can_decode_status(const struct omni4_can_frame *f, int *node, struct can_status *s,
		      uint8_t *counter)
{
	uint64_t w;
	int rc = -EINVAL;

	for (int n = 0; n < CAN_NODES && rc == -EINVAL; n++) {
		rc = check(f, CAN_ID_STATUS(n), RESERVED_STATUS, &w, counter);
		*node = n;
	}
	if (rc)
		return rc;
	for (unsigned k = 0; k < 2; k++) {
		s->current_a[k] = (float)sign_extend(get(w, 12 * k, 12), 12) * CAN_CURR_LSB;
		s->speed_rad_s[k] = (float)sign_extend(get(w, 24 + 14 * k, 14), 14) * CAN_SPEED_LSB;
	}
	return 0;
}

int can_encode_health(int node, const struct can_health *h, uint8_t counter,
		      struct omni4_can_frame *f)
{
	uint64_t w = 0;

	if (node < 0 || node >= CAN_NODES)
		return -EINVAL;
	if (!(h->supply_v >= 0.0f && h->supply_v <= 655.35f) || h->state > CAN_STATE_FAULT)
		return -ERANGE;
	put(&w, 0, 8, h->faults);
	put(&w, 8, 16, (uint64_t)lroundf(h->supply_v / 0.01f));
	put(&w, 24, 8, (uint8_t)h->temp_c);
	put(&w, 32, 8, h->state);
	finish(CAN_ID_HEALTH(node), w, counter, f);
	return 0;
}

int can_decode_health(const struct omni4_can_frame *f, int *node, struct can_health *h,
		      uint8_t *counter)
{
	uint64_t w;
	int rc = -EINVAL;

	for (int n = 0; n < CAN_NODES && rc == -EINVAL; n++) {
		rc = check(f, CAN_ID_HEALTH(n), RESERVED_HEALTH, &w, counter);
		*node = n;
	}
	if (rc)
		return rc;
	h->faults = (uint8_t)get(w, 0, 8);
	h->supply_v = (float)get(w, 8, 16) * 0.01f;
	h->temp_c = (int8_t)get(w, 24, 8);
	h->state = (uint8_t)get(w, 32, 8);
	return 0;
}

int can_counter_gap(uint8_t prev, uint8_t now)
{
	const int d = (now - prev) & 0xF;

	if (d == 0)
		return -EALREADY;
	return d - 1;
}

unsigned can_frame_bits_worst(unsigned n)
{
	/* 44 framing bits of a base frame; stuff bits over the 34 + 8n stuffable bits; IFS 3. */
	return 8 * n + 44 + (34 + 8 * n - 1) / 4 + 3;
}

double can_bus_load_1khz(double bitrate)
{
	const double per_ms = 3.0 * can_frame_bits_worst(8) + 2 * 0.1 * can_frame_bits_worst(8);

	return per_ms * 1000.0 / bitrate;
}
