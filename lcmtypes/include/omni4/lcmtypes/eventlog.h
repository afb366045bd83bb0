/*
 * eventlog.h - the one way the project appends an event to an LCM event log: liblcm's writer
 * (lcm_eventlog_write_event: sync word, event number, time, channel, data), one call for the
 * recorder, the lockstep simulator and the experiment runner. C and C++.
 */
#ifndef OMNI4_EVENTLOG_H
#define OMNI4_EVENTLOG_H

#include <errno.h>
#include <lcm/eventlog.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* Bytes an event takes in the file besides its channel name and data. */
#define OMNI4_EVENT_HEADER_BYTES 28

/* Appends one event stamped utime [us]. 0, or -errno (-EIO if the writer left none). */
static inline int omni4_eventlog_write(lcm_eventlog_t *log, const char *channel, int64_t utime,
                                       const void *data, size_t len)
{
	lcm_eventlog_event_t ev;

	memset(&ev, 0, sizeof(ev));
	ev.timestamp = utime;
	ev.channellen = (int32_t)strlen(channel);
	ev.datalen = (int32_t)len;
	ev.channel = (char *)channel;
	ev.data = (void *)data;
	errno = 0;
	if (lcm_eventlog_write_event(log, &ev) == 0)
		return 0;
	return errno ? -errno : -EIO;
}

#endif /* OMNI4_EVENTLOG_H */
