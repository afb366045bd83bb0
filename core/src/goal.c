/* goal.c - position control on the trajectory generator, the tick's side: checks, the plans
 * asked for and handed over (made by goal_plan.c beside the loop), tracking law, progress
 * (goal.h, docs/goal.md). */
#include "goal_int.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define PI_F GOAL_PI_F

static float norm2(float x, float y)
{
	return sqrtf(x * x + y * y);
}

static float clampf(float x, float lim)
{
	return x > lim ? lim : (x < -lim ? -lim : x);
}

static bool active(const struct goal *g)
{
	return g->rep.status == GOAL_ACTIVE;
}

static bool holding(const struct goal *g, const struct ctl *c)
{
	return (g->rep.status == GOAL_ACTIVE || g->rep.status == GOAL_REACHED || g->brake) &&
	       c->mode == CTL_GOAL;
}

/* A goal that ended (REACHED, ABORTED, REFUSED), remembered as it ended. */
static void remember(struct goal *g, const struct goal_report *r)
{
	g->ended[g->ended_next] = *r;
	g->ended_next = (g->ended_next + 1) % GOAL_ENDED_IDS;
}

/* How goal id ended, or NULL if it is not among the last GOAL_ENDED_IDS that did. */
static const struct goal_report *ended(const struct goal *g, int64_t id)
{
	for (int i = 0; i < GOAL_ENDED_IDS; i++)
		if (g->ended[i].id == id && g->ended[i].status != GOAL_NONE)
			return &g->ended[i];
	return NULL;
}

static void set_status(struct goal *g, enum goal_status st, enum goal_reason why)
{
	const bool change = g->rep.status != (int8_t)st || g->rep.reason != (int8_t)why;

	if (change)
		g->changed = true;
	g->rep.status = (int8_t)st;
	g->rep.reason = (int8_t)why;
	if (change && (st == GOAL_REACHED || st == GOAL_ABORTED))
		remember(g, &g->rep);
}

void goal_limits(const struct ctl_settings *cfg, struct traj_limits *lim)
{
	const bool floor = cfg->limits.traction_mu > 0.0;

	*lim = (struct traj_limits){
	    .p = cfg->model,
	    .supply_v = cfg->limits.supply_v,
	    .margin_v = fmin(cfg->goal.margin_v, 0.25 * cfg->limits.supply_v),
	    .mu = floor ? cfg->limits.traction_mu : cfg->goal.floor_mu,
	    .traction_margin = cfg->limits.traction_margin,
	    .motor_speed_max_rad_s = cfg->goal.motor_speed_max,
	    .speed_cap_m_s = cfg->limits.vel_lin_max,
	    .omega_cap_rad_s = cfg->limits.vel_rot_max,
	    .rot_share = cfg->goal.rot_share,
	    .com_height_m = cfg->limits.com_height,
	};
	ctl_settings_wheels(cfg, &lim->w);
}

void goal_init(struct goal *g, const struct ctl_settings *cfg)
{
	struct traj_limits lim;

	goal_limits(cfg, &lim);
	goal_init_limits(g, cfg, &lim);
}

void goal_init_limits(struct goal *g, const struct ctl_settings *cfg, const struct traj_limits *lim)
{
	const bool again = active(g) && g->traj_ok;
	struct traj_limits l = *lim;
	struct wheel_geom geom;
	const struct wheel_geom *use;

	if (!l.geom && ctl_settings_layout(cfg, &geom, &use) == 0)
		l.geom = use; /* the layout of cfg (NULL: the paper's) */
	/* Into the scratch first: limits it refuses leave the goal in force its plan, to be
	 * aborted at the next step (goal_step), never a reference at the origin. */
	g->traj_ok = traj_init(&g->scratch, &l) == 0;
	g->gen++; /* a plan asked for under the old limits is asked again */
	g->lead_s = GOAL_PLAN_LEAD_S;
	g->kp_pos = GOAL_KP_POS;
	g->kp_theta = GOAL_KP_THETA;
	g->kinematic = cfg->goal.feedforward == CTL_GOAL_FF_KINEMATIC;
	g->fixed = cfg->goal.limits == CTL_GOAL_LIMITS_FIXED;
	if (g->traj_ok && g->fixed)
		g->traj_ok = goal_fixed_limits(&g->scratch, &g->fx) == 0;
	if (!g->traj_ok)
		return;
	const float cap = g->tr.c.speed_cap_m_s; /* a goal's own speed_max stays */

	g->tr.c = g->scratch.c;
	if (again)
		g->tr.c.speed_cap_m_s = fminf(cap, g->scratch.c.speed_cap_m_s);
	if (g->rep.status != GOAL_ACTIVE && g->rep.status != GOAL_REACHED)
		g->tr = g->scratch; /* nothing in force: hold still at the origin */
	g->speed_cap_m_s = g->scratch.c.speed_cap_m_s;
	/* New limits while a goal runs: its plan asked again beside the loop (GOAL_JOB_REPLAN),
	 * from the reference a lead ahead (no jump); the plan in force goes on meanwhile. */
	g->replan_want = g->replan_want || again;
}

