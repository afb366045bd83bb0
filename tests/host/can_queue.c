/* can_queue.c - the lockstep's CAN socket (can_queue.h). */
#include "can_queue.h"

#include <errno.h>
#include <stdbool.h>
#include <string.h>

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd);
void __wrap_sc_os_close(int fd);
int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f);
int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);

static struct sc_os_filter filters[SC_OS_MAX_FILTERS];
static int n_filters;
static struct omni4_can_frame rxq[CAN_QUEUE_FRAMES], txq[CAN_QUEUE_FRAMES];
static int rx_head, rx_tail, n_tx, tx_total;

void can_queue_reset(void)
{
	n_filters = rx_head = rx_tail = n_tx = tx_total = 0;
}

void can_queue_deliver(const struct omni4_can_frame *f)
{
	bool pass = n_filters == 0;

	for (int i = 0; i < n_filters; i++)
		pass |= (f->id & filters[i].mask) == (filters[i].id & filters[i].mask);
	if (!pass)
		return;
	if (rx_head == rx_tail)
		rx_head = rx_tail = 0;
	if (rx_tail < CAN_QUEUE_FRAMES)
		rxq[rx_tail++] = *f;
}

int can_queue_take_sent(struct omni4_can_frame *out, int max)
{
	const int n = n_tx < max ? n_tx : max;
	const int total = tx_total;

	memcpy(out, txq, (size_t)n * sizeof(*out));
	n_tx = tx_total = 0;
	return total;
}

const struct omni4_can_frame *can_queue_sent(int *n)
{
	*n = n_tx;
	return txq;
}

void can_queue_clear_sent(void)
{
	n_tx = tx_total = 0;
}

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd)
{
	(void)iface;
	if (n_filt > SC_OS_MAX_FILTERS)
		return -EINVAL;
	memcpy(filters, filt, (size_t)n_filt * sizeof(*filt));
	n_filters = n_filt;
	*fd = 3;
	return 0;
}

void __wrap_sc_os_close(int fd)
{
	(void)fd;
}

int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f)
{
	(void)fd;
	tx_total++;
	if (n_tx == CAN_QUEUE_FRAMES)
		return -ENOBUFS;
	txq[n_tx++] = *f;
	return 0;
}

int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class)
{
	(void)fd;
	(void)err_class;
	if (rx_head == rx_tail)
		return -EAGAIN;
	*f = rxq[rx_head++];
	return 1;
}
