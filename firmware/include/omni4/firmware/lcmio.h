/*
 * lcmio.h - omni4-fw's LCM threads: receive (commands into the mailbox), logger (the log ring
 * drained and published, lcmcodec.h's bytes), and the watch for another controller's samples.
 * Nothing here runs in the fast loop.
 */
#ifndef OMNI4_LCMIO_H
#define OMNI4_LCMIO_H

#include <lcm/lcm.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/core/ctl.h"
#include "omni4/core/fw.h"
#include "omni4/firmware/lcmcodec.h"

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
	_Atomic uint64_t rx_bad; /* undecodable command and goal messages */
	_Atomic uint64_t published;
	_Atomic uint64_t publish_errors;
	void (*note)(void *note_ctx, const struct log_entry *e);
	void *note_ctx;
	/* OMNI4_MOTORS watch (lcmio_start_watching; NULL: not subscribed). */
	lcm_subscription_t *motors_sub;
	lcm_subscription_t *pose_sub; /* OMNI4_POSE -> the estimator (lcmio_take_camera) */
	lcm_subscription_t *goal_sub; /* OMNI4_GOAL -> the goal mailbox */
	_Atomic uint64_t pose_bad;    /* undecodable or non-finite pose_t */
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

/* After start: camera poses on OMNI4_POSE (pose_t.utime = capture time) go to the loop's
 * estimator (fw_post_pose). For a robot whose camera is on the bus; a simulated camera feeds
 * the estimator from inside the loop instead (and publishes its poses: not to be taken again).
 * 0 or -EIO. */
int lcmio_take_camera(struct lcmio *io);

/* Stop both threads; the logger drains what is left in the ring first. */
void lcmio_stop(struct lcmio *io);

#endif /* OMNI4_LCMIO_H */