/* 0 if the goal's fields are usable, else the reason. */
static enum goal_reason check_fields(const struct goal_cmd *cmd)
{
	if (cmd->n < 1 || cmd->n > GOAL_POSES_MAX)
		return GOAL_R_OUT_OF_RANGE;
	if (!isfinite(cmd->blend_m) || !isfinite(cmd->speed_max))
		return GOAL_R_NOT_FINITE;
	for (int i = 0; i < cmd->n; i++)
		for (int k = 0; k < 3; k++)
			if (!isfinite(cmd->poses[i][k]))
				return GOAL_R_NOT_FINITE;
	for (int i = 0; i < cmd->n; i++)
		if (fabs(cmd->poses[i][0]) > GOAL_RANGE_M ||
		    fabs(cmd->poses[i][1]) > GOAL_RANGE_M ||
		    fabs(cmd->poses[i][2]) > GOAL_THETA_MAX_RAD)
			return GOAL_R_OUT_OF_RANGE;
	if (cmd->blend_m != 0.0 &&
	    (cmd->blend_m < GOAL_BLEND_MIN_M || cmd->blend_m > GOAL_BLEND_MAX_M))
		return GOAL_R_OUT_OF_RANGE;
	if (cmd->speed_max < 0.0)
		return GOAL_R_OUT_OF_RANGE;
	return GOAL_R_NONE;
}

/* Goal id's end, told to its sender now (goal_take_refused) and remembered. */
static void tell(struct goal *g, int64_t id, int32_t n, enum goal_status st, enum goal_reason why)
{
	g->refused = (struct goal_report){.id = id, .status = st, .reason = (int8_t)why, .n = n};
	g->refused_pending = true;
	remember(g, &g->refused);
}

static void refuse(struct goal *g, const struct goal_cmd *cmd, enum goal_status st,
                   enum goal_reason why)
{
	tell(g, cmd->id, cmd->n, st, why);
}

/* Where an asked-for plan starts. While a goal is tracked: its reference a lead ahead on its
 * clock (bumpless from goal to goal). Else the estimate, its velocity turned into the world
 * frame (eq 1), carried a lead ahead at that velocity and handed over then; from rest, as it
 * is and handed over as soon as made. */
static void plan_start(const struct goal *g, const struct ctl *c, const struct est_output *est,
                       int64_t now_us, struct goal_job *j)
{
	j->on_clock = holding(g, c);
	j->asap = false;
	if (j->on_clock) {
		j->tr.handover_s = g->tr.t_s + j->lead_s;
		traj_eval(&g->tr, j->tr.handover_s, &j->from);
		return;
	}
	const float th = est->pose[2];
	float cs, sn;

	goal_cos_sin(th, &cs, &sn);
	memset(&j->from, 0, sizeof(j->from));
	memcpy(j->from.pose, est->pose, sizeof(j->from.pose));
	j->from.vel[0] = cs * est->vel[0] - sn * est->vel[1];
	j->from.vel[1] = sn * est->vel[0] + cs * est->vel[1];
	j->from.vel[2] = est->vel[2];
	j->asap = norm2(est->vel[0], est->vel[1]) < GOAL_REST_SPEED_M_S &&
	          fabsf(est->vel[2]) < GOAL_REST_RATE_RAD_S;
	if (j->asap)
		return;
	for (int k = 0; k < 3; k++)
		j->from.pose[k] += j->lead_s * j->from.vel[k];
	j->handover_us = now_us + (int64_t)(j->lead_s * 1e6f);
}

