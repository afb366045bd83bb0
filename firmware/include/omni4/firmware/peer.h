/*
 * peer.h - one controller per bus. Before omni4-fw starts, OMNI4_MOTORS is listened for
 * PEER_LISTEN_MS: another controller heard there means refusing to start (before any backend
 * is opened, so nothing reaches the other controller's bus). While it runs, a foreign
 * OMNI4_MOTORS sample (lcmio's watch) makes every reading of the motor backend carry
 * HAL_FAULT_BUS for PEER_HOLD_US, which the controller latches as FAULT_BUS (outputs off).
 */
#ifndef OMNI4_PEER_H
#define OMNI4_PEER_H

#include <lcm/lcm.h>
#include <stdatomic.h>
#include <stdint.h>

#include "omni4/core/hal.h"

/* Another controller publishes one OMNI4_MOTORS per tick (1 ms at 1 kHz, 20 ms at 50 Hz), so
 * 300 ms hears at least 15 of its samples even at 50 Hz and a lost datagram or a scheduling
 * hiccup of 100 ms on either side cannot hide it, while adding little to start-up. */
#define PEER_LISTEN_MS 300
/* A foreign OMNI4_MOTORS sample keeps FAULT_BUS present this long: MODE_CLEAR_FAULT is refused
 * until the other controller has been silent for 1 s. */
#define PEER_HOLD_US 1000000

struct peer_guard {
	struct motor_hal backend; /* what the guard forwards to */
	const char *url;          /* for the messages */
	_Atomic int64_t last_us;  /* rtloop_clock_us() of the last foreign sample; 0 none */
};

/* lcm_create(url), then OMNI4_MOTORS listened for PEER_LISTEN_MS. The lcm_t, or NULL (said on
 * stderr, prefixed "omni4-fw: "): LCM cannot open, or another controller is there. */
lcm_t *peer_open_lcm_alone(const char *url);

/* The backend as the controller sees it (robot_spec.wrap; ctx: a struct peer_guard whose url
 * is set). */
struct motor_hal peer_guard_wrap(void *ctx, struct motor_hal backend);

/* Receive thread (lcmio_foreign_fn; ctx: the guard): a sample this process did not publish.
 * Said once per episode (after PEER_HOLD_US of silence). */
void peer_on_foreign(void *ctx, int64_t seq, int64_t utime);

#endif /* OMNI4_PEER_H */
