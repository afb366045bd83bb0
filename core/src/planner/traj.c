/*
 * traj.c - trajectory generator (traj.h, docs/trajectory.md): the instance, the choice among
 * the plans (a straight line, the x/y box, stop first), the heading's share, re-planning and the
 * hand-over. Single precision after traj_init; every loop has a fixed bound.
 */
#include "omni4/core/planner/traj.h"
#include "omni4/model/consts.h"
#include "traj_int.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#define TURN_CAPS 3       /* heading rate caps tried when turning leaves the translation no room */
#define TURN_CAP_CUT 0.3f /* each a share of the rate the one before reached */

static bool finite3(const float v[3])
{
	return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* ---- the instance -------------------------------------------------------------------------- */

/* The limits in single precision; 0 if each is in its range (NaN fails every comparison). */
struct limits_f {
	float supply, margin, mu, tmargin, wmax, vcap, wcap, share, height;
};

static bool limits_ok(const struct traj_limits *l, struct limits_f *f)
{
	if (model_params_check(&l->p, NULL) || model_wheels_check(&l->w, NULL))
		return false;
	*f = (struct limits_f){(float)l->supply_v,
	                       (float)l->margin_v,
	                       (float)l->mu,
	                       (float)l->traction_margin,
	                       (float)l->motor_speed_max_rad_s,
	                       (float)l->speed_cap_m_s,
	                       (float)l->omega_cap_rad_s,
	                       (float)l->rot_share,
	                       (float)l->com_height_m};
	return f->supply - f->margin > 0.0f && f->margin >= 0.0f && isfinite(f->supply) &&
	       f->mu > 0.0f && isfinite(f->mu) && f->tmargin >= 0.0f && f->tmargin < 1.0f &&
	       f->wmax > 0.0f && isfinite(f->wmax) && f->vcap > 0.0f && f->wcap > 0.0f &&
	       f->share > 0.0f && f->share < 1.0f && f->height >= 0.0f && isfinite(f->height);
}

int traj_init(struct traj *tr, const struct traj_limits *l)
{
	struct limits_f f;

	if (!limits_ok(l, &f))
		return -EINVAL;
	const float gear = (float)l->p.l, M = (float)l->p.M;
	struct traj_coef c = {
	    .M = M,
	    .J = (float)l->p.J,
	    .B = {(float)l->p.Bv, (float)l->p.Bvn, (float)l->p.Bw},
	    .C = {(float)l->p.Cv, (float)l->p.Cvn, (float)l->p.Cw},
	    .u_max_v = f.supply - f.margin,
	    .speed_cap_m_s = f.vcap,
	    .omega_cap_rad_s = f.wcap,
	    .rot_share = f.share,
	};
	struct wheel_geom g;
	struct wheel_phys ph;
	const float hold = f.mu * (1.0f - f.tmargin);

	if (l->geom)
		g = *l->geom;
	else
		wheel_geom_paper(l->p.d, &g);
	if (wheel_phys_init(&ph, &g, &l->p, &l->w, (double)f.height))
		return -EINVAL;
	wheel_phys_to_f32(&ph, &c.wh);
	for (int j = 0; j < c.wh.n; j++) {
		c.e[j] = c.wh.b[j] * c.wh.kemf[j];
		c.rim_max[j] = f.wmax * (float)l->w.r[j] / gear;
		c.turn[j] = sqrtf(c.wh.split[j][0] * c.wh.split[j][0] +
		                  c.wh.split[j][1] * c.wh.split[j][1]);
		c.f_max_n[j] = hold * c.wh.load0[j];
		c.f_load[j][0] = -hold * c.wh.load_a[j][0];
		c.f_load[j][1] = -hold * c.wh.load_a[j][1];
	}
	/* at rest, each axis and the heading alone must have room to accelerate */
	struct row r[3 * 4];
	const int nt = traj_rows_translation(&c, 0.0f, 1.0f, 1.0f, 0.0f, r);
	if (!(traj_rows_acc(r, nt, 1.0f, 0.0f, 0.0f, 0.0f) > 0.0f) ||
	    !(traj_rows_acc(r, nt, 0.0f, 1.0f, 0.0f, 0.0f) > 0.0f) ||
	    !(traj_rows_acc(r, traj_rows_rotation(&c, 1.0f, r), 1.0f, 0.0f, 0.0f, 0.0f) > 0.0f))
		return -EINVAL;
	*tr = (struct traj){.c = c};
	const float origin[3] = {0.0f, 0.0f, 0.0f};
	return traj_reset(tr, origin);
}

int traj_reset(struct traj *tr, const float pose[3])
{
	if (!finite3(pose))
		return -EINVAL;
	for (int i = 0; i < 3; i++)
		traj_1d_hold(&tr->axis[i], pose[i]);
	tr->t_s = 0.0f;
	tr->duration_s = 0.0f;
	tr->alpha_rad = 0.0f;
	tr->flags = 0;
	tr->on_path = 0;
	tr->pre_s = 0.0f;
	return 0;
}

/* The heading's profile with its share; returns its duration. */
static float plan_heading(struct traj *tr, const struct traj_ref *from, float goal, float share,
                          float cap)
{
	struct row r[12];
	const int n = traj_rows_rotation(&tr->c, share, r);
	struct axes ax = {.n = 1,
	                  .stop = true,
	                  .p0 = {from->pose[2]},
	                  .v0 = {from->vel[2]},
	                  .goal = {goal},
	                  .cap = cap,
	                  .out = {&tr->axis[2]}};
	const float t =
	    traj_line_plan(r, n, 1.0f, 0.0f, from->pose[2], from->vel[2], goal, cap, &tr->axis[2]);
	return t < INFINITY ? t : traj_box_limits(r, n, &ax, 1.0f, 0.0f, &tr->flags);
}

/* The translation is a straight line: the start velocity along the line to the goal (either
 * way) or none. e: the unit direction, dist: the distance. */
static bool on_line(const struct traj_ref *from, const float goal[3], float e[2], float *dist)
{
	const float dx = goal[0] - from->pose[0], dy = goal[1] - from->pose[1];

	*dist = sqrtf(dx * dx + dy * dy);
	if (!(*dist >= TRAJ_IDLE_POS))
		return false;
	e[0] = dx / *dist;
	e[1] = dy / *dist;
	return fabsf(from->vel[0] * e[1] - from->vel[1] * e[0]) < TRAJ_IDLE_VEL;
}

/* The heading rate the translation's rows carry: the heading profile's largest, or with
 * settle (a start turning faster than cap slows to it first) cap. */
static float rows_turn_rate(const struct traj_1d *heading, bool rot_idle, float cap, bool settle)
{
	const float w_top = rot_idle ? 0.0f : traj_1d_speed_max(heading);

	return settle ? minf(w_top, cap) : w_top;
}

/* One plan with the heading's share of every wheel's budget, its rate within cap; returns its
 * duration. settle: a start turning faster than cap slows to it first at the heading's full
 * deceleration, and the translation's rows carry the turning body's force at cap, not at the
 * start's rate (docs/trajectory.md, "A turning body"). */
static float plan_share_cap(struct traj *tr, const struct traj_ref *from, const float goal[3],
                            float share, bool rot_idle, bool tr_idle, float cap, bool settle)
{
	const float th_goal = from->pose[2] + model_wrap_pi_f32(goal[2] - from->pose[2]);
	float t_rot = 0.0f, t_xy = 0.0f, lo = from->pose[2], hi = from->pose[2];

	tr->flags = 0;
	tr->alpha_rad = 0.0f;
	if (rot_idle) {
		traj_1d_hold(&tr->axis[2], th_goal);
	} else {
		t_rot = plan_heading(tr, from, th_goal, share, cap);
		traj_1d_range(&tr->axis[2], &lo, &hi);
	}
	if (tr_idle) {
		traj_1d_hold(&tr->axis[0], goal[0]);
		traj_1d_hold(&tr->axis[1], goal[1]);
		return t_rot;
	}
	struct row r[TRAJ_ROWS_MAX];
	float phi[TRAJ_HEADINGS_MAX], cos_h;
	const float w_max = rows_turn_rate(&tr->axis[2], rot_idle, cap, settle);
	const int nh = traj_heading_samples(lo, hi, phi, &cos_h);
	int n = 0;
	for (int k = 0; k < nh; k++)
		n += traj_rows_translation(&tr->c, phi[k], 1.0f - share, cos_h, w_max, r + n);
	float e[2], dist;
	if (on_line(from, goal, e, &dist)) {
		struct traj_1d line;
		const float v0 = from->vel[0] * e[0] + from->vel[1] * e[1];
		t_xy = traj_line_plan(r, n, e[0], e[1], 0.0f, v0, dist, tr->c.speed_cap_m_s, &line);
		if (t_xy < INFINITY) {
			for (int i = 0; i < 2; i++)
				traj_line_project(&line, e[i], from->pose[i], goal[i],
				                  &tr->axis[i]);
			tr->alpha_rad = atan2f(fabsf(e[1]), fabsf(e[0]));
			return maxf(t_rot, t_xy);
		}
	}
	struct traj_1d bg[2];
	const float tb =
	    traj_line_brake_go(r, n, from->pose, from->vel, goal, tr->c.speed_cap_m_s, bg);
	const uint32_t flags = tr->flags;
	struct axes ax = {.n = 2,
	                  .stop = fabsf(from->vel[0]) < TRAJ_IDLE_VEL &&
	                          fabsf(from->vel[1]) < TRAJ_IDLE_VEL,
	                  .p0 = {from->pose[0], from->pose[1]},
	                  .v0 = {from->vel[0], from->vel[1]},
	                  .goal = {goal[0], goal[1]},
	                  .cap = tr->c.speed_cap_m_s};
	t_xy = traj_box_plan(tr, r, n, &ax);
	if (traj_sooner(tb, flags, t_xy, tr->flags)) {
		tr->axis[0] = bg[0];
		tr->axis[1] = bg[1];
		tr->flags = flags;
		t_xy = tb;
	}
	return maxf(t_rot, t_xy);
}

/* plan_share_cap at the heading's cap, then, while the turning body's M w x v leaves the
 * translation no room (beyond the envelope), at a lower one (below the start's rate: the
 * heading slows to it first). */
static float plan_share(struct traj *tr, const struct traj_ref *from, const float goal[3],
                        float share, bool rot_idle, bool tr_idle)
{
	float cap = tr->c.omega_cap_rad_s, t = INFINITY;

	for (int k = 0; k < TURN_CAPS; k++) {
		t = plan_share_cap(tr, from, goal, share, rot_idle, tr_idle, cap, k > 0);
		if (rot_idle || tr_idle || !(tr->flags & TRAJ_F_BEYOND_ENVELOPE))
			break;
		cap = TURN_CAP_CUT * minf(cap, traj_1d_speed_max(&tr->axis[2]));
	}
	return t;
}

/* Both move: the heading's share among three, the earliest arrival kept (inside the envelope
 * first). */
static void share_three(struct traj *tr, const struct traj_ref *from, const float goal[3], float s)
{
	const float shares[TRAJ_SHARES] = {0.5f * s, s, 0.5f * (1.0f + s)};
	struct traj cand = *tr;

	tr->duration_s = INFINITY;
	tr->flags = TRAJ_F_BEYOND_ENVELOPE;
	for (int k = 0; k < TRAJ_SHARES; k++) {
		cand.duration_s = plan_share(&cand, from, goal, shares[k], false, false);
		if (traj_sooner(cand.duration_s, cand.flags, tr->duration_s, tr->flags))
			*tr = cand;
	}
}

/* Both move on a straight line: the heading's share by bisection until the heading and the
 * translation arrive together (the heading's time falls with its share, the translation's
 * rises), the earliest arrival kept (inside the envelope first). */
static void share_bisect(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	struct traj cand = *tr;
	float lo = 0.0f, hi = 1.0f;

	tr->duration_s = INFINITY;
	tr->flags = TRAJ_F_BEYOND_ENVELOPE;
	for (int it = 0; it < TRAJ_SHARE_ITERS; it++) {
		const float share = 0.5f * (lo + hi);
		cand.duration_s = plan_share(&cand, from, goal, share, false, false);
		if (traj_sooner(cand.duration_s, cand.flags, tr->duration_s, tr->flags))
			*tr = cand;
		const float t_rot = traj_1d_duration(&cand.axis[2]);
		if (t_rot > maxf(traj_1d_duration(&cand.axis[0]), traj_1d_duration(&cand.axis[1])))
			lo = share;
		else
			hi = share;
	}
}

/* A straight move with the heading still at the start: the heading swing, if sooner. */
static void swing(struct traj *tr, const struct traj_ref *from, const float goal[3], bool tr_idle)
{
	float e[2], dist;

	if (tr_idle || fabsf(from->vel[2]) > TRAJ_IDLE_VEL || !on_line(from, goal, e, &dist))
		return;
	const float v0 = from->vel[0] * e[0] + from->vel[1] * e[1];
	if (v0 >= 0.0f)
		traj_line_paths_try(tr, from, goal, v0);
}

/* A moving start: the brake prelude, then the plan from rest where it stops, if that arrives
 * sooner (inside the envelope first: traj_sooner). */
static void brake_first(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	if (!(fabsf(from->vel[0]) >= TRAJ_IDLE_VEL || fabsf(from->vel[1]) >= TRAJ_IDLE_VEL ||
	      fabsf(from->vel[2]) >= TRAJ_IDLE_VEL))
		return;
	struct traj_1d pre[3];
	struct traj_ref rest = {.pose = {0}};
	const float t_pre = traj_brake_prelude(tr, from, pre, rest.pose);
	if (!(t_pre < tr->duration_s))
		return;
	struct traj cand = {.c = tr->c};
	traj_plan(&cand, &rest, goal); /* from rest: no prelude of its own */
	if (!traj_sooner(t_pre + cand.duration_s, cand.flags, tr->duration_s, tr->flags))
		return;
	*tr = cand;
	for (int i = 0; i < 3; i++)
		tr->pre[i] = pre[i];
	tr->pre_s = t_pre;
	tr->duration_s += t_pre;
}

/* The one curve's timings (traj_curve.c): 48 fit the Cortex-M4's lead (docs/trajectory.md) */
#define TRAJ_PLAN_EVALS 48

int traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	if (!finite3(from->pose) || !finite3(from->vel) || !finite3(goal))
		return -EINVAL;
	if (traj_plan_curve(tr, from, goal, TRAJ_PLAN_EVALS) == 0)
		return 0;
	/* no curve timed (a floor too slippery to turn and move at once, a start far outside the
	 * envelope): the stepped plans, each axis in its own profile */
	const float th_goal = from->pose[2] + model_wrap_pi_f32(goal[2] - from->pose[2]);
	const bool rot_idle = traj_1d_idle(from->pose[2], from->vel[2], th_goal);
	const bool tr_idle = traj_1d_idle(from->pose[0], from->vel[0], goal[0]) &&
	                     traj_1d_idle(from->pose[1], from->vel[1], goal[1]);
	const float s = tr->c.rot_share;

	tr->on_path = 0;
	tr->pre_s = 0.0f;
	if (rot_idle || tr_idle) {
		tr->duration_s =
		    plan_share(tr, from, goal, tr_idle ? 1.0f : 0.0f, rot_idle, tr_idle);
	} else {
		float e[2], dist;
		if (on_line(from, goal, e, &dist))
			share_bisect(tr, from, goal);
		else
			share_three(tr, from, goal, s);
	}
	swing(tr, from, goal, tr_idle);
	brake_first(tr, from, goal);
	tr->t_s = 0.0f;
	return 0;
}