/* Asks for the waiting goal's plan (or else the stepped goal's next pose) if the job is free. */
static void post(struct goal *g, const struct ctl *c, const struct est_output *est, int64_t now_us)
{
	struct goal_job *j = &g->job;
	const bool first = g->want_set && !g->want_posted;
	const bool brake = !first && g->brake && g->brake_want;

	if (g->next_want) /* the next pose's plan is made under the new limits anyway */
		g->replan_want = false;
	if ((!first && !brake && !g->next_want && !g->replan_want) ||
	    atomic_load_explicit(&j->state, memory_order_acquire) != GOAL_JOB_IDLE ||
	    (!est && !holding(g, c)))
		return;
	j->tr = g->tr; /* the limits in force */
	j->gen = g->gen;
	j->fixed = g->fixed;
	j->fx = g->fx;
	j->lead_s = g->lead_s;
	if (first) {
		const struct goal_cmd *cmd = &g->want;

		j->kind = GOAL_JOB_FIRST;
		j->id = cmd->id;
		j->n = cmd->n;
		j->index = 0;
		j->blend_m = cmd->blend_m > 0.0 ? (float)cmd->blend_m : GOAL_BLEND_DEFAULT_M;
		j->tr.c.speed_cap_m_s = cmd->speed_max > 0.0
		                            ? fminf((float)cmd->speed_max, g->speed_cap_m_s)
		                            : g->speed_cap_m_s;
		for (int i = 0; i < cmd->n; i++)
			for (int k = 0; k < 3; k++)
				j->poses[i][k] = (float)cmd->poses[i][k];
		g->want_posted = true;
	} else if (brake) {
		j->kind = GOAL_JOB_BRAKE;
		j->id = g->rep.id;
		j->n = 1;
		j->index = 0;
		j->blend_m = g->blend_m;
		g->brake_want = false;
	} else {
		j->kind = g->next_want ? GOAL_JOB_NEXT : GOAL_JOB_REPLAN;
		j->id = g->rep.id;
		j->n = g->n;
		j->index = g->index;
		j->whole = g->whole;
		j->blend_m = g->blend_m;
		memcpy(j->poses, g->poses, sizeof(j->poses));
		g->next_want = false;
		g->replan_want = false;
	}
	plan_start(g, c, est, now_us, j);
	atomic_store_explicit(&j->state, GOAL_JOB_POSTED, memory_order_release);
}

/* The job back to the tick's side, its plan asked again (first: the waiting goal's). */
static void job_free(struct goal_job *j)
{
	atomic_store_explicit(&j->state, GOAL_JOB_IDLE, memory_order_release);
}

static void ask_again(struct goal *g, enum goal_job_kind kind)
{
	if (kind == GOAL_JOB_FIRST)
		g->want_posted = false;
	else if (kind == GOAL_JOB_BRAKE)
		g->brake_want = true;
	else if (kind == GOAL_JOB_REPLAN)
		g->replan_want = true;
	else
		g->next_want = true;
	job_free(&g->job);
}

/* The waiting goal's plan handed over: the goal in force from now on, or refused (FAULT). */
static void take_first(struct goal *g, struct ctl *c, float past_s)
{
	const struct goal_cmd *cmd = &g->want;
	const struct goal_job *j = &g->job;

	g->want_set = false;
	if (ctl_goal(c, g->want_alive_us)) { /* FAULT or ESTOP meanwhile */
		refuse(g, cmd, GOAL_REFUSED, GOAL_R_FAULT);
		return;
	}
	if (active(g) && g->rep.id != cmd->id) /* the goal in force: its sender is told */
		tell(g, g->rep.id, g->rep.n, GOAL_ABORTED, GOAL_R_REPLACED);
	g->brake = 0;
	g->tr = j->tr;
	g->tr.t_s = fmaxf(past_s, 0.0f);
	g->tr.handover_s = 0.0f;
	g->n = j->n;
	g->index = 0;
	g->whole = j->whole;
	memcpy(g->poses, j->poses, sizeof(g->poses));
	g->blend_m = j->blend_m;
	g->next_want = false;
	g->stale_since_us = 0;
	g->ended_us = 0;
	g->rep = (struct goal_report){.id = cmd->id, .n = cmd->n};
	g->rep.status = GOAL_NONE;
	set_status(g, GOAL_ACTIVE, GOAL_R_NONE);
}

