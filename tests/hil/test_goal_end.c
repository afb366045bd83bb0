/* Every goal ends (docs/goal.md "Rules", "Arrival"), in the firmware loop against the sim
 * plant in lockstep: paths that cannot be one plan are followed pose by pose to the last; a
 * goal that makes no progress is aborted with its reason; a second sender's goal replaces the
 * first, whose sender is told and never gets it back; a cancel brakes the robot to rest; REACHED
 * waits for the estimate to be sure, so a robot whose wheel radii are off ends where it was
 * sent. Scored against the plant's truth and the controller's own clock. */
#include "omni4_test.h"

#include <math.h>
#include <stdio.h>

#include "goal_rig.h"
#include "omni4/core/ctl.h"

#define DEG (3.14159265358979 / 180.0)
#define S_ACTIVE OMNI4_GOAL_STATUS_T_STATUS_ACTIVE
#define S_REACHED OMNI4_GOAL_STATUS_T_STATUS_REACHED
#define S_ABORTED OMNI4_GOAL_STATUS_T_STATUS_ABORTED

/* The truth's distance [m] and heading error [rad] from pose p. */
static void truth_off(struct simrun *sr, const double p[3], double *e, double *a)
{
	double x[3], pose[3];

	simrun_truth(sr, x, pose);
	*e = hypot(pose[0] - p[0], pose[1] - p[1]);
	*a = fabs(remainder(pose[2] - p[2], 2 * M_PI));
}

/* Goal id over path p of n poses, kept alive until it ends (limit_s at most): REACHED, every
 * pose aimed at in turn (index 0 .. n-1, never back), the truth within 1 cm and 1 deg. */
static void follow_to_the_end(const char *name, int64_t id, int n, const double (*p)[3],
                              double limit_s)
{
	struct heard h;
	struct simrun *sr = make(true, &h);
	const double t = drive_until_done(sr, &h, id, n, p, limit_s);
	double e, a;
	int last_index = 0;

	for (int i = 0; i < h.n_change; i++) {
		if (h.change[i].goal_id != id)
			continue;
		assert_true(h.change[i].index >= last_index); /* never back to an earlier pose */
		last_index = h.change[i].index;
	}
	truth_off(sr, p[n - 1], &e, &a);
	printf("%s (%d poses): %s after %.2f s, last index %d, truth off by %.2f mm, %.3f deg\n",
	       name, n, h.last.status == S_REACHED ? "REACHED" : "not reached", t, last_index,
	       e * 1e3, a / DEG);
	assert_int_equal(h.last.goal_id, id);
	assert_int_equal(h.last.status, S_REACHED);
	assert_int_equal(last_index, n - 1);
	assert_true(e < 0.01);
	assert_true(a < 1.0 * DEG);
	simrun_destroy(sr);
}

/* A turn in place, a repeated pose, more poses than one plan holds (docs/goal.md "Paths"):
 * followed pose by pose, each reached; the first turn is the one a user sent 59.5 m away. */
static void test_paths_that_cannot_be_one_plan_end_at_their_last_pose(void **state)
{
	static const double far_turn[][3] = {{59.5, 0, 0}, {59.5, 0, 1}, {59.5, 0.5, 1}};
	static const double turn[][3] = {{1.5, 0, 0}, {1.5, 0, 1}, {1.5, 0.5, 1}};
	static const double repeated[][3] = {{0.5, 0, 0}, {0.5, 0, 0}, {1.0, 0.5, 0}};
	static const double twice[][3] = {{1.0, 0, 0}, {1.0, 0, 0}};
	double nine[9][3], many[32][3];

	(void)state;
	for (int i = 0; i < 9; i++) { /* a zigzag, turning as it goes */
		nine[i][0] = 0.3 * (i + 1);
		nine[i][1] = (i % 2) * 0.3;
		nine[i][2] = 0.1 * i;
	}
	for (int i = 0; i < 32; i++) { /* an opening spiral, turning 6.2 rad in all */
		many[i][0] = 0.5 * cos(i * 0.4) * (1 + i * 0.05);
		many[i][1] = 0.5 * sin(i * 0.4) * (1 + i * 0.05);
		many[i][2] = 0.2 * i;
	}
	follow_to_the_end("turn in place, 59.5 m away", 11, 3, far_turn, 120.0);
	follow_to_the_end("turn in place", 12, 3, turn, 60.0);
	follow_to_the_end("a pose repeated", 13, 3, repeated, 60.0);
	follow_to_the_end("one pose twice", 14, 2, twice, 60.0);
	follow_to_the_end("nine poses", 15, 9, (const double (*)[3])nine, 60.0);
	follow_to_the_end("32 poses", 16, 32, (const double (*)[3])many, 120.0);
}

