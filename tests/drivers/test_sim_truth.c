/*
 * The simulated plant's true state on OMNI4_SIM_TRUTH (docs/log-contract.md): a robot on the
 * sim backend (robot.h), the loop (fw_tick), the log ring drained through the codec
 * (lcmcodec.h) as omni4-fw and omni4-sim do. One sim_truth_t per tick, stamped and numbered as
 * that tick's motors_t, equal to the plant after the tick's step. The ring's headroom with it
 * (two entries per tick) is measured against the loop without it.
 */
#include "omni4_test.h"

#include <string.h>

#include "omni4/config/config.h"
#include "omni4/firmware/lcmcodec.h"
#include "omni4/firmware/robot.h"
#include "omni4_motors_t.h"
#include "omni4_sim_truth_t.h"

struct seen {
	int truth, motors, pose;
	omni4_sim_truth_t last;
	int64_t motors_utime, motors_seq;
};

static int emit(void *ctx, const char *channel, int64_t utime, int64_t seq, const void *data,
                size_t len)
{
	struct seen *s = ctx;

	if (!strcmp(channel, OMNI4_CHANNEL_SIM_TRUTH)) {
		assert_int_equal(omni4_sim_truth_t_decode(data, 0, (int)len, &s->last), (int)len);
		assert_int_equal(utime, s->last.utime);
		s->truth++;
	} else if (!strcmp(channel, OMNI4_CHANNEL_MOTORS)) {
		omni4_motors_t m;

		assert_int_equal(omni4_motors_t_decode(data, 0, (int)len, &m), (int)len);
		assert_int_equal(seq, m.seq); /* the sink is told the sample's tick and time */
		assert_int_equal(utime, m.utime);
		s->motors_utime = m.utime;
		s->motors_seq = m.seq;
		s->motors++;
	} else if (!strcmp(channel, OMNI4_CHANNEL_POSE)) {
		s->pose++;
	}
	return 0;
}

static struct robot R;

static void open_robot(const char *ini)
{
	static struct omni4_config cfg;
	struct config_error err;
	char why[128];

	config_defaults(&cfg);
	if (config_load_string(ini, "test.ini", &cfg, &err))
		fail_msg("%s", err.msg);
	const struct robot_spec spec = {.ctl = &cfg.ctl,
	                                .motor = OMNI4_MOTOR_SIM,
	                                .lines = OMNI4_LINES_SIM,
	                                .sim = &cfg.sim,
	                                .sim_exact = false,
	                                .utime0 = 5000000};

	if (robot_open(&R, &spec, why, sizeof(why)))
		fail_msg("%s", why);
}

/* A velocity command the floor cannot carry (mu 0.15: 2 mu M g / 4 = 1.72 N < Cv = 1.87 N
 * along v), kept alive every 50 ms: the controller pushes, the wheels slip. */
static void command(int64_t now_us, int64_t seq)
{
	const struct ctl_command c = {
	    .utime = now_us, .seq = seq, .mode = CTL_VELOCITY, .velocity = {0.5, 0.0, 1.0}};

	fw_post_command(&R.fw, &c);
}