/* The made plan is still the one wanted: the waiting goal's, the brake's, the next pose's. */
static bool job_wanted(const struct goal *g, const struct ctl *c, const struct goal_job *j)
{
	if (j->kind == GOAL_JOB_FIRST)
		return g->want_set && g->want.id == j->id;
	if (j->kind == GOAL_JOB_BRAKE)
		return g->brake == 1 && holding(g, c) && g->rep.id == j->id;
	if (j->kind == GOAL_JOB_REPLAN && j->whole) /* a path's: whatever pose it aims at now */
		return active(g) && holding(g, c) && g->rep.id == j->id;
	return active(g) && holding(g, c) && g->rep.id == j->id && g->index == j->index;
}

/* No plan: a new goal refused; a next pose's plan aborts the goal; a brake stops at once. */
static void job_failed(struct goal *g, struct ctl *c, const struct goal_job *j, int64_t now_us)
{
	if (j->kind == GOAL_JOB_FIRST) {
		g->want_set = false;
		refuse(g, &g->want, GOAL_REFUSED, (enum goal_reason)j->reason);
		return;
	}
	if (j->kind == GOAL_JOB_NEXT || j->kind == GOAL_JOB_REPLAN)
		set_status(g, GOAL_ABORTED, (enum goal_reason)j->reason);
	g->brake = 0;
	ctl_stop(c, now_us);
}

/* A plan made: dropped if no longer wanted, asked again if its basis changed or it came late,
 * refused if there is none, else handed over when the clock gets to its start. */
static void take(struct goal *g, struct ctl *c, int64_t now_us)
{
	struct goal_job *j = &g->job;

	if (atomic_load_explicit(&j->state, memory_order_acquire) != GOAL_JOB_DONE)
		return;
	const enum goal_job_kind kind = (enum goal_job_kind)j->kind;

	if (!job_wanted(g, c, j)) {
		job_free(j);
		return;
	}
	if (j->gen != g->gen || j->on_clock != holding(g, c)) {
		ask_again(g, kind);
		return;
	}
	if (j->reason != GOAL_R_NONE) {
		job_failed(g, c, j, now_us);
		job_free(j);
		return;
	}
	float past_s = 0.0f;

	if (j->on_clock) {
		if (g->tr.t_s < j->tr.handover_s - TRAJ_HANDOVER_TOL_S &&
		    g->tr.t_s < g->tr.duration_s)
			return; /* not yet */
		past_s = g->tr.t_s - j->tr.handover_s;
	} else if (!j->asap) {
		if (now_us < j->handover_us)
			return;
		past_s = 1e-6f * (float)(now_us - j->handover_us);
	}
	if (past_s > GOAL_PLAN_LATE_S) { /* late: its start has gone by */
		g->lead_s = fminf(2.0f * g->lead_s, GOAL_PLAN_LEAD_MAX_S);
		ask_again(g, kind);
		return;
	}
	if (kind == GOAL_JOB_FIRST) {
		take_first(g, c, past_s);
	} else {
		traj_take_over(&g->tr, &j->tr);
		if (kind == GOAL_JOB_BRAKE)
			g->brake = 2;
		if (kind == GOAL_JOB_REPLAN)
			g->whole = j->whole;
	}
	job_free(j);
}

