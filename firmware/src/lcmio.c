/* lcmio.c - LCM command receive, log encoding and publishing threads. */
#include "omni4/lcmio.h"

#include "omni4/rtloop.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "omni4_command_t.h"
#include "omni4_motors_t.h"
#include "omni4_param_changed_t.h"
#include "omni4_pose_t.h"

/* The controller's modes and fault bits go out unchanged as motors_t's (lcmtypes/), and
 * command_t's modes come in unchanged: the two vocabularies must agree bit by bit. */
#define SAME(a, b) _Static_assert((a) == (b), #a " != " #b)
SAME(CTL_IDLE, OMNI4_MOTORS_T_MODE_IDLE);
SAME(CTL_VELOCITY, OMNI4_MOTORS_T_MODE_VELOCITY);
SAME(CTL_VOLTAGE, OMNI4_MOTORS_T_MODE_VOLTAGE);
SAME(CTL_COAST, OMNI4_MOTORS_T_MODE_COAST);
SAME(CTL_FAULT, OMNI4_MOTORS_T_MODE_FAULT);
SAME(CTL_ESTOP, OMNI4_MOTORS_T_MODE_ESTOP);
SAME(CTL_IDLE, OMNI4_COMMAND_T_MODE_IDLE);
SAME(CTL_VELOCITY, OMNI4_COMMAND_T_MODE_VELOCITY);
SAME(CTL_VOLTAGE, OMNI4_COMMAND_T_MODE_VOLTAGE);
SAME(CTL_COAST, OMNI4_COMMAND_T_MODE_COAST);
SAME(CTL_CLEAR_FAULT, OMNI4_COMMAND_T_MODE_CLEAR_FAULT);
SAME(CTL_FAULT_OVERCURRENT, OMNI4_MOTORS_T_FAULT_OVERCURRENT);
SAME(CTL_FAULT_DRIVER_TIMEOUT, OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT);
SAME(CTL_FAULT_DRIVER, OMNI4_MOTORS_T_FAULT_DRIVER);
SAME(CTL_FAULT_BUS, OMNI4_MOTORS_T_FAULT_BUS);
SAME(CTL_FAULT_ENCODER, OMNI4_MOTORS_T_FAULT_ENCODER);
SAME(CTL_FAULT_CURRENT_SENSOR, OMNI4_MOTORS_T_FAULT_CURRENT_SENSOR);
SAME(CTL_FAULT_SUPPLY, OMNI4_MOTORS_T_FAULT_SUPPLY);
SAME(CTL_FAULT_ESTOP, OMNI4_MOTORS_T_FAULT_ESTOP);
SAME(CTL_FAULT_CMD_TIMEOUT, OMNI4_MOTORS_T_FAULT_CMD_TIMEOUT);
SAME(CTL_FAULT_CMD_REJECTED, OMNI4_MOTORS_T_FAULT_CMD_REJECTED);
SAME(CTL_FAULT_LOG_OVERFLOW, OMNI4_MOTORS_T_FAULT_LOG_OVERFLOW);
SAME(CTL_FAULT_OVERRUN, OMNI4_MOTORS_T_FAULT_OVERRUN);
#undef SAME

int lcmio_decode_command(const void *data, size_t len, struct ctl_command *out)
{
	omni4_command_t m;

	if (len > INT32_MAX || omni4_command_t_decode(data, 0, (int)len, &m) != (int)len)
		return -EINVAL;
	out->utime = m.utime;
	out->seq = m.seq;
	out->mode = m.mode;
	memcpy(out->velocity, m.velocity, sizeof(out->velocity));
	memcpy(out->voltage, m.voltage, sizeof(out->voltage));
	out->ramp_s = m.ramp_s;
	omni4_command_t_decode_cleanup(&m);
	return 0;
}

void lcmio_fault_channels(uint32_t mask, char out[8])
{
	char *p = out;

	for (int j = 0; j < 4; j++)
		if (mask & (1u << j)) {
			if (p != out)
				*p++ = ',';
			*p++ = (char)('0' + j);
		}
	*p = '\0';
}

/* LOG_CALIBRATION -> param_changed_t (lcmio.h). */
static int encode_calibration(const struct log_entry *e, void *buf, size_t cap)
{
	enum { KEYS = 6, VAL = 32 };
	static const char *const names[KEYS] = {
		"calibration.current_offset_a0", "calibration.current_offset_a1",
		"calibration.current_offset_a2", "calibration.current_offset_a3",
		"calibration.samples",           "calibration.fault_channels",
	};
	char now[KEYS][VAL], before[KEYS][VAL];
	char *keys[KEYS], *values[KEYS], *old_values[KEYS];
	const bool first = e->mode < 0;
	const uint32_t prev_faults = first ? 0 : (uint32_t)e->mode;
	int n = 5;

	for (int j = 0; j < 4; j++) {
		snprintf(now[j], VAL, "%.6f", (double)e->current[j]);
		snprintf(before[j], VAL, "%.6f", (double)e->voltage[j]);
	}
	snprintf(now[4], VAL, "%u", (unsigned)e->cal_samples);
	/* Before the first set nothing was measured; every set has the same count. */
	snprintf(before[4], VAL, "%u", first ? 0u : (unsigned)e->cal_samples);
	if (e->faults) {
		lcmio_fault_channels((uint32_t)e->faults, now[5]);
		lcmio_fault_channels(prev_faults, before[5]);
		n = 6;
	}
	for (int k = 0; k < n; k++) {
		keys[k] = (char *)names[k];
		values[k] = now[k];
		old_values[k] = before[k];
	}
	const omni4_param_changed_t m = {.utime = e->utime, .seq = e->seq, .request_id = 0,
					 .source = (char *)"calibration", .path = (char *)"", .n = n,
					 .keys = keys, .old_values = old_values, .values = values};

	if ((size_t)omni4_param_changed_t_encoded_size(&m) > cap)
		return -ENOSPC;
	return omni4_param_changed_t_encode(buf, 0, (int)cap, &m);
}

