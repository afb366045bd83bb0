/*
 * socketcan_motor.h - the "socketcan" backend of the motor HAL: the two driver boards of
 * can_proto.h on a raw CAN socket. Never blocks: write sends one CMD_VOLTAGE frame per tick
 * (a full TX queue is counted), read drains what the kernel has queued (bounded per tick).
 * Faults: no STATUS from a node for status_timeout_ms -> DRIVER_TIMEOUT; bus-off -> BUS;
 * HEALTH fault bits -> DRIVER; CRC errors, replayed and lost frames counted.
 * Counter policy per ID: a frame is accepted if its counter is 1..3 ahead of the last accepted
 * one (up to 2 frames lost); the same counter again or one further off is a stale or replayed
 * frame and is rejected, unless the next frame continues from it (resynchronisation after an
 * outage).
 * Plausibility (struct sc_limits, derivation in docs/faults.md): a STATUS frame whose current
 * or wheel speed moved further since the last accepted one than the motor physics allows in
 * the frame periods between them (counted by the counter, at most 2), or that reports a
 * current above the limit, is held, not acted on; it is only taken when it is the
 * confirm_frames-th of consecutive received frames (counter steps within the window) that each
 * agree with their predecessor. A HEALTH frame that raises a fault bit or the FAULT state, or
 * moves the supply by more than 0.5 V, is confirmed the same way. So no single frame can latch
 * a fault in the controller.
 * Crash safety: socketcan_motor_halt() (async-signal-safe) closes a gate that every write
 * passes through, waits for a write in flight on another thread to leave it, then sends the
 * final DISABLE + 0 V frames; after it no thread sends anything.
 */
#ifndef OMNI4_SOCKETCAN_MOTOR_H
#define OMNI4_SOCKETCAN_MOTOR_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"
#include "omni4/core/hal.h"
#include "omni4/drivers/sc_os.h"

/* Frames drained per read: 64 per millisecond since the previous read (a real 1 Mbit/s bus
 * carries at most 7.4 frames per ms), at most 4 ms' worth (256 frames, a real bus's backlog of
 * 34 ms). The loop's time under a flood stays bounded, and a read after a stall of the loop
 * still reaches the STATUS frames queued behind the frames that arrived meanwhile (a node is
 * not declared silent while its reports wait in the queue). */
#define SC_MAX_FRAMES_PER_READ 64
#define SC_MAX_READ_CATCHUP 4

struct sc_counters {
	uint64_t rx_frames, tx_frames, tx_dropped;
	uint64_t crc_errors; /* bad CRC or DLC on our IDs */
	uint64_t replayed;   /* same counter as the previous frame of that ID: rejected */
	uint64_t lost;       /* counter jumps */
	uint64_t error_frames, bus_off;
	uint64_t flood_cut;   /* reads that stopped at their frame budget */
	uint64_t implausible; /* frames held by the plausibility check (not acted on) */
	uint64_t confirmed;   /* held values taken after confirm_frames consecutive frames */
};

/* Plausibility limits of STATUS frames (per frame period, i.e. per counter step): numbers the
 * adapter computes from the robot's settings (firmware's can_limits.h). */
struct sc_limits {
	float current_step_a;   /* largest |current change| between two frames [A] */
	float speed_step_rad_s; /* largest |wheel speed change| between two frames [rad/s] */
	float current_limit_a;  /* a |current| above it needs confirmation [A] */
	int confirm_frames;     /* N: consecutive agreeing frames that confirm a held value */
};

/* The driver boards' current-sense noise allowance in a STATUS step [A]: 10 sigma of their
 * 0.02 A sense noise (a property of the boards, not of the robot's settings). */
#define SC_CURRENT_NOISE_MARGIN_A 0.2

/* A run of held (implausible) frames of one kind from one node: confirmed as the
 * confirm_frames-th consecutive one that agrees with its predecessor. */
struct sc_run {
	uint8_t counter; /* of the latest held frame */
	int len;         /* consecutive agreeing held frames, 0 = none */
};

struct sc_node {
	struct can_status status;
	struct can_health health;
	int64_t last_status_us, last_health_us;
	uint8_t status_counter, health_counter;
	int status_candidate, health_candidate; /* counter of a rejected frame, -1 = none */
	bool have_status, have_health;
	int status_periods; /* frame periods (by counter) since the last accepted STATUS */
	struct can_status status_held; /* the latest held frame of each kind */
	struct can_health health_held;
	struct sc_run status_run, health_run;
};

struct socketcan_motor {
	int fd;
	int64_t timeout_us;
	int64_t opened_us;
	int64_t last_read_us; /* time of the previous read (frame budget) */
	bool enabled;
	bool bus_off;
	uint8_t cmd_counter, ctl_counter;
	struct sc_node node[CAN_NODES];
	struct sc_counters n;
	struct sc_limits lim;
	atomic_bool halted;   /* socketcan_motor_halt() ran: nothing more is sent */
	atomic_int in_flight; /* writes inside the gate */
};

extern const struct motor_hal_ops socketcan_motor_ops;

/* Start-up, with the plausibility limits lim. -EINVAL for a non-positive timeout or invalid
 * limits (as socketcan_motor_set_limits); -ENODEV etc. from the socket layer; the message
 * helper is sc_os_strerror(). */
int socketcan_motor_open(struct socketcan_motor *m, const char *iface, int status_timeout_ms,
                         const struct sc_limits *lim);

/* Replace the plausibility limits (after open). -EINVAL for non-positive steps or
 * confirm_frames outside 1..8. */
int socketcan_motor_set_limits(struct socketcan_motor *m, const struct sc_limits *lim);

/* Crash path, async-signal-safe: close the write gate, wait (at most 20 ms) for a write of
 * another thread to leave it, send CMD_CONTROL DISABLE and twice CMD_VOLTAGE 0 V disabled
 * (retrying a full TX queue for at most 20 ms). If that write is still inside then (its thread
 * preempted), wait for it at most 1 s more and send the three frames again, so they are the
 * last on the bus. Returns the number of frames sent (3, or 6). */
int socketcan_motor_halt(struct socketcan_motor *m);

static inline struct motor_hal socketcan_motor_hal(struct socketcan_motor *m)
{
	return (struct motor_hal){.ops = &socketcan_motor_ops, .ctx = m};
}

#endif /* OMNI4_SOCKETCAN_MOTOR_H */
