/* socketcan_motor.c - motor HAL over the omni4 CAN protocol (OS calls only via sc_os.h). */
#include "omni4/drivers/socketcan_motor.h"

#include <errno.h>
#include <math.h>
#include <poll.h>
#include <string.h>
#include <time.h>

#include "omni4/base/clock.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/drivers/sc_rx.h"

static bool limits_valid(const struct sc_limits *lim);

int socketcan_motor_open(struct socketcan_motor *m, const char *iface, int status_timeout_ms,
                         const struct sc_limits *lim)
{
	const uint32_t ids[] = {CAN_ID_STATUS(0), CAN_ID_STATUS(1), CAN_ID_HEALTH(0),
	                        CAN_ID_HEALTH(1)};

	memset(m, 0, sizeof(*m));
	m->fd = -1;
	if (status_timeout_ms <= 0 || !limits_valid(lim))
		return -EINVAL;
	const int rc = sc_os_open(iface, ids, 4, &m->fd);

	if (rc)
		return rc;
	m->timeout_us = (int64_t)status_timeout_ms * 1000;
	m->lim = *lim;
	atomic_init(&m->halted, false);
	atomic_init(&m->in_flight, 0);
	for (int n = 0; n < CAN_NODES; n++)
		m->node[n].status_candidate = m->node[n].health_candidate = -1;
	m->opened_us = m->last_read_us = sc_os_now_us();
	return 0;
}

/* Plausible limits: positive steps, 1..8 confirming frames. */
static bool limits_valid(const struct sc_limits *lim)
{
	return lim->current_step_a > 0.0f && lim->speed_step_rad_s > 0.0f &&
	       lim->current_limit_a > 0.0f && lim->confirm_frames >= 1 && lim->confirm_frames <= 8;
}

int socketcan_motor_set_limits(struct socketcan_motor *m, const struct sc_limits *lim)
{
	if (!limits_valid(lim))
		return -EINVAL;
	m->lim = *lim;
	return 0;
}

/* The write gate. Every send of the loop (or any thread) happens between gate_enter() and
 * gate_leave(); socketcan_motor_halt() sets halted and then waits for in_flight to be 0. Both
 * sides use sequentially consistent atomics (store, then load the other's flag), so either the
 * writer sees halted and sends nothing, or the halt sees the writer and waits until its frame
 * is out: the halt's frames are always the last ones. */
static _Thread_local bool tl_in_gate; /* this thread is inside the gate (crash inside a write) */

static bool gate_enter(struct socketcan_motor *m)
{
	atomic_fetch_add(&m->in_flight, 1);
	if (atomic_load(&m->halted)) {
		atomic_fetch_sub(&m->in_flight, 1);
		return false;
	}
	tl_in_gate = true;
	return true;
}

static void gate_leave(struct socketcan_motor *m)
{
	tl_in_gate = false;
	atomic_fetch_sub(&m->in_flight, 1);
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

	if (!gate_enter(m))
		return 0; /* halted: the crash handler sent the last frames */
	m->enabled = on;
	const int rc = send_control(m, on ? CAN_CTL_ENABLE : CAN_CTL_DISABLE);

	gate_leave(m);
	return rc;
}

