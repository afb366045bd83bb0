/* sc_rx.c - a CAN socket's queue as the motor backends read it (sc_rx.h). */
#include "omni4/drivers/sc_rx.h"

#include <errno.h>

#include "omni4/drivers/sc_os.h"

int sc_rx_next(int fd, const struct sc_rx_tally *t, struct omni4_can_frame *f)
{
	uint32_t err;
	const int rc = sc_os_recv(fd, f, &err);

	if (rc == -EAGAIN)
		return 0;
	if (rc < 0)
		return rc;
	if (rc != 2) {
		(*t->rx_frames)++;
		return 1;
	}
	(*t->error_frames)++;
	if (err & SC_ERR_BUSOFF) {
		(*t->bus_off_count)++;
		*t->bus_off = true;
	}
	return 2;
}

int sc_rx_budget(int64_t *last_us, int64_t now_us, int per_ms, int max_ms)
{
	int64_t since_ms = (now_us - *last_us) / 1000;

	*last_us = now_us;
	if (since_ms < 1)
		since_ms = 1;
	if (since_ms > max_ms)
		since_ms = max_ms;
	return per_ms * (int)since_ms;
}
