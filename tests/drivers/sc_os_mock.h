/* sc_os_mock.h - the OS adapter (sc_os.h) replaced at link time (--wrap) for the tests of the
 * CAN drive backends: the filters the socket was opened with, every frame sent, a queue of
 * frames the "kernel" hands out, the clock. Included by one test file per executable. */
#ifndef OMNI4_SC_OS_MOCK_H
#define OMNI4_SC_OS_MOCK_H

#include "omni4_test.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "omni4/drivers/sc_os.h"

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd);
void __wrap_sc_os_close(int fd);
int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f);
int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class);
int64_t __wrap_sc_os_now_us(void);

#define MOCK_FD 42

static struct sc_os_filter mock_filt[SC_OS_MAX_FILTERS];
static int mock_n_filt;
static char mock_iface[16];
static bool mock_open, mock_closed;
static struct omni4_can_frame mock_sent[4096];
static int mock_n_sent;
static struct omni4_can_frame mock_rxq[256];
static uint32_t mock_rxerr[256];
static int mock_rx_head, mock_rx_tail;
static int64_t mock_clock_us;

static inline void mock_reset(void)
{
	mock_n_filt = mock_n_sent = mock_rx_head = mock_rx_tail = 0;
	mock_open = mock_closed = false;
	mock_clock_us = 1000000;
}

int __wrap_sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt,
                              int *fd)
{
	assert_true(n_filt >= 0 && n_filt <= SC_OS_MAX_FILTERS);
	snprintf(mock_iface, sizeof(mock_iface), "%s", iface);
	memcpy(mock_filt, filt, (size_t)n_filt * sizeof(*filt));
	mock_n_filt = n_filt;
	mock_open = true;
	*fd = MOCK_FD;
	return 0;
}

void __wrap_sc_os_close(int fd)
{
	assert_int_equal(fd, MOCK_FD);
	mock_closed = true;
}

int __wrap_sc_os_send(int fd, const struct omni4_can_frame *f)
{
	assert_int_equal(fd, MOCK_FD);
	assert_true(mock_n_sent < (int)(sizeof(mock_sent) / sizeof(mock_sent[0])));
	mock_sent[mock_n_sent++] = *f;
	return 0;
}

int __wrap_sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class)
{
	assert_int_equal(fd, MOCK_FD);
	if (mock_rx_head == mock_rx_tail)
		return -EAGAIN;
	if (mock_rxerr[mock_rx_head]) {
		*err_class = mock_rxerr[mock_rx_head++];
		return 2;
	}
	*f = mock_rxq[mock_rx_head++];
	return 1;
}

int64_t __wrap_sc_os_now_us(void)
{
	return mock_clock_us;
}

/* A frame the kernel will hand out. */
static inline void mock_push(const struct omni4_can_frame *f)
{
	if (mock_rx_head == mock_rx_tail)
		mock_rx_head = mock_rx_tail = 0; /* all taken: start over */
	assert_true(mock_rx_tail < (int)(sizeof(mock_rxq) / sizeof(mock_rxq[0])));
	mock_rxerr[mock_rx_tail] = 0;
	mock_rxq[mock_rx_tail++] = *f;
}

static inline void mock_push_error(uint32_t err_class)
{
	mock_rxerr[mock_rx_tail++] = err_class;
}

/* Whether a filter of the socket passes a frame with this id (the kernel's rule). */
static inline bool mock_filter_passes(uint32_t id)
{
	for (int i = 0; i < mock_n_filt; i++)
		if ((id & mock_filt[i].mask) == (mock_filt[i].id & mock_filt[i].mask))
			return true;
	return false;
}

#endif /* OMNI4_SC_OS_MOCK_H */
