/* vesc_proto.c - pack/unpack of the VESC single-frame CAN messages (see vesc_proto.h, vesc.dbc;
 * written from the VESC document "VESC CAN-Bus Communication", documentation/comm_can.md). */
#include "omni4/drivers/vesc_proto.h"

#include <errno.h>
#include <math.h>
#include <string.h>

/* Round to nearest and saturate to [lo, hi]; x finite. (float)INT32_MAX is 2^31, so anything
 * that passes the first test fits a long. */
static int32_t sat_round(float x, int32_t lo, int32_t hi)
{
	if (x >= (float)hi)
		return hi;
	if (x <= (float)lo)
		return lo;
	return (int32_t)lroundf(x);
}

static int32_t sat_i32(float x)
{
	return sat_round(x, INT32_MIN, INT32_MAX);
}

static int16_t sat_i16(float x)
{
	return (int16_t)sat_round(x, INT16_MIN, INT16_MAX);
}

/* n bytes, most significant first. */
static void put_be(uint8_t *p, uint32_t u, unsigned n)
{
	for (unsigned i = 0; i < n; i++)
		p[i] = (uint8_t)(u >> (8 * (n - 1 - i)));
}

static uint32_t get_be(const uint8_t *p, unsigned n)
{
	uint32_t u = 0;

	for (unsigned i = 0; i < n; i++)
		u = (u << 8) + p[i];
	return u;
}

static void put_be32(uint8_t *p, int32_t v)
{
	put_be(p, (uint32_t)v, 4);
}

static void put_be16(uint8_t *p, int16_t v)
{
	put_be(p, (uint16_t)v, 2);
}

/* Two's complement without an implementation-defined conversion. */
static int32_t get_be32(const uint8_t *p)
{
	const uint32_t u = get_be(p, 4);

	return u <= INT32_MAX ? (int32_t)u : (int32_t)(u - 0x80000000u) - INT32_MAX - 1;
}

static int16_t get_be16(const uint8_t *p)
{
	const int32_t u = (int32_t)get_be(p, 2);

	return (int16_t)(u <= INT16_MAX ? u : u - 65536);
}

static void start(enum vesc_cmd cmd, uint8_t controller, uint8_t dlc, struct omni4_can_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->id = VESC_CAN_ID(cmd, controller);
	f->dlc = dlc;
}

/* A frame of ours: extended data frame, bits 28-16 clear, the command, the length. */
static int check(const struct omni4_can_frame *f, enum vesc_cmd cmd, uint8_t dlc,
                 uint8_t *controller)
{
	if (!(f->id & OMNI4_CAN_EFF_FLAG) || (f->id & OMNI4_CAN_RTR_FLAG) ||
	    ((f->id & OMNI4_CAN_EFF_MASK) >> 8) != (uint32_t)cmd || f->dlc != dlc)
		return -EINVAL;
	*controller = (uint8_t)(f->id & 0xFFu);
	return 0;
}

static int encode_command(enum vesc_cmd cmd, uint8_t controller, float value, float scale,
                          struct omni4_can_frame *f)
{
	if (!isfinite(value))
		return -EINVAL;
	start(cmd, controller, 4, f);
	put_be32(f->data, sat_i32(value * scale));
	return 0;
}

int vesc_encode_set_duty(uint8_t controller, float duty, struct omni4_can_frame *f)
{
	if (isfinite(duty))
		duty = fmaxf(-1.0f, fminf(1.0f, duty));
	return encode_command(VESC_CMD_SET_DUTY, controller, duty, VESC_SCALE_DUTY, f);
}

int vesc_encode_set_current(uint8_t controller, float current_a, struct omni4_can_frame *f)
{
	return encode_command(VESC_CMD_SET_CURRENT, controller, current_a, VESC_SCALE_CURRENT, f);
}

int vesc_encode_set_current_brake(uint8_t controller, float current_a, struct omni4_can_frame *f)
{
	return encode_command(VESC_CMD_SET_CURRENT_BRAKE, controller, current_a, VESC_SCALE_CURRENT,
	                      f);
}

int vesc_encode_set_rpm(uint8_t controller, float erpm, struct omni4_can_frame *f)
{
	return encode_command(VESC_CMD_SET_RPM, controller, erpm, 1.0f, f);
}

int vesc_decode_command(const struct omni4_can_frame *f, enum vesc_cmd cmd, uint8_t *controller,
                        float *value)
{
	float scale;

	switch (cmd) {
	case VESC_CMD_SET_DUTY:
		scale = VESC_SCALE_DUTY;
		break;
	case VESC_CMD_SET_CURRENT:
	case VESC_CMD_SET_CURRENT_BRAKE:
		scale = VESC_SCALE_CURRENT;
		break;
	case VESC_CMD_SET_RPM:
		scale = 1.0f;
		break;
	default:
		return -EINVAL;
	}
	if (check(f, cmd, 4, controller))
		return -EINVAL;
	*value = (float)get_be32(f->data) / scale;
	return 0;
}

