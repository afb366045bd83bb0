/* vesc_motor.c - motor HAL over four VESC controllers (vesc_motor.h; OS calls only via
 * sc_os.h, frames via vesc_proto.h). */
#include "omni4/drivers/vesc_motor.h"
#include "omni4/drivers/sc_rx.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define TWO_PI 6.28318530717958647692

static int check_config(const struct vesc_motor_config *cfg)
{
	if (cfg->pole_pairs < 1 || cfg->status_timeout_ms <= 0 ||
	    (cfg->mode != VESC_MODE_DUTY && cfg->mode != VESC_MODE_CURRENT) ||
	    cfg->host_id == VESC_ID_BROADCAST)
		return -EINVAL;
	for (int j = 0; j < 4; j++) {
		if (cfg->id[j] == VESC_ID_BROADCAST || cfg->id[j] == cfg->host_id)
			return -EINVAL;
		for (int k = 0; k < j; k++)
			if (cfg->id[k] == cfg->id[j])
				return -EINVAL;
	}
	return 0;
}

int vesc_motor_open(struct vesc_motor *m, const struct vesc_motor_config *cfg)
{
	struct sc_os_filter filt[6];

	memset(m, 0, sizeof(*m));
	m->fd = -1;
	tx_gate_init(&m->gate);
	if (check_config(cfg))
		return -EINVAL;
	for (int j = 0; j < 4; j++) {
		/* every frame of controller id[j]: extended, bits 28-16 zero, low byte the id */
		filt[j] = (struct sc_os_filter){.id = OMNI4_CAN_EFF_FLAG | cfg->id[j],
		                                .mask = OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG |
		                                        0x1FFF00FFu};
		m->id[j] = cfg->id[j];
		m->d[j].input_v = NAN;
	}
	/* STATUS_1 of any id; the fault code replies addressed to us */
	filt[4] =
	    (struct sc_os_filter){.id = VESC_CAN_ID(VESC_CMD_STATUS_1, 0),
	                          .mask = OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG | 0x1FFFFF00u};
	filt[5] =
	    (struct sc_os_filter){.id = VESC_CAN_ID(VESC_CMD_PROCESS_SHORT_BUFFER, cfg->host_id),
	                          .mask = SC_OS_MASK_EXACT_EFF};
	const int rc = sc_os_open_filters(cfg->iface, filt, 6, &m->fd);

	if (rc) {
		m->fd = -1;
		return rc;
	}
	m->host_id = cfg->host_id;
	m->pole_pairs = cfg->pole_pairs;
	m->mode = cfg->mode;
	m->timeout_us = (int64_t)cfg->status_timeout_ms * 1000;
	m->consts = cfg->consts;
	m->opened_us = m->last_read_us = sc_os_now_us();
	return 0;
}

void vesc_motor_set_consts(struct vesc_motor *m, const struct drive_consts *c)
{
	m->consts = *c;
}

static int send_frame(struct vesc_motor *m, const struct omni4_can_frame *f)
{
	const int rc = sc_os_send(m->fd, f);

	if (rc)
		m->n.tx_dropped++;
	else
		m->n.tx_frames++;
	return rc;
}

static int vesc_enable(void *ctx, bool on)
{
	struct vesc_motor *m = ctx;

	m->enabled = on; /* nothing to send: the next write says it */
	return 0;
}

/* Wheel speed after the gearbox [rad/s] from a STATUS_1's ERPM; NaN before the first. */
static float wheel_speed(const struct vesc_motor *m, const struct vesc_drive *d)
{
	if (!d->have_status1)
		return NAN;
	const double motor_rpm = (double)d->s1.erpm / m->pole_pairs;

	return (float)(motor_rpm * TWO_PI / 60.0 / m->consts.gear);
}

/* This tick's command to controller j for volts; SET_CURRENT 0 (release) when disabled or
 * when what it is computed from is not measured yet. */
static int encode_command(const struct vesc_motor *m, int j, float volts, float current_a,
                          struct omni4_can_frame *f)
{
	const float supply = m->d[j].input_v;

	if (!m->enabled)
		return vesc_encode_set_current(m->id[j], 0.0f, f);
	if (m->mode == VESC_MODE_CURRENT)
		return vesc_encode_set_current(m->id[j], isfinite(current_a) ? current_a : 0.0f, f);
	if (!(supply > 0.0f))
		return vesc_encode_set_current(m->id[j], 0.0f, f);
	const float duty = fmaxf(-VESC_DUTY_MAX, fminf(VESC_DUTY_MAX, volts / supply));

	return vesc_encode_set_duty(m->id[j], duty, f);
}

