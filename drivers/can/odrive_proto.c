/* odrive_proto.c - pack/unpack of the ODrive CANSimple messages (see odrive_proto.h, odrive.dbc;
 * written from ODrive's "CAN Protocol" documents). */
#include "omni4/drivers/odrive_proto.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>

/* The wire's floats are IEEE 754 binary32: the host's float must be the same to copy its bits. */
_Static_assert(sizeof(float) == 4 && FLT_RADIX == 2 && FLT_MANT_DIG == 24 && FLT_MAX_EXP == 128,
               "float is not IEEE 754 binary32");

/* 4 bytes, least significant first. */
static void put_le32(uint8_t *p, uint32_t u)
{
	for (unsigned i = 0; i < 4; i++)
		p[i] = (uint8_t)(u >> (8 * i));
}

static uint32_t get_le32(const uint8_t *p)
{
	uint32_t u = 0;

	for (unsigned i = 0; i < 4; i++)
		u += (uint32_t)p[i] << (8 * i);
	return u;
}

static void put_f32(uint8_t *p, float v)
{
	uint32_t u;

	memcpy(&u, &v, sizeof(u));
	put_le32(p, u);
}

static float get_f32(const uint8_t *p)
{
	const uint32_t u = get_le32(p);
	float v;

	memcpy(&v, &u, sizeof(v));
	return v;
}

static int start(uint8_t node, enum odrive_cmd cmd, uint8_t dlc, struct omni4_can_frame *f)
{
	if (node > ODRIVE_NODE_MAX)
		return -EINVAL;
	memset(f, 0, sizeof(*f));
	f->id = ODRIVE_CAN_ID(node, cmd);
	f->dlc = dlc;
	return 0;
}

/* A data frame of the command with at least min_dlc bytes. */
static int check(const struct omni4_can_frame *f, enum odrive_cmd cmd, uint8_t min_dlc,
                 uint8_t *node)
{
	if (f->id & (OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG) || f->id > OMNI4_CAN_SFF_MASK ||
	    (f->id & 0x1Fu) != (uint32_t)cmd || f->dlc < min_dlc || f->dlc > 8)
		return -EINVAL;
	*node = (uint8_t)(f->id >> 5);
	return 0;
}

static int encode_two_f32(uint8_t node, enum odrive_cmd cmd, float a, float b,
                          struct omni4_can_frame *f)
{
	if (!isfinite(a) || !isfinite(b))
		return -EINVAL;
	const int rc = start(node, cmd, 8, f);

	if (rc)
		return rc;
	put_f32(f->data, a);
	put_f32(f->data + 4, b);
	return 0;
}

static int decode_two_f32(const struct omni4_can_frame *f, enum odrive_cmd cmd, uint8_t *node,
                          float *a, float *b)
{
	if (check(f, cmd, 8, node))
		return -EINVAL;
	*a = get_f32(f->data);
	*b = get_f32(f->data + 4);
	return 0;
}

int odrive_encode_estop(uint8_t node, struct omni4_can_frame *f)
{
	return start(node, ODRIVE_CMD_ESTOP, 0, f);
}

int odrive_encode_set_axis_state(uint8_t node, uint32_t state, struct omni4_can_frame *f)
{
	if (state > ODRIVE_AXIS_STATE_MAX)
		return -EINVAL;
	const int rc = start(node, ODRIVE_CMD_SET_AXIS_STATE, 8, f);

	if (rc)
		return rc;
	put_le32(f->data, state);
	return 0;
}

int odrive_encode_set_controller_mode(uint8_t node, enum odrive_control_mode control,
                                      enum odrive_input_mode input, struct omni4_can_frame *f)
{
	if ((unsigned)control > ODRIVE_CONTROL_POSITION || (unsigned)input > ODRIVE_INPUT_TUNING)
		return -EINVAL;
	const int rc = start(node, ODRIVE_CMD_SET_CONTROLLER_MODE, 8, f);

	if (rc)
		return rc;
	put_le32(f->data, (uint32_t)control);
	put_le32(f->data + 4, (uint32_t)input);
	return 0;
}

int odrive_encode_set_input_vel(uint8_t node, float vel_turn_s, float torque_ff_nm,
                                struct omni4_can_frame *f)
{
	return encode_two_f32(node, ODRIVE_CMD_SET_INPUT_VEL, vel_turn_s, torque_ff_nm, f);
}

int odrive_encode_set_input_torque(uint8_t node, float torque_nm, struct omni4_can_frame *f)
{
	if (!isfinite(torque_nm))
		return -EINVAL;
	const int rc = start(node, ODRIVE_CMD_SET_INPUT_TORQUE, 8, f);

	if (rc)
		return rc;
	put_f32(f->data, torque_nm);
	return 0;
}

int odrive_encode_clear_errors(uint8_t node, struct omni4_can_frame *f)
{
	return start(node, ODRIVE_CMD_CLEAR_ERRORS, 1, f); /* identify = 0 */
}

