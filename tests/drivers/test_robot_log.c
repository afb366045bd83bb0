/* The robot describes itself in its logs (docs/design.md, "Layout"): the lockstep simulator's log
 * opens with a robot_t on OMNI4_ROBOT, stamped with the first tick, and the controller sends one
 * every second of its clock; each carries the layout in force (the paper's: four wheels at 0, 90,
 * 180 and 270 deg, here all at the INI's d) with each wheel's own radius and the gear. The
 * expected values are written here from the contract, not read from the controller. */
#include "omni4_test.h"

#include <lcm/eventlog.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "config_ini.h"
#include "omni4/config/config.h"
#include "omni4/lcmtypes/channels.h"
#include "omni4/sil/simrun.h"
#include "omni4_robot_t.h"

#define TICKS 2500 /* 2.5 s at the default 1 kHz: robot_t at 0, 1 and 2 s */

static void test_a_simulated_log_opens_with_the_robot_and_repeats_it_at_1_hz(void **state)
{
	(void)state;
	struct omni4_config cfg = config_ini("[model]\nd = 0.1\nr = 0.0325\nl = 5\nKv = 0.0259\n"
	                                     "Kt = 0.0259\nR = 4.3111\nM = 2.34\nJ = 0.0228\n"
	                                     "Bv = 0.4978\nBvn = 0.6763\nBw = 0.0141\n"
	                                     "Cv = 1.8738\nCvn = 2.2198\nCw = 0.1385\n"
	                                     "r_2 = 0.031\n");
	char path[] = "/tmp/omni4_robot_log_XXXXXX", err[256];
	const int fd = mkstemp(path);

	assert_true(fd >= 0);
	close(fd);
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, false, path, err, sizeof(err));

	assert_non_null(sr);
	const int64_t t0 = simrun_now_us(sr);

	for (int k = 0; k < TICKS; k++)
		simrun_tick(sr);
	assert_int_equal(simrun_flush_log(sr), 0);
	simrun_destroy(sr);
	lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
	lcm_eventlog_event_t *ev;
	int n = 0, events = 0, first_robot = -1;

	assert_non_null(log);
	while ((ev = lcm_eventlog_read_next_event(log))) {
		if (!strcmp(ev->channel, OMNI4_CHANNEL_ROBOT)) {
			omni4_robot_t m;

			assert_int_equal(omni4_robot_t_decode(ev->data, 0, (int)ev->datalen, &m),
			                 (int)ev->datalen);
			assert_int_equal(m.utime - t0, 1000000 * (int64_t)n);
			assert_int_equal(m.wheels, 4);
			for (int j = 0; j < 4; j++) {
				assert_true(fabs(m.wheel_angle[j] - j * M_PI / 2.0) <= 1e-15);
				assert_true(m.wheel_distance[j] == 0.1);
				assert_true(m.wheel_radius[j] == (j == 2 ? 0.031 : 0.0325));
			}
			assert_true(m.l == 5.0);
			if (first_robot < 0)
				first_robot = events;
			n++;
		}
		events++;
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	unlink(path);
	printf("%d robot_t in %d events over %d ticks; the first is event %d\n", n, events, TICKS,
	       first_robot);
	assert_int_equal(n, 3);
	assert_true(first_robot >= 0 && first_robot < 8); /* among the first tick's entries */
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_a_simulated_log_opens_with_the_robot_and_repeats_it_at_1_hz),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
