/* goal.c - position control on the trajectory generator: checks, plan, path, tracking law,
 * progress (goal.h, docs/goal.md). */
#include "omni4/core/goal.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#define PI_F 3.14159265358979f

static float wrap(float a)
{
	a = fmodf(a + PI_F, 2.0f * PI_F);
	if (a < 0.0f)
		a += 2.0f * PI_F;
	return a - PI_F;
}

static float norm2(float x, float y)
{
	return sqrtf(x * x + y * y);
}

/* cos and sin of a (sin as a shifted cos: no sincosf, which the core's objects may not call). */
static void cos_sin(float a, float *c, float *s)
{
	*c = cosf(a);
	*s = cosf(a - 0.5f * PI_F);
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
	return (g->rep.status == GOAL_ACTIVE || g->rep.status == GOAL_REACHED) &&
	       c->mode == CTL_GOAL;
}

static void set_status(struct goal *g, enum goal_status st, enum goal_reason why)
{
	if (g->rep.status != (int8_t)st || g->rep.reason != (int8_t)why)
		g->changed = true;
	g->rep.status = (int8_t)st;
	g->rep.reason = (int8_t)why;
}

void goal_traction(const struct ctl_settings *cfg, double *mu, double *margin)
{
	const bool floor = cfg->limits.traction_mu > 0.0;

	*mu = floor ? cfg->limits.traction_mu : GOAL_MU_DEFAULT;
	*margin = floor ? cfg->limits.traction_margin : GOAL_TRACTION_MARGIN;
}

/* A plan from `from` to `to` in tr under the limits in force: the envelope's (traj_plan) or the
 * fixed box's, its speed within tr's cap (a goal's speed_max). */
static int plan(const struct goal *g, struct traj *tr, const struct traj_ref *from,
                const float to[3])
{
	if (!g->fixed)
		return traj_plan(tr, from, to);
	struct goal_fixed fx = g->fx;

	fx.speed_m_s = fminf(fx.speed_m_s, tr->c.speed_cap_m_s);
	return goal_fixed_plan(&fx, tr, from, to);
}

/* plan from the reference at tr's clock now (no jump). */
static int replan(const struct goal *g, struct traj *tr, const float to[3])
{
	struct traj_ref now;

	traj_eval(tr, tr->t_s, &now);
	return plan(g, tr, &now, to);
}

