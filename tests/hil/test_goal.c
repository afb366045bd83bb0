/* The goal mode (core/ goal.c, docs/goal.md) in the firmware loop against the sim plant, in
 * lockstep through simrun: goals as goal_t bytes in, their progress read back as the
 * goal_status_t messages the controller emits, the arrival scored against the plant's truth. */
#include "omni4_test.h"

#include <math.h>
#include <stdio.h>

#include "goal_rig.h"
#include "omni4/core/ctl.h"
#include "omni4/core/goal.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4_goal_status_t.h"
#include "omni4_goal_t.h"

#define DEG (3.14159265358979 / 180.0)

/* The course: short and long moves, turns while translating, a path with corners. */
static const double course[][3] = {
    {0.5, 0.0, 0.0}, {1.5, 1.0, 1.57}, {0.2, 1.2, -2.5}, {0.2, 1.25, 3.0}, {-1.0, -0.5, 0.0},
};
static const double corners[][3] = {
    {1.0, 0.0, 0.0}, {1.0, 1.0, 0.0}, {0.0, 1.0, 1.57}, {0.0, 0.0, 0.0}};

/* Each goal of the course, then the path, reached: the plant's true pose within 1 cm and
 * 1 deg of the goal (mean and max printed), the controller back in IDLE after a cancel. */
static void arrive(bool noise)
{
	struct heard h;
	struct simrun *sr = make(noise, &h);
	double sum_e = 0, max_e = 0, sum_a = 0, max_a = 0, x[3], pose[3];
	const int n_goals = (int)(sizeof(course) / sizeof(course[0])) + 1;

	for (int k = 0; k < n_goals; k++) {
		const bool path = k == n_goals - 1;
		const double (*p)[3] = path ? corners : &course[k];
		const int n = path ? 4 : 1;
		const double t = drive_until_done(sr, &h, 100 + k, n, p, 20.0);

		assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_REACHED);
		simrun_truth(sr, x, pose);
		const double e = hypot(pose[0] - p[n - 1][0], pose[1] - p[n - 1][1]);
		const double a = fabs(remainder(pose[2] - p[n - 1][2], 2 * M_PI));

		printf("goal %d (%s): %.2f s, truth off by %.2f mm, %.3f deg\n", k,
		       path ? "path of 4" : "pose", t, e * 1e3, a / DEG);
		sum_e += e;
		sum_a += a;
		max_e = fmax(max_e, e);
		max_a = fmax(max_a, a);
		assert_true(e < 0.01);
		assert_true(a < 1.0 * DEG);
		send_goal(sr, 100 + k, OMNI4_GOAL_T_ACTION_CANCEL, 0, NULL, 0.0);
		hil_run(sr, 0.5);
		assert_int_equal(mode_of(sr), CTL_IDLE);
	}
	printf("final pose against truth (%s sensors): mean %.2f mm, max %.2f mm; mean %.3f deg, "
	       "max %.3f deg\n",
	       noise ? "noisy" : "exact", sum_e / n_goals * 1e3, max_e * 1e3, sum_a / n_goals / DEG,
	       max_a / DEG);
	assert_int_equal(simrun_watchdog_trips(sr), 0);
	simrun_destroy(sr);
}

static void test_goals_reached_within_1cm_1deg_of_truth_exact_sensors(void **state)
{
	(void)state;
	arrive(false);
}

static void test_goals_reached_within_1cm_1deg_of_truth_paper_camera(void **state)
{
	(void)state;
	arrive(true);
}

static const double far_pose[1][3] = {{3.0, 2.0, 1.0}};

/* A goal sent once: the watchdog stops it (ABORTED, WATCHDOG) with the ramp, then IDLE. */
static void test_goal_whose_sender_stops_is_stopped_by_the_watchdog(void **state)
{
	struct heard h;
	struct simrun *sr = make(true, &h);

	(void)state;
	send_goal(sr, 7, OMNI4_GOAL_T_ACTION_GO, 1, far_pose, 0.0);
	hil_run(sr, 0.1);
	assert_int_equal(mode_of(sr), CTL_GOAL);
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ACTIVE);
	hil_run(sr, 0.15); /* 250 ms after the goal: the watchdog (200 ms) fired */
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ABORTED);
	assert_int_equal(h.last.reason, OMNI4_GOAL_STATUS_T_REASON_WATCHDOG);
	assert_int_equal(mode_of(sr), CTL_VOLTAGE); /* the stop ramp */
	assert_int_equal(simrun_watchdog_trips(sr), 1);
	hil_run(sr, 0.3);
	assert_int_equal(mode_of(sr), CTL_IDLE);
	/* The same id again does not restart an ended goal. */
	send_goal(sr, 7, OMNI4_GOAL_T_ACTION_GO, 1, far_pose, 0.0);
	hil_run(sr, 0.05);
	assert_int_equal(mode_of(sr), CTL_IDLE);
	simrun_destroy(sr);
}

/* A refused goal: REFUSED with reason, the controller not moved. */
static void expect_refused(struct simrun *sr, struct heard *h, int64_t id, const double (*p)[3],
                           double speed_max, int8_t reason, int8_t mode)
{
	const int before = h->refused;

	send_goal(sr, id, OMNI4_GOAL_T_ACTION_GO, 1, p, speed_max);
	hil_run(sr, 0.02);
	assert_int_equal(h->refused, before + 1);
	assert_int_equal(h->last.goal_id, id);
	assert_int_equal(h->last.status, OMNI4_GOAL_STATUS_T_STATUS_REFUSED);
	assert_int_equal(h->last.reason, reason);
	assert_int_equal(mode_of(sr), mode);
}