/* An estimator that cannot become sure (its camera's heading noise taken as 20 deg: 250 frames
 * leave 1.3 deg, beyond the arrival's 1 deg at 2 sd): the goal holds the pose for 10 s after
 * its plan ends (docs/goal.md: GOAL_SETTLE_MAX_US), ACTIVE, then ends ABORTED with
 * NO_PROGRESS and the robot stops with the ramp. */
static void test_a_goal_that_cannot_be_reached_is_aborted_for_no_progress(void **state)
{
	static const double p[1][3] = {{0.5, 0.2, 0.3}};
	struct omni4_config cfg;
	char err[256];
	struct heard h;

	(void)state;
	config_defaults(&cfg);
	cfg.ctl.est.cam_theta_noise = 20.0 * DEG;
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, true, NULL, err, sizeof(err));

	assert_non_null(sr);
	memset(&h, 0, sizeof(h));
	simrun_set_tap(sr, tap, &h);
	hil_run(sr, 0.3);
	const int64_t t0 = simrun_now_us(sr);
	const double t = drive_until_done(sr, &h, 21, 1, p, 40.0);
	int64_t ended_us = 0, aborted_us = 0;

	for (int i = 0; i < h.n_change; i++) {
		if (h.change[i].status == S_ACTIVE && h.change[i].reason != 0 && !ended_us)
			ended_us = h.change[i].utime; /* SETTLING: at the pose, not yet sure */
		if (h.change[i].status == S_ABORTED)
			aborted_us = h.change[i].utime;
	}
	printf("no progress: ABORTED reason %d after %.2f s (SETTLING from %.2f s, aborted at "
	       "%.2f s)\n",
	       h.last.reason, t, 1e-6 * (double)(ended_us - t0), 1e-6 * (double)(aborted_us - t0));
	assert_int_equal(h.last.status, S_ABORTED);
	assert_int_equal(h.last.reason, OMNI4_GOAL_STATUS_T_REASON_NO_PROGRESS);
	assert_true(ended_us > t0);
	/* 10 s after the plan ended: the plan ends after the goal was sent and before SETTLING */
	assert_true(aborted_us - t0 >= 10000000);
	assert_true(aborted_us - ended_us <= 10000000 + 1000);
	hil_run(sr, 1.0); /* the stop ramp, 0.2 s */
	assert_int_equal(mode_of(sr), CTL_IDLE);
	simrun_destroy(sr);
}

/* Two senders: A's goal in force, B sends its own (both keep repeating theirs, as two clients
 * that do not know of each other). B's replaces A's; A is told (ABORTED, REPLACED) and its
 * repeats never bring its goal back; B's is reached. */
static void test_a_second_senders_goal_replaces_the_first_whose_sender_is_told(void **state)
{
	static const double pa[1][3] = {{2.0, 0.0, 0.0}}, pb[1][3] = {{0.3, 0.6, -0.5}};
	struct heard h;
	struct simrun *sr = make(true, &h);
	int a_told = 0, a_back = 0, b_in = -1;
	double e, a;

	(void)state;
	for (int k = 0; k < 20; k++) { /* A alone, 1 s */
		send_goal(sr, 31, OMNI4_GOAL_T_ACTION_GO, 1, pa, 0.0);
		hil_run(sr, 0.05);
	}
	assert_int_equal(h.last.goal_id, 31);
	assert_int_equal(h.last.status, S_ACTIVE);
	for (int k = 0; k < 300 && !(h.last.goal_id == 32 && h.last.status == S_REACHED); k++) {
		send_goal(sr, 31, OMNI4_GOAL_T_ACTION_GO, 1, pa, 0.0);
		hil_run(sr, 0.025);
		send_goal(sr, 32, OMNI4_GOAL_T_ACTION_GO, 1, pb, 0.0);
		hil_run(sr, 0.025);
	}
	for (int i = 0; i < h.n_change; i++) {
		const struct heard_change *c = &h.change[i];

		if (c->goal_id == 32 && c->status == S_ACTIVE && b_in < 0)
			b_in = i;
		if (c->goal_id == 31 && c->status == S_ABORTED &&
		    c->reason == OMNI4_GOAL_STATUS_T_REASON_REPLACED)
			a_told++;
		if (b_in >= 0 && c->goal_id == 31 && c->status == S_ACTIVE)
			a_back++;
	}
	truth_off(sr, pb[0], &e, &a);
	printf("two senders: B in force at change %d, A told %d times, A back %d times; B %s, "
	       "truth off by %.2f mm, %.3f deg\n",
	       b_in, a_told, a_back, h.last.status == S_REACHED ? "REACHED" : "not reached",
	       e * 1e3, a / DEG);
	assert_true(b_in >= 0);
	assert_true(a_told >= 1);
	assert_int_equal(a_back, 0);
	assert_int_equal(h.last.goal_id, 32);
	assert_int_equal(h.last.status, S_REACHED);
	assert_true(e < 0.01 && a < 1.0 * DEG);
	simrun_destroy(sr);
}

