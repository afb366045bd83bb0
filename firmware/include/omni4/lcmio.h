/*
 * lcmio.h - the controller's LCM side: command_t bytes -> ctl_command, log entries ->
 * motors_t / pose_t bytes, and the two threads that move them (receive, logger).
 * Nothing here runs in the fast loop.
 */
#ifndef OMNI4_LCMIO_H
#define OMNI4_LCMIO_H

#include <lcm/lcm.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/channels.h"
#include "omni4/ctl.h"
#include "omni4/fw.h"

#define LCMIO_MAX_MSG 1024 /* a calibration notice (param_changed_t) takes ~0.5 kB */

/* Decode a command_t; -EINVAL if the bytes are not a complete command_t. */
int lcmio_decode_command(const void *data, size_t len, struct ctl_command *out);

/*
 * Encode a log entry; returns the length (> 0) or -ENOSPC, and the channel to use. A
 * LOG_CALIBRATION entry becomes a param_changed_t on OMNI4_PARAM_CHANGED: source
 * "calibration", request_id 0, path "", seq the first tick with the new offsets subtracted,
 * utime the controller clock, keys calibration.current_offset_a0 .. _a3 (values and
 * old_values "%.6f" in A), calibration.samples (readings per channel; old value the previous
 * set's count, "0" before the first), and when a channel is beyond the limit
 * calibration.fault_channels (e.g. "2" or "0,3"; old value the previous set's, "" if none).
 */
int lcmio_encode_log(const struct log_entry *e, void *buf, size_t cap, const char **channel);

/* Channels of a calibration entry beyond the limit as text ("2", "0,3"; "" for none). */
void lcmio_fault_channels(uint32_t mask, char out[8]);

/* Where encoded messages go: lcm_publish in the robot, an event log in the simulator. note
 * (may be NULL) also sees every LOG_CALIBRATION entry as it is drained (omni4-fw says it on
 * stderr). */
struct lcmio_sink {
	int (*emit)(void *ctx, const char *channel, int64_t utime, const void *data, size_t len);
	void *ctx;
	void (*note)(void *note_ctx, const struct log_entry *e);
	void *note_ctx;
};

/* Drain the ring into the sink; returns the number of entries written. */
size_t lcmio_drain(struct fw *fw, const struct lcmio_sink *sink, uint64_t *sink_errors);

/* The samples this process published, by seq % LCMIO_OWN_SLOTS (4 s at 1 kHz): an
 * OMNI4_MOTORS sample heard back whose (seq, utime) is not in its slot came from another
 * controller on the same URL. */
#define LCMIO_OWN_SLOTS 4096

/* Another controller's OMNI4_MOTORS sample (receive thread). */
typedef void (*lcmio_foreign_fn)(void *ctx, int64_t seq, int64_t utime);

struct lcmio {
	lcm_t *lcm;
	struct fw *fw;
	lcm_subscription_t *sub;
	pthread_t rx_thread, log_thread;
	atomic_bool stop;
	_Atomic uint64_t rx_bad;   /* undecodable command messages */
	_Atomic uint64_t published;
	_Atomic uint64_t publish_errors;
	void (*note)(void *note_ctx, const struct log_entry *e);
	void *note_ctx;
	/* OMNI4_MOTORS watch (lcmio_start_watching; NULL: not subscribed). */
	lcm_subscription_t *motors_sub;
	lcmio_foreign_fn foreign_cb;
	void *foreign_ctx;
	_Atomic uint64_t own_heard; /* our own samples heard back */
	_Atomic uint64_t foreign;   /* samples from another controller */
	_Atomic uint64_t own[LCMIO_OWN_SLOTS];
	int started;
};

/* Start the receive and logger threads on an open lcm_t. 0 or a negative errno. */
int lcmio_start(struct lcmio *io, lcm_t *lcm, struct fw *fw);
/* The same, with note (may be NULL) called on the logger thread for every new set of
 * current-sense offsets (lcmio_sink.note). */
int lcmio_start_noting(struct lcmio *io, lcm_t *lcm, struct fw *fw,
		       void (*note)(void *note_ctx, const struct log_entry *e), void *note_ctx);
/* The same, also listening to OMNI4_MOTORS: the logger keeps the (seq, utime) of what it
 * publishes, and every sample heard that is not one of them goes to foreign (receive thread;
 * counted in io->foreign). */
int lcmio_start_watching(struct lcmio *io, lcm_t *lcm, struct fw *fw,
			 void (*note)(void *note_ctx, const struct log_entry *e), void *note_ctx,
			 lcmio_foreign_fn foreign, void *foreign_ctx);

/* Before a controller starts: listens on lcm for OMNI4_MOTORS for ms milliseconds. The number
 * of samples heard (0: no other controller publishes there), the first one's seq and utime in
 * *seq, *utime. -errno if LCM fails. */
long lcmio_listen_motors(lcm_t *lcm, int ms, int64_t *seq, int64_t *utime);

/* Stop both threads; the logger drains what is left in the ring first. */
void lcmio_stop(struct lcmio *io);

#endif /* OMNI4_LCMIO_H */
