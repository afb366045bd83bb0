/* Tests for where the goal mode's plans are made (core/src/goal.c, goal_plan.c; docs/goal.md
 * "Where plans are made"): never in the tick, beside it (goal_work); a new goal while moving
 * handed over a lead ahead of the reference without a jump (bounds from the floor's traction,
 * worked out here, not taken from the planner); a plan that comes late asked again with a
 * longer lead; refusals that come from the plan; a waiting goal replaced or cancelled; the
 * plans made on another thread than the tick's. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "omni4/core/ctl.h"
#include "omni4/core/goal.h"

#define TICK_US 1000
#define DT_S 1e-3
#define KEEP_TICKS 50 /* keep-alive every 50 ms, as the clients */
#define G_M_S2 9.80665

struct rig {
	struct ctl_settings cfg;
	struct ctl c;
	struct goal g;
	struct est_output est;
	int64_t now_us;
	struct goal_report prev;   /* the report after the previous tick */
	double jump_pos, jump_vel; /* largest step of the reference beyond its bound, per tick */
	double jump_th, jump_w;
	int64_t refused_id; /* the last refusal taken (goal_take_refused) */
	int8_t refused_status, refused_reason;
};

static struct rig R;

/* Every plan the core makes passes one of these (linked with --wrap): counted when made in the
 * tick (in_tick set around goal_command, goal_init and goal_step on the tick's thread). */
static _Thread_local bool in_tick;
static atomic_int planned_in_tick, planned_beside;

static void count_plan(void)
{
	if (in_tick)
		atomic_fetch_add(&planned_in_tick, 1);
	else
		atomic_fetch_add(&planned_beside, 1);
}

int __real_traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3]);
int __wrap_traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3]);
int __wrap_traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	count_plan();
	return __real_traj_plan(tr, from, goal);
}

int __real_traj_replan(struct traj *tr, const float goal[3]);
int __wrap_traj_replan(struct traj *tr, const float goal[3]);
int __wrap_traj_replan(struct traj *tr, const float goal[3])
{
	count_plan();
	return __real_traj_replan(tr, goal);
}

int __real_traj_plan_path(struct traj *tr, const struct traj_ref *from, const float (*poses)[3],
                          int n, float radius_m);
int __wrap_traj_plan_path(struct traj *tr, const struct traj_ref *from, const float (*poses)[3],
                          int n, float radius_m);
int __wrap_traj_plan_path(struct traj *tr, const struct traj_ref *from, const float (*poses)[3],
                          int n, float radius_m)
{
	count_plan();
	return __real_traj_plan_path(tr, from, poses, n, radius_m);
}

static void rig_init(struct rig *r)
{
	memset(r, 0, sizeof(*r));
	ctl_settings_defaults(&r->cfg);
	assert_int_equal(ctl_init(&r->c, &r->cfg), 0);
	goal_init(&r->g, &r->cfg);
	assert_true(r->g.traj_ok);
	r->now_us = 1000000;
}

static int send(struct rig *r, int64_t id, double x, double y, double th, double speed_max)
{
	struct goal_cmd cmd = {.id = id, .action = GOAL_GO, .n = 1, .speed_max = speed_max};

	cmd.poses[0][0] = x;
	cmd.poses[0][1] = y;
	cmd.poses[0][2] = th;
	const int rc = goal_command(&r->g, &r->c, &cmd, &r->est, r->now_us);
	const struct goal_report *rep = goal_take_refused(&r->g);

	if (rep) {
		r->refused_id = rep->id;
		r->refused_status = rep->status;
		r->refused_reason = rep->reason;
	}
	return rc;
}

/* The reference's step from one tick to the next beyond what the floor allows: all four
 * wheels at traction move the body at most mu g (1 - margin) (and the heading at that force
 * over the wheels' lever d, J). A plan handed over from the wrong place or time jumps. */
static void watch_reference(struct rig *r)
{
	const struct goal_report *a = &r->prev, *b = &r->g.rep;
	const struct ctl_settings *cfg = &r->cfg;
	/* the larger of the floors a plan in force may have been made on: the default (floor_mu)
	 * and a live traction_mu (a plan made before a change goes on until the hand-over) */
	const double mu = fmax(cfg->limits.traction_mu, cfg->goal.floor_mu);
	const double acc = mu * G_M_S2 * (1.0 - cfg->limits.traction_margin);
	const double rot = acc * r->cfg.model.M * r->cfg.model.d / r->cfg.model.J;

	if (a->status == GOAL_ACTIVE && b->status == GOAL_ACTIVE) {
		for (int i = 0; i < 2; i++) {
			const double vmax = fmax(fabs(a->ref_vel[i]), fabs(b->ref_vel[i]));
			r->jump_pos =
			    fmax(r->jump_pos, fabs(b->ref[i] - a->ref[i]) - vmax * DT_S - 1e-5);
			r->jump_vel = fmax(r->jump_vel,
			                   fabs(b->ref_vel[i] - a->ref_vel[i]) - acc * DT_S - 1e-5);
		}
		const double wmax = fmax(fabs(a->ref_vel[2]), fabs(b->ref_vel[2]));
		r->jump_th = fmax(r->jump_th, fabs(b->ref[2] - a->ref[2]) - wmax * DT_S - 1e-5);
		r->jump_w =
		    fmax(r->jump_w, fabs(b->ref_vel[2] - a->ref_vel[2]) - rot * DT_S - 1e-5);
	}
	r->prev = *b;
}