void goal_init(struct goal *g, const struct ctl_settings *cfg)
{
	const bool again = active(g) && g->traj_ok;
	struct traj_ref ref;

	if (again)
		traj_eval(&g->tr, g->tr.t_s, &ref);
	struct traj_limits lim = {
	    .p = cfg->model,
	    .supply_v = cfg->limits.supply_v,
	    .margin_v = fmin(GOAL_MARGIN_V, 0.25 * cfg->limits.supply_v),
	    .motor_speed_max_rad_s = GOAL_MOTOR_SPEED_MAX_RAD_S,
	    .speed_cap_m_s = cfg->limits.vel_lin_max,
	    .omega_cap_rad_s = cfg->limits.vel_rot_max,
	    .rot_share = GOAL_ROT_SHARE,
	};

	goal_traction(cfg, &lim.mu, &lim.traction_margin);
	ctl_settings_wheels(cfg, &lim.w);
	/* Into the scratch first: limits it refuses leave the goal in force its plan, to be
	 * aborted at the next step (goal_step), never a reference at the origin. */
	g->traj_ok = traj_init(&g->scratch, &lim) == 0;
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
	/* New limits while a goal runs: a new plan from where the reference is (no jump). */
	if (!again)
		return;
	if (g->tr.on_path && !g->fixed && traj_replan(&g->tr, g->poses[g->n - 1]) == 0)
		return; /* the same path, re-timed */
	plan(g, &g->tr, &ref, g->poses[g->index]);
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

/* Where a new plan starts: the reference while a goal is tracked (bumpless from goal to
 * goal), else the estimate with its velocity turned into the world frame (eq 1). */
static void plan_start(const struct goal *g, const struct ctl *c, const struct est_output *est,
                       struct traj_ref *from)
{
	if (holding(g, c)) {
		traj_eval(&g->tr, g->tr.t_s, from);
		return;
	}
	const float th = est->pose[2];
	float cs, sn;

	cos_sin(th, &cs, &sn);

	memset(from, 0, sizeof(*from));
	memcpy(from->pose, est->pose, sizeof(from->pose));
	from->vel[0] = cs * est->vel[0] - sn * est->vel[1];
	from->vel[1] = sn * est->vel[0] + cs * est->vel[1];
	from->vel[2] = est->vel[2];
}

/* A path of up to TRAJ_PATH_MAX poses: one plan through them all (no stop at the
 * intermediate ones, each passed within the blend radius); false if it cannot be planned. */
static bool plan_path(const struct goal_cmd *cmd, const struct traj_ref *from, struct traj *tr)
{
	float poses[TRAJ_PATH_MAX][3];
	const float blend = cmd->blend_m > 0.0 ? (float)cmd->blend_m : GOAL_BLEND_DEFAULT_M;

	if (cmd->n < 2 || cmd->n > TRAJ_PATH_MAX)
		return false;
	for (int i = 0; i < cmd->n; i++)
		for (int k = 0; k < 3; k++)
			poses[i][k] = (float)cmd->poses[i][k];
	return traj_plan_path(tr, from, (const float (*)[3])poses, cmd->n, blend) == 0 &&
	       tr->duration_s <= GOAL_PLAN_MAX_S;
}

/* Plans cmd's first segment into tr (a copy: the goal in force keeps its plan if refused). */
static enum goal_reason plan_first(const struct goal *g, const struct ctl *c,
                                   const struct goal_cmd *cmd, const struct est_output *est,
                                   struct traj *tr)
{
	struct traj_ref from;
	const float to[3] = {(float)cmd->poses[0][0], (float)cmd->poses[0][1],
	                     (float)cmd->poses[0][2]};

	if (!g->traj_ok)
		return GOAL_R_UNREACHABLE;
	*tr = g->tr;
	tr->c.speed_cap_m_s = cmd->speed_max > 0.0 ? fminf((float)cmd->speed_max, g->speed_cap_m_s)
	                                           : g->speed_cap_m_s;
	plan_start(g, c, est, &from);
	if (!g->fixed && plan_path(cmd, &from, tr))
		return GOAL_R_NONE;
	if (plan(g, tr, &from, to) || !(tr->duration_s <= GOAL_PLAN_MAX_S))
		return GOAL_R_UNREACHABLE;
	return GOAL_R_NONE;
}

/* A new goal: checked, planned and taken, or refused (the goal in force, if any, goes on). */
static int start(struct goal *g, struct ctl *c, const struct goal_cmd *cmd,
                 const struct est_output *est, int64_t now_us)
{
	enum goal_reason why = check_fields(cmd);

	if (!why && (!est || (est->flags & EST_FLAG_CAMERA_STALE)))
		why = GOAL_R_NO_ESTIMATE;
	if (!why)
		why = plan_first(g, c, cmd, est, &g->scratch);
	if (!why && ctl_goal(c, now_us)) /* FAULT or ESTOP */
		why = GOAL_R_FAULT;
	if (why) {
		g->refused = (struct goal_report){
		    .id = cmd->id, .status = GOAL_REFUSED, .reason = (int8_t)why, .n = cmd->n};
		g->refused_pending = true;
		return why == GOAL_R_FAULT ? -EPERM
		                           : (why == GOAL_R_UNREACHABLE ? -ERANGE : -EINVAL);
	}
	g->tr = g->scratch;
	g->n = cmd->n;
	g->index = 0;
	for (int i = 0; i < cmd->n; i++)
		for (int k = 0; k < 3; k++)
			g->poses[i][k] = (float)cmd->poses[i][k];
	g->blend_m = cmd->blend_m > 0.0 ? (float)cmd->blend_m : GOAL_BLEND_DEFAULT_M;
	g->stale_since_us = 0;
	g->rep = (struct goal_report){.id = cmd->id, .n = cmd->n};
	g->rep.status = GOAL_NONE;
	set_status(g, GOAL_ACTIVE, GOAL_R_NONE);
	return 0;
}

int goal_command(struct goal *g, struct ctl *c, const struct goal_cmd *cmd,
                 const struct est_output *est, int64_t now_us)
{
	const bool mine = cmd->id == g->rep.id;

	if (cmd->action == GOAL_CANCEL) {
		if ((mine || cmd->id == 0) && holding(g, c)) {
			if (active(g))
				set_status(g, GOAL_ABORTED, GOAL_R_CANCELLED);
			ctl_stop(c, now_us);
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
		return ctl_goal(c, now_us); /* keep-alive */
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
	else if (c->mode == CTL_FAULT || c->mode == CTL_ESTOP)
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
 * blend radius of an intermediate one (re-planned from the reference: no jump). */
static void advance(struct goal *g, float dt_s, struct traj_ref *ref)
{
	traj_step(&g->tr, dt_s, ref);
	if (g->index >= g->n - 1)
		return;
	const float *p = g->poses[g->index];

	if (norm2(ref->pose[0] - p[0], ref->pose[1] - p[1]) >= g->blend_m)
		return;
	g->index++;
	g->changed = true;
	if (g->tr.on_path)
		return; /* the path plan goes on through the next pose */
	replan(g, &g->tr, g->poses[g->index]);
	traj_eval(&g->tr, g->tr.t_s, ref);
}

/* The tracking law: world velocity of the reference plus P on the pose error, turned into the
 * robot frame at the estimated heading (eq 1); the reference's acceleration turned likewise,
 * as the rate of the robot-frame reference velocity (the frame turns at w). */
static void track(struct goal *g, struct ctl *c, const struct est_output *est,
                  const struct traj_ref *ref)
{
	const float th = est->pose[2];
	float cs, sn;

	cos_sin(th, &cs, &sn);
	const float e[3] = {ref->pose[0] - est->pose[0], ref->pose[1] - est->pose[1],
	                    wrap(ref->pose[2] - th)};
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

/* Distance, heading and time still to go; REACHED once the plan has ended and the estimate is
 * at the last pose, at rest. */
static void progress(struct goal *g, const struct est_output *est, const struct traj_ref *ref)
{
	const float *p = g->poses[g->index];
	float dist = norm2(p[0] - est->pose[0], p[1] - est->pose[1]);

	for (int i = g->index + 1; i < g->n; i++)
		dist +=
		    norm2(g->poses[i][0] - g->poses[i - 1][0], g->poses[i][1] - g->poses[i - 1][1]);
	g->rep.index = g->index;
	g->rep.distance_m = dist;
	g->rep.angle_rad = wrap(g->poses[g->n - 1][2] - est->pose[2]);
	g->rep.time_to_go_s = fmaxf(0.0f, g->tr.duration_s - g->tr.t_s);
	memcpy(g->rep.ref, ref->pose, sizeof(g->rep.ref));
	memcpy(g->rep.ref_vel, ref->vel, sizeof(g->rep.ref_vel));
	const float speed = norm2(est->vel[0], est->vel[1]);

	if (active(g) && g->index == g->n - 1 && g->tr.t_s >= g->tr.duration_s &&
	    dist < GOAL_REACHED_POS_M && fabsf(g->rep.angle_rad) < GOAL_REACHED_THETA_RAD &&
	    speed < GOAL_REACHED_SPEED_M_S)
		set_status(g, GOAL_REACHED, GOAL_R_NONE);
}

void goal_step(struct goal *g, struct ctl *c, const struct est_output *est, int64_t now_us)
{
	struct traj_ref ref;

	follow_controller(g, c);
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
	progress(g, est, &ref);
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
