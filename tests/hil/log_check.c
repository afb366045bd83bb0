/* log_check LOG: counts OMNI4_MOTORS in an LCM event log and checks seq continuity.
 * Prints "motors N, first seq A, last seq B, gaps G, duplicates D"; exit 0 if G = D = 0. */
#include <lcm/eventlog.h>
#include <stdio.h>
#include <string.h>

#include "omni4_motors_t.h"

int main(int argc, char **argv)
{
	if (argc != 2) {
		fprintf(stderr, "usage: log_check LOG\n");
		return 2;
	}
	lcm_eventlog_t *log = lcm_eventlog_create(argv[1], "r");

	if (!log) {
		fprintf(stderr, "log_check: %s: cannot open\n", argv[1]);
		return 2;
	}
	long long n = 0, gaps = 0, dups = 0, first = -1, last = -1;
	lcm_eventlog_event_t *ev;

	while ((ev = lcm_eventlog_read_next_event(log))) {
		omni4_motors_t m;

		if (!strcmp(ev->channel, "OMNI4_MOTORS") &&
		    omni4_motors_t_decode(ev->data, 0, ev->datalen, &m) == ev->datalen) {
			if (first < 0)
				first = m.seq;
			else if (m.seq > last + 1)
				gaps += m.seq - last - 1;
			else if (m.seq <= last)
				dups++;
			last = m.seq;
			n++;
		}
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	printf("motors %lld, first seq %lld, last seq %lld, gaps %lld, duplicates %lld\n", n, first,
	       last, gaps, dups);
	return n > 0 && gaps == 0 && dups == 0 ? 0 : 1;
}
