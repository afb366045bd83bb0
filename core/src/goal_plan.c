/* goal_plan.c - the goal mode's plans, made beside the loop (goal_work; goal.h, docs/goal.md
 * "Where plans are made"): a path through the poses, else the first (or next) pose alone. */
#include "goal_int.h"

#include <errno.h>
#include <math.h>

/* The brake's stop point this much beyond v^2 / (2 a): a curve from the moving start brakes
 * straight to it (the path timing's braking ends without friction's help and keeps a little
 * under the traction bound). From 1.53 m/s, at 1.1 no curve got there and the plan braked
 * first, 0.41 m on (0.48 m turning at 0.37 rad/s), and came back; at 1.2 it braked straight,
 * 0.38 m on. On the path timing's grid of its own times (traj_topp.c) 1.1 brakes straight
 * too (0.405 m on from 1.52 m/s), 1.2 0.439 m: the reference's lead and its speed above the
 * robot's (1.532 against 1.520 m/s) took all of the 20 % the goal mode allows a cancel. */
#define BRAKE_ROOM 1.15f

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
 * ones, each passed within the blend radius); false if it cannot be planned (more poses, two
 * at one place, a turn in place): then each pose is planned in turn (stepped). */
static bool plan_path(struct goal_job *j)
{
	if (j->fixed || j->n < 2 || j->n > TRAJ_PATH_MAX)
		return false;
	return traj_plan_path(&j->tr, &j->from, (const float (*)[3])j->poses, j->n, j->blend_m) ==
	           0 &&
	       j->tr.duration_s <= GOAL_PLAN_MAX_S;
}

/* New limits under a path in force (j->tr: it, on the tick's clock): the same path re-timed
 * from its reference at the hand-over; false if the new limits cannot hold it from there (then
 * the pose aimed at alone is planned). */
static bool replan_path(struct goal_job *j)
{
	if (j->fixed)
		return false;
	j->tr.t_s = j->tr.handover_s;
	return traj_replan(&j->tr, j->poses[j->n - 1]) == 0 && j->tr.on_path &&
	       j->tr.duration_s <= GOAL_PLAN_MAX_S;
}

/* A cancelled goal's brake: a plan from the reference to where it can stop, ahead along its
 * velocity by BRAKE_ROOM v^2 / (2 a), a the acceleration the envelope gives from rest against
 * the motion plus twice the Coulomb friction's share along it (from rest it opposes that
 * acceleration, braking it helps; the back-EMF and the viscous friction help besides), the
 * heading turning on at half its rate meanwhile. -EINVAL if there is none. */
static int plan_brake(struct goal_job *j)
{
	const struct traj_ref *f = &j->from;
	const float speed = sqrtf(f->vel[0] * f->vel[0] + f->vel[1] * f->vel[1]);
	float to[3] = {f->pose[0], f->pose[1], f->pose[2]};

	if (speed > 1e-3f) {
		float c, s;

		goal_cos_sin(f->pose[2], &c, &s);
		const float ux = f->vel[0] / speed, uy = f->vel[1] / speed;
		const float back[2] = {-(c * ux + s * uy), -(-s * ux + c * uy)}; /* robot frame */
		float acc = 0.0f, vmax;

		if (traj_envelope(&j->tr, back, 0.0f, &acc, &vmax) || !(acc > 0.0f))
			return -EINVAL;
		acc += 2.0f * (j->tr.c.C[0] * fabsf(back[0]) + j->tr.c.C[1] * fabsf(back[1])) /
		       j->tr.c.M;
		const float d = BRAKE_ROOM * speed * speed / (2.0f * acc);

		to[0] += ux * d;
		to[1] += uy * d;
		to[2] += 0.5f * f->vel[2] * speed / acc;
	}
	return traj_plan(&j->tr, f, to);
}

bool goal_work(struct goal *g)
{
	struct goal_job *j = &g->job;

	if (atomic_load_explicit(&j->state, memory_order_acquire) != GOAL_JOB_POSTED)
		return false;
	const float handover_s = j->tr.handover_s;

	j->reason = GOAL_R_NONE;
	if (j->kind == GOAL_JOB_REPLAN)
		j->whole = j->whole && replan_path(j);
	else
		j->whole = j->kind == GOAL_JOB_FIRST && plan_path(j);
	if (j->kind == GOAL_JOB_BRAKE) {
		if (plan_brake(j))
			j->reason = GOAL_R_UNREACHABLE;
	} else if (!j->whole &&
	           (goal_plan_to(j->fixed, &j->fx, &j->tr, &j->from, j->poses[j->index]) ||
	            !(j->tr.duration_s <= GOAL_PLAN_MAX_S)))
		j->reason = GOAL_R_UNREACHABLE;
	j->tr.handover_s = handover_s;
	atomic_store_explicit(&j->state, GOAL_JOB_DONE, memory_order_release);
	return true;
}