int odrive_encode_request(uint8_t node, enum odrive_cmd cmd, struct omni4_can_frame *f)
{
	if (cmd != ODRIVE_CMD_GET_ENCODER_ESTIMATES && cmd != ODRIVE_CMD_GET_IQ &&
	    cmd != ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT)
		return -EINVAL;
	const int rc =
	    start(node, cmd, 8, f); /* DLC of the answer, as CAN asks of a remote frame */

	if (rc)
		return rc;
	f->id |= OMNI4_CAN_RTR_FLAG;
	return 0;
}

int odrive_split_id(const struct omni4_can_frame *f, uint8_t *node, uint8_t *cmd)
{
	const uint32_t id = f->id & ~OMNI4_CAN_RTR_FLAG;

	if (id > OMNI4_CAN_SFF_MASK)
		return -EINVAL;
	*node = (uint8_t)(id >> 5);
	*cmd = (uint8_t)(id & 0x1Fu);
	return 0;
}

int odrive_decode_set_axis_state(const struct omni4_can_frame *f, uint8_t *node, uint32_t *state)
{
	if (check(f, ODRIVE_CMD_SET_AXIS_STATE, 4, node))
		return -EINVAL;
	*state = get_le32(f->data);
	return 0;
}

int odrive_decode_set_controller_mode(const struct omni4_can_frame *f, uint8_t *node,
                                      uint32_t *control, uint32_t *input)
{
	if (check(f, ODRIVE_CMD_SET_CONTROLLER_MODE, 8, node))
		return -EINVAL;
	*control = get_le32(f->data);
	*input = get_le32(f->data + 4);
	return 0;
}

int odrive_decode_set_input_vel(const struct omni4_can_frame *f, uint8_t *node, float *vel_turn_s,
                                float *torque_ff_nm)
{
	return decode_two_f32(f, ODRIVE_CMD_SET_INPUT_VEL, node, vel_turn_s, torque_ff_nm);
}

int odrive_decode_set_input_torque(const struct omni4_can_frame *f, uint8_t *node, float *torque_nm)
{
	if (check(f, ODRIVE_CMD_SET_INPUT_TORQUE, 4, node))
		return -EINVAL;
	*torque_nm = get_f32(f->data);
	return 0;
}

int odrive_encode_heartbeat(uint8_t node, const struct odrive_heartbeat *h,
                            struct omni4_can_frame *f)
{
	const int rc = start(node, ODRIVE_CMD_HEARTBEAT, 8, f);

	if (rc)
		return rc;
	put_le32(f->data, h->axis_error);
	f->data[4] = h->axis_state;
	f->data[5] = h->procedure_result;
	f->data[6] = h->trajectory_done ? 1 : 0;
	return 0;
}

int odrive_decode_heartbeat(const struct omni4_can_frame *f, uint8_t *node,
                            struct odrive_heartbeat *h)
{
	if (check(f, ODRIVE_CMD_HEARTBEAT, 8, node))
		return -EINVAL;
	h->axis_error = get_le32(f->data);
	h->axis_state = f->data[4];
	h->procedure_result = f->data[5];
	h->trajectory_done = f->data[6] & 1u;
	return 0;
}

int odrive_encode_encoder_estimates(uint8_t node, const struct odrive_encoder_estimates *e,
                                    struct omni4_can_frame *f)
{
	return encode_two_f32(node, ODRIVE_CMD_GET_ENCODER_ESTIMATES, e->pos_turn, e->vel_turn_s,
	                      f);
}

int odrive_decode_encoder_estimates(const struct omni4_can_frame *f, uint8_t *node,
                                    struct odrive_encoder_estimates *e)
{
	return decode_two_f32(f, ODRIVE_CMD_GET_ENCODER_ESTIMATES, node, &e->pos_turn,
	                      &e->vel_turn_s);
}

int odrive_encode_iq(uint8_t node, const struct odrive_iq *q, struct omni4_can_frame *f)
{
	return encode_two_f32(node, ODRIVE_CMD_GET_IQ, q->setpoint_a, q->measured_a, f);
}

int odrive_decode_iq(const struct omni4_can_frame *f, uint8_t *node, struct odrive_iq *q)
{
	return decode_two_f32(f, ODRIVE_CMD_GET_IQ, node, &q->setpoint_a, &q->measured_a);
}

int odrive_encode_bus(uint8_t node, const struct odrive_bus *b, struct omni4_can_frame *f)
{
	return encode_two_f32(node, ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT, b->voltage_v, b->current_a,
	                      f);
}

int odrive_decode_bus(const struct omni4_can_frame *f, uint8_t *node, struct odrive_bus *b)
{
	return decode_two_f32(f, ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT, node, &b->voltage_v,
	                      &b->current_a);
}

const char *odrive_error_name(uint32_t bit)
{
#define ODRIVE_ERROR_CASE(value, name)                                                             \
	case value:                                                                                \
		return name;
	switch (bit) {
		ODRIVE_ERRORS(ODRIVE_ERROR_CASE)
	default:
		return "unknown";
	}
#undef ODRIVE_ERROR_CASE
}

const char *odrive_axis_state_name(uint32_t state)
{
#define ODRIVE_STATE_CASE(value, name)                                                             \
	case value:                                                                                \
		return name;
	switch (state) {
		ODRIVE_AXIS_STATES(ODRIVE_STATE_CASE)
	default:
		return "unknown";
	}
#undef ODRIVE_STATE_CASE
}
