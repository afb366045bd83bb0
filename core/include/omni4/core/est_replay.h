/*
 * est_replay.h - measurements that arrive late, at the tick they were taken (est.h). The
 * estimator keeps a ring of its past ticks (inputs, readings, one late measurement per tick;
 * state and covariance before every EST_SNAP_EVERY-th tick). A late measurement goes back to
 * the snapshot before its tick, re-runs the ticks up to it, is gated and applied there by its
 * own update, and the ticks since are re-run; it stays in the ring, so a later one re-applies it
 * on the way. Any late sensor uses it with its own kind and update; the camera pose is the
 * first (est_camera). Fast loop, between ticks. The ticks up to the measurement's are re-run at
 * once (fewer than EST_SNAP_EVERY); those since it, EST_REPLAY_PER_TICK (e->replay_per_tick) at
 * the start of each following live tick, the live state going on meanwhile, until the re-run
 * catches up and its state becomes the live one (a 40 ms late frame: 6 ticks later at 1 kHz).
 * Cost: about one tick per tick replayed, at most EST_SNAP_EVERY + EST_REPLAY_PER_TICK of them
 * in one tick; a late measurement that comes while a re-run is under way finishes it first.
 */
#ifndef OMNI4_EST_REPLAY_H
#define OMNI4_EST_REPLAY_H

#include <stdint.h>

#include "omni4/core/est.h"

/* A late measurement's update at its tick's state: gate z, apply it if it passes. 0 taken,
 * nonzero refused (the replay then restores the present state). */
typedef int (*est_late_fn)(struct est *e, const float z[3]);

/* The tick of a measurement captured at capture_us (the last one at or before it): 0 and *tick,
 * or -ERANGE when it is older than the ring keeps. */
int est_replay_find(const struct est *e, int64_t capture_us, uint32_t *tick);

/* Measurement z of kind (EST_LATE_*) taken at tick (est_replay_find), updated by apply: 0 taken
 * and the present state re-run from it (over the next ticks, above); the code apply returned,
 * the state as it was. The tick's earlier late measurement is replaced if this one is taken
 * (kept if not). */
int est_replay_at(struct est *e, uint32_t tick, uint8_t kind, const float z[3], est_late_fn apply);

#endif /* OMNI4_EST_REPLAY_H */
