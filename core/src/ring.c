/* ring.c - SPSC ring (see ring.h). */
#include "omni4/core/ring.h"

#include <errno.h>
#include <string.h>

int spsc_init(struct spsc_ring *r, void *buf, size_t capacity, size_t slot_size)
{
	if (capacity < 2 || (capacity & (capacity - 1)) || slot_size == 0 || !buf)
		return -EINVAL;
	atomic_init(&r->head, 0);
	atomic_init(&r->tail, 0);
	r->mask = capacity - 1;
	r->slot_size = slot_size;
	r->buf = buf;
	return 0;
}

bool spsc_push(struct spsc_ring *r, const void *item)
{
	const size_t head = atomic_load_explicit(&r->head, memory_order_relaxed);
	const size_t tail = atomic_load_explicit(&r->tail, memory_order_acquire);

	if (head - tail > r->mask)
		return false;
	memcpy(r->buf + (head & r->mask) * r->slot_size, item, r->slot_size);
	atomic_store_explicit(&r->head, head + 1, memory_order_release);
	return true;
}

bool spsc_pop(struct spsc_ring *r, void *item)
{
	const size_t tail = atomic_load_explicit(&r->tail, memory_order_relaxed);
	const size_t head = atomic_load_explicit(&r->head, memory_order_acquire);

	if (head == tail)
		return false;
	memcpy(item, r->buf + (tail & r->mask) * r->slot_size, r->slot_size);
	atomic_store_explicit(&r->tail, tail + 1, memory_order_release);
	return true;
}

size_t spsc_count(const struct spsc_ring *r)
{
	return atomic_load_explicit(&((struct spsc_ring *)r)->head, memory_order_acquire) -
	       atomic_load_explicit(&((struct spsc_ring *)r)->tail, memory_order_acquire);
}
