/*
 * est_priv.h - what the estimator's files share between themselves (not an interface): the
 * filter's tick (est.c), the camera (est_camera.c), the replay of late measurements
 * (est_replay.c), the wheel calibration (est_cal.c).
 */
#ifndef OMNI4_EST_PRIV_H
#define OMNI4_EST_PRIV_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/est.h"

/* est.c: one tick (predict, wheel update, the late measurement stored at it); live: the real
 * tick (flags and outputs), not a replay. */
void est_run_tick(struct est *e, const struct est_tick *t, bool live);
/* est.c: mirror P's upper triangle into the lower. */
void est_symmetrise(struct est *e);
/* est.c: P's cross-covariances below EST_COV_TINY zeroed (both triangles). */
void est_flush_tiny(struct est *e);
/* est.c: the camera pose z as three scalar updates (the upper triangle: then est_symmetrise). */
void est_pose_update(struct est *e, const float z[3]);
/* est.c: the state, covariance diagonal and wheel scales into e->out at utime. */
void est_publish(struct est *e, int64_t utime);
/* est.c: all n values finite. */
bool est_all_finite(const float *v, int n);

/* est_replay.c: the snapshot before tick n, when n is one the ring keeps. */
void est_replay_snap(struct est *e, uint32_t n);
/* est_replay.c: ticks n0 .. seq - 1 re-run from the snapshot before n0 (n0 a multiple of
 * EST_SNAP_EVERY whose snapshot the ring keeps); a re-run under way is finished first. */
void est_replay_from(struct est *e, uint32_t n0);
/* est_replay.c: before the live tick seq: the re-run under way (e->job) goes on by up to
 * max_ticks ticks (0: to the end); when it reaches seq its state becomes the live one. */
void est_replay_advance(struct est *e, uint32_t max_ticks);

/* est_cal.c: after the live tick n: a reading that fits a rigid body teaches the calibration;
 * every EST_CAL_EVERY ticks the scale errors in force are solved again. */
void est_cal_step(struct est *e, const struct est_tick *t, uint32_t n);

/* est_slip.c: slip on every wheel, the wheels named. The slip state cleared (est_reset). */
void est_slip_reset(struct est *e);
/* Live tick with a reading: the readings wh (scale-corrected) against the prediction in e->s. */
void est_slip_model(struct est *e, const struct est_tick *t, const float wh[4]);
/* A finite camera pose z captured at tick k (capture_us), gated or not. */
void est_slip_camera(struct est *e, uint32_t k, const float z[3], int64_t capture_us);
/* EST_FLAG_SLIP_j of the wheels the model or the camera say slip (and EST_FLAG_SLIP). */
uint32_t est_slip_flags(const struct est *e, int64_t utime);
/* The model says some wheel runs ahead: the innovation is a slip's, not a collision's. */
bool est_slip_common(const struct est *e);
/* Predict: the voltages of tick t with each untrusted wheel's (t->untrusted) less the back-EMF
 * its rim (scale-corrected reading) runs ahead of the ground speed x (v, vn, w) gives it: the
 * force its motor gives at the speed it spins (a slipping wheel's, not a gripping one's). */
void est_slip_volts(const struct est *e, const struct est_tick *t, const float x[3],
                    float volts[4]);
/* The wheel update with only the trusted wheels (t->untrusted set): one scalar update per
 * wheel (eq 2's row, wheel_noise^2), none when all four slip (the model and the camera carry
 * the state). wh: the scale-corrected readings [m/s]. */
void est_slip_update(struct est *e, const struct est_tick *t, const float wh[4]);
/* The wheel update as one scalar update per wheel reading (eq 2's row, wheel_noise^2), the
 * wheels in skip (bit j: wheel j) left out: the readings' noise is independent, so the
 * sequence is the batch least-squares update exactly (a layout's H^T H is not diagonal).
 * Another layout's four wheels, none left out (e->white): the same update as three scalar
 * updates of the whitened readings y = W wh (rows U, H^T H = U^T U). */
void est_slip_rows(struct est *e, const float wh[4], uint8_t skip);
/* After the live tick, the wheels fresh (bit j: wheel j) newly flagged: the ticks since the
 * witnesses' onset (their averaging and run, EST_INNOV_AVG_TICKS and slip_ticks, twice over)
 * re-run with those wheels untrusted, so the estimate does not keep what the spinning wheels
 * gave it before the flag. */
void est_slip_rewind(struct est *e, uint8_t fresh);

#endif /* OMNI4_EST_PRIV_H */