static int write_voltage(struct socketcan_motor *m, const float volts[4])
{
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

static int sc_write(void *ctx, const float volts[4])
{
	struct socketcan_motor *m = ctx;

	if (!gate_enter(m))
		return 0;
	const int rc = write_voltage(m, volts);

	gate_leave(m);
	return rc;
}

/* One frame from the crash path: a full TX queue is retried until deadline_us. */
static bool halt_send(struct socketcan_motor *m, const struct omni4_can_frame *f,
                      int64_t deadline_us)
{
	for (;;) {
		const int rc = sc_os_send(m->fd, f);

		if (rc == 0)
			return true;
		if (rc != -EAGAIN || omni4_monotonic_us() >= deadline_us)
			return false;
		struct pollfd p = {.fd = m->fd, .events = POLLOUT};

		poll(&p, 1, 1);
	}
}

/* Waits until no other thread is inside the gate (own = 1 if this thread is), at most
 * limit_us; sleeps 1 ms per check (poll is async-signal-safe) so a preempted writer can run. */
static void wait_gate_empty(struct socketcan_motor *m, int own, int64_t limit_us)
{
	const int64_t t0 = omni4_monotonic_us();

	while (atomic_load(&m->in_flight) > own && omni4_monotonic_us() - t0 < limit_us)
		poll(NULL, 0, 1);
}

/* DISABLE, then 0 V with the bridges disabled twice; returns the frames sent. */
#define SC_HALT_TX_US 200000 /* [us] */

static int send_halt_frames(struct socketcan_motor *m)
{
	static const float zero[4] = {0, 0, 0, 0};
	/* A full TX queue is retried this long: on a starved machine the kernel may take tens of
	 * ms to drain it, and a halt frame given up leaves a driving frame the last on the bus. */
	const int64_t deadline = omni4_monotonic_us() + SC_HALT_TX_US;
	struct omni4_can_frame f;
	int sent = 0;

	can_encode_control(CAN_CTL_DISABLE, m->ctl_counter++, &f);
	sent += halt_send(m, &f, deadline);
	for (int k = 0; k < 2; k++) {
		can_encode_cmd_voltage(zero, false, m->cmd_counter, &f);
		m->cmd_counter = (m->cmd_counter + 1) & 0xF;
		sent += halt_send(m, &f, deadline);
	}
	return sent;
}

int socketcan_motor_halt(struct socketcan_motor *m)
{
	int sent = 0;

	if (m->fd < 0 || atomic_exchange(&m->halted, true))
		return 0;
	/* A write of another thread inside the gate finishes first (it does not block: the
	 * socket is non-blocking). If this thread itself was inside (crashed in a write), it
	 * never resumes, so there is nothing to wait for. */
	const int own = tl_in_gate ? 1 : 0;

	m->enabled = false;
	wait_gate_empty(m, own, 20000);
	sent += send_halt_frames(m);
	/* A writer preempted inside the gate for longer than that (a starved machine) may still
	 * put its frame on the bus after ours: wait for it (at most 1 s more) and send ours again,
	 * so the last frame on the bus is always 0 V, disabled. */
	if (atomic_load(&m->in_flight) > own) {
		wait_gate_empty(m, own, 1000000);
		sent += send_halt_frames(m);
	}
	return sent;
}

/* Up to 2 frames lost: the counter window CAN_COUNTER_WINDOW = 3 of can_proto.h. */
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

/* Within k frame periods of b (k capped at 2: a larger change always needs confirmation, so
 * no single frame moves a wheel speed by more than 2 steps, below the controller's
 * encoder-jump threshold). */
static bool status_near(const struct sc_limits *lim, const struct can_status *a,
                        const struct can_status *b, int k)
{
	const float f = (float)(k < 1 ? 1 : k > 2 ? 2 : k);

	for (int c = 0; c < 2; c++)
		if (!(fabsf(a->current_a[c] - b->current_a[c]) <= f * lim->current_step_a) ||
		    !(fabsf(a->speed_rad_s[c] - b->speed_rad_s[c]) <= f * lim->speed_step_rad_s))
			return false;
	return true;
}

static bool status_over_limit(const struct sc_limits *lim, const struct can_status *s)
{
	return !(fabsf(s->current_a[0]) <= lim->current_limit_a) ||
	       !(fabsf(s->current_a[1]) <= lim->current_limit_a);
}

/* Counter step from a held frame to this one, if it is within the window (else 0). */
static int run_step(uint8_t from, uint8_t to)
{
	const int d = (to - from) & 0xF;

	return d >= 1 && d <= CAN_COUNTER_WINDOW ? d : 0;
}

/* A held frame joins its run (agrees: its counter steps within the window from the run's latest
 * and its values agree with that frame's). true when it is the confirm_frames-th in a row: taken
 * (counted confirmed, the run ends); else held (counted implausible). */
static bool run_confirms(struct socketcan_motor *m, struct sc_run *run, uint8_t counter,
                         bool agrees)
{
	run->len = agrees ? run->len + 1 : 1;
	run->counter = counter;
	if (run->len >= m->lim.confirm_frames) {
		run->len = 0;
		m->n.confirmed++;
		return true;
	}
	m->n.implausible++;
	return false;
}

/* Plausibility of a STATUS frame that passed CRC and counter (see the header). periods =
 * frame periods since the last accepted STATUS of the node (by counter). */
static bool status_plausible(struct socketcan_motor *m, struct sc_node *n,
                             const struct can_status *s, uint8_t counter, int periods)
{
	const bool suspect = status_over_limit(&m->lim, s) ||
	                     (n->have_status && !status_near(&m->lim, s, &n->status, periods));

	if (!suspect) {
		n->status_run.len = 0;
		return true;
	}
	const int d = n->status_run.len > 0 ? run_step(n->status_run.counter, counter) : 0;
	const bool agrees = d && status_near(&m->lim, s, &n->status_held, d);

	n->status_held = *s;
	return run_confirms(m, &n->status_run, counter, agrees);
}

static bool health_same(const struct can_health *a, const struct can_health *b)
{
	return a->faults == b->faults && a->state == b->state &&
	       fabsf(a->supply_v - b->supply_v) <= 0.5f;
}

/* A HEALTH frame that raises a fault or the FAULT state, or moves the supply by more than
 * 0.5 V, is confirmed as a STATUS frame is. */
static bool health_plausible(struct socketcan_motor *m, struct sc_node *n,
                             const struct can_health *h, uint8_t counter)
{
	const bool alarming = h->faults || h->state == CAN_STATE_FAULT;
	const bool suspect = n->have_health
	                         ? !health_same(h, &n->health) &&
	                               (alarming || fabsf(h->supply_v - n->health.supply_v) > 0.5f)
	                         : alarming;

	if (!suspect) {
		n->health_run.len = 0;
		return true;
	}
	const bool agrees = n->health_run.len > 0 && run_step(n->health_run.counter, counter) &&
	                    health_same(h, &n->health_held);

	n->health_held = *h;
	return run_confirms(m, &n->health_run, counter, agrees);
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

		const int step = n->have_status ? run_step(n->status_counter, c) : 1;

		if (!counter_ok(m, n->have_status, &n->status_counter, &n->status_candidate, c))
			return;
		n->status_periods += step ? step : 1; /* resync: unknown, count one */
		if (!status_plausible(m, n, &s, c, n->status_periods))
			return;
		n->status_periods = 0;
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
		if (!health_plausible(m, n, &h, c))
			return;
		n->health = h;
		n->last_health_us = now;
		n->have_health = true;
	}
}