/* The deceleration the planner's limits allow against a motion along the robot-frame unit
 * direction (uv, uvn), written from the model (docs/trajectory.md): each wheel's force within
 * mu (1 - margin) M g / 4 (the goal mode's floor without [limits] traction_mu: 0.6 less 10 %),
 * a body force F along u loads wheels 1, 3 with F uv / 2 and wheels 0, 2 with F uvn / 2 (eq 2's
 * least-squares split), and the Coulomb friction Cv |uv| + Cvn |uvn| helps. Table III. */
static double brake_decel(double uv, double uvn)
{
	const double M = 2.34, Cv = 1.8738, Cvn = 2.2198, f_wheel = 0.6 * 0.9 * M * 9.81 / 4.0;
	const double F = 2.0 * f_wheel / fmax(fabs(uv), fabs(uvn));

	return (F + Cv * fabs(uv) + Cvn * fabs(uvn)) / M;
}

/* A cancel at speed (the goal 4 m away, cancelled at 1.5 m/s or more): ABORTED, CANCELLED at
 * once; the robot brakes to rest on a plan inside the drives' envelope, then the stop ramp:
 * IDLE, at rest, with no wheel slipping, within the distance the planner's deceleration allows
 * (brake_decel) after the plan's lead (20 ms at the speed), plus 20 %. Before, the stop ramp
 * let it coast: 1.47 m from 1.74 m/s. */
static void test_a_cancel_at_speed_brakes_to_rest(void **state)
{
	static const double far[1][3] = {{4.0, 0.0, 0.0}};
	struct heard h;
	struct simrun *sr = make(true, &h);
	double x[3], pose[3], at[3], v0 = 0.0;

	(void)state;
	for (int k = 0; k < 100 && v0 < 1.5; k++) {
		send_goal(sr, 41, OMNI4_GOAL_T_ACTION_GO, 1, far, 0.0);
		hil_run(sr, 0.05);
		simrun_truth(sr, x, pose);
		v0 = hypot(x[0], x[1]);
	}
	assert_true(v0 >= 1.5);
	memcpy(at, pose, sizeof(at));
	/* the truth's velocity is in the robot frame: its direction there */
	const double a_brake = brake_decel(x[0] / v0, x[1] / v0);
	const double bound = 1.2 * (0.02 * v0 + v0 * v0 / (2.0 * a_brake));
	send_goal(sr, 41, OMNI4_GOAL_T_ACTION_CANCEL, 0, NULL, 0.0);
	hil_run(sr, 0.002);
	assert_int_equal(h.last.goal_id, 41);
	assert_int_equal(h.last.status, S_ABORTED);
	assert_int_equal(h.last.reason, OMNI4_GOAL_STATUS_T_REASON_CANCELLED);
	double t = 0.0;

	h.slip_ticks = 0;
	for (; t < 5.0 && mode_of(sr) != CTL_IDLE; t += 0.001)
		hil_run(sr, 0.001);
	const long slip = h.slip_ticks;
	hil_run(sr, 0.3);
	simrun_truth(sr, x, pose);
	const double d = hypot(pose[0] - at[0], pose[1] - at[1]);

	printf("cancel at %.2f m/s: IDLE after %.2f s, %.3f m on (the planner's deceleration "
	       "%.2f m/s^2: bound %.3f m), %ld slipping ticks, at rest %.4f m/s\n",
	       v0, t, d, a_brake, bound, slip, hypot(x[0], x[1]));
	assert_int_equal(mode_of(sr), CTL_IDLE);
	assert_true(d <= bound);
	assert_int_equal(slip, 0);
	assert_true(hypot(x[0], x[1]) < 0.01);
	simrun_destroy(sr);
}

/* The user's robot: wheel radii off by up to 1 % (not yet identified: odometry drifts) and
 * the paper's late, noisy camera. Each goal REACHED only once the estimate is sure of it, and
 * then the truth is within 1 cm and 1 deg of the goal, every time. */
