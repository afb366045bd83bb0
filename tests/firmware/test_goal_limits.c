/* Tests for the goal mode's limits (core/src/goal.c, docs/goal.md): the planner's traction from
 * [limits] traction_mu and traction_margin, checked against each wheel's force worked out here
 * from the plan (Newton with the model's friction, split onto the wheels by least norm, eqs
 * 9-11), never from the planner's own code; a parameter change re-plans without a jump. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "omni4/core/ctl.h"
#include "omni4/core/goal.h"

static const double G = 9.80665;

static double sgn(double x)
{
	return (x > 0) - (x < 0);
}

/* Wheel j's drive force [N] at the reference ref (world frame), by hand: the body's force in
 * the robot frame F = M a_r + B v + C sgn(v), T = J a_w + Bw w + Cw sgn(w), where a_r is the
 * rate of the robot-frame velocity; the least-norm split f_0 = F_vn/2 + T/4d, f_1 = -F_v/2 +
 * T/4d, f_2 = -F_vn/2 + T/4d, f_3 = F_v/2 + T/4d. */
static void wheel_forces(const struct model_params *p, const struct traj_ref *ref, double f[4])
{
	const double th = ref->pose[2], c = cos(th), s = sin(th), w = ref->vel[2];
	const double v = c * ref->vel[0] + s * ref->vel[1], vn = -s * ref->vel[0] + c * ref->vel[1];
	const double av = c * ref->acc[0] + s * ref->acc[1] + w * vn;
	const double avn = -s * ref->acc[0] + c * ref->acc[1] - w * v;
	const double Fv = p->M * av + p->Bv * v + p->Cv * sgn(v);
	const double Fvn = p->M * avn + p->Bvn * vn + p->Cvn * sgn(vn);
	const double T = p->J * ref->acc[2] + p->Bw * w + p->Cw * sgn(w);

	f[0] = Fvn / 2 + T / (4 * p->d);
	f[1] = -Fv / 2 + T / (4 * p->d);
	f[2] = -Fvn / 2 + T / (4 * p->d);
	f[3] = Fv / 2 + T / (4 * p->d);
}

struct rig {
	struct ctl_settings cfg;
	struct ctl c;
	struct goal g;
	struct est_output est;
};

static void rig_init(struct rig *r, double mu, double margin)
{
	memset(r, 0, sizeof(*r));
	ctl_settings_defaults(&r->cfg);
	r->cfg.limits.traction_mu = mu;
	r->cfg.limits.traction_margin = margin;
	assert_int_equal(ctl_init(&r->c, &r->cfg), 0);
	goal_init(&r->g, &r->cfg);
	assert_true(r->g.traj_ok);
}

static void go(struct rig *r, int64_t id, double x, double y, double th)
{
	struct goal_cmd cmd = {.id = id, .action = GOAL_GO, .n = 1};

	cmd.poses[0][0] = x;
	cmd.poses[0][1] = y;
	cmd.poses[0][2] = th;
	assert_int_equal(goal_command(&r->g, &r->c, &cmd, &r->est, 0), 0);
	assert_true(goal_work(&r->g));       /* its plan, beside the loop */
	goal_step(&r->g, &r->c, &r->est, 0); /* handed over: from rest, at once */
	assert_int_equal(r->g.rep.status, GOAL_ACTIVE);
}

/* The largest |f_j| over the plan sampled every 1 ms [N]. */
static double largest_force(const struct rig *r)
{
	double top = 0.0;

	for (float t = 0.0f; t <= r->g.tr.duration_s; t += 1e-3f) {
		struct traj_ref ref;
		double f[4];

		traj_eval(&r->g.tr, t, &ref);
		wheel_forces(&r->cfg.model, &ref, f);
		for (int j = 0; j < 4; j++)
			top = fmax(top, fabs(f[j]));
	}
	return top;
}

/* Along the diagonal (all four wheels push), along v and along vn (two do). (Turning while
 * translating, the planner's forces on this model run up to ~6 % over at mu 0.4: the rate of
 * the robot-frame velocity has a w x v part the envelope does not see; docs/goal.md.) */
static const double moves[][3] = {{1.5, 1.5, 0.0}, {1.2, 0.0, 0.0}, {0.0, -1.0, 0.0}};

/* Each wheel's force within mu M g / 4 (1 - margin), and at it somewhere (the limit binds:
 * a planner that ignored mu would be over it); a lower mu, a later arrival. */
static void test_lower_mu_gives_a_slower_plan_within_mu_times_load(void **state)
{
	(void)state;
	const double mus[] = {0.4, 0.6};
	const double margin = 0.05;

	for (size_t k = 0; k < sizeof(moves) / sizeof(moves[0]); k++) {
		double dur[2];

		for (int i = 0; i < 2; i++) {
			struct rig r;

			rig_init(&r, mus[i], margin);
			go(&r, 1, moves[k][0], moves[k][1], moves[k][2]);
			const double hold = mus[i] * r.cfg.model.M * G / 4.0 * (1.0 - margin);
			const double top = largest_force(&r);

			dur[i] = r.g.tr.duration_s;
			printf("mu %.2f, move %zu: %.3f s, largest wheel force %.3f N of %.3f N\n",
			       mus[i], k, dur[i], top, hold);
			assert_true(top <= hold * 1.01);
			assert_true(top >= hold * 0.9);
		}
		assert_true(dur[0] > dur[1] * 1.05);
	}
}

