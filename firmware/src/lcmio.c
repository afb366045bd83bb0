/* lcmio.c - the LCM threads of omni4-fw: command receive, log publishing, the watch for another
 * controller (lcmio.h); the bytes are lcmcodec's. */
#include "omni4/firmware/lcmio.h"

#include "omni4/firmware/goalcodec.h"
#include "omni4/firmware/rtloop.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "omni4_command_t.h"
#include "omni4_motors_t.h"
#include "omni4_pose_t.h"

/* Receive thread: a camera pose for the estimator (a bad one counted, never passed on). */
static void on_pose(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct lcmio *io = user;
	omni4_pose_t p;

	(void)channel;
	if (rbuf->data_size > INT32_MAX ||
	    omni4_pose_t_decode(rbuf->data, 0, (int)rbuf->data_size, &p) != (int)rbuf->data_size ||
	    !isfinite(p.x) || !isfinite(p.y) || !isfinite(p.theta)) {
		atomic_fetch_add(&io->pose_bad, 1);
		return;
	}
	fw_post_pose(io->fw, p.utime, (const double[3]){p.x, p.y, p.theta});
}

int lcmio_take_camera(struct lcmio *io)
{
	io->pose_sub = lcm_subscribe(io->lcm, OMNI4_CHANNEL_POSE, on_pose, io);
	return io->pose_sub ? 0 : -EIO;
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

/* Receive thread: a goal for the loop (too many poses: passed on as a goal refused as out of
 * range, so its sender hears why). */
static void on_goal(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct lcmio *io = user;
	struct goal_cmd g;

	(void)channel;
	if (lcmio_decode_goal(rbuf->data, rbuf->data_size, &g) == -EINVAL) {
		atomic_fetch_add(&io->rx_bad, 1);
		return;
	}
	fw_post_goal(io->fw, &g);
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

static int publish(void *ctx, const char *channel, int64_t utime, int64_t seq, const void *data,
                   size_t len)
{
	struct lcmio *io = ctx;

	/* Each motors_t sample is noted before it goes out, so the receive thread always finds
	 * it. */
	if (io->motors_sub && !strcmp(channel, OMNI4_CHANNEL_MOTORS))
		atomic_store(&io->own[(uint64_t)seq % LCMIO_OWN_SLOTS], own_key(seq, utime));
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
	const struct lcmio_sink sink = {
	    .emit = publish, .ctx = io, .note = io->note, .note_ctx = io->note_ctx};
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
	io->goal_sub = lcm_subscribe(lcm, OMNI4_CHANNEL_GOAL, on_goal, io);
	if (!io->goal_sub) {
		lcm_unsubscribe(lcm, io->sub);
		return -EIO;
	}
	if (foreign) {
		io->motors_sub = lcm_subscribe(lcm, OMNI4_CHANNEL_MOTORS, on_motors, io);
		if (!io->motors_sub) {
			lcm_unsubscribe(lcm, io->goal_sub);
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
	lcm_unsubscribe(lcm, io->goal_sub);
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
	if (io->pose_sub)
		lcm_unsubscribe(io->lcm, io->pose_sub);
	lcm_unsubscribe(io->lcm, io->goal_sub);
	lcm_unsubscribe(io->lcm, io->sub);
	io->started = 0;
}