static void test_reached_means_the_truth_is_there_with_radii_off_by_1pc(void **state)
{
	static const double goals[][3] = {{1.0, 0.5, 1.0},  {-0.5, 0.8, -1.5}, {0.0, 0.0, 0.0},
	                                  {1.5, -0.5, 3.0}, {0.2, 0.1, 1.6},   {-1.0, -1.0, -2.0}};
	const double err_r[4] = {0.01, -0.008, 0.006, -0.01};
	struct omni4_config cfg;
	char err[256];
	struct heard h;
	double worst_e = 0.0, worst_a = 0.0, total = 0.0;

	(void)state;
	config_defaults(&cfg);
	for (int j = 0; j < 4; j++)
		cfg.sim.wheel_radius_error[j] = err_r[j];
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, true, NULL, err, sizeof(err));

	assert_non_null(sr);
	memset(&h, 0, sizeof(h));
	simrun_set_tap(sr, tap, &h);
	hil_run(sr, 0.3);
	for (int k = 0; k < 6; k++) {
		const double t = drive_until_done(sr, &h, 50 + k, 1, &goals[k], 30.0);
		double e, a;

		truth_off(sr, goals[k], &e, &a);
		printf("radii off: goal %d %s after %.2f s, truth off by %.2f mm, %.3f deg\n", k,
		       h.last.status == S_REACHED ? "REACHED" : "not reached", t, e * 1e3, a / DEG);
		assert_int_equal(h.last.status, S_REACHED);
		worst_e = fmax(worst_e, e);
		worst_a = fmax(worst_a, a);
		total += t;
		send_goal(sr, 50 + k, OMNI4_GOAL_T_ACTION_CANCEL, 0, NULL, 0.0);
		hil_run(sr, 0.3);
	}
	printf("radii off: worst truth %.2f mm, %.3f deg; %.2f s for 6 goals\n", worst_e * 1e3,
	       worst_a / DEG, total);
	assert_true(worst_e < 0.01);
	assert_true(worst_a < 1.0 * DEG);
	simrun_destroy(sr);
}

/* A camera three times as noisy in position (3 cm, the estimator told so): the position's own
 * standard deviation, not the heading's, is what REACHED waits for. At every REACHED the
 * estimate published then (OMNI4_STATE's covariance) is sure as docs/goal.md says: distance
 * plus 2 sd within 1 cm, heading plus 2 sd within 1 deg (the state of at most 10 ms before the
 * REACHED tick: 2 % slack); the truth is within 1 cm and 1 deg. */
static void test_reached_waits_for_a_sure_position_with_a_noisy_camera(void **state)
{
	static const double goals[][3] = {{0.8, 0.3, 0.5},
	                                  {0.0, 0.6, -1.0},
	                                  {-0.4, -0.2, 2.0},
	                                  {0.5, -0.5, 0.0},
	                                  {0.0, 0.0, 1.0}};
	struct omni4_config cfg;
	char err[256];
	struct heard h;
	double worst_e = 0.0;

	(void)state;
	config_defaults(&cfg);
	cfg.sim.camera_pos_noise_m = 0.03;
	cfg.ctl.est.cam_pos_noise = 0.03;
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, true, NULL, err, sizeof(err));

	assert_non_null(sr);
	memset(&h, 0, sizeof(h));
	simrun_set_tap(sr, tap, &h);
	hil_run(sr, 0.3);
	for (int k = 0; k < 5; k++) {
		h.n_change = 0;
		const double t = drive_until_done(sr, &h, 60 + k, 1, &goals[k], 30.0);
		double e, a;
		int settling = 0;

		for (int i = 0; i < h.n_change; i++)
			settling += h.change[i].reason == OMNI4_GOAL_STATUS_T_REASON_SETTLING;
		truth_off(sr, goals[k], &e, &a);
		printf(
		    "noisy camera: goal %d %s after %.2f s (settling seen %d), truth off by %.2f "
		    "mm, %.3f deg; at REACHED %.2f + 2 x %.2f mm, %.3f + 2 x %.3f deg\n",
		    k, h.last.status == S_REACHED ? "REACHED" : "not reached", t, settling, e * 1e3,
		    a / DEG, h.reached_dist * 1e3, h.reached_sd_pos * 1e3, h.reached_angle / DEG,
		    h.reached_sd_th / DEG);
		assert_int_equal(h.last.status, S_REACHED);
		assert_true(h.reached_dist + 2.0f * h.reached_sd_pos <= 1.02f * 0.01f);
		assert_true(h.reached_angle + 2.0f * h.reached_sd_th <= 1.02f * 1.0f * (float)DEG);
		assert_true(e < 0.01 && a < 1.0 * DEG);
		worst_e = fmax(worst_e, e);
		send_goal(sr, 60 + k, OMNI4_GOAL_T_ACTION_CANCEL, 0, NULL, 0.0);
		hil_run(sr, 0.3);
	}
	printf("noisy camera: worst truth %.2f mm\n", worst_e * 1e3);
	simrun_destroy(sr);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_paths_that_cannot_be_one_plan_end_at_their_last_pose),
	    cmocka_unit_test(test_a_goal_that_cannot_be_reached_is_aborted_for_no_progress),
	    cmocka_unit_test(test_a_second_senders_goal_replaces_the_first_whose_sender_is_told),
	    cmocka_unit_test(test_a_cancel_at_speed_brakes_to_rest),
	    cmocka_unit_test(test_reached_means_the_truth_is_there_with_radii_off_by_1pc),
	    cmocka_unit_test(test_reached_waits_for_a_sure_position_with_a_noisy_camera),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
