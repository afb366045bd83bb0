/*
 * sc_rx.h - one read of a CAN socket's queue, as every CAN backend of the motor HAL (socketcan,
 * vesc, odrive) takes it: up to a frame budget, data and remote frames handed to the backend,
 * error frames counted and bus-off latched. Part of can_socket, in a file of its own so that it
 * reaches the socket only through sc_os.h (which the drivers' tests replace at link time).
 */
#ifndef OMNI4_SC_RX_H
#define OMNI4_SC_RX_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"

/* Where one backend counts what it receives. */
struct sc_rx_tally {
	uint64_t *rx_frames;     /* data and remote frames handed on */
	uint64_t *error_frames;  /* error frames, any class */
	uint64_t *bus_off_count; /* error frames saying bus-off */
	bool *bus_off;           /* set (never cleared here) by a bus-off error frame */
};

/* A frame received by a read that began at now_us [us, sc_os_now_us]. */
typedef void (*sc_rx_frame_fn)(void *ctx, const struct omni4_can_frame *f, int64_t now_us);

/* Takes up to max frames queued on fd: each data or remote frame to on_frame(ctx, frame,
 * now_us). The number of frames taken (max: the queue may hold more), or a receive error other
 * than -EAGAIN (an empty queue). */
int sc_rx_drain(int fd, int max, int64_t now_us, const struct sc_rx_tally *t,
                sc_rx_frame_fn on_frame, void *ctx);

#endif /* OMNI4_SC_RX_H */
