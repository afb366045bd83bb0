/* odrive_motor.c - motor HAL over four ODrive axes, CANSimple (odrive_motor.h; OS calls only
 * via sc_os.h, frames via odrive_proto.h). */
#include "omni4/drivers/odrive_motor.h"
#include "omni4/drivers/sc_rx.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define TWO_PI 6.28318530717958647692

static int send_frame(struct odrive_motor *m, int rc_encode, const struct omni4_can_frame *f)
{
	if (rc_encode)
		return rc_encode;
	const int rc = sc_os_send(m->fd, f);

	if (rc)
		m->n.tx_dropped++;
	else
		m->n.tx_frames++;
	return rc;
}

/* Clear_Errors, torque control, closed loop: to each axis. 0 or the first send's error. */
static int start_axes(struct odrive_motor *m)
{
	struct omni4_can_frame f;
	int rc = 0;

	for (int j = 0; j < 4 && !rc; j++) {
		const uint8_t node = m->node[j];

		rc = send_frame(m, odrive_encode_clear_errors(node, &f), &f);
		if (!rc)
			rc = send_frame(
			    m,
			    odrive_encode_set_controller_mode(node, ODRIVE_CONTROL_TORQUE,
			                                      ODRIVE_INPUT_PASSTHROUGH, &f),
			    &f);
		if (!rc)
			rc = send_frame(
			    m,
			    odrive_encode_set_axis_state(node, ODRIVE_AXIS_STATE_CLOSED_LOOP, &f),
			    &f);
	}
	return rc;
}

static int check_config(const struct odrive_motor_config *cfg)
{
	if (cfg->status_timeout_ms <= 0 || cfg->mode != ODRIVE_MODE_TORQUE)
		return -EINVAL;
	for (int j = 0; j < 4; j++) {
		if (cfg->node[j] > ODRIVE_NODE_MAX)
			return -EINVAL;
		for (int k = 0; k < j; k++)
			if (cfg->node[k] == cfg->node[j])
				return -EINVAL;
	}
	return 0;
}

int odrive_motor_open(struct odrive_motor *m, const struct odrive_motor_config *cfg)
{
	struct sc_os_filter filt[6];

	memset(m, 0, sizeof(*m));
	m->fd = -1;
	tx_gate_init(&m->gate);
	if (check_config(cfg))
		return -EINVAL;
	for (int j = 0; j < 4; j++) {
		/* every data frame of node[j]: standard ID, the node in bits 10-5 */
		filt[j] = (struct sc_os_filter){.id = ODRIVE_CAN_ID(cfg->node[j], 0),
		                                .mask = SC_OS_MASK_EXACT_SFF & ~0x1Fu};
		m->node[j] = cfg->node[j];
		m->a[j].iq_a = m->a[j].bus_v = NAN;
	}
	/* the estimates and heartbeats of any node (data frames) */
	filt[4] = (struct sc_os_filter){.id = ODRIVE_CAN_ID(0, ODRIVE_CMD_GET_ENCODER_ESTIMATES),
	                                .mask = OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG | 0x1Fu};
	filt[5] = (struct sc_os_filter){.id = ODRIVE_CAN_ID(0, ODRIVE_CMD_HEARTBEAT),
	                                .mask = OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG | 0x1Fu};
	int rc = sc_os_open_filters(cfg->iface, filt, 6, &m->fd);

	if (rc) {
		m->fd = -1;
		return rc;
	}
	m->timeout_us = (int64_t)cfg->status_timeout_ms * 1000;
	m->consts = cfg->consts;
	rc = start_axes(m);
	if (rc) {
		sc_os_close(m->fd);
		m->fd = -1;
		return rc;
	}
	m->opened_us = m->last_read_us = sc_os_now_us();
	return 0;
}

void odrive_motor_set_consts(struct odrive_motor *m, const struct drive_consts *c)
{
	m->consts = *c;
}