int lcmio_encode_log(const struct log_entry *e, void *buf, size_t cap, const char **channel)
{
	int n;

	if (e->kind == LOG_CALIBRATION) {
		*channel = OMNI4_CHANNEL_PARAM_CHANGED;
		n = encode_calibration(e, buf, cap);
	} else if (e->kind == LOG_POSE) {
		const omni4_pose_t p = {.utime = e->utime, .x = e->pose[0], .y = e->pose[1],
					.theta = e->pose[2]};

		*channel = OMNI4_CHANNEL_POSE;
		n = omni4_pose_t_encode(buf, 0, (int)cap, &p);
	} else {
		omni4_motors_t m = {.utime = e->utime, .seq = e->seq, .mode = e->mode,
				    .faults = e->faults};

		memcpy(m.voltage, e->voltage, sizeof(m.voltage));
		memcpy(m.current, e->current, sizeof(m.current));
		memcpy(m.wheel_speed, e->wheel_speed, sizeof(m.wheel_speed));
		*channel = OMNI4_CHANNEL_MOTORS;
		n = omni4_motors_t_encode(buf, 0, (int)cap, &m);
	}
	return n > 0 ? n : -ENOSPC;
}

size_t lcmio_drain(struct fw *fw, const struct lcmio_sink *sink, uint64_t *sink_errors)
{
	struct log_entry e;
	unsigned char buf[LCMIO_MAX_MSG];
	const char *channel;
	size_t n = 0;

	while (fw_pop_log(fw, &e)) {
		const int len = lcmio_encode_log(&e, buf, sizeof(buf), &channel);

		if (e.kind == LOG_CALIBRATION && sink->note)
			sink->note(sink->note_ctx, &e);

		if (len < 0 || sink->emit(sink->ctx, channel, e.utime, buf, (size_t)len) < 0)
			(*sink_errors)++;
		n++;
	}
	return n;
}

static void on_command(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct lcmio *io = user;
	struct ctl_command cmd;

	(void)channel;
	if (lcmio_decode_command(rbuf->data, rbuf->data_size, &cmd)) {
		atomic_fetch_add(&io->rx_bad, 1);
		return;
	}
	fw_post_command(io->fw, &cmd);
}

static void *rx_main(void *arg)
{
	struct lcmio *io = arg;

	while (!atomic_load(&io->stop))
		lcm_handle_timeout(io->lcm, 50);
	return NULL;
}

/* One published sample as one word (0: empty slot). */
static uint64_t own_key(int64_t seq, int64_t utime)
{
	const uint64_t k = ((uint64_t)utime * 0x9E3779B97F4A7C15ull) ^ (uint64_t)seq;

	return k ? k : 1;
}

static int64_t be64(const unsigned char *p)
{
	uint64_t v = 0;

	for (int i = 0; i < 8; i++)
		v = v << 8 | p[i];
	return (int64_t)v;
}

static int publish(void *ctx, const char *channel, int64_t utime, const void *data, size_t len)
{
	struct lcmio *io = ctx;

	(void)utime;
	/* motors_t on the wire: fingerprint, utime, seq (8 bytes each, big-endian). Kept before
	 * it goes out, so the receive thread always finds it. */
	if (io->motors_sub && len >= 24 &&
	    !strcmp(channel, OMNI4_CHANNEL_MOTORS)) {
		const int64_t t = be64((const unsigned char *)data + 8);
		const int64_t seq = be64((const unsigned char *)data + 16);

		atomic_store(&io->own[(uint64_t)seq % LCMIO_OWN_SLOTS], own_key(seq, t));
	}
	return lcm_publish(io->lcm, channel, data, (unsigned int)len);
}

static void on_motors(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct lcmio *io = user;
	omni4_motors_t m;

	(void)channel;
	if (rbuf->data_size > INT32_MAX ||
	    omni4_motors_t_decode(rbuf->data, 0, (int)rbuf->data_size, &m) < 0)
		return; /* not a motors_t: nobody's sample */
	if (atomic_load(&io->own[(uint64_t)m.seq % LCMIO_OWN_SLOTS]) == own_key(m.seq, m.utime)) {
		atomic_fetch_add(&io->own_heard, 1);
	} else {
		atomic_fetch_add(&io->foreign, 1);
		if (io->foreign_cb)
			io->foreign_cb(io->foreign_ctx, m.seq, m.utime);
	}
	omni4_motors_t_decode_cleanup(&m);
}