/* Frames this read may take: SC_MAX_FRAMES_PER_READ per millisecond since the previous read
 * (at least 1 ms' worth, at most SC_MAX_READ_CATCHUP ms'). */
static int read_budget(struct socketcan_motor *m, int64_t now)
{
	return sc_rx_budget(&m->last_read_us, now, SC_MAX_FRAMES_PER_READ, SC_MAX_READ_CATCHUP);
}

/* Takes what the kernel has queued, up to the read's frame budget. 0, or a receive error
 * other than -EAGAIN (an empty queue). */
static int drain_frames(struct socketcan_motor *m, int64_t now)
{
	const int budget = read_budget(m, now);
	const struct sc_rx_tally t = {&m->n.rx_frames, &m->n.error_frames, &m->n.bus_off,
	                              &m->bus_off};
	struct omni4_can_frame f;
	int k, rc = 0;

	for (k = 0; k < budget && (rc = sc_rx_next(m->fd, &t, &f)) > 0; k++)
		if (rc == 1)
			handle(m, &f, now);
	if (rc < 0)
		return rc;
	if (k == budget)
		m->n.flood_cut++;
	return 0;
}

/* The HAL fault bits of one node: silent for longer than the status timeout (since open if it
 * never reported), or a fault in its last accepted HEALTH. */
