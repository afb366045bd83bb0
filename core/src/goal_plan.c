/* goal_plan.c - the goal mode's plans, made beside the loop (goal_work; goal.h, docs/goal.md
 * "Where plans are made"): a path through the poses, else the first (or next) pose alone. */
#include "goal_int.h"

#include <math.h>

int goal_plan_to(bool fixed, const struct goal_fixed *fx, struct traj *tr,
                 const struct traj_ref *from, const float to[3])
{
	if (!fixed)
		return traj_plan(tr, from, to);
	struct goal_fixed box = *fx;

	box.speed_m_s = fminf(box.speed_m_s, tr->c.speed_cap_m_s);
	return goal_fixed_plan(&box, tr, from, to);
}

/* A path of 2 to TRAJ_PATH_MAX poses: one plan through them all (no stop at the intermediate
 * ones, each passed within the blend radius); false if it cannot be planned. */
static bool plan_path(struct goal_job *j)
{
	if (j->fixed || j->n < 2 || j->n > TRAJ_PATH_MAX)
		return false;
	return traj_plan_path(&j->tr, &j->from, (const float (*)[3])j->poses, j->n, j->blend_m) ==
	           0 &&
	       j->tr.duration_s <= GOAL_PLAN_MAX_S;
}

bool goal_work(struct goal *g)
{
	struct goal_job *j = &g->job;

	if (atomic_load_explicit(&j->state, memory_order_acquire) != GOAL_JOB_POSTED)
		return false;
	const float handover_s = j->tr.handover_s;

	j->reason = GOAL_R_NONE;
	if (!(j->kind == GOAL_JOB_FIRST && plan_path(j)) &&
	    (goal_plan_to(j->fixed, &j->fx, &j->tr, &j->from, j->poses[j->index]) ||
	     !(j->tr.duration_s <= GOAL_PLAN_MAX_S)))
		j->reason = GOAL_R_UNREACHABLE;
	j->tr.handover_s = handover_s;
	atomic_store_explicit(&j->state, GOAL_JOB_DONE, memory_order_release);
	return true;
}