struct heard {
	long n;
	int64_t seq, utime;
};

static void on_heard(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct heard *h = user;
	omni4_motors_t m;

	(void)channel;
	if (rbuf->data_size > INT32_MAX ||
	    omni4_motors_t_decode(rbuf->data, 0, (int)rbuf->data_size, &m) < 0)
		return;
	if (h->n++ == 0) {
		h->seq = m.seq;
		h->utime = m.utime;
	}
	omni4_motors_t_decode_cleanup(&m);
}

long lcmio_listen_motors(lcm_t *lcm, int ms, int64_t *seq, int64_t *utime)
{
	struct heard h = {0};
	lcm_subscription_t *sub = lcm_subscribe(lcm, OMNI4_CHANNEL_MOTORS, on_heard, &h);

	if (!sub)
		return -EIO;
	const int64_t end = rtloop_clock_us() + (int64_t)ms * 1000;

	for (int64_t now = rtloop_clock_us(); now < end && h.n == 0; now = rtloop_clock_us()) {
		if (lcm_handle_timeout(lcm, (int)((end - now + 999) / 1000)) < 0) {
			lcm_unsubscribe(lcm, sub);
			return -EIO;
		}
	}
	lcm_unsubscribe(lcm, sub);
	*seq = h.seq;
	*utime = h.utime;
	return h.n;
}

static void *log_main(void *arg)
{
	struct lcmio *io = arg;
	const struct lcmio_sink sink = {.emit = publish, .ctx = io, .note = io->note,
					.note_ctx = io->note_ctx};
	const struct timespec nap = {.tv_sec = 0, .tv_nsec = 500000};

	for (;;) {
		uint64_t errors = 0;
		const bool stopping = atomic_load(&io->stop);
		const size_t n = lcmio_drain(io->fw, &sink, &errors);

		atomic_fetch_add(&io->published, n - errors);
		atomic_fetch_add(&io->publish_errors, errors);
		if (stopping)
			break; /* one last drain after the stop request */
		if (n == 0)
			nanosleep(&nap, NULL);
	}
	return NULL;
}

int lcmio_start(struct lcmio *io, lcm_t *lcm, struct fw *fw)
{
	return lcmio_start_noting(io, lcm, fw, NULL, NULL);
}

int lcmio_start_noting(struct lcmio *io, lcm_t *lcm, struct fw *fw,
		       void (*note)(void *note_ctx, const struct log_entry *e), void *note_ctx)
{
	return lcmio_start_watching(io, lcm, fw, note, note_ctx, NULL, NULL);
}

int lcmio_start_watching(struct lcmio *io, lcm_t *lcm, struct fw *fw,
			 void (*note)(void *note_ctx, const struct log_entry *e), void *note_ctx,
			 lcmio_foreign_fn foreign, void *foreign_ctx)
{
	int rc;

	memset(io, 0, sizeof(*io));
	io->lcm = lcm;
	io->fw = fw;
	io->note = note;
	io->note_ctx = note_ctx;
	io->foreign_cb = foreign;
	io->foreign_ctx = foreign_ctx;
	atomic_init(&io->stop, false);
	io->sub = lcm_subscribe(lcm, OMNI4_CHANNEL_CMD, on_command, io);
	if (!io->sub)
		return -EIO;
	if (foreign) {
		io->motors_sub = lcm_subscribe(lcm, OMNI4_CHANNEL_MOTORS, on_motors, io);
		if (!io->motors_sub) {
			lcm_unsubscribe(lcm, io->sub);
			return -EIO;
		}
	}
	pthread_attr_t attr;

	pthread_attr_init(&attr);
	pthread_attr_setstacksize(&attr, RTLOOP_STACK_BYTES);
	rc = pthread_create(&io->rx_thread, &attr, rx_main, io);
	if (rc) {
		pthread_attr_destroy(&attr);
		goto err_unsub;
	}
	rc = pthread_create(&io->log_thread, &attr, log_main, io);
	pthread_attr_destroy(&attr);
	if (rc)
		goto err_rx;
	io->started = 1;
	return 0;

err_rx:
	atomic_store(&io->stop, true);
	pthread_join(io->rx_thread, NULL);
err_unsub:
	if (io->motors_sub)
		lcm_unsubscribe(lcm, io->motors_sub);
	lcm_unsubscribe(lcm, io->sub);
	return -rc;
}

void lcmio_stop(struct lcmio *io)
{
	if (!io->started)
		return;
	atomic_store(&io->stop, true);
	pthread_join(io->rx_thread, NULL);
	pthread_join(io->log_thread, NULL);
	if (io->motors_sub)
		lcm_unsubscribe(io->lcm, io->motors_sub);
	lcm_unsubscribe(io->lcm, io->sub);
	io->started = 0;
}