static int odrive_enable(void *ctx, bool on)
{
	struct odrive_motor *m = ctx;

	m->enabled = on; /* the next write's torques say it */
	return 0;
}

/* Wheel speed after the gearbox [rad/s] from an encoder estimate; NaN before the first. */
static float wheel_speed(const struct odrive_motor *m, const struct odrive_axis *a)
{
	if (!a->have_estimate)
		return NAN;
	return (float)((double)a->vel_turn_s * TWO_PI / m->consts.gear);
}

/* This tick's remote frame: Get_Iq or Get_Bus_Voltage_Current of one axis, in turn. */
static int send_request(struct odrive_motor *m)
{
	const unsigned k = m->request++ % 8u;
	const enum odrive_cmd cmd = k % 2u ? ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT : ODRIVE_CMD_GET_IQ;
	struct omni4_can_frame f;

	return send_frame(m, odrive_encode_request(m->node[k / 2u], cmd, &f), &f);
}

/* Torque control and closed loop again for each axis whose heartbeat says IDLE without an
 * error, at most every ODRIVE_RESTART_PERIOD_US. 0 or the first send's error. */
static int restart_idle_axes(struct odrive_motor *m, int64_t now)
{
	struct omni4_can_frame f;
	int rc = 0;

	for (int j = 0; j < 4; j++) {
		struct odrive_axis *a = &m->a[j];

		if (!a->have_hb || a->hb.axis_state != ODRIVE_AXIS_STATE_IDLE || a->hb.axis_error ||
		    (a->restart_us && now - a->restart_us < ODRIVE_RESTART_PERIOD_US))
			continue;
		a->restart_us = now;
		int s =
		    send_frame(m,
		               odrive_encode_set_controller_mode(m->node[j], ODRIVE_CONTROL_TORQUE,
		                                                 ODRIVE_INPUT_PASSTHROUGH, &f),
		               &f);
		if (!s)
			s = send_frame(m,
			               odrive_encode_set_axis_state(
			                   m->node[j], ODRIVE_AXIS_STATE_CLOSED_LOOP, &f),
			               &f);
		if (s && !rc)
			rc = s;
	}
	return rc;
}

static int odrive_write(void *ctx, const float volts[4])
{
	struct odrive_motor *m = ctx;
	struct omni4_can_frame f;
	float w[4], cur[4];
	int rc = 0;

	for (int j = 0; j < 4; j++)
		w[j] = wheel_speed(m, &m->a[j]);
	drive_currents(&m->consts, volts, w, cur);
	if (!tx_gate_enter(&m->gate))
		return 0; /* halted: the crash path sent the last frames */
	for (int j = 0; j < 4; j++) {
		const float torque = (float)m->consts.w.Kt[j] * cur[j];
		const float nm = m->enabled && isfinite(torque) ? torque : 0.0f;
		const int s = send_frame(m, odrive_encode_set_input_torque(m->node[j], nm, &f), &f);

		if (s && !rc)
			rc = s;
	}
	const int s = send_request(m);
	const int r = restart_idle_axes(m, sc_os_now_us());

	tx_gate_leave(&m->gate);
	return rc ? rc : s ? s : r;
}

/* Set_Input_Torque 0, then Set_Axis_State IDLE, to each axis; the frames sent. */
static int send_stop(struct odrive_motor *m)
{
	struct omni4_can_frame f;
	int sent = 0;

	for (int j = 0; j < 4; j++)
		sent +=
		    send_frame(m, odrive_encode_set_input_torque(m->node[j], 0.0f, &f), &f) == 0;
	for (int j = 0; j < 4; j++)
		sent += send_frame(
		            m, odrive_encode_set_axis_state(m->node[j], ODRIVE_AXIS_STATE_IDLE, &f),
		            &f) == 0;
	return sent;
}

