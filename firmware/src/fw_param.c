/* fw_param.c - a parameter update handed to the loop, with a bounded wait (see fw_param.h). */
#include "omni4/fw_param.h"

#include <errno.h>
#include <time.h>

static int64_t monotonic_us(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (int64_t)t.tv_sec * 1000000 + t.tv_nsec / 1000;
}

struct fw_param_result fw_param_apply(struct fw *fw, struct fw_param_update *u,
				      int64_t timeout_us)
{
	const struct timespec nap = {.tv_sec = 0, .tv_nsec = 100000};
	struct fw_param_result r = {.rc = -ETIMEDOUT, .seq = -1};
	const int64_t t0 = monotonic_us();

	fw_param_offer(fw, u);
	for (;;) {
		if (fw_param_done(fw, u, &r))
			return r;
		if (monotonic_us() - t0 > timeout_us) {
			/* Withdraw it; if the loop took it meanwhile, wait for its answer. */
			if (fw_param_withdraw(fw, u))
				return r;
			timeout_us = INT64_MAX;
		}
		nanosleep(&nap, NULL);
	}
}
