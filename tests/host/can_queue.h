/*
 * can_queue.h - the CAN socket of a controller run in lockstep with simulated drives: the OS
 * adapter (drivers/ sc_os.h) replaced at link time (-Wl,--wrap for sc_os_open_filters,
 * sc_os_close, sc_os_send, sc_os_recv, sc_os_now_us) by a queue each way with the kernel's
 * receive filters. The clock (__wrap_sc_os_now_us) is the user's: each lockstep has its own.
 */
#ifndef OMNI4_TEST_CAN_QUEUE_H
#define OMNI4_TEST_CAN_QUEUE_H

#include <stdint.h>

#include "omni4/drivers/sc_os.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CAN_QUEUE_FRAMES 1024 /* each way; a full queue drops the frame, as a socket's buffer */

/* Both queues emptied, no filter set. */
void can_queue_reset(void);
/* A drive's frame for the controller, if the socket's filters pass it. */
void can_queue_deliver(const struct omni4_can_frame *f);
/* The frames the controller sent since the last take: at most max into out; returns how many
 * it sent (more than max: the rest were dropped). */
int can_queue_take_sent(struct omni4_can_frame *out, int max);
/* The same without a copy: the queue's frames (valid until the next send), their count. */
const struct omni4_can_frame *can_queue_sent(int *n);
void can_queue_clear_sent(void);

/* The controller's clock, defined by the user of the queue. */
int64_t __wrap_sc_os_now_us(void);

#ifdef __cplusplus
}
#endif

#endif /* OMNI4_TEST_CAN_QUEUE_H */