void traj_eval(const struct traj *tr, float t_s, struct traj_ref *out)
{
	/* at the end at rest at the goal (the prelude's and the rest's sum may round short of the
	 * parts' own ends) */
	if (!(t_s < tr->duration_s))
		t_s = INFINITY;
	if (t_s < tr->pre_s) {
		for (int i = 0; i < 3; i++)
			traj_1d_eval(&tr->pre[i], t_s, &out->pose[i], &out->vel[i], &out->acc[i]);
		return;
	}
	t_s -= tr->pre_s;
	if (tr->on_path) {
		traj_path_eval(&tr->path, t_s, out);
		return;
	}
	for (int i = 0; i < 3; i++)
		traj_1d_eval(&tr->axis[i], t_s, &out->pose[i], &out->vel[i], &out->acc[i]);
}

void traj_step(struct traj *tr, float dt_s, struct traj_ref *out)
{
	if (tr->t_s < tr->duration_s)
		tr->t_s += dt_s;
	traj_eval(tr, tr->t_s, out);
}

int traj_replan(struct traj *tr, const float goal[3])
{
	struct traj_ref now;

	if (!finite3(goal))
		return -EINVAL;
	if (tr->on_path && !(tr->pre_s > 0.0f) && goal[0] == tr->path.goal[0] &&
	    goal[1] == tr->path.goal[1] &&
	    fabsf(model_wrap_pi_f32(goal[2] - tr->path.goal[2])) < 1e-5f)
		return traj_path_retime(tr); /* the same path from where the reference is */
	traj_eval(tr, tr->t_s, &now);
	return traj_plan(tr, &now, goal);
}

int traj_plan_ahead(const struct traj *tr, float lead_s, const float goal[3], struct traj *next)
{
	struct traj_ref at;
	struct traj cand = {.c = tr->c};
	const float start_s = tr->t_s + lead_s;

	if (!(lead_s >= 0.0f) || !isfinite(lead_s) || !finite3(goal))
		return -EINVAL;
	traj_eval(tr, start_s, &at);
	const int rc = traj_plan(&cand, &at, goal);
	if (rc)
		return rc;
	cand.handover_s = start_s;
	*next = cand;
	return 0;
}

int traj_take_over(struct traj *tr, const struct traj *next)
{
	const float at_s = next->handover_s;

	if (tr->t_s < at_s - TRAJ_HANDOVER_TOL_S && tr->t_s < tr->duration_s)
		return 0;
	const float past = tr->t_s >= at_s ? tr->t_s - at_s : 0.0f;
	*tr = *next;
	tr->t_s = past;
	tr->handover_s = 0.0f;
	return 1;
}