static void test_one_truth_per_tick_equal_to_the_plant(void **state)
{
	(void)state;
	struct seen s = {0};
	const struct lcmio_sink sink = {.emit = emit, .ctx = &s};
	uint64_t errors = 0;
	int slipping = 0;

	open_robot("[sim]\ntraction_mu = 0.15\nslip_noise = 0.002\n");
	const int64_t period = R.sim.period_us;

	for (int k = 0; k < 3000; k++) {
		const int64_t now = 5000000 + k * period;

		if (k % 50 == 0)
			command(now, k / 50);
		fw_tick(&R.fw, now);
		const int before = s.truth;

		lcmio_drain(&R.fw, &sink, &errors);
		assert_int_equal(s.truth, before + 1);
		assert_int_equal(s.motors, k + 1);
		assert_true(s.last.utime == now && s.last.seq == k);
		assert_true(s.motors_utime == now && s.motors_seq == k);
		struct hal_truth t;

		sim_motor_truth(&R.sim, &t);
		assert_memory_equal(s.last.pose, t.pose, sizeof(t.pose));
		for (int a = 0; a < 3; a++)
			assert_true(s.last.vel[a] == (float)t.vel[a]);
		for (int j = 0; j < 4; j++)
			assert_true(s.last.wheel_slip[j] == (float)t.wheel_slip[j]);
		assert_int_equal(s.last.flags, (int32_t)t.flags);
		slipping += (s.last.flags & OMNI4_SIM_TRUTH_T_FLAG_SLIP_0) != 0;
	}
	print_message("3000 ticks: %d truth, %d motors, %d pose; wheel 0 slipped in %d ticks\n",
	              s.truth, s.motors, s.pose, slipping);
	assert_int_equal(errors, 0);
	assert_true(slipping > 100);
	assert_int_equal(R.fw.n.log_dropped, 0);
	robot_close(&R);
}

/* The camera's poses still come (the truth takes no frame's place); a backend without a truth
 * op (as a real robot's) logs none. */
static void test_poses_beside_the_truth_and_none_without_a_source(void **state)
{
	(void)state;
	struct seen s = {0};
	const struct lcmio_sink sink = {.emit = emit, .ctx = &s};
	uint64_t errors = 0;

	open_robot("[sim]\ncamera_latency_ms = 0\n");
	for (int k = 0; k < 500; k++) {
		fw_tick(&R.fw, 5000000 + k * R.sim.period_us);
		lcmio_drain(&R.fw, &sink, &errors);
	}
	assert_int_equal(s.truth, 500);
	assert_int_equal(s.pose, 13); /* 25 Hz: at 1 ms, then every 40 ms */
	robot_close(&R);

	memset(&s, 0, sizeof(s));
	open_robot("[sim]\n");
	R.sim.cfg.truth = false;
	for (int k = 0; k < 500; k++) {
		fw_tick(&R.fw, 5000000 + k * R.sim.period_us);
		lcmio_drain(&R.fw, &sink, &errors);
	}
	assert_int_equal(s.truth, 0);
	assert_int_equal(s.motors, 500);
	assert_true(s.pose > 0);
	robot_close(&R);
}

/* A logger that stops draining: the truth adds one ring entry per tick to what the loop logs
 * anyway (motors, estimator state, poses), so FW_LOG_RING_SLOTS / ticks-to-overflow grows by 1
 * (measured: 3855 ticks with it, 7281 without, 2.1251 - 1.1251 entries per tick). */
static int ticks_until_the_ring_overflows(bool truth)
{
	int k;

	open_robot("[sim]\n");
	R.sim.cfg.truth = truth;
	for (k = 0; k < 20000 && R.fw.n.log_dropped == 0; k++)
		fw_tick(&R.fw, 5000000 + k * R.sim.period_us);
	robot_close(&R);
	return k;
}

static void test_ring_headroom_with_the_truth(void **state)
{
	(void)state;
	const int with = ticks_until_the_ring_overflows(true);
	const int without = ticks_until_the_ring_overflows(false);

	print_message("log ring of %d entries, undrained, overflows after %d ticks with the truth, "
	              "%d without\n",
	              FW_LOG_RING_SLOTS, with, without);
	const double per_tick_with = (double)FW_LOG_RING_SLOTS / with;
	const double per_tick_without = (double)FW_LOG_RING_SLOTS / without;

	print_message("entries per tick: %.4f with, %.4f without\n", per_tick_with,
	              per_tick_without);
	assert_near(per_tick_with - per_tick_without, 1.0, 0.003);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_one_truth_per_tick_equal_to_the_plant),
	    cmocka_unit_test(test_poses_beside_the_truth_and_none_without_a_source),
	    cmocka_unit_test(test_ring_headroom_with_the_truth),
	};

	return cmocka_run_group_tests_name("sim_truth", tests, NULL, NULL);
}
