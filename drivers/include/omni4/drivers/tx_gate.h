/*
 * tx_gate.h - the write gate of a CAN drive backend (vesc, odrive): every send of the loop
 * happens between tx_gate_enter() and tx_gate_leave(); the crash path's tx_gate_close() shuts
 * it and waits for a send in flight on another thread to leave, so the halt's stop frames are
 * the last on the bus. Sequentially consistent atomics on both sides (store, then load the
 * other's flag): either the writer sees the gate shut and sends nothing, or the halt sees the
 * writer and waits for it. The socketcan backend's gate, as a block of its own (tx_gate.c, in
 * the can_socket library).
 */
#ifndef OMNI4_TX_GATE_H
#define OMNI4_TX_GATE_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

struct tx_gate {
	atomic_bool shut;
	atomic_int in_flight;
};

void tx_gate_init(struct tx_gate *g);
/* Fast loop. true: inside, send, then tx_gate_leave(); false: shut, send nothing. */
bool tx_gate_enter(struct tx_gate *g);
void tx_gate_leave(struct tx_gate *g);
/* Async-signal-safe. Shut the gate (false if it already was) and wait, at most limit_us,
 * 1 ms per check, for the senders inside to leave. A crash inside a send of this thread: its
 * send never resumes, so it waits out limit_us, then the caller's frames follow. */
bool tx_gate_close(struct tx_gate *g, int64_t limit_us);

#endif /* OMNI4_TX_GATE_H */