/* traction_mu = 0 (the controller's limit off, the floor not identified): the planner takes
 * [goal] floor_mu for the floor, less the same [limits] traction_margin; a lower floor_mu plans
 * within its own, lower, traction. */
static void test_traction_off_plans_on_floor_mu_less_the_margin(void **state)
{
	(void)state;
	const double floor_mu[2] = {0.0, 0.35}; /* 0: the key table's default */

	for (int i = 0; i < 2; i++) {
		struct rig r;

		rig_init(&r, 0.0, 0.2);
		if (floor_mu[i] > 0.0) {
			r.cfg.goal.floor_mu = floor_mu[i];
			goal_init(&r.g, &r.cfg);
		}
		go(&r, 1, 1.5, 1.5, 0.0);
		const double hold = r.cfg.goal.floor_mu * r.cfg.model.M * G / 4.0 * (1.0 - 0.2);
		const double top = largest_force(&r);

		printf("floor_mu %.2f: largest wheel force %.3f N of %.3f N\n", r.cfg.goal.floor_mu,
		       top, hold);
		assert_true(top <= hold * 1.01);
		assert_true(top >= hold * 0.9);
	}
}

/* A live change of mu while a goal runs: the tick that takes it plans nothing (the plan in
 * force goes on); the new plan, made beside the loop (goal_work), is handed over a lead
 * (GOAL_PLAN_LEAD_S) later where the reference is then: no step in pose or velocity beyond a
 * tick's motion, and under the lower mu it arrives later; the goal goes on. */
static void test_parameter_change_replans_from_the_reference_without_a_jump(void **state)
{
	(void)state;
	struct rig r;
	struct traj_ref prev, now;

	rig_init(&r, 0.5, 0.05);
	go(&r, 1, 2.0, 1.0, 0.5);
	int i = 0;

	for (; i < 400; i++) { /* 0.4 s: moving fast */
		assert_int_equal(ctl_goal(&r.c, i * 1000), 0);
		goal_step(&r.g, &r.c, &r.est, i * 1000);
		memcpy(r.est.pose, r.g.rep.ref, sizeof(r.est.pose));
	}
	traj_eval(&r.g.tr, r.g.tr.t_s, &prev);
	const float t_was = r.g.tr.t_s, end_was = r.g.tr.duration_s;

	assert_true(hypotf(prev.vel[0], prev.vel[1]) > 0.3f);
	r.cfg.limits.traction_mu = 0.25;
	goal_init(&r.g, &r.cfg); /* as the tick takes a parameter change */
	assert_true(r.g.tr.t_s == t_was && r.g.tr.duration_s == end_was); /* nothing planned */
	bool handed = false;
	float left = 0.0f;
	int k = 0;

	for (; k < 200 && !handed; k++, i++) {
		const float t_before = r.g.tr.t_s;

		left = r.g.tr.duration_s - t_before;
		assert_int_equal(ctl_goal(&r.c, i * 1000), 0);
		goal_step(&r.g, &r.c, &r.est, i * 1000);
		memcpy(r.est.pose, r.g.rep.ref, sizeof(r.est.pose));
		traj_eval(&r.g.tr, r.g.tr.t_s, &now);
		for (int q = 0; q < 3; q++) { /* one tick's motion, at most */
			assert_true(fabsf(now.pose[q] - prev.pose[q]) <=
			            fmaxf(fabsf(now.vel[q]), fabsf(prev.vel[q])) * 1e-3f + 1e-5f);
			assert_true(fabsf(now.vel[q] - prev.vel[q]) < 0.05f);
		}
		handed = r.g.tr.t_s < t_before; /* the new plan's clock */
		prev = now;
		goal_work(&r.g);
	}
	assert_true(handed);
	print_message("handed over at the %d. tick after the change; %.3f s left, %.3f s before\n",
	              k, (double)(r.g.tr.duration_s - r.g.tr.t_s), (double)left);
	assert_true(k >= (int)(GOAL_PLAN_LEAD_S * 1e3f)); /* a lead after it, not in its tick */
	assert_true(r.g.tr.duration_s - r.g.tr.t_s > left * 1.05f);
	assert_int_equal(r.g.rep.status, GOAL_ACTIVE);
}

/* Limits that leave no acceleration (friction beyond the floor) while a goal runs: the goal
 * is aborted (UNREACHABLE) with the stop ramp, never sent toward the origin. */
static void test_limits_without_acceleration_abort_the_goal_in_force(void **state)
{
	(void)state;
	struct rig r;

	rig_init(&r, 0.5, 0.05);
	go(&r, 1, 2.0, 1.0, 0.5);
	for (int i = 0; i < 100; i++) {
		assert_int_equal(ctl_goal(&r.c, i * 1000), 0);
		goal_step(&r.g, &r.c, &r.est, i * 1000);
	}
	r.cfg.limits.traction_mu = 0.01;
	goal_init(&r.g, &r.cfg);
	assert_false(r.g.traj_ok);
	goal_step(&r.g, &r.c, &r.est, 100000);
	assert_int_equal(r.g.rep.status, GOAL_ABORTED);
	assert_int_equal(r.g.rep.reason, GOAL_R_UNREACHABLE);
	assert_int_equal(r.c.mode, CTL_VOLTAGE); /* the stop ramp */
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_lower_mu_gives_a_slower_plan_within_mu_times_load),
	    cmocka_unit_test(test_traction_off_plans_on_floor_mu_less_the_margin),
	    cmocka_unit_test(test_parameter_change_replans_from_the_reference_without_a_jump),
	    cmocka_unit_test(test_limits_without_acceleration_abort_the_goal_in_force),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
