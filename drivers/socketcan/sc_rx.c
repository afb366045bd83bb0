/* sc_rx.c - one read of a CAN socket's queue for the motor backends (sc_rx.h). */
#include "omni4/drivers/sc_rx.h"

#include <errno.h>

#include "omni4/drivers/sc_os.h"

int sc_rx_drain(int fd, int max, int64_t now_us, const struct sc_rx_tally *t,
                sc_rx_frame_fn on_frame, void *ctx)
{
	struct omni4_can_frame f;
	uint32_t err;
	int k;

	for (k = 0; k < max; k++) {
		const int rc = sc_os_recv(fd, &f, &err);

		if (rc == -EAGAIN)
			break;
		if (rc < 0)
			return rc;
		if (rc == 2) {
			(*t->error_frames)++;
			if (err & SC_ERR_BUSOFF) {
				(*t->bus_off_count)++;
				*t->bus_off = true;
			}
			continue;
		}
		(*t->rx_frames)++;
		on_frame(ctx, &f, now_us);
	}
	return k;
}
