/* Round-trips every omni4 message through a real LCM event log file. */
#include "omni4_test.h"

#include <lcm/eventlog.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "omni4_command_t.h"
#include "omni4_experiment_t.h"
#include "omni4_motors_t.h"
#include "omni4_pose_t.h"

static char path[64];

static int setup(void **state)
{
	(void)state;
	snprintf(path, sizeof(path), "/tmp/omni4_test_log_XXXXXX");
	const int fd = mkstemp(path);

	if (fd < 0)
		return -1;
	close(fd);
	return 0;
}

static int teardown(void **state)
{
	(void)state;
	unlink(path);
	return 0;
}

static void write_event(lcm_eventlog_t *log, const char *channel, int64_t utime, void *buf, int len)
{
	lcm_eventlog_event_t ev = {
	    .timestamp = utime,
	    .channellen = (int32_t)strlen(channel),
	    .datalen = len,
	    .channel = (char *)channel,
	    .data = buf,
	};

	assert_int_equal(lcm_eventlog_write_event(log, &ev), 0);
}

static void test_every_type_round_trips_through_an_event_log(void **state)
{
	(void)state;
	char dir[] = "v";
	omni4_command_t cmd = {.utime = 11,
	                       .seq = 7,
	                       .mode = OMNI4_COMMAND_T_MODE_VOLTAGE,
	                       .velocity = {0.1, -0.2, 3.0},
	                       .voltage = {1, -2, 3.5, -12},
	                       .ramp_s = 0.25};
	omni4_motors_t mot = {.utime = 12,
	                      .seq = 123456789012LL,
	                      .mode = OMNI4_MOTORS_T_MODE_FAULT,
	                      .faults =
	                          OMNI4_MOTORS_T_FAULT_OVERCURRENT | OMNI4_MOTORS_T_FAULT_ESTOP,
	                      .voltage = {1.5f, 2, 3, 4},
	                      .current = {-0.5f, 0, 0.25f, 9},
	                      .wheel_speed = {10, -20, 30.5f, 0}};
	omni4_pose_t pose = {.utime = 13, .x = 1.25, .y = -3.5, .theta = 3.1};
	omni4_experiment_t exp = {.utime = 14, .kind = "coast", .direction = dir, .level = 6.0};
	uint8_t buf[4][512];
	int len[4];

	len[0] = omni4_command_t_encode(buf[0], 0, sizeof(buf[0]), &cmd);
	len[1] = omni4_motors_t_encode(buf[1], 0, sizeof(buf[1]), &mot);
	len[2] = omni4_pose_t_encode(buf[2], 0, sizeof(buf[2]), &pose);
	len[3] = omni4_experiment_t_encode(buf[3], 0, sizeof(buf[3]), &exp);
	for (int i = 0; i < 4; i++)
		assert_true(len[i] > 0);

	lcm_eventlog_t *log = lcm_eventlog_create(path, "w");

	assert_non_null(log);
	write_event(log, "OMNI4_CMD", 11, buf[0], len[0]);
	write_event(log, "OMNI4_MOTORS", 12, buf[1], len[1]);
	write_event(log, "OMNI4_POSE", 13, buf[2], len[2]);
	write_event(log, "OMNI4_EXPERIMENT", 14, buf[3], len[3]);
	lcm_eventlog_destroy(log);

	log = lcm_eventlog_create(path, "r");
	assert_non_null(log);
	lcm_eventlog_event_t *ev;

	ev = lcm_eventlog_read_next_event(log);
	assert_non_null(ev);
	assert_string_equal(ev->channel, "OMNI4_CMD");
	omni4_command_t c2;

	assert_int_equal(omni4_command_t_decode(ev->data, 0, ev->datalen, &c2), ev->datalen);
	assert_int_equal(c2.seq, 7);
	assert_int_equal(c2.mode, 2);
	assert_memory_equal(c2.velocity, cmd.velocity, sizeof(cmd.velocity));
	assert_memory_equal(c2.voltage, cmd.voltage, sizeof(cmd.voltage));
	assert_near(c2.ramp_s, 0.25, 0);
	omni4_command_t_decode_cleanup(&c2);
	lcm_eventlog_free_event(ev);

	ev = lcm_eventlog_read_next_event(log);
	assert_string_equal(ev->channel, "OMNI4_MOTORS");
	omni4_motors_t m2;

	assert_int_equal(omni4_motors_t_decode(ev->data, 0, ev->datalen, &m2), ev->datalen);
	assert_int_equal(m2.seq, 123456789012LL);
	assert_int_equal(m2.mode, 5);
	assert_int_equal(m2.faults, 0x0101);
	assert_memory_equal(m2.voltage, mot.voltage, sizeof(mot.voltage));
	assert_memory_equal(m2.current, mot.current, sizeof(mot.current));
	assert_memory_equal(m2.wheel_speed, mot.wheel_speed, sizeof(mot.wheel_speed));
	omni4_motors_t_decode_cleanup(&m2);
	lcm_eventlog_free_event(ev);

	ev = lcm_eventlog_read_next_event(log);
	assert_string_equal(ev->channel, "OMNI4_POSE");
	omni4_pose_t p2;

	assert_int_equal(omni4_pose_t_decode(ev->data, 0, ev->datalen, &p2), ev->datalen);
	assert_near(p2.x, 1.25, 0);
	assert_near(p2.y, -3.5, 0);
	assert_near(p2.theta, 3.1, 0);
	lcm_eventlog_free_event(ev);

	ev = lcm_eventlog_read_next_event(log);
	assert_string_equal(ev->channel, "OMNI4_EXPERIMENT");
	omni4_experiment_t e2;

	assert_int_equal(omni4_experiment_t_decode(ev->data, 0, ev->datalen, &e2), ev->datalen);
	assert_string_equal(e2.kind, "coast");
	assert_string_equal(e2.direction, "v");
	assert_near(e2.level, 6.0, 0);
	omni4_experiment_t_decode_cleanup(&e2);
	lcm_eventlog_free_event(ev);

	assert_null(lcm_eventlog_read_next_event(log));
	lcm_eventlog_destroy(log);
}

static void test_decoder_rejects_wrong_type_and_short_buffers(void **state)
{
	(void)state;
	omni4_pose_t pose = {.utime = 1, .x = 2, .y = 3, .theta = 4};
	uint8_t buf[128];
	const int n = omni4_pose_t_encode(buf, 0, sizeof(buf), &pose);
	omni4_motors_t m;
	omni4_pose_t p2;

	/* The fingerprint check refuses a pose decoded as motors_t. */
	assert_true(omni4_motors_t_decode(buf, 0, n, &m) < 0);
	/* A truncated message is refused, not read past its end. */
	assert_true(omni4_pose_t_decode(buf, 0, n - 1, &p2) < 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test_setup_teardown(test_every_type_round_trips_through_an_event_log, setup,
	                                    teardown),
	    cmocka_unit_test(test_decoder_rejects_wrong_type_and_short_buffers),
	};

	return cmocka_run_group_tests_name("lcm_eventlog", tests, NULL, NULL);
}
