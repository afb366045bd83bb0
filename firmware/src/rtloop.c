/* rtloop.c - fixed-rate loop thread with latency statistics. */
#include "omni4/firmware/rtloop.h"

#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include "omni4/base/clock.h"

static int64_t ts_ns(const struct timespec *t)
{
	return (int64_t)t->tv_sec * 1000000000LL + t->tv_nsec;
}

static struct timespec ns_ts(int64_t ns)
{
	return (struct timespec){.tv_sec = ns / 1000000000LL, .tv_nsec = ns % 1000000000LL};
}

int64_t rtloop_clock_us(void)
{
	static _Atomic int64_t offset_ns;
	int64_t off = atomic_load(&offset_ns);

	if (off == 0) {
		struct timespec r;

		clock_gettime(CLOCK_REALTIME, &r);
		off = ts_ns(&r) - omni4_monotonic_ns();
		int64_t expected = 0;

		if (!atomic_compare_exchange_strong(&offset_ns, &expected, off))
			off = expected;
	}
	return (omni4_monotonic_ns() + off) / 1000;
}

int rtloop_lock_memory(void)
{
	return mlockall(MCL_CURRENT | MCL_FUTURE) ? -errno : 0;
}

int rtloop_cpu_dma_latency(int us)
{
	const int32_t v = us;
	const int fd = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);

	if (fd < 0)
		return -errno;
	if (write(fd, &v, sizeof(v)) != (ssize_t)sizeof(v)) {
		const int e = errno;

		close(fd);
		return -e;
	}
	return fd;
}

static void *loop_main(void *arg)
{
	struct rtloop *l = arg;
	int64_t next = omni4_monotonic_ns() + l->period_ns;

	while (!atomic_load_explicit(&l->stop, memory_order_relaxed)) {
		const struct timespec wake = ns_ts(next);

		while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, NULL) == EINTR)
			;
		const int64_t now = omni4_monotonic_ns();
		const int64_t late = now - next;

		if (late > l->latency_max_ns)
			l->latency_max_ns = late;
		const int64_t bin = late / 1000;

		l->hist[bin < 0 ? 0 : (bin > RTLOOP_HIST_US ? RTLOOP_HIST_US : bin)]++;
		l->tick(l->ctx, rtloop_clock_us());
		l->ticks++;
		if (l->max_ticks && (int64_t)l->ticks >= l->max_ticks)
			break;
		next += l->period_ns;
		const int64_t after = omni4_monotonic_ns();

		if (after >= next + l->period_ns) {
			/* Missed at least one whole period: count it and re-align. */
			l->overruns++;
			next = after - (after - next) % l->period_ns + l->period_ns;
		}
	}
	return NULL;
}

int rtloop_start(struct rtloop *l, double rate_hz, int priority, int64_t max_ticks,
                 rtloop_tick_fn tick, void *ctx)
{
	pthread_attr_t attr;
	int rc;

	if (!(rate_hz > 0.0) || !tick)
		return -EINVAL;
	memset(l, 0, sizeof(*l));
	l->period_ns = (int64_t)(1e9 / rate_hz + 0.5);
	l->tick = tick;
	l->ctx = ctx;
	l->max_ticks = max_ticks;
	atomic_init(&l->stop, false);
	rtloop_clock_us(); /* fix the epoch offset outside the loop */

	pthread_attr_init(&attr);
	/* A small stack: with mlockall(MCL_FUTURE) every byte of it is resident. */
	pthread_attr_setstacksize(&attr, RTLOOP_STACK_BYTES);
	if (priority > 0) {
		struct sched_param sp = {.sched_priority = priority};

		pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
		pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
		pthread_attr_setschedparam(&attr, &sp);
	}
	rc = pthread_create(&l->thread, &attr, loop_main, l);
	if (rc == EPERM && priority > 0) {
		snprintf(l->warning, sizeof(l->warning),
		         "SCHED_FIFO priority %d not permitted; running at normal priority",
		         priority);
		pthread_attr_destroy(&attr);
		pthread_attr_init(&attr);
		pthread_attr_setstacksize(&attr, RTLOOP_STACK_BYTES);
		rc = pthread_create(&l->thread, &attr, loop_main, l);
	}
	pthread_attr_destroy(&attr);
	if (rc)
		return -rc;
	l->started = true;
	return 0;
}

void rtloop_request_stop(struct rtloop *l)
{
	atomic_store(&l->stop, true);
}

void rtloop_join(struct rtloop *l)
{
	if (l->started)
		pthread_join(l->thread, NULL);
	l->started = false;
}

double rtloop_latency_percentile_us(const struct rtloop *l, double pct)
{
	uint64_t total = 0, acc = 0;

	for (int i = 0; i <= RTLOOP_HIST_US; i++)
		total += l->hist[i];
	if (!total)
		return 0.0;
	const double want = pct / 100.0 * (double)total;

	for (int i = 0; i <= RTLOOP_HIST_US; i++) {
		acc += l->hist[i];
		if ((double)acc >= want)
			return i;
	}
	return RTLOOP_HIST_US;
}