int vesc_encode_status1(uint8_t controller, const struct vesc_status1 *s, struct omni4_can_frame *f)
{
	if (!isfinite(s->current_a) || !isfinite(s->duty))
		return -EINVAL;
	start(VESC_CMD_STATUS_1, controller, 8, f);
	put_be32(f->data, s->erpm);
	put_be16(f->data + 4, sat_i16(s->current_a * VESC_SCALE_STATUS_CURRENT));
	put_be16(f->data + 6, sat_i16(s->duty * VESC_SCALE_STATUS_DUTY));
	return 0;
}

int vesc_decode_status1(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status1 *s)
{
	if (check(f, VESC_CMD_STATUS_1, 8, controller))
		return -EINVAL;
	s->erpm = get_be32(f->data);
	s->current_a = (float)get_be16(f->data + 4) / VESC_SCALE_STATUS_CURRENT;
	s->duty = (float)get_be16(f->data + 6) / VESC_SCALE_STATUS_DUTY;
	return 0;
}

int vesc_encode_status4(uint8_t controller, const struct vesc_status4 *s, struct omni4_can_frame *f)
{
	if (!isfinite(s->temp_fet_c) || !isfinite(s->temp_motor_c) || !isfinite(s->current_in_a) ||
	    !isfinite(s->pid_pos_deg))
		return -EINVAL;
	start(VESC_CMD_STATUS_4, controller, 8, f);
	put_be16(f->data, sat_i16(s->temp_fet_c * VESC_SCALE_TEMP));
	put_be16(f->data + 2, sat_i16(s->temp_motor_c * VESC_SCALE_TEMP));
	put_be16(f->data + 4, sat_i16(s->current_in_a * VESC_SCALE_STATUS_CURRENT));
	put_be16(f->data + 6, sat_i16(s->pid_pos_deg * VESC_SCALE_PID_POS));
	return 0;
}

int vesc_decode_status4(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status4 *s)
{
	if (check(f, VESC_CMD_STATUS_4, 8, controller))
		return -EINVAL;
	s->temp_fet_c = (float)get_be16(f->data) / VESC_SCALE_TEMP;
	s->temp_motor_c = (float)get_be16(f->data + 2) / VESC_SCALE_TEMP;
	s->current_in_a = (float)get_be16(f->data + 4) / VESC_SCALE_STATUS_CURRENT;
	s->pid_pos_deg = (float)get_be16(f->data + 6) / VESC_SCALE_PID_POS;
	return 0;
}

int vesc_encode_status5(uint8_t controller, const struct vesc_status5 *s, struct omni4_can_frame *f)
{
	if (!isfinite(s->input_v))
		return -EINVAL;
	start(VESC_CMD_STATUS_5, controller, 8, f);
	put_be32(f->data, s->tacho_steps);
	put_be16(f->data + 4, sat_i16(s->input_v * VESC_SCALE_VOLTAGE));
	return 0; /* bytes 6-7 reserved, 0 */
}

int vesc_decode_status5(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status5 *s)
{
	if (check(f, VESC_CMD_STATUS_5, 8, controller))
		return -EINVAL;
	s->tacho_steps = get_be32(f->data);
	s->input_v = (float)get_be16(f->data + 4) / VESC_SCALE_VOLTAGE;
	return 0;
}

int vesc_encode_fault_request(uint8_t controller, uint8_t host, struct omni4_can_frame *f)
{
	if (controller == host || controller == VESC_ID_BROADCAST || host == VESC_ID_BROADCAST)
		return -EINVAL;
	start(VESC_CMD_PROCESS_SHORT_BUFFER, controller, 7, f);
	f->data[0] = host;
	f->data[1] = VESC_BUFFER_PROCESS;
	f->data[2] = VESC_COMM_GET_VALUES_SELECTIVE;
	put_be(f->data + 3, VESC_VALUES_FAULT_CODE, 4);
	return 0;
}

int vesc_decode_fault_reply(const struct omni4_can_frame *f, uint8_t host, uint8_t *controller,
                            uint8_t *code)
{
	uint8_t to;

	if (check(f, VESC_CMD_PROCESS_SHORT_BUFFER, 8, &to) || to != host ||
	    f->data[1] != VESC_BUFFER_REPLY || f->data[2] != VESC_COMM_GET_VALUES_SELECTIVE ||
	    get_be(f->data + 3, 4) != VESC_VALUES_FAULT_CODE)
		return -EINVAL;
	*controller = f->data[0];
	*code = f->data[7];
	return 0;
}

const char *vesc_fault_name(uint32_t code)
{
#define VESC_FAULT_CASE(value, name)                                                               \
	case value:                                                                                \
		return name;
	switch (code) {
		VESC_FAULTS(VESC_FAULT_CASE)
	default:
		return "unknown";
	}
#undef VESC_FAULT_CASE
}
