/* tx_gate.c - the write gate of the CAN drive backends (tx_gate.h). */
#include "omni4/drivers/tx_gate.h"

#include <poll.h>

#include "omni4/base/clock.h"

void tx_gate_init(struct tx_gate *g)
{
	atomic_init(&g->shut, false);
	atomic_init(&g->in_flight, 0);
}

bool tx_gate_enter(struct tx_gate *g)
{
	atomic_fetch_add(&g->in_flight, 1);
	if (atomic_load(&g->shut)) {
		atomic_fetch_sub(&g->in_flight, 1);
		return false;
	}
	return true;
}

void tx_gate_leave(struct tx_gate *g)
{
	atomic_fetch_sub(&g->in_flight, 1);
}

bool tx_gate_close(struct tx_gate *g, int64_t limit_us)
{
	if (atomic_exchange(&g->shut, true))
		return false;
	const int64_t t0 = omni4_monotonic_us();

	while (atomic_load(&g->in_flight) > 0 && omni4_monotonic_us() - t0 < limit_us)
		poll(NULL, 0, 1);
	return true;
}
