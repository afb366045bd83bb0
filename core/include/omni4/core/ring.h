/*
 * ring.h - lock-free single-producer single-consumer ring of fixed-size slots.
 * The buffer is handed in at set-up (no allocation here). Push and pop never block: a full
 * ring refuses the push (the caller counts it), an empty ring refuses the pop.
 * One thread pushes, one thread pops; C11 acquire/release atomics order the slot contents.
 */
#ifndef OMNI4_RING_H
#define OMNI4_RING_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>

struct spsc_ring {
	_Atomic size_t head; /* next slot to write (producer) */
	_Atomic size_t tail; /* next slot to read (consumer) */
	size_t mask;         /* capacity - 1, capacity a power of two */
	size_t slot_size;
	unsigned char *buf; /* capacity * slot_size bytes */
};

/* capacity must be a power of two >= 2; -EINVAL otherwise. */
int spsc_init(struct spsc_ring *r, void *buf, size_t capacity, size_t slot_size);
/* Fast loop / producer only. false if full. */
bool spsc_push(struct spsc_ring *r, const void *item);
/* Consumer only. false if empty. */
bool spsc_pop(struct spsc_ring *r, void *item);
/* Either side; a snapshot. */
size_t spsc_count(const struct spsc_ring *r);

#endif /* OMNI4_RING_H */
