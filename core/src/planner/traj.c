/*
 * traj.c - trajectory generator (traj.h, docs/trajectory.md): the instance, the plan (the one
 * curve, else a turn in place first), re-planning and the hand-over. Single precision after
 * traj_init; every loop has a fixed bound.
 */
#include "omni4/core/planner/traj.h"
#include "omni4/model/consts.h"
#include "traj_int.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

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
		c.lift_max[j] = (1.0f - f.tmargin) * c.f_max_n[j];
	}
	/* at rest, each axis and the heading alone must have room to accelerate */
	struct row r[4 * 4];
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
	tr->on_path = 0;
	tr->pre_s = 0.0f;
	return 0;
}

/* No curve timed (a floor too slippery to turn and move at once: a turn's Coulomb friction and
 * a translation's together beyond traction): the brake prelude (a moving start), a turn in
 * place to the goal's heading, then the curve with the heading held. */
static int turn_first(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	struct traj_1d pre[3];
	struct traj_ref rest = {.pose = {from->pose[0], from->pose[1], from->pose[2]}};
	float t_pre = 0.0f;

	for (int i = 0; i < 3; i++)
		traj_1d_hold(&pre[i], from->pose[i]);
	if (traj_ref_moving(from))
		t_pre = traj_brake_prelude(tr, from, pre, rest.pose);
	rest.pose[2] += model_wrap_pi_f32(goal[2] - rest.pose[2]);
	if (t_pre < INFINITY)
		t_pre = traj_turn_in_place(tr, pre, t_pre, rest.pose[2]);
	rest.pose[2] = pre[2].goal; /* where the prelude ends (no turn under TRAJ_IDLE_POS) */
	struct traj cand = {.c = tr->c};
	const float held[3] = {goal[0], goal[1], rest.pose[2]}; /* unwrapped: no turn at all */
	if (!(t_pre < INFINITY) || traj_plan_curve(&cand, &rest, held, CURVE_EVALS_MIN))
		return -ERANGE;
	*tr = cand;
	for (int i = 0; i < 3; i++)
		tr->pre[i] = pre[i];
	tr->pre_s = t_pre;
	tr->duration_s += t_pre;
	return 0;
}

/* The one curve's timings (traj_curve.c) from rest and from a moving start (half of them for
 * the curve after the brake prelude): each fits the Cortex-M4's lead (docs/trajectory.md) */
#define TRAJ_PLAN_EVALS 48
#define TRAJ_PLAN_EVALS_MOVING 36

int traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	if (!finite3(from->pose) || !finite3(from->vel) || !finite3(goal))
		return -EINVAL;
	const int evals = traj_ref_moving(from) ? TRAJ_PLAN_EVALS_MOVING : TRAJ_PLAN_EVALS;
	if (traj_plan_curve(tr, from, goal, evals) == 0)
		return 0;
	return turn_first(tr, from, goal);
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