static void test_nan_out_of_range_and_unreachable_goals_are_refused(void **state)
{
	struct heard h;
	struct simrun *sr = make(true, &h);
	const double nan_pose[1][3] = {{1.0, NAN, 0.0}};
	const double beyond[1][3] = {{GOAL_RANGE_M + 1.0, 0.0, 0.0}};

	(void)state;
	expect_refused(sr, &h, 1, nan_pose, 0.0, OMNI4_GOAL_STATUS_T_REASON_NOT_FINITE, CTL_IDLE);
	expect_refused(sr, &h, 2, beyond, 0.0, OMNI4_GOAL_STATUS_T_REASON_OUT_OF_RANGE, CTL_IDLE);
	/* 3.6 m at 1 cm/s: beyond the longest plan allowed. */
	expect_refused(sr, &h, 3, far_pose, 0.01, OMNI4_GOAL_STATUS_T_REASON_UNREACHABLE, CTL_IDLE);
	simrun_destroy(sr);
}

static void test_goal_during_fault_is_refused(void **state)
{
	struct heard h;
	struct simrun *sr = make(true, &h);

	(void)state;
	simrun_faults(sr)->current_offset_a = 20.0; /* over-current: FAULT */
	hil_run(sr, 0.01);
	assert_int_equal(mode_of(sr), CTL_FAULT);
	expect_refused(sr, &h, 4, far_pose, 0.0, OMNI4_GOAL_STATUS_T_REASON_FAULT, CTL_FAULT);
	simrun_destroy(sr);
}

/* Kept alive 50 ms at a time for seconds s. */
static void keep(struct simrun *sr, int64_t id, const double (*p)[3], double s)
{
	for (double t = 0; t < s; t += 0.05) {
		send_goal(sr, id, OMNI4_GOAL_T_ACTION_GO, 1, p, 0.0);
		hil_run(sr, 0.05);
	}
}

/* A goal pushed back hard: ABORTED, COLLISION, the outputs ramp down (no step to 0 V). */
static void test_collision_aborts_the_goal_with_the_stop_ramp(void **state)
{
	struct heard h;
	struct simrun *sr = make(true, &h);

	(void)state;
	keep(sr, 5, far_pose, 0.5);
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ACTIVE);
	double x[3], pose[3];

	simrun_truth(sr, x, pose);
	const double speed = hypot(x[0], x[1]);

	for (int k = 0; k < 2; k++) /* 25 N against the motion */
		simrun_faults(sr)->ext_force[k] = -25.0 * x[k] / speed;
	int ms = 0;

	for (; ms < 500 && h.last.status == OMNI4_GOAL_STATUS_T_STATUS_ACTIVE; ms++) {
		if (ms % 50 == 0)
			send_goal(sr, 5, OMNI4_GOAL_T_ACTION_GO, 1, far_pose, 0.0);
		simrun_tick(sr);
	}
	printf("pushed with 25 N: ABORTED after %d ms\n", ms);
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ABORTED);
	assert_int_equal(h.last.reason, OMNI4_GOAL_STATUS_T_REASON_COLLISION);
	assert_int_equal(mode_of(sr), CTL_VOLTAGE); /* stop_ramp_s = 0.2 s */
	assert_int_equal(simrun_watchdog_trips(sr), 0);
	hil_run(sr, 0.25);
	assert_int_equal(mode_of(sr), CTL_IDLE);
	simrun_destroy(sr);
}

/* The camera goes dark: odometry carries the goal GOAL_ODOM_ONLY_US after the last frame, not
 * longer (ABORTED, STALE_ESTIMATE); a new goal without a camera is refused (NO_ESTIMATE). */
static void test_stale_estimate_stops_the_goal_after_one_second_of_odometry(void **state)
{
	struct heard h;
	struct simrun *sr = make(true, &h);

	(void)state;
	keep(sr, 6, far_pose, 0.2);
	simrun_faults(sr)->camera_off = true;
	keep(sr, 6, far_pose, 0.8);
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ACTIVE);
	keep(sr, 6, far_pose, 0.4);
	assert_int_equal(h.last.status, OMNI4_GOAL_STATUS_T_STATUS_ABORTED);
	assert_int_equal(h.last.reason, OMNI4_GOAL_STATUS_T_REASON_STALE_ESTIMATE);
	hil_run(sr, 0.3);
	assert_int_equal(mode_of(sr), CTL_IDLE);
	expect_refused(sr, &h, 8, far_pose, 0.0, OMNI4_GOAL_STATUS_T_REASON_NO_ESTIMATE, CTL_IDLE);
	simrun_destroy(sr);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_goals_reached_within_1cm_1deg_of_truth_exact_sensors),
	    cmocka_unit_test(test_goals_reached_within_1cm_1deg_of_truth_paper_camera),
	    cmocka_unit_test(test_goal_whose_sender_stops_is_stopped_by_the_watchdog),
	    cmocka_unit_test(test_nan_out_of_range_and_unreachable_goals_are_refused),
	    cmocka_unit_test(test_goal_during_fault_is_refused),
	    cmocka_unit_test(test_collision_aborts_the_goal_with_the_stop_ramp),
	    cmocka_unit_test(test_stale_estimate_stops_the_goal_after_one_second_of_odometry),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
