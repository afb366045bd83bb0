/*
 * sc_os.h - the one place that talks to the Linux CAN stack (raw CAN sockets): the library
 * can_socket, used by both ends of the motor-driver bus, the CAN backends of the motor HAL
 * (socketcan, vesc, odrive) and the simulated driver boards (omni4-motorsim). Every function
 * returns 0 (or a count) or a negative errno; none blocks.
 */
#ifndef OMNI4_SC_OS_H
#define OMNI4_SC_OS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"

/* Error frames seen (classes of linux/can/error.h). */
#define SC_ERR_BUSOFF 0x1u
#define SC_ERR_OTHER 0x2u

/* A kernel receive filter: a frame passes if (its id & mask) == (id & mask), id and mask with
 * the frame-format flags of can_proto.h (OMNI4_CAN_EFF_FLAG, OMNI4_CAN_RTR_FLAG) as SocketCAN
 * has them. A socket passes a frame that any of its filters passes. */
struct sc_os_filter {
	uint32_t id;
	uint32_t mask;
};
/* Masks that admit one data frame's ID exactly: a standard (11-bit) or an extended one. */
#define SC_OS_MASK_EXACT_SFF (OMNI4_CAN_SFF_MASK | OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG)
#define SC_OS_MASK_EXACT_EFF (OMNI4_CAN_EFF_MASK | OMNI4_CAN_EFF_FLAG | OMNI4_CAN_RTR_FLAG)
#define SC_OS_MAX_FILTERS 16

/* Open a raw CAN socket on iface, non-blocking, bound, with the kernel receive filters filt
 * (at most SC_OS_MAX_FILTERS) and error frames enabled. n_filt = 0: receive everything. *fd on
 * success. */
int sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt, int *fd);
/* sc_os_open_filters with one exact filter per standard data frame ID of ids. */
int sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd);
void sc_os_close(int fd);
/* Send one frame, standard or extended (OMNI4_CAN_EFF_FLAG), data or remote
 * (OMNI4_CAN_RTR_FLAG); -EAGAIN if the TX queue is full. */
int sc_os_send(int fd, const struct omni4_can_frame *f);
/* Receive one frame: 1 = a data or remote frame in *f (id with its flags), 2 = error frame
 * (*err_class set), -EAGAIN = none. */
int sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
/* CLOCK_MONOTONIC [us]. */
int64_t sc_os_now_us(void);
/* The message for rc (a negative errno of the functions above) in buf, which it returns:
 * strerror's text, with what to check for the errors a first set-up meets (a kernel without
 * CAN, an interface that does not exist or is down). */
const char *sc_os_strerror(int rc, char *buf, size_t n);

#endif /* OMNI4_SC_OS_H */
