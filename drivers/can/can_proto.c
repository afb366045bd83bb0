/* can_proto.c - pack/unpack of the omni4 CAN frames (see can_proto.h and omni4.dbc). */
#include "omni4/drivers/can_proto.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define COUNTER_BIT 44
#define CRC_BIT 48

uint16_t can_crc16(const uint8_t *p, size_t n)
{
	uint16_t crc = 0xFFFF;

	for (size_t i = 0; i < n; i++) {
		crc ^= (uint16_t)(p[i] << 8);
		for (int b = 0; b < 8; b++)
			crc = (uint16_t)(crc & 0x8000 ? (crc << 1) ^ 0x1021 : crc << 1);
	}
	return crc;
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

uint16_t can_frame_crc(const struct omni4_can_frame *f)
{
	const unsigned data_id = CAN_DATA_ID(f->id);
	uint8_t buf[8];

	memcpy(buf, f->data, 6);
	buf[6] = (uint8_t)data_id;
	buf[7] = (uint8_t)(data_id >> 8);
	return can_crc16(buf, 8);
}

static void finish(uint32_t id, uint64_t w, uint8_t counter, struct omni4_can_frame *f)
{
	put(&w, COUNTER_BIT, 4, counter & 0xF);
	f->id = id;
	f->dlc = 8;
	store(w, f->data);
	const uint16_t crc = can_frame_crc(f);

	f->data[6] = (uint8_t)crc;
	f->data[7] = (uint8_t)(crc >> 8);
}

/* Reserved bits per frame (must be 0: a frame that sets them is not one of ours). Every frame
 * has at least 2, which the acceptance probability of docs/faults.md counts. */
#define RESERVED_CMD_VOLTAGE (0x7ull << 41)
#define RESERVED_CMD_CONTROL (((1ull << 36) - 1) << 8)
#define RESERVED_STATUS (0x3ull << 42)
#define RESERVED_HEALTH (((1ull << 10) - 1) << 34)

static int check(const struct omni4_can_frame *f, uint32_t id, uint64_t reserved, uint64_t *w,
                 uint8_t *counter)
{
	if (f->id != id || f->dlc != 8)
		return -EINVAL;
	*w = load(f->data);
	if (get(*w, CRC_BIT, 16) != can_frame_crc(f) || (*w & reserved))
		return -EBADMSG;
	if (counter)
		*counter = (uint8_t)get(*w, COUNTER_BIT, 4);
	return 0;
}

int can_encode_cmd_voltage(const float volts[4], bool enable, uint8_t counter,
                           struct omni4_can_frame *f)
{
	uint64_t w = 0, raw;

	for (unsigned j = 0; j < 4; j++) {
		if (to_raw(volts[j], CAN_VOLT_LSB, 10, &raw))
			return -ERANGE;
		put(&w, 10 * j, 10, raw);
	}
	put(&w, 40, 1, enable);
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
		volts[j] = (float)sign_extend(get(w, 10 * j, 10), 10) * CAN_VOLT_LSB;
	*enable = get(w, 40, 1);
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
		return -EBADMSG;
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
		if (to_raw(s->current_a[k], CAN_CURR_LSB, 10, &raw))
			return -ERANGE;
		put(&w, 10 * k, 10, raw);
		if (to_raw(s->speed_rad_s[k], CAN_SPEED_LSB, 11, &raw))
			return -ERANGE;
		put(&w, 20 + 11 * k, 11, raw);
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
		s->current_a[k] = (float)sign_extend(get(w, 10 * k, 10), 10) * CAN_CURR_LSB;
		s->speed_rad_s[k] = (float)sign_extend(get(w, 20 + 11 * k, 11), 11) * CAN_SPEED_LSB;
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
	put(&w, 32, 2, h->state);
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
	h->state = (uint8_t)get(w, 32, 2);
	if (h->state > CAN_STATE_FAULT)
		return -EBADMSG;
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
