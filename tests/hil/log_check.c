/* log_check [--gaps] [--sums] LOG...: counts OMNI4_MOTORS in LCM event logs (several files
 * are one stream, in the order given: the parts of a split log) and checks seq continuity.
 * Prints "motors N, first seq A, last seq B, gaps G, duplicates D"; exit 0 if G = D = 0.
 * --gaps also prints one line per gap: where it is (seq, log time) and how many are missing.
 * --sums also prints the sums of every decoded voltage, current and wheel speed (for checking
 * another decoder against this one). */
#include <lcm/eventlog.h>
#include <stdio.h>
#include <string.h>

#include "omni4_motors_t.h"

int main(int argc, char **argv)
{
	int show_gaps = 0, show_sums = 0, nfiles = 0;
	double sum_v = 0, sum_i = 0, sum_w = 0;

	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--gaps"))
			show_gaps = 1;
		else if (!strcmp(argv[i], "--sums"))
			show_sums = 1;
		else
			nfiles++;
	}
	if (!nfiles) {
		fprintf(stderr, "usage: log_check [--gaps] [--sums] LOG...\n");
		return 2;
	}
	long long n = 0, gaps = 0, dups = 0, first = -1, last = -1, t0 = -1;

	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--gaps") || !strcmp(argv[i], "--sums"))
			continue;
		lcm_eventlog_t *log = lcm_eventlog_create(argv[i], "r");
		lcm_eventlog_event_t *ev;

		if (!log) {
			fprintf(stderr, "log_check: %s: cannot open\n", argv[i]);
			return 2;
		}
		while ((ev = lcm_eventlog_read_next_event(log))) {
			omni4_motors_t m;

			if (!strcmp(ev->channel, "OMNI4_MOTORS") &&
			    omni4_motors_t_decode(ev->data, 0, ev->datalen, &m) == ev->datalen) {
				if (t0 < 0)
					t0 = ev->timestamp;
				if (first < 0) {
					first = m.seq;
				} else if (m.seq > last + 1) {
					gaps += m.seq - last - 1;
					if (show_gaps)
						printf("gap: %lld missing after seq %lld (t = %.3f "
						       "s)\n",
						       (long long)m.seq - last - 1, last,
						       (ev->timestamp - t0) * 1e-6);
				} else if (m.seq <= last) {
					dups++;
				}
				last = m.seq;
				n++;
				for (int j = 0; j < 4; j++) {
					sum_v += m.voltage[j];
					sum_i += m.current[j];
					sum_w += m.wheel_speed[j];
				}
			}
			lcm_eventlog_free_event(ev);
		}
		lcm_eventlog_destroy(log);
	}
	printf("motors %lld, first seq %lld, last seq %lld, gaps %lld, duplicates %lld\n", n, first,
	       last, gaps, dups);
	if (show_sums)
		printf("sums: voltage %.9e current %.9e wheel_speed %.9e\n", sum_v, sum_i, sum_w);
	return n > 0 && gaps == 0 && dups == 0 ? 0 : 1;
}
