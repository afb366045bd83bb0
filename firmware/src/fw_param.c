/* fw_param.c - a parameter update handed to the loop, with a bounded wait (see fw_param.h). */
#include "omni4/firmware/fw_param.h"

#include <errno.h>
#include <time.h>

#include "omni4/base/clock.h"

struct fw_param_result fw_param_apply(struct fw *fw, struct fw_param_update *u, int64_t timeout_us)
{
	const struct timespec nap = {.tv_sec = 0, .tv_nsec = 100000};
	struct fw_param_result r = {.rc = -ETIMEDOUT, .seq = -1};
	const int64_t t0 = omni4_monotonic_us();

	fw_param_offer(fw, u);
	for (;;) {
		if (fw_param_done(fw, u, &r))
			return r;
		if (omni4_monotonic_us() - t0 > timeout_us) {
			/* Withdraw it; if the loop took it meanwhile, wait for its answer. */
			if (fw_param_withdraw(fw, u))
				return r;
			timeout_us = INT64_MAX;
		}
		nanosleep(&nap, NULL);
	}
}
