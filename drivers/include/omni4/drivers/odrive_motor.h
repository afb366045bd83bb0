/*
 * odrive_motor.h - the "odrive" backend of the motor HAL: four ODrive axes speaking CANSimple on
 * a raw CAN socket (odrive_proto.h's frames; docs/odrive.md). Never blocks.
 * open (and clear_faults) starts each axis: Clear_Errors, Set_Controller_Mode (torque control,
 * passthrough input), Set_Axis_State CLOSED_LOOP_CONTROL.
 * write: one Set_Input_Torque per axis per tick, torque = Kt_j drive_currents() at the wheel's
 * measured speed; 0 Nm when disabled (an axis in closed loop at 0 Nm free-wheels) or before a
 * speed is measured. Then one remote frame (RTR) per tick, in turn for each axis's Get_Iq and
 * Get_Bus_Voltage_Current (the drive may also send them cyclically). An axis whose heartbeat says
 * IDLE without an error (an ODrive that came up after the controller and missed the start) is
 * started again: Set_Controller_Mode and Set_Axis_State CLOSED_LOOP_CONTROL, at most every
 * ODRIVE_RESTART_PERIOD_US per axis, for as long as its heartbeat says so.
 * read: Get_Encoder_Estimates gives the wheel speed (turn/s x 2 pi / gear), Get_Iq the motor
 * current (measured), Get_Bus_Voltage_Current the supply (the lowest), the Heartbeat the axis
 * error. An axis without an encoder estimate for status_timeout_ms -> HAL_FAULT_DRIVER_TIMEOUT;
 * a heartbeat with an axis_error bit not reported yet -> HAL_FAULT_DRIVER in the next sample
 * (the controller latches it). The drive keeps its error until Clear_Errors, which clear_faults
 * sends only once the controller has accepted a clear, i.e. once the fault is not present: so
 * the fault is reported once, and again if the drive still has it after the clear (bits kept
 * for the summary: odrive_motor_fault_text). Bus-off -> HAL_FAULT_BUS.
 * close and halt: Set_Input_Torque 0, then Set_Axis_State IDLE, to each axis.
 */
#ifndef OMNI4_ODRIVE_MOTOR_H
#define OMNI4_ODRIVE_MOTOR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/core/hal.h"
#include "omni4/drivers/drive_consts.h"
#include "omni4/drivers/odrive_proto.h"
#include "omni4/drivers/odrive_settings.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/drivers/tx_gate.h"

/* Frames drained per read: 64 per millisecond since the previous read (4 axes x 2-3 reports
 * at 1 kHz), at most 4 ms' worth (256), as the VESC backend: a fixed 64 a read left a loop late
 * behind a starved machine's backlog acting on ever older estimates. */
#define ODRIVE_MAX_FRAMES_PER_READ 64
#define ODRIVE_MAX_READ_CATCHUP 4
/* An idle axis without an error is asked for closed loop again at most this often: the
 * heartbeat's default period (100 ms), so an axis that is entering closed loop is not asked
 * twice per heartbeat. */
#define ODRIVE_RESTART_PERIOD_US 100000

struct odrive_counters {
	uint64_t rx_frames, tx_frames, tx_dropped;
	uint64_t other_frames; /* frames of our nodes that are no report we use */
	uint64_t error_frames, bus_off;
};

struct odrive_axis {
	struct odrive_heartbeat hb;
	float vel_turn_s;         /* encoder estimate [turn/s] */
	float iq_a;               /* Iq measured [A], NaN before the first */
	float bus_v;              /* bus voltage [V], NaN before the first */
	uint32_t seen_errors;     /* every axis_error bit a heartbeat carried since open */
	uint32_t reported_errors; /* the bits already reported as HAL_FAULT_DRIVER */
	bool fault_pending;       /* a new error bit: the next sample reports it */
	int64_t last_estimate_us;
	int64_t restart_us; /* the last closed-loop request after open's (0: none) */
	bool have_estimate, have_hb;
};

/* What the opener hands in (plain numbers). */
struct odrive_motor_config {
	const char *iface;
	uint8_t node[4]; /* CANSimple node id of wheel j's axis, 0..63 */
	enum odrive_mode mode;
	int status_timeout_ms; /* > 0 */
	struct drive_consts consts;
};

struct odrive_motor {
	int fd;
	uint8_t node[4];
	int64_t timeout_us, opened_us, last_read_us;
	struct drive_consts consts;
	bool enabled, bus_off;
	unsigned request; /* the next remote frame: axis request / 2, Iq or bus by request % 2 */
	uint8_t heard_other[8]; /* bit set of the nodes not ours that sent an estimate/heartbeat */
	struct odrive_axis a[4];
	struct odrive_counters n;
	struct tx_gate gate; /* shut by odrive_motor_halt(): nothing more is sent */
};

extern const struct motor_hal_ops odrive_motor_ops;

/* Start-up: the socket with one receive filter per node (and one for the encoder estimates and
 * heartbeats of any node: a drive on a node not configured is named), then each axis started
 * (above). -EINVAL for a bad config, else the socket layer's error (message: sc_os_strerror());
 * nothing left open then. */
int odrive_motor_open(struct odrive_motor *m, const struct odrive_motor_config *cfg);
/* Loop thread, between two ticks: the model's numbers in force (a parameter change). */
void odrive_motor_set_consts(struct odrive_motor *m, const struct drive_consts *c);
/* Crash path, async-signal-safe: every later write is dropped, then Set_Input_Torque 0 and
 * Set_Axis_State IDLE to each axis. Returns the frames sent. */
int odrive_motor_halt(struct odrive_motor *m);
/* Start-up, before the loop runs: takes the frames queued; the number of axes without an
 * encoder estimate yet. */
int odrive_motor_poll_missing(struct odrive_motor *m);
/* Start-up or after the loop: the axes without an estimate and the nodes not configured that
 * sent an estimate or a heartbeat, as one line in buf ("" if every axis reported); returns buf. */
const char *odrive_motor_missing_text(const struct odrive_motor *m, char *buf, size_t n);
/* The axis errors seen ("wheel 1 (node 5): dc_bus_under_voltage motor_over_temp; ..."), or
 * "none", in buf, which it returns. Not the fast loop. */
const char *odrive_motor_fault_text(const struct odrive_motor *m, char *buf, size_t n);

static inline struct motor_hal odrive_motor_hal(struct odrive_motor *m)
{
	return (struct motor_hal){.ops = &odrive_motor_ops, .ctx = m};
}

#endif /* OMNI4_ODRIVE_MOTOR_H */