/* The robot follows its reference exactly (the estimate is the reference, its velocity
 * turned into the robot frame). */
static void follow(struct rig *r)
{
	const float th = r->g.rep.ref[2], c = cosf(th), s = sinf(th);
	const float *v = r->g.rep.ref_vel;

	memcpy(r->est.pose, r->g.rep.ref, sizeof(r->est.pose));
	r->est.vel[0] = c * v[0] + s * v[1];
	r->est.vel[1] = -s * v[0] + c * v[1];
	r->est.vel[2] = v[2];
}

/* One tick: the goal's step (the refusals it makes taken), then, if work, goal_work beside it. */
static void tick(struct rig *r, bool work)
{
	r->now_us += TICK_US;
	goal_step(&r->g, &r->c, &r->est, r->now_us);
	const struct goal_report *rep = goal_take_refused(&r->g);

	if (rep) {
		r->refused_id = rep->id;
		r->refused_status = rep->status;
		r->refused_reason = rep->reason;
	}
	if (r->g.rep.status == GOAL_ACTIVE)
		follow(r);
	watch_reference(r);
	if (work)
		goal_work(&r->g);
}

/* Goal id at (x, y, th), kept alive, for n ticks with the plans made after each tick. */
static void run(struct rig *r, int64_t id, const double p[3], int n)
{
	for (int k = 0; k < n; k++) {
		if (k % KEEP_TICKS == 0)
			send(r, id, p[0], p[1], p[2], 0.0);
		tick(r, true);
	}
}

static const double A[3] = {1.2, 0.6, 1.0}, B[3] = {0.2, 1.0, -0.5};

static void check_no_jump(const struct rig *r)
{
	print_message("reference steps beyond the floor's bound: %.2e m, %.2e m/s, %.2e rad, "
	              "%.2e rad/s\n",
	              r->jump_pos, r->jump_vel, r->jump_th, r->jump_w);
	assert_true(r->jump_pos <= 0.0 && r->jump_vel <= 0.0);
	assert_true(r->jump_th <= 0.0 && r->jump_w <= 0.0);
}

/* The tick never plans: a goal waits (not ACTIVE, the controller not in GOAL, nothing planned)
 * for as many ticks as goal_work is not called, then is handed over at the next tick. */
static void test_the_tick_never_plans(void **state)
{
	(void)state;
	rig_init(&R);
	assert_int_equal(send(&R, 7, A[0], A[1], A[2], 0.0), 0);
	for (int k = 0; k < 100; k++)
		tick(&R, false);
	assert_int_equal(atomic_load(&R.g.job.state), GOAL_JOB_POSTED);
	assert_int_equal(R.g.rep.status, GOAL_NONE);
	assert_true(R.c.mode != CTL_GOAL);
	assert_true(R.g.tr.duration_s == 0.0f); /* holding still where it was */
	assert_true(goal_work(&R.g));
	assert_false(goal_work(&R.g)); /* one plan asked for, one made */
	tick(&R, false);
	assert_int_equal(R.g.rep.id, 7);
	assert_int_equal(R.g.rep.status, GOAL_ACTIVE);
	assert_int_equal(R.c.mode, CTL_GOAL);
	assert_true(R.g.tr.duration_s > 1.0f);
}

/* A new goal while the first one moves fast: handed over when the reference's clock gets a
 * lead ahead of the tick it came in (GOAL_PLAN_LEAD_S), from the reference there: no step of
 * the reference beyond the floor's bound; both goals reached. */