int odrive_motor_halt(struct odrive_motor *m)
{
	if (m->fd < 0 || !tx_gate_close(&m->gate, 20000))
		return 0;
	m->enabled = false;
	return send_stop(m);
}

static int axis_index(const struct odrive_motor *m, uint8_t node)
{
	for (int j = 0; j < 4; j++)
		if (m->node[j] == node)
			return j;
	return -1;
}

/* One data frame of one of our nodes. */
static void handle(struct odrive_motor *m, const struct omni4_can_frame *f, int64_t now)
{
	struct odrive_heartbeat hb;
	struct odrive_encoder_estimates e;
	struct odrive_iq q;
	struct odrive_bus b;
	uint8_t node, cmd;
	int j;

	if (odrive_split_id(f, &node, &cmd)) {
		m->n.other_frames++;
		return;
	}
	if ((j = axis_index(m, node)) < 0) {
		m->heard_other[node / 8u] |= (uint8_t)(1u << (node % 8u)); /* the filters' cmds */
		m->n.other_frames++;
		return;
	}
	struct odrive_axis *a = &m->a[j];

	if (odrive_decode_encoder_estimates(f, &node, &e) == 0) {
		a->vel_turn_s = e.vel_turn_s;
		a->last_estimate_us = now;
		a->have_estimate = true;
	} else if (odrive_decode_heartbeat(f, &node, &hb) == 0) {
		const uint32_t fresh = hb.axis_error & ~a->reported_errors;

		a->hb = hb;
		a->have_hb = true;
		a->seen_errors |= hb.axis_error;
		a->reported_errors = hb.axis_error ? a->reported_errors | fresh : 0;
		a->fault_pending |= fresh != 0;
	} else if (odrive_decode_iq(f, &node, &q) == 0) {
		a->iq_a = q.measured_a;
	} else if (odrive_decode_bus(f, &node, &b) == 0) {
		a->bus_v = b.voltage_v;
	} else {
		m->n.other_frames++;
	}
}

static int drain_frames(struct odrive_motor *m, int64_t now)
{
	const struct sc_rx_tally t = {&m->n.rx_frames, &m->n.error_frames, &m->n.bus_off,
	                              &m->bus_off};
	const int budget = sc_rx_budget(&m->last_read_us, now, ODRIVE_MAX_FRAMES_PER_READ,
	                                ODRIVE_MAX_READ_CATCHUP);
	struct omni4_can_frame f;
	int rc = 0;

	for (int k = 0; k < budget && (rc = sc_rx_next(m->fd, &t, &f)) > 0; k++)
		if (rc == 1)
			handle(m, &f, now);
	return rc < 0 ? rc : 0;
}

/* The sample from the axes' last frames; true if each has sent an estimate and an Iq. */
static bool fill_sample(const struct odrive_motor *m, struct motor_sample *out, int64_t now)
{
	uint32_t faults = m->bus_off ? HAL_FAULT_BUS : 0;
	float supply = NAN;
	bool all = true;

	for (int j = 0; j < 4; j++) {
		const struct odrive_axis *a = &m->a[j];
		const int64_t since = a->have_estimate ? a->last_estimate_us : m->opened_us;

		if (now - since > m->timeout_us)
			faults |= HAL_FAULT_DRIVER_TIMEOUT;
		if (a->fault_pending)
			faults |= HAL_FAULT_DRIVER;
		all &= a->have_estimate && !isnan(a->iq_a);
		if (!isnan(a->bus_v))
			supply = isnan(supply) ? a->bus_v : fminf(supply, a->bus_v);
		out->wheel_rad_s[j] = wheel_speed(m, a);
		out->current_a[j] = a->iq_a;
	}
	out->supply_v = supply;
	out->faults = faults;
	return all;
}