/* A new goal: checked, then waits for its plan (goal_work; taken or refused in goal_step). */
static int start(struct goal *g, struct ctl *c, const struct goal_cmd *cmd,
                 const struct est_output *est, int64_t now_us)
{
	enum goal_reason why = check_fields(cmd);

	if (!why && (!est || (est->flags & EST_FLAG_CAMERA_STALE)))
		why = GOAL_R_NO_ESTIMATE;
	if (!why && !g->traj_ok)
		why = GOAL_R_UNREACHABLE;
	if (!why && mode_faulted(c->mode))
		why = GOAL_R_FAULT;
	if (why) {
		refuse(g, cmd, GOAL_REFUSED, why);
		return why == GOAL_R_FAULT ? -EPERM
		                           : (why == GOAL_R_UNREACHABLE ? -ERANGE : -EINVAL);
	}
	if (g->want_set) /* the one waiting before it is never taken */
		refuse(g, &g->want, GOAL_REFUSED, GOAL_R_REPLACED);
	g->want = *cmd;
	g->want_set = true;
	g->want_posted = false;
	g->want_alive_us = now_us;
	post(g, c, est, now_us);
	return 0;
}

/* A cancelled goal in force: braked to rest on a plan of its own if the reference or the
 * estimate moves (goal_work; the stop ramp once at rest), else the stop ramp now. */
static void brake_or_stop(struct goal *g, struct ctl *c, const struct est_output *est,
                          int64_t now_us)
{
	struct traj_ref ref;

	traj_eval(&g->tr, g->tr.t_s, &ref);
	const bool moving = norm2(ref.vel[0], ref.vel[1]) >= GOAL_REST_SPEED_M_S ||
	                    fabsf(ref.vel[2]) >= GOAL_REST_RATE_RAD_S ||
	                    (est && (norm2(est->vel[0], est->vel[1]) >= GOAL_REST_SPEED_M_S ||
	                             fabsf(est->vel[2]) >= GOAL_REST_RATE_RAD_S));

	if (!moving) {
		g->brake = 0;
		ctl_stop(c, now_us);
		return;
	}
	if (g->brake) /* braking already: a repeated cancel changes nothing */
		return;
	g->brake = 1;
	g->brake_want = true;
	g->brake_since_us = now_us;
	g->next_want = false;
}

int goal_command(struct goal *g, struct ctl *c, const struct goal_cmd *cmd,
                 const struct est_output *est, int64_t now_us)
{
	const bool mine = cmd->id == g->rep.id;

	if (cmd->action == GOAL_CANCEL) {
		if (g->want_set && (cmd->id == g->want.id || cmd->id == 0)) {
			g->want_set = false; /* its plan, if made, is dropped */
			refuse(g, &g->want, GOAL_ABORTED, GOAL_R_CANCELLED);
		}
		if ((mine || cmd->id == 0) && holding(g, c)) {
			if (active(g))
				set_status(g, GOAL_ABORTED, GOAL_R_CANCELLED);
			brake_or_stop(g, c, est, now_us);
		}
		return 0;
	}
	if (cmd->action != GOAL_GO) {
		g->refused = (struct goal_report){
		    .id = cmd->id, .status = GOAL_REFUSED, .reason = GOAL_R_OUT_OF_RANGE};
		g->refused_pending = true;
		return -EINVAL;
	}
	if (mine && holding(g, c))
		return ctl_goal(c, now_us);         /* keep-alive */
	if (g->want_set && cmd->id == g->want.id) { /* the waiting goal's keep-alive */
		g->want_alive_us = now_us;
		return holding(g, c) ? ctl_goal(c, now_us)
		                     : 0; /* its sender left the one in force */
	}
	const struct goal_report *was = ended(g, cmd->id);

	if (was && !mine) { /* an ended goal never starts again: its sender hears how it ended */
		tell(g, was->id, was->n, (enum goal_status)was->status,
		     (enum goal_reason)was->reason);
		return -ECANCELED;
	}
	if (mine && g->rep.status != GOAL_NONE)
		return -ECANCELED; /* an ended goal never starts again under its id */
	return start(g, c, cmd, est, now_us);
}

/* The goal ended outside: the controller left GOAL (watchdog, fault, a command). */
static void follow_controller(struct goal *g, const struct ctl *c)
{
	if (!active(g) || c->mode == CTL_GOAL)
		return;
	if (c->warnings & CTL_FAULT_CMD_TIMEOUT)
		set_status(g, GOAL_ABORTED, GOAL_R_WATCHDOG);
	else if (mode_faulted(c->mode))
		set_status(g, GOAL_ABORTED, GOAL_R_FAULT);
	else
		set_status(g, GOAL_ABORTED, GOAL_R_REPLACED);
}