static uint32_t node_faults(const struct socketcan_motor *m, const struct sc_node *nd, int64_t now)
{
	const int64_t since = nd->have_status ? nd->last_status_us : m->opened_us;
	uint32_t faults = 0;

	if (now - since > m->timeout_us)
		faults |= HAL_FAULT_DRIVER_TIMEOUT;
	if (nd->have_health && (nd->health.faults || nd->health.state == CAN_STATE_FAULT))
		faults |= HAL_FAULT_DRIVER;
	return faults;
}

/* The sample from the nodes' last accepted frames: NaN for a node without a STATUS yet, the
 * lowest reported supply (NaN without HEALTH). Returns true if every node has reported. */
static bool fill_sample(const struct socketcan_motor *m, struct motor_sample *out, int64_t now)
{
	uint32_t faults = m->bus_off ? HAL_FAULT_BUS : 0;
	float supply = NAN;
	bool all = true;

	for (int n = 0; n < CAN_NODES; n++) {
		const struct sc_node *nd = &m->node[n];

		faults |= node_faults(m, nd, now);
		all &= nd->have_status;
		if (nd->have_health)
			supply = isnan(supply) ? nd->health.supply_v
			                       : fminf(supply, nd->health.supply_v);
		for (int c = 0; c < 2; c++) {
			out->current_a[2 * n + c] = nd->have_status ? nd->status.current_a[c] : NAN;
			out->wheel_rad_s[2 * n + c] =
			    nd->have_status ? nd->status.speed_rad_s[c] : NAN;
		}
	}
	out->supply_v = supply;
	out->faults = faults;
	return all;
}

/* Timed out before any report: a full sample of zeros with the fault set. */
static void zero_unreported(struct motor_sample *out)
{
	for (int j = 0; j < 4; j++) {
		if (isnan(out->current_a[j]))
			out->current_a[j] = 0.0f;
		if (isnan(out->wheel_rad_s[j]))
			out->wheel_rad_s[j] = 0.0f;
	}
}

static int sc_read(void *ctx, struct motor_sample *out)
{
	struct socketcan_motor *m = ctx;
	const int64_t now = sc_os_now_us();
	const int rc = drain_frames(m, now);

	if (rc)
		return rc;
	const bool all = fill_sample(m, out, now);

	if (!all && !(out->faults & HAL_FAULT_DRIVER_TIMEOUT))
		return -EAGAIN; /* still waiting for the first reports */
	if (!all)
		zero_unreported(out);
	return 0;
}

static int sc_clear_faults(void *ctx)
{
	struct socketcan_motor *m = ctx;

	m->bus_off = false;
	if (!gate_enter(m))
		return 0;
	const int rc = send_control(m, CAN_CTL_CLEAR_FAULTS);

	gate_leave(m);
	return rc;
}

static void sc_close(void *ctx)
{
	struct socketcan_motor *m = ctx;
	static const float zero[4] = {0, 0, 0, 0};

	if (m->fd < 0)
		return;
	if (gate_enter(m)) {
		m->enabled = false;
		write_voltage(m, zero);
		send_control(m, CAN_CTL_DISABLE);
		gate_leave(m);
	}
	sc_os_close(m->fd);
	m->fd = -1;
}

static void sc_halt(void *ctx)
{
	socketcan_motor_halt(ctx);
}

const struct motor_hal_ops socketcan_motor_ops = {
    .enable = sc_enable,
    .write = sc_write,
    .read = sc_read,
    .clear_faults = sc_clear_faults,
    .halt = sc_halt,
    .close = sc_close,
};
