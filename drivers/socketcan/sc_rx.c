/* sc_rx.c - a CAN socket's queue as the motor backends read it (sc_rx.h). */
#include "omni4/drivers/sc_rx.h"

#include <errno.h>
#include <stdio.h>

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

static size_t advance(size_t n, size_t at, int k)
{
	at += k > 0 ? (size_t)k : 0;
	return at < n ? at : n - 1;
}

const char *sc_missing_text(const struct sc_missing *w, const uint8_t id[4], const bool have[4],
                            const uint8_t *heard, char *buf, size_t n)
{
	size_t at = 0;
	int others = 0;

	if (n == 0)
		return buf;
	buf[0] = '\0';
	for (int j = 0; j < 4; j++)
		if (!have[j])
			at = advance(n, at,
			             snprintf(buf + at, n - at, "%s %s %u (wheel %d)",
			                      at ? "," : w->missing, w->unit, (unsigned)id[j], j));
	if (at == 0)
		return buf;
	for (unsigned k = 0; k <= w->max_id; k++) {
		if (!(heard[k / 8u] & (1u << (k % 8u))))
			continue;
		const int c =
		    others++ ? snprintf(buf + at, n - at, ", %u", k)
		             : snprintf(buf + at, n - at, "; heard instead: %s %u", w->unit, k);

		at = advance(n, at, c);
	}
	if (!others)
		snprintf(buf + at, n - at, "%s", w->none_heard);
	return buf;
}