/* Every VESC_FAULT_POLL_TICKS-th write: the fault code request to one controller in turn. */
static int send_fault_request(struct vesc_motor *m)
{
	const uint32_t k = m->writes++;
	struct omni4_can_frame f;

	if (k % VESC_FAULT_POLL_TICKS)
		return 0;
	if (vesc_encode_fault_request(m->id[(k / VESC_FAULT_POLL_TICKS) % 4u], m->host_id, &f))
		return -ERANGE;
	return send_frame(m, &f);
}

static int vesc_write(void *ctx, const float volts[4])
{
	struct vesc_motor *m = ctx;
	struct omni4_can_frame f;
	float w[4], cur[4];
	int rc = 0;

	for (int j = 0; j < 4; j++)
		w[j] = wheel_speed(m, &m->d[j]);
	drive_currents(&m->consts, volts, w, cur);
	if (!tx_gate_enter(&m->gate))
		return 0; /* halted: the crash path sent the last frames */
	for (int j = 0; j < 4; j++) {
		if (encode_command(m, j, volts[j], cur[j], &f)) {
			rc = -ERANGE;
			continue;
		}
		const int s = send_frame(m, &f);

		if (s && !rc)
			rc = s;
	}
	const int s = send_fault_request(m);

	tx_gate_leave(&m->gate);
	return rc ? rc : s;
}

/* The stop command of the mode, twice to each controller; the frames sent. */
static int send_stop(struct vesc_motor *m)
{
	struct omni4_can_frame f;
	int sent = 0;

	for (int k = 0; k < 2; k++)
		for (int j = 0; j < 4; j++) {
			if (m->mode == VESC_MODE_DUTY)
				vesc_encode_set_duty(m->id[j], 0.0f, &f);
			else
				vesc_encode_set_current(m->id[j], 0.0f, &f);
			sent += send_frame(m, &f) == 0;
		}
	return sent;
}

int vesc_motor_halt(struct vesc_motor *m)
{
	if (m->fd < 0 || !tx_gate_close(&m->gate, 20000))
		return 0;
	m->enabled = false;
	return send_stop(m);
}

static int drive_index(const struct vesc_motor *m, uint8_t id)
{
	for (int j = 0; j < 4; j++)
		if (m->id[j] == id)
			return j;
	return -1;
}

/* A fault code reply of controller j: a code other than the one reported is news. */
static void take_fault(struct vesc_drive *d, uint8_t code)
{
	d->fault_code = code;
	if (code && code != d->reported_fault)
		d->fault_pending = true;
	if (!code)
		d->reported_fault = 0;
	else
		d->last_fault = code;
}

static void handle(struct vesc_motor *m, const struct omni4_can_frame *f, int64_t now)
{
	struct vesc_status1 s1;
	struct vesc_status5 s5;
	uint8_t id, code;
	int j;

	if (vesc_decode_status1(f, &id, &s1) == 0) {
		if ((j = drive_index(m, id)) < 0) {
			m->heard_other[id / 8u] |= (uint8_t)(1u << (id % 8u));
			m->n.other_frames++;
			return;
		}
		m->d[j].s1 = s1;
		m->d[j].last_status1_us = now;
		m->d[j].have_status1 = true;
	} else if (vesc_decode_status5(f, &id, &s5) == 0 && (j = drive_index(m, id)) >= 0) {
		m->d[j].input_v = s5.input_v;
	} else if (vesc_decode_fault_reply(f, m->host_id, &id, &code) == 0 &&
	           (j = drive_index(m, id)) >= 0) {
		take_fault(&m->d[j], code);
	} else {
		m->n.other_frames++; /* STATUS_4 and the rest: not used */
	}
}

/* Frames this read may take: VESC_MAX_FRAMES_PER_READ per millisecond since the previous read
 * (at least 1 ms' worth, at most VESC_MAX_READ_CATCHUP ms'). */
static int read_budget(struct vesc_motor *m, int64_t now)
{
	return sc_rx_budget(&m->last_read_us, now, VESC_MAX_FRAMES_PER_READ, VESC_MAX_READ_CATCHUP);
}

static int drain_frames(struct vesc_motor *m, int64_t now)
{
	const struct sc_rx_tally t = {&m->n.rx_frames, &m->n.error_frames, &m->n.bus_off,
	                              &m->bus_off};
	const int budget = read_budget(m, now);
	struct omni4_can_frame f;
	int rc = 0;

	for (int k = 0; k < budget && (rc = sc_rx_next(m->fd, &t, &f)) > 0; k++)
		if (rc == 1)
			handle(m, &f, now);
	return rc < 0 ? rc : 0;
}