static void test_new_goal_while_moving_is_handed_over_a_lead_ahead_without_a_jump(void **state)
{
	(void)state;
	const int lead_ticks = (int)lroundf(GOAL_PLAN_LEAD_S / (float)DT_S);
	rig_init(&R);
	run(&R, 1, A, 400);
	assert_int_equal(R.g.rep.id, 1);
	assert_true(hypot(R.g.rep.ref_vel[0], R.g.rep.ref_vel[1]) > 0.5);
	int taken = -1;

	for (int k = 0; k < 5000 && R.g.rep.status != GOAL_REACHED; k++) {
		if (k % KEEP_TICKS == 0)
			send(&R, 2, B[0], B[1], B[2], 0.0);
		tick(&R, true);
		if (taken < 0 && R.g.rep.id == 2)
			taken = k;
	}
	print_message("goal 2 handed over %d ticks after it came (lead %d ticks)\n", taken,
	              lead_ticks);
	assert_true(taken >= lead_ticks - 1 && taken <= lead_ticks + 1);
	assert_int_equal(R.g.rep.id, 2);
	assert_int_equal(R.g.rep.status, GOAL_REACHED);
	check_no_jump(&R);
}

/* A plan that comes after its start has gone by (the work beside the loop starved): not taken
 * (the reference would jump), asked again with twice the lead, then taken without a jump. */
static void test_late_plan_is_asked_again_with_a_longer_lead(void **state)
{
	(void)state;
	const int lead_ticks = (int)lroundf(GOAL_PLAN_LEAD_S / (float)DT_S);
	rig_init(&R);
	run(&R, 1, A, 400);
	send(&R, 2, B[0], B[1], B[2], 0.0);
	for (int k = 0; k < lead_ticks + 5; k++)
		tick(&R, false);
	assert_true(goal_work(&R.g)); /* made, but its start has gone by */
	tick(&R, false);
	assert_int_equal(R.g.rep.id, 1);
	assert_int_equal(atomic_load(&R.g.job.state), GOAL_JOB_POSTED); /* asked again */
	assert_true(fabsf(R.g.lead_s - 2.0f * GOAL_PLAN_LEAD_S) < 1e-6f);
	run(&R, 2, B, 3 * lead_ticks);
	assert_int_equal(R.g.rep.id, 2);
	assert_int_equal(R.g.rep.status, GOAL_ACTIVE);
	check_no_jump(&R);
}

/* Refusals that only the plan can make come after it, and the goal in force stays. */
static void
test_unreachable_goal_is_refused_after_its_plan_and_the_goal_in_force_stays(void **state)
{
	(void)state;
	rig_init(&R);
	run(&R, 1, A, 3000);
	assert_int_equal(R.g.rep.status, GOAL_REACHED);
	/* 2.6 m at 1 cm/s: beyond the longest plan allowed */
	assert_int_equal(send(&R, 2, 3.0, 2.5, 0.0, 0.01), 0);
	assert_true(R.refused_id != 2); /* not yet: only its plan can tell */
	run(&R, 1, A, 100);
	assert_int_equal(R.refused_id, 2);
	assert_int_equal(R.refused_status, GOAL_REFUSED);
	assert_int_equal(R.refused_reason, GOAL_R_UNREACHABLE);
	assert_int_equal(R.g.rep.id, 1);
	assert_int_equal(R.g.rep.status, GOAL_REACHED);
	assert_int_equal(R.c.mode, CTL_GOAL); /* still holding goal 1's pose */
	check_no_jump(&R);
}

/* A goal waiting for its plan: replaced by a newer one (REFUSED, REPLACED: never taken), or
 * cancelled (ABORTED, CANCELLED: its plan dropped when made). */
static void test_waiting_goal_replaced_or_cancelled_is_never_taken(void **state)
{
	(void)state;
	rig_init(&R);
	assert_int_equal(send(&R, 1, A[0], A[1], A[2], 0.0), 0);
	assert_int_equal(send(&R, 2, B[0], B[1], B[2], 0.0), 0);
	assert_int_equal(R.refused_id, 1);
	assert_int_equal(R.refused_status, GOAL_REFUSED);
	assert_int_equal(R.refused_reason, GOAL_R_REPLACED);
	run(&R, 2, B, 10);
	assert_int_equal(R.g.rep.id, 2);
	assert_int_equal(R.g.rep.status, GOAL_ACTIVE);

	assert_int_equal(send(&R, 3, A[0], A[1], A[2], 0.0), 0);
	struct goal_cmd cancel = {.id = 3, .action = GOAL_CANCEL};
	assert_int_equal(goal_command(&R.g, &R.c, &cancel, &R.est, R.now_us), 0);
	const struct goal_report *rep = goal_take_refused(&R.g);
	assert_non_null(rep);
	assert_int_equal(rep->id, 3);
	assert_int_equal(rep->status, GOAL_ABORTED);
	assert_int_equal(rep->reason, GOAL_R_CANCELLED);
	for (int k = 0; k < 200; k++) {
		run(&R, 2, B, 1);
		assert_int_equal(R.g.rep.id, 2); /* goal 3's plan, made, was dropped */
	}
	assert_int_equal(atomic_load(&R.g.job.state), GOAL_JOB_IDLE);
	check_no_jump(&R);
}

