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
 */
#ifndef OMNI4_SOCKETCAN_MOTOR_H
#define OMNI4_SOCKETCAN_MOTOR_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/can_proto.h"
#include "omni4/hal.h"

#define SC_MAX_FRAMES_PER_READ 64 /* bounds the loop's time under a frame flood */

struct sc_counters {
	uint64_t rx_frames, tx_frames, tx_dropped;
	uint64_t crc_errors;   /* bad CRC or DLC on our IDs */
	uint64_t replayed;     /* same counter as the previous frame of that ID: rejected */
	uint64_t lost;         /* counter jumps */
	uint64_t error_frames, bus_off;
	uint64_t flood_cut;    /* reads that stopped at SC_MAX_FRAMES_PER_READ */
};

struct sc_node {
	struct can_status status;
	struct can_health health;
	int64_t last_status_us, last_health_us;
	uint8_t status_counter, health_counter;
	int status_candidate, health_candidate; /* counter of a rejected frame, -1 = none */
	bool have_status, have_health;
};

struct socketcan_motor {
	int fd;
	int64_t timeout_us;
	int64_t opened_us;
	bool enabled;
	bool bus_off;
	uint8_t cmd_counter, ctl_counter;
	struct sc_node node[CAN_NODES];
	struct sc_counters n;
};

extern const struct motor_hal_ops socketcan_motor_ops;

/* Start-up. -ENODEV etc. from the socket layer; the message helper is strerror(-rc). */
int socketcan_motor_open(struct socketcan_motor *m, const char *iface, int status_timeout_ms);

static inline struct motor_hal socketcan_motor_hal(struct socketcan_motor *m)
{
	return (struct motor_hal){.ops = &socketcan_motor_ops, .ctx = m};
}

#endif /* OMNI4_SOCKETCAN_MOTOR_H */