/* The sample from the controllers' last frames; true if each has sent a STATUS_1. */
static bool fill_sample(const struct vesc_motor *m, struct motor_sample *out, int64_t now)
{
	uint32_t faults = m->bus_off ? HAL_FAULT_BUS : 0;
	float supply = NAN;
	bool all = true;

	for (int j = 0; j < 4; j++) {
		const struct vesc_drive *d = &m->d[j];
		const int64_t since = d->have_status1 ? d->last_status1_us : m->opened_us;

		if (now - since > m->timeout_us)
			faults |= HAL_FAULT_DRIVER_TIMEOUT;
		if (d->fault_pending)
			faults |= HAL_FAULT_DRIVER;
		all &= d->have_status1;
		if (!isnan(d->input_v))
			supply = isnan(supply) ? d->input_v : fminf(supply, d->input_v);
		out->wheel_rad_s[j] = wheel_speed(m, d);
		out->current_a[j] = d->have_status1 ? d->s1.current_a : NAN;
	}
	/* the most a VESC applies: the controller bounds its outputs by it (duty clamped) */
	out->supply_v = VESC_DUTY_MAX * supply;
	out->faults = faults;
	return all;
}

/* A sample is handed out: the fault codes it carries are reported. */
static void faults_reported(struct vesc_motor *m)
{
	for (int j = 0; j < 4; j++)
		if (m->d[j].fault_pending) {
			m->d[j].fault_pending = false;
			m->d[j].reported_fault = m->d[j].fault_code;
		}
}

static int vesc_read(void *ctx, struct motor_sample *out)
{
	struct vesc_motor *m = ctx;
	const int64_t now = sc_os_now_us();
	const int rc = drain_frames(m, now);

	if (rc)
		return rc;
	if (fill_sample(m, out, now)) {
		faults_reported(m);
		return 0;
	}
	if (!(out->faults & HAL_FAULT_DRIVER_TIMEOUT))
		return -EAGAIN; /* still waiting for the first reports */
	for (int j = 0; j < 4; j++) {
		if (isnan(out->wheel_rad_s[j]))
			out->wheel_rad_s[j] = 0.0f;
		if (isnan(out->current_a[j]))
			out->current_a[j] = 0.0f;
	}
	faults_reported(m);
	return 0;
}

static int vesc_clear_faults(void *ctx)
{
	struct vesc_motor *m = ctx;

	m->bus_off = false;
	for (int j = 0; j < 4; j++) {
		m->d[j].reported_fault = 0; /* a code still there is reported again */
		m->d[j].fault_pending = false;
	}
	return 0;
}

static void vesc_close(void *ctx)
{
	struct vesc_motor *m = ctx;

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

static void vesc_halt(void *ctx)
{
	vesc_motor_halt(ctx);
}

const struct motor_hal_ops vesc_motor_ops = {
    .enable = vesc_enable,
    .write = vesc_write,
    .read = vesc_read,
    .clear_faults = vesc_clear_faults,
    .halt = vesc_halt,
    .close = vesc_close,
};

int vesc_motor_poll_missing(struct vesc_motor *m)
{
	int missing = 0;

	drain_frames(m, sc_os_now_us());
	for (int j = 0; j < 4; j++)
		missing += !m->d[j].have_status1;
	return missing;
}

const char *vesc_motor_missing_text(const struct vesc_motor *m, char *buf, size_t n)
{
	static const struct sc_missing w = {"no STATUS_1 from", "id", "; no other VESC heard", 255};
	bool have[4];

	for (int j = 0; j < 4; j++)
		have[j] = m->d[j].have_status1;
	return sc_missing_text(&w, m->id, have, m->heard_other, buf, n);
}

/* at + k (a snprintf's count), within the buffer of n. */
static size_t advance(size_t n, size_t at, int k)
{
	at += k > 0 ? (size_t)k : 0;
	return at < n ? at : n - 1;
}

const char *vesc_motor_fault_text(const struct vesc_motor *m, char *buf, size_t n)
{
	size_t at = 0;

	if (n == 0)
		return buf;
	buf[0] = '\0';
	for (int j = 0; j < 4; j++) {
		const unsigned code = m->d[j].last_fault;

		if (code)
			at = advance(n, at,
			             snprintf(buf + at, n - at, "%swheel %d (id %u): %s (%u)",
			                      at ? "; " : "", j, (unsigned)m->id[j],
			                      vesc_fault_name(code), code));
	}
	if (at == 0)
		snprintf(buf, n, "none");
	return buf;
}
