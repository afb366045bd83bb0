/* hil_util.h - helpers for the HIL tests: send commands into a simrun, read logs back. */
#ifndef OMNI4_HIL_UTIL_H
#define OMNI4_HIL_UTIL_H

#include <lcm/eventlog.h>
#include <stdlib.h>
#include <string.h>

#include "omni4/sil/simrun.h"
#include "omni4_command_t.h"
#include "omni4_motors_t.h"

static inline int hil_send(struct simrun *sr, int8_t mode, const double vel[3],
                           const double volt[4], double ramp_s)
{
	static int64_t seq;
	omni4_command_t c = {
	    .utime = simrun_now_us(sr), .seq = seq++, .mode = mode, .ramp_s = ramp_s};
	uint8_t buf[256];

	if (vel)
		memcpy(c.velocity, vel, sizeof(c.velocity));
	if (volt)
		memcpy(c.voltage, volt, sizeof(c.voltage));
	const int n = omni4_command_t_encode(buf, 0, sizeof(buf), &c);

	return simrun_command(sr, buf, (size_t)n);
}

static inline void hil_run(struct simrun *sr, double seconds)
{
	const long n = lround(seconds / simrun_period_s(sr));

	for (long i = 0; i < n; i++)
		simrun_tick(sr);
}

/* Read every OMNI4_MOTORS message of an event log into a malloc'd array; returns the count. */
static inline size_t hil_read_motors(const char *path, omni4_motors_t **out)
{
	lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
	size_t n = 0, cap = 1024;
	lcm_eventlog_event_t *ev;

	*out = malloc(cap * sizeof(**out));
	if (!log)
		return 0;
	while ((ev = lcm_eventlog_read_next_event(log))) {
		if (!strcmp(ev->channel, "OMNI4_MOTORS")) {
			if (n == cap)
				*out = realloc(*out, (cap *= 2) * sizeof(**out));
			if (omni4_motors_t_decode(ev->data, 0, ev->datalen, &(*out)[n]) > 0)
				n++;
		}
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	return n;
}

#endif /* OMNI4_HIL_UTIL_H */