static int odrive_read(void *ctx, struct motor_sample *out)
{
	struct odrive_motor *m = ctx;
	const int64_t now = sc_os_now_us();
	const int rc = drain_frames(m, now);

	if (rc)
		return rc;
	const bool all = fill_sample(m, out, now);

	if (!all && !(out->faults & HAL_FAULT_DRIVER_TIMEOUT))
		return -EAGAIN; /* still waiting for the first reports */
	for (int j = 0; j < 4; j++) {
		m->a[j].fault_pending = false; /* this sample reports it */
		if (isnan(out->wheel_rad_s[j]))
			out->wheel_rad_s[j] = 0.0f;
		if (isnan(out->current_a[j]))
			out->current_a[j] = 0.0f;
	}
	return 0;
}

/* Clear_Errors and the start again (an axis that faulted dropped to idle). An error the drive
 * still has after it is reported again by the next heartbeat. */
static int odrive_clear_faults(void *ctx)
{
	struct odrive_motor *m = ctx;

	m->bus_off = false;
	for (int j = 0; j < 4; j++) {
		m->a[j].reported_errors = 0;
		m->a[j].fault_pending = false;
	}
	if (!tx_gate_enter(&m->gate))
		return 0;
	const int rc = start_axes(m);

	tx_gate_leave(&m->gate);
	return rc;
}

static void odrive_close(void *ctx)
{
	struct odrive_motor *m = ctx;

	if (m->fd < 0)
		return;
	if (tx_gate_enter(&m->gate)) {
		m->enabled = false;
		send_stop(m);
		tx_gate_leave(&m->gate);
	}
	sc_os_close(m->fd);
	m->fd = -1;
}

static void odrive_halt(void *ctx)
{
	odrive_motor_halt(ctx);
}

/* " name name" of the bits set in errors (a bit without a name: its value). */
static size_t append_bits(char *buf, size_t n, size_t at, uint32_t errors)
{
	for (int b = 0; b < 32 && at < n; b++) {
		const uint32_t bit = 1u << b;

		if (!(errors & bit))
			continue;
		const char *name = odrive_error_name(bit);
		const int k = strcmp(name, "unknown")
		                  ? snprintf(buf + at, n - at, " %s", name)
		                  : snprintf(buf + at, n - at, " 0x%08x", (unsigned)bit);

		at += k > 0 ? (size_t)k : 0;
	}
	return at;
}

const char *odrive_motor_fault_text(const struct odrive_motor *m, char *buf, size_t n)
{
	size_t at = 0;

	if (n == 0)
		return buf;
	buf[0] = '\0';
	for (int j = 0; j < 4 && at < n; j++) {
		if (!m->a[j].seen_errors)
			continue;
		const int k = snprintf(buf + at, n - at,
		                       "%swheel %d (node %u, error 0x%08x):", at ? "; " : "", j,
		                       (unsigned)m->node[j], (unsigned)m->a[j].seen_errors);

		at += k > 0 ? (size_t)k : 0;
		at = append_bits(buf, n, at, m->a[j].seen_errors);
	}
	if (at == 0)
		snprintf(buf, n, "none");
	return buf;
}

const struct motor_hal_ops odrive_motor_ops = {
    .enable = odrive_enable,
    .write = odrive_write,
    .read = odrive_read,
    .clear_faults = odrive_clear_faults,
    .halt = odrive_halt,
    .close = odrive_close,
};

int odrive_motor_poll_missing(struct odrive_motor *m)
{
	int missing = 0;

	drain_frames(m, sc_os_now_us());
	for (int j = 0; j < 4; j++)
		missing += !m->a[j].have_estimate;
	return missing;
}

const char *odrive_motor_missing_text(const struct odrive_motor *m, char *buf, size_t n)
{
	static const struct sc_missing w = {"no encoder estimate from", "node",
	                                    "; no other node heard", ODRIVE_NODE_MAX};
	bool have[4];

	for (int j = 0; j < 4; j++)
		have[j] = m->a[j].have_estimate;
	return sc_missing_text(&w, m->node, have, m->heard_other, buf, n);
}
