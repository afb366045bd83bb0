/*
 * sc_os.h - the one place that talks to the Linux CAN stack (raw CAN sockets): the library
 * can_socket, used by both ends of the motor-driver bus, the socketcan backend of the motor HAL
 * and the simulated driver boards (omni4-motorsim). Every function returns 0 (or a count) or a
 * negative errno; none blocks.
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

/* Open a raw CAN socket on iface, non-blocking, bound, with kernel receive filters for the
 * given IDs and error frames enabled. n_ids = 0: receive everything. *fd on success. */
int sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd);
void sc_os_close(int fd);
/* Send one frame; -EAGAIN if the TX queue is full. */
int sc_os_send(int fd, const struct omni4_can_frame *f);
/* Receive one frame: 1 = data frame in *f, 2 = error frame (*err_class set), -EAGAIN = none. */
int sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
/* CLOCK_MONOTONIC [us]. */
int64_t sc_os_now_us(void);
/* The message for rc (a negative errno of the functions above) in buf, which it returns:
 * strerror's text, with what to check for the errors a first set-up meets (a kernel without
 * CAN, an interface that does not exist or is down). */
const char *sc_os_strerror(int rc, char *buf, size_t n);

#endif /* OMNI4_SC_OS_H */
