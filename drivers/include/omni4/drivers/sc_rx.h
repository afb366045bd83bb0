/*
 * sc_rx.h - a CAN socket's queue as every CAN backend of the motor HAL (socketcan, vesc,
 * odrive) reads it: data and remote frames counted and handed to the backend, error frames
 * counted and bus-off latched. Part of can_socket, in a file of its own so that it
 * reaches the socket only through sc_os.h (which the drivers' tests replace at link time).
 */
#ifndef OMNI4_SC_RX_H
#define OMNI4_SC_RX_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"

/* Where one backend counts what it receives. */
struct sc_rx_tally {
	uint64_t *rx_frames;     /* data and remote frames handed on */
	uint64_t *error_frames;  /* error frames, any class */
	uint64_t *bus_off_count; /* error frames saying bus-off */
	bool *bus_off;           /* set (never cleared here) by a bus-off error frame */
};

/* The next frame queued on fd: 1 = a data or remote frame in *f; 2 = an error frame (counted,
 * bus-off latched; nothing in *f); 0 = the queue is empty; or a receive error. Every frame is
 * counted, so a reader's frame budget bounds a flood of either kind. */
int sc_rx_next(int fd, const struct sc_rx_tally *t, struct omni4_can_frame *f);

/* Frames a read may take: per_ms for every millisecond since the previous read (*last_us, set
 * to now_us), at least 1 ms' worth and at most max_ms' (a late loop catches up its backlog,
 * a flood cannot hold it). */
int sc_rx_budget(int64_t *last_us, int64_t now_us, int per_ms, int max_ms);

/* What a backend's drives did not say, as one line in buf: "<missing> <unit> a (wheel j), ...",
 * then "; heard instead: <unit> x, y" for the ids set in heard (a bit set of ids 0..max_id) or
 * none_heard; "" if every wheel reported (have[j]). Returns buf. */
struct sc_missing {
	const char *missing;    /* e.g. "no STATUS_1 from" */
	const char *unit;       /* "id", "node" */
	const char *none_heard; /* e.g. "; no other VESC heard" */
	unsigned max_id;
};
const char *sc_missing_text(const struct sc_missing *w, const uint8_t id[4], const bool have[4],
                            const uint8_t *heard, char *buf, size_t n);

#endif /* OMNI4_SC_RX_H */