/* ---- the plans made on another thread (the robot binary's way; ThreadSanitizer sees it) --- */

static atomic_bool g_stop;

static void *planner(void *arg)
{
	struct goal *g = arg;

	while (!atomic_load(&g_stop))
		if (!goal_work(g))
			sched_yield();
	return NULL;
}

/* The tick waits (a hang bound, not a timing) while a plan is asked for: the goals then go
 * exactly as with the plans made in the tick's thread. */
static void wait_for_plan(struct rig *r)
{
	const time_t t0 = time(NULL);

	while (atomic_load(&r->g.job.state) == GOAL_JOB_POSTED) {
		assert_true(time(NULL) - t0 < 60);
		sched_yield();
	}
}

static void test_plans_made_on_another_thread(void **state)
{
	(void)state;
	pthread_t th;
	const double *goals[3] = {A, B, A};
	int reached = 0;

	rig_init(&R);
	atomic_store(&g_stop, false);
	assert_int_equal(pthread_create(&th, NULL, planner, &R.g), 0);
	for (int id = 1; id <= 3; id++) {
		const double *p = goals[id - 1];
		for (int k = 0; k < 4000 && !(R.g.rep.id == id && R.g.rep.status == GOAL_REACHED);
		     k++) {
			if (k % KEEP_TICKS == 0)
				send(&R, id, p[0], p[1], p[2], 0.0);
			wait_for_plan(&R);
			tick(&R, false);
			if (id == 2 && k == 300)
				break; /* the next goal while this one moves */
		}
		reached += R.g.rep.id == id && R.g.rep.status == GOAL_REACHED;
	}
	atomic_store(&g_stop, true);
	pthread_join(th, NULL);
	assert_int_equal(R.g.rep.id, 3);
	assert_int_equal(reached, 2); /* the first and the last */
	check_no_jump(&R);
}

/* A live parameter change during a goal (the controller takes it in its tick: goal_init), for
 * a single pose and for a path: the tick plans nothing, the new plan is made beside the loop
 * and handed over without a jump, and the goal is reached. */
static void test_a_parameter_change_plans_nothing_in_the_tick(void **state)
{
	static const float path[3][3] = {
	    {1.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 1.0f}};

	(void)state;
	for (int with_path = 0; with_path < 2; with_path++) {
		rig_init(&R);
		struct goal_cmd cmd = {.id = 9, .action = GOAL_GO, .n = with_path ? 3 : 1};

		for (int i = 0; i < cmd.n; i++)
			for (int k = 0; k < 3; k++)
				cmd.poses[i][k] = with_path ? path[i][k] : A[k];
		atomic_store(&planned_in_tick, 0);
		int changes = 0, k = 0;

		for (; k < 20000 && !(R.g.rep.id == 9 && R.g.rep.status == GOAL_REACHED); k++) {
			in_tick = true;
			if (k % KEEP_TICKS == 0)
				goal_command(&R.g, &R.c, &cmd, &R.est, R.now_us);
			if (k == 400 || k == 900) { /* a live change, as the tick takes it */
				R.cfg.limits.traction_mu =
				    k == 400 ? 0.4 : 0.55; /* within the jump check's floors */
				goal_init(&R.g, &R.cfg);
				atomic_store(&planned_beside, 0);
				changes++;
			}
			tick(&R, false);
			in_tick = false;
			goal_work(&R.g);
		}
		print_message(
		    "%s: reached after %d ticks, %d changes; plans in the tick %d, beside "
		    "it after the last change %d\n",
		    with_path ? "path" : "pose", k, changes, atomic_load(&planned_in_tick),
		    atomic_load(&planned_beside));
		assert_int_equal(R.g.rep.status, GOAL_REACHED);
		assert_int_equal(changes, 2);
		assert_int_equal(atomic_load(&planned_in_tick), 0);
		assert_true(atomic_load(&planned_beside) >= 1); /* the change was planned for */
		check_no_jump(&R);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_the_tick_never_plans),
	    cmocka_unit_test(test_new_goal_while_moving_is_handed_over_a_lead_ahead_without_a_jump),
	    cmocka_unit_test(test_late_plan_is_asked_again_with_a_longer_lead),
	    cmocka_unit_test(
	        test_unreachable_goal_is_refused_after_its_plan_and_the_goal_in_force_stays),
	    cmocka_unit_test(test_waiting_goal_replaced_or_cancelled_is_never_taken),
	    cmocka_unit_test(test_plans_made_on_another_thread),
	    cmocka_unit_test(test_a_parameter_change_plans_nothing_in_the_tick),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
