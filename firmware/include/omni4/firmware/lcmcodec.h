/*
 * lcmcodec.h - the controller's messages as LCM bytes: command_t bytes -> ctl_command, log
 * entries -> motors_t / pose_t / param_changed_t bytes, and the drain of the log ring into a
 * sink. No threads, no LCM instance: omni4-fw's threads (lcmio.h) and the lockstep simulator's
 * event log (sil/) both use it.
 */
#ifndef OMNI4_LCMCODEC_H
#define OMNI4_LCMCODEC_H

#include <stddef.h>
#include <stdint.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/core/ctl.h"
#include "omni4/core/fw.h"

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

/* Where encoded messages go: lcm_publish in the robot, an event log in the simulator. emit gets
 * the entry's time and tick (seq: the motors_t's, without decoding it again). note (may be
 * NULL) also sees every LOG_CALIBRATION entry as it is drained (omni4-fw says it on stderr). */
struct lcmio_sink {
	int (*emit)(void *ctx, const char *channel, int64_t utime, int64_t seq, const void *data,
	            size_t len);
	void *ctx;
	void (*note)(void *note_ctx, const struct log_entry *e);
	void *note_ctx;
};

/* Drain the ring into the sink; returns the number of entries written. */
size_t lcmio_drain(struct fw *fw, const struct lcmio_sink *sink, uint64_t *sink_errors);

#endif /* OMNI4_LCMCODEC_H */
