/*
 * clock.h - the one monotonic clock of the Linux side: CLOCK_MONOTONIC in microseconds. Header
 * only and async-signal-safe (clock_gettime is), so the crash path may call it too. Not for the
 * core, which takes its time as an argument.
 */
#ifndef OMNI4_CLOCK_H
#define OMNI4_CLOCK_H

#include <stdint.h>
#include <time.h>

static inline int64_t omni4_monotonic_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

static inline int64_t omni4_monotonic_us(void)
{
	return omni4_monotonic_ns() / 1000;
}

#endif /* OMNI4_CLOCK_H */
