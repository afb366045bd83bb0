/* socketcan_motor.c - motor HAL over the omni4 CAN protocol (OS calls only via sc_os.h). */
#include "omni4/socketcan_motor.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "omni4_motors_t.h"
#include "omni4/sc_os.h"

int socketcan_motor_open(struct socketcan_motor *m, const char *iface, int status_timeout_ms)
{
	const uint32_t ids[] = {CAN_ID_STATUS(0), CAN_ID_STATUS(1), CAN_ID_HEALTH(0),
				CAN_ID_HEALTH(1)};

	memset(m, 0, sizeof(*m));
	m->fd = -1;
	if (status_timeout_ms <= 0)
		return -EINVAL;
	const int rc = sc_os_open(iface, ids, 4, &m->fd);

	if (rc)
		return rc;
	m->timeout_us = (int64_t)status_timeout_ms * 1000;
	for (int n = 0; n < CAN_NODES; n++)
		m->node[n].status_candidate = m->node[n].health_candidate = -1;
	m->opened_us = sc_os_now_us();
	return 0;
}

static int send_control(struct socketcan_motor *m, enum can_control cmd)
{
	struct omni4_can_frame f;

	can_encode_control(cmd, m->ctl_counter++, &f);
	const int rc = sc_os_send(m->fd, &f);

	if (rc)
		m->n.tx_dropped++;
	else
		m->n.tx_frames++;
	return rc;
}

static int sc_enable(void *ctx, bool on)
{
	struct socketcan_motor *m = ctx;

	m->enabled = on;
	return send_control(m, on ? CAN_CTL_ENABLE : CAN_CTL_DISABLE);
}

static int sc_write(void *ctx, const float volts[4])
{
	struct socketcan_motor *m = ctx;
	struct omni4_can_frame f;
	float v[4];

	/* The loop clamps to the supply; the frame's range is wider. Disabled: send zeros. */
	for (int j = 0; j < 4; j++)
		v[j] = m->enabled ? volts[j] : 0.0f;
	if (can_encode_cmd_voltage(v, m->enabled, m->cmd_counter, &f))
		return -ERANGE;
	m->cmd_counter = (m->cmd_counter + 1) & 0xF;
	const int rc = sc_os_send(m->fd, &f);

	if (rc) {
		m->n.tx_dropped++;
		return rc;
	}
	m->n.tx_frames++;
	return 0;
}

#define SC_MAX_LOST 2

/* Accept a frame's counter (see the policy in the header); losses and rejections counted. */
static bool counter_ok(struct socketcan_motor *m, bool have, uint8_t *last, int *candidate,
		       uint8_t now)
{
	if (have) {
		const int gap = can_counter_gap(*last, now);

		if (gap == -EALREADY || gap > SC_MAX_LOST) {
			if (gap != -EALREADY && *candidate >= 0 &&
			    can_counter_gap((uint8_t)*candidate, now) == 0) {
				*candidate = -1; /* two in a row: the sender moved on, resync */
				*last = now;
				return true;
			}
			*candidate = gap == -EALREADY ? -1 : now;
			m->n.replayed++;
			return false;
		}
		m->n.lost += (uint64_t)gap;
	}
	*candidate = -1;
	*last = now;
	return true;
}

static void handle(struct socketcan_motor *m, const struct omni4_can_frame *f, int64_t now)
{
	struct can_status s;
	struct can_health h;
	uint8_t c;
	int node, rc;

	if (f->id == CAN_ID_STATUS(0) || f->id == CAN_ID_STATUS(1)) {
		rc = can_decode_status(f, &node, &s, &c);
		if (rc) {
			m->n.crc_errors++;
			return;
		}
		struct sc_node *n = &m->node[node];

		if (!counter_ok(m, n->have_status, &n->status_counter, &n->status_candidate, c))
			return;
		n->status = s;
		n->last_status_us = now;
		n->have_status = true;
	} else if (f->id == CAN_ID_HEALTH(0) || f->id == CAN_ID_HEALTH(1)) {
		rc = can_decode_health(f, &node, &h, &c);
		if (rc) {
			m->n.crc_errors++;
			return;
		}
		struct sc_node *n = &m->node[node];

		if (!counter_ok(m, n->have_health, &n->health_counter, &n->health_candidate, c))
			return;
		n->health = h;
		n->last_health_us = now;
		n->have_health = true;
	}
}

static int sc_read(void *ctx, struct motor_sample *out)
{
	struct socketcan_motor *m = ctx;
	const int64_t now = sc_os_now_us();
	struct omni4_can_frame f;
	uint32_t err;
	int k, rc = 0;

	for (k = 0; k < SC_MAX_FRAMES_PER_READ; k++) {
		rc = sc_os_recv(m->fd, &f, &err);
		if (rc < 0)
			break;
		if (rc == 2) {
			m->n.error_frames++;
			if (err & SC_ERR_BUSOFF) {
				m->n.bus_off++;
				m->bus_off = true;
			}
			continue;
		}
		m->n.rx_frames++;
		handle(m, &f, now);
	}
	if (k == SC_MAX_FRAMES_PER_READ)
		m->n.flood_cut++;
	else if (rc != -EAGAIN && rc < 0)
		return rc;

	uint32_t faults = m->bus_off ? OMNI4_MOTORS_T_FAULT_BUS : 0;
	float supply = NAN;
	bool all = true;

	for (int n = 0; n < CAN_NODES; n++) {
		const struct sc_node *nd = &m->node[n];
		const int64_t since = nd->have_status ? nd->last_status_us : m->opened_us;

		if (now - since > m->timeout_us)
			faults |= OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT;
		all &= nd->have_status;
		if (nd->have_health) {
			if (nd->health.faults || nd->health.state == CAN_STATE_FAULT)
				faults |= OMNI4_MOTORS_T_FAULT_DRIVER;
			supply = isnan(supply) ? nd->health.supply_v : fminf(supply, nd->health.supply_v);
		}
		for (int c = 0; c < 2; c++) {
			out->current_a[2 * n + c] = nd->have_status ? nd->status.current_a[c] : NAN;
			out->wheel_rad_s[2 * n + c] = nd->have_status ? nd->status.speed_rad_s[c] : NAN;
		}
	}
	out->supply_v = supply;
	out->faults = faults;
	if (!all && !(faults & OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT))
		return -EAGAIN; /* still waiting for the first reports */
	if (!all) {
		/* Timed out before any report: a full sample of zeros with the fault set. */
		for (int j = 0; j < 4; j++) {
			if (isnan(out->current_a[j]))
				out->current_a[j] = 0.0f;
			if (isnan(out->wheel_rad_s[j]))
				out->wheel_rad_s[j] = 0.0f;
		}
	}
	return 0;
}

static int sc_clear_faults(void *ctx)
{
	struct socketcan_motor *m = ctx;

	m->bus_off = false;
	return send_control(m, CAN_CTL_CLEAR_FAULTS);
}

static void sc_close(void *ctx)
{
	struct socketcan_motor *m = ctx;
	static const float zero[4] = {0, 0, 0, 0};

	if (m->fd < 0)
		return;
	m->enabled = false;
	sc_write(m, zero);
	send_control(m, CAN_CTL_DISABLE);
	sc_os_close(m->fd);
	m->fd = -1;
}

const struct motor_hal_ops socketcan_motor_ops = {
	.enable = sc_enable,
	.write = sc_write,
	.read = sc_read,
	.clear_faults = sc_clear_faults,
	.close = sc_close,
};
