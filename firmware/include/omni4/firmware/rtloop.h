/*
 * rtloop.h - the fixed-rate loop thread: clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC,
 * optional SCHED_FIFO and mlockall, wake-up latency histogram, overrun count.
 * An overrun is a tick that started a whole period or more late; the loop then re-aligns to
 * the next period boundary instead of running a burst of late ticks.
 */
#ifndef OMNI4_RTLOOP_H
#define OMNI4_RTLOOP_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

/* Latency histogram: 1 us bins up to 10 ms, then one overflow bin. */
#define RTLOOP_HIST_US 10000
/* Stack of the loop and the LCM threads, locked in RAM by mlockall (every byte resident). The
 * deepest measured use is ~20 kB (omni4-fw at 20 kHz with parameter requests, no mlockall: the
 * stacks' resident pages): 128 kB leaves six times that. */
#define RTLOOP_STACK_BYTES (128 * 1024)

typedef void (*rtloop_tick_fn)(void *ctx, int64_t now_us);

struct rtloop {
	int64_t period_ns;
	rtloop_tick_fn tick;
	void *ctx;
	int64_t max_ticks; /* 0 = until stopped */
	atomic_bool stop;
	pthread_t thread;
	bool started;
	/* statistics (read after rtloop_join) */
	uint64_t ticks;
	uint64_t overruns;
	int64_t latency_max_ns;
	uint32_t hist[RTLOOP_HIST_US + 1];
	char warning[160]; /* non-fatal set-up problem (e.g. SCHED_FIFO not permitted) */
};

/* Controller clock [us]: CLOCK_MONOTONIC shifted to the Unix epoch at first use. */
int64_t rtloop_clock_us(void);

/* Lock memory if asked (before threads start). Returns 0 or -errno. */
int rtloop_lock_memory(void);

/* Ask the kernel (PM QoS, /dev/cpu_dma_latency) to keep CPU wake-up latency at or below us
 * for as long as the returned descriptor stays open (as cyclictest does). fd >= 0 or -errno. */
int rtloop_cpu_dma_latency(int us);

/* Start the loop thread. priority > 0 asks for SCHED_FIFO at that priority (on failure the
 * loop runs at normal priority and warning says why). */
int rtloop_start(struct rtloop *l, double rate_hz, int priority, int64_t max_ticks,
                 rtloop_tick_fn tick, void *ctx);
void rtloop_request_stop(struct rtloop *l);
void rtloop_join(struct rtloop *l);

/* Latency percentile (0..100) from the histogram [us]. */
double rtloop_latency_percentile_us(const struct rtloop *l, double pct);

#endif /* OMNI4_RTLOOP_H */