/* false if the estimate says stop: a collision, or odometry alone for too long. */
static bool estimate_ok(struct goal *g, struct ctl *c, const struct est_output *est, int64_t now_us)
{
	enum goal_reason why = GOAL_R_NONE;

	if (est->flags & EST_FLAG_CAMERA_STALE) {
		if (!g->stale_since_us)
			g->stale_since_us = now_us;
		else if (now_us - g->stale_since_us >= GOAL_STALE_GRACE_US)
			why = GOAL_R_STALE_ESTIMATE;
	} else {
		g->stale_since_us = 0;
	}
	if (est->flags & EST_FLAG_COLLISION)
		why = GOAL_R_COLLISION;
	if (!why)
		return true;
	if (active(g))
		set_status(g, GOAL_ABORTED, why);
	ctl_stop(c, now_us);
	return false;
}

/* The reference's next pose: the pose aimed at changes when the reference comes within the
 * blend radius of an intermediate one; off a path, its plan is asked for (from the reference a
 * lead ahead: no jump) and the reference goes on toward the one passed meanwhile. */
static void advance(struct goal *g, float dt_s, struct traj_ref *ref)
{
	traj_step(&g->tr, dt_s, ref);
	if (g->index >= g->n - 1 || g->brake)
		return;
	const float *p = g->poses[g->index];

	if (norm2(ref->pose[0] - p[0], ref->pose[1] - p[1]) >= g->blend_m)
		return;
	g->index++;
	g->changed = true;
	if (!g->whole) /* a stepped goal: the next pose's plan, beside the loop; the reference */
		g->next_want = true; /* goes on meanwhile */
}

/* The tracking law: world velocity of the reference plus P on the pose error, turned into the
 * robot frame at the estimated heading (eq 1); the reference's acceleration turned likewise,
 * as the rate of the robot-frame reference velocity (the frame turns at w). */
static void track(struct goal *g, struct ctl *c, const struct est_output *est,
                  const struct traj_ref *ref)
{
	const float th = est->pose[2];
	float cs, sn;

	goal_cos_sin(th, &cs, &sn);
	const float e[3] = {ref->pose[0] - est->pose[0], ref->pose[1] - est->pose[1],
	                    model_wrap_pi_f32(ref->pose[2] - th)};
	const float vx = ref->vel[0] + g->kp_pos * e[0], vy = ref->vel[1] + g->kp_pos * e[1];
	const float lin = (float)c->t.vel_lin_max, rot = (float)c->t.vel_rot_max;
	float vel[3] = {cs * vx + sn * vy, -sn * vx + cs * vy, ref->vel[2] + g->kp_theta * e[2]};
	const float vr = cs * ref->vel[0] + sn * ref->vel[1],
	            vnr = -sn * ref->vel[0] + cs * ref->vel[1];
	const float w = ref->vel[2];
	float acc[3] = {cs * ref->acc[0] + sn * ref->acc[1] + w * vnr,
	                -sn * ref->acc[0] + cs * ref->acc[1] - w * vr, ref->acc[2]};

	if (g->kinematic) /* the peer: velocity reference + PI, no acceleration fed forward */
		memset(acc, 0, sizeof(acc));

	vel[0] = clampf(vel[0], lin);
	vel[1] = clampf(vel[1], lin);
	vel[2] = clampf(vel[2], rot);
	ctl_goal_reference(c, vel, acc);
	memcpy(g->rep.error, e, sizeof(e));
}

/* At the last pose, at rest, and sure of it (goal.h: GOAL_REACHED_*, GOAL_TOL_*). */
static bool arrived(const struct goal *g, const struct est_output *est, float dist, bool *at)
{
	const float angle = fabsf(g->rep.angle_rad);
	const float sd_pos = sqrtf(fmaxf(est->cov[0], 0.0f) + fmaxf(est->cov[1], 0.0f));
	const float sd_th = sqrtf(fmaxf(est->cov[2], 0.0f));

	*at = g->index == g->n - 1 && dist < GOAL_REACHED_POS_M && angle < GOAL_REACHED_THETA_RAD &&
	      norm2(est->vel[0], est->vel[1]) < GOAL_REACHED_SPEED_M_S;
	return *at && dist + 2.0f * sd_pos <= GOAL_TOL_POS_M &&
	       angle + 2.0f * sd_th <= GOAL_TOL_THETA_RAD;
}

