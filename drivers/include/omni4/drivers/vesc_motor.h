/*
 * vesc_motor.h - the "vesc" backend of the motor HAL: four VESC motor controllers on a raw CAN
 * socket (vesc_proto.h's frames; docs/vesc.md). Never blocks.
 * write: one command per controller per tick: SET_DUTY (mode duty: the wheel's voltage over
 * its controller's measured input voltage, STATUS_5, clamped to +-VESC_DUTY_MAX) or SET_CURRENT
 * (mode current: drive_currents() at the wheel's measured speed). Disabled, or nothing measured
 * yet to compute it from: SET_CURRENT 0, which releases the motor (free-wheeling).
 * read: STATUS_1 gives the wheel speed (ERPM / pole_pairs / gear) and the motor current,
 * STATUS_5 the input voltage (the sample's supply: the lowest times VESC_DUTY_MAX, the most the
 * controllers apply, so the controller never asks for a voltage a duty clamp cuts). A controller
 * without a STATUS_1 for status_timeout_ms -> HAL_FAULT_DRIVER_TIMEOUT; bus-off -> HAL_FAULT_BUS.
 * The status frames carry no fault code (vesc_proto.h): every VESC_FAULT_POLL_TICKS-th write asks
 * one controller in turn for its mc_fault_code (COMM_GET_VALUES_SELECTIVE, the reply addressed
 * to host_id); a code other than 0 (new since the last report or clear) -> HAL_FAULT_DRIVER once,
 * the code kept for vesc_motor_fault_text(). Nothing to start: the VESC's own command timeout
 * (0.5 s by default) stops a motor whose commands stop. close and halt send the mode's zero
 * (SET_DUTY 0 or SET_CURRENT 0) twice.
 */
#ifndef OMNI4_VESC_MOTOR_H
#define OMNI4_VESC_MOTOR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/core/hal.h"
#include "omni4/drivers/drive_consts.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/drivers/tx_gate.h"
#include "omni4/drivers/vesc_proto.h"
#include "omni4/drivers/vesc_settings.h"

#define VESC_DUTY_MAX 0.95f
/* omni4's own id on the VESC bus (the opener's host_id): the fault code replies come to it, so
 * no VESC may have it. */
#define VESC_HOST_ID 254u
/* Frames drained per read: 64 per millisecond since the previous read (4 controllers x 3 status
 * frames at 1 kHz are 12 per ms), at most 4 ms' worth (256). A read after a late tick reaches the
 * newest STATUS_1 behind the frames queued meanwhile: a fixed 64 a read left a loop slower than
 * the reports (the CAN VM: 200-300 Hz against 12 frames per ms) acting on ever older speeds. */
#define VESC_MAX_FRAMES_PER_READ 64
#define VESC_MAX_READ_CATCHUP 4
/* A fault code request every 4th write, to one controller in turn: each VESC asked every 16
 * ticks (16 ms at 1 kHz); a 7-byte request and an 8-byte reply, about 75 bits a tick. */
#define VESC_FAULT_POLL_TICKS 4

struct vesc_counters {
	uint64_t rx_frames, tx_frames, tx_dropped;
	uint64_t other_frames; /* frames of our controllers' ids that are no status of ours */
	uint64_t error_frames, bus_off;
};

struct vesc_drive {
	struct vesc_status1 s1;
	float input_v; /* STATUS_5 [V], NaN before the first */
	int64_t last_status1_us;
	bool have_status1;
	uint8_t fault_code;     /* mc_fault_code of the last reply (0: none) */
	uint8_t reported_fault; /* the code a sample reported (0 after a clear or a reply of 0) */
	uint8_t last_fault;     /* the last code other than 0 a reply carried (0: never) */
	bool fault_pending;     /* a new code for the next sample */
};

/* What the opener hands in (plain numbers). */
struct vesc_motor_config {
	const char *iface;
	uint8_t id[4];   /* controller CAN id of wheel j */
	uint8_t host_id; /* our id on the VESC bus: the fault code replies come to it */
	int pole_pairs;  /* >= 1 */
	enum vesc_mode mode;
	int status_timeout_ms; /* > 0 */
	struct drive_consts consts;
};

struct vesc_motor {
	int fd;
	uint8_t id[4], host_id;
	uint32_t writes;         /* writes sent (the fault code polls' turn) */
	uint8_t heard_other[32]; /* bit set of the ids not ours that sent a STATUS_1 */
	int pole_pairs;
	enum vesc_mode mode;
	int64_t timeout_us, opened_us, last_read_us;
	struct drive_consts consts;
	bool enabled, bus_off;
	struct vesc_drive d[4];
	struct vesc_counters n;
	struct tx_gate gate; /* shut by vesc_motor_halt(): nothing more is sent */
};

extern const struct motor_hal_ops vesc_motor_ops;

/* Start-up: the socket with one receive filter per controller id, one for the STATUS_1 of any
 * id (a controller on an id not configured is named) and one for the replies to host_id.
 * -EINVAL for a bad config (an id twice, 255, host_id one of the ids), else the socket layer's
 * error (message: sc_os_strerror()). */
int vesc_motor_open(struct vesc_motor *m, const struct vesc_motor_config *cfg);
/* Start-up, before the loop runs: takes the frames queued; the number of controllers that have
 * not sent a STATUS_1 yet. */
int vesc_motor_poll_missing(struct vesc_motor *m);
/* Start-up or after the loop: the controllers without a STATUS_1 and the ids not configured
 * that sent one, as one line in buf ("" if every controller reported); returns buf. */
const char *vesc_motor_missing_text(const struct vesc_motor *m, char *buf, size_t n);
/* After the loop: the last fault code each controller reported, named ("none" if none did);
 * returns buf. */
const char *vesc_motor_fault_text(const struct vesc_motor *m, char *buf, size_t n);
/* Loop thread, between two ticks: the model's numbers in force (a parameter change). */
void vesc_motor_set_consts(struct vesc_motor *m, const struct drive_consts *c);
/* Crash path, async-signal-safe: every later write is dropped and the mode's zero is sent to
 * each controller. Returns the frames sent. */
int vesc_motor_halt(struct vesc_motor *m);

static inline struct motor_hal vesc_motor_hal(struct vesc_motor *m)
{
	return (struct motor_hal){.ops = &vesc_motor_ops, .ctx = m};
}

#endif /* OMNI4_VESC_MOTOR_H */