/* Once the plan has ended: REACHED when arrived, else ACTIVE (SETTLING while at the pose), and
 * ABORTED (NO_PROGRESS, the robot stopped) GOAL_SETTLE_MAX_US after the plan ended. */
static void settle(struct goal *g, struct ctl *c, const struct est_output *est, float dist,
                   int64_t now_us)
{
	bool at;

	if (g->tr.t_s < g->tr.duration_s) {
		g->ended_us = 0;
		return;
	}
	if (!g->ended_us)
		g->ended_us = now_us;
	if (arrived(g, est, dist, &at)) {
		set_status(g, GOAL_REACHED, GOAL_R_NONE);
	} else if (now_us - g->ended_us >= GOAL_SETTLE_MAX_US) {
		set_status(g, GOAL_ABORTED, GOAL_R_NO_PROGRESS);
		ctl_stop(c, now_us);
	} else {
		set_status(g, GOAL_ACTIVE, at ? GOAL_R_SETTLING : GOAL_R_NONE);
	}
}

/* Distance, heading and time still to go; the arrival (settle) while the goal is active. */
static void progress(struct goal *g, struct ctl *c, const struct est_output *est,
                     const struct traj_ref *ref, int64_t now_us)
{
	const float *p = g->poses[g->index];
	float dist = norm2(p[0] - est->pose[0], p[1] - est->pose[1]);

	for (int i = g->index + 1; i < g->n; i++)
		dist +=
		    norm2(g->poses[i][0] - g->poses[i - 1][0], g->poses[i][1] - g->poses[i - 1][1]);
	g->rep.index = g->index;
	g->rep.distance_m = dist;
	g->rep.angle_rad = model_wrap_pi_f32(g->poses[g->n - 1][2] - est->pose[2]);
	g->rep.time_to_go_s = fmaxf(0.0f, g->tr.duration_s - g->tr.t_s);
	memcpy(g->rep.ref, ref->pose, sizeof(g->rep.ref));
	memcpy(g->rep.ref_vel, ref->vel, sizeof(g->rep.ref_vel));
	if (active(g))
		settle(g, c, est, dist, now_us);
}

/* A cancelled goal braking: kept alive by the goal mode itself (its sender is gone), ended
 * with the stop ramp once its plan has brought the reference to rest, or GOAL_BRAKE_MAX_US
 * after the cancel. */
static void brake_step(struct goal *g, struct ctl *c, int64_t now_us)
{
	if (!g->brake)
		return;
	if (c->mode != CTL_GOAL) {
		g->brake = 0;
		return;
	}
	ctl_goal_keep(c, now_us);
	if ((g->brake == 2 && g->tr.t_s >= g->tr.duration_s) ||
	    now_us - g->brake_since_us >= GOAL_BRAKE_MAX_US) {
		g->brake = 0;
		ctl_stop(c, now_us);
	}
}

void goal_step(struct goal *g, struct ctl *c, const struct est_output *est, int64_t now_us)
{
	struct traj_ref ref;

	brake_step(g, c, now_us);
	follow_controller(g, c);
	take(g, c, now_us);
	post(g, c, est, now_us);
	if (holding(g, c) && !g->traj_ok) { /* new limits left no acceleration */
		if (active(g))
			set_status(g, GOAL_ABORTED, GOAL_R_UNREACHABLE);
		ctl_stop(c, now_us);
		return;
	}
	if (!holding(g, c) || !est || !estimate_ok(g, c, est, now_us))
		return;
	advance(g, c->t.dt, &ref);
	track(g, c, est, &ref);
	progress(g, c, est, &ref, now_us);
}

const struct goal_report *goal_report(struct goal *g, bool *changed)
{
	if (changed)
		*changed = g->changed;
	g->changed = false;
	return &g->rep;
}

const struct goal_report *goal_take_refused(struct goal *g)
{
	if (!g->refused_pending)
		return NULL;
	g->refused_pending = false;
	return &g->refused;
}
