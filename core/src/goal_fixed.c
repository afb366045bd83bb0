/* goal_fixed.c - the fixed-limits peer of the goal mode's planner: a box inside the model's
 * envelope and a TIGERs-style plan under it (goal_fixed.h, docs/goal.md). */
#include "omni4/core/goal_fixed.h"
#include "omni4/model/consts.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>

#define PI_F MODEL_PI_F
#define IDLE_POS 1e-6f /* as TRAJ_IDLE_POS, TRAJ_IDLE_VEL: an axis this close and slow holds */
/* (sin as a shifted cos below: no sincosf, which the core's objects may not call) */

/* The lowest acceleration over every direction at speed v, and the lowest top speed. */
static void worst_direction(const struct traj *tr, float v, float *acc, float *top)
{
	*acc = INFINITY;
	*top = INFINITY;
	for (int k = 0; k < GOAL_FIXED_DIRS; k++) {
		const float a = 2.0f * PI_F * (float)k / GOAL_FIXED_DIRS;
		const float dir[2] = {cosf(a), cosf(a - 0.5f * PI_F)};
		float acc_k, top_k;

		if (traj_envelope(tr, dir, v, &acc_k, &top_k))
			continue;
		*acc = fminf(*acc, acc_k);
		*top = fminf(*top, top_k);
	}
}

/* Pure rotation at rate w: the largest angular acceleration every wheel allows (each pushes
 * its share q_j T of the torque, 1 / 4d for the paper's layout (wheels.h); its force within
 * traction and within its voltage less the back-EMF of d_j w). */
static float rotation_acc(const struct traj_coef *c, float w)
{
	float T = INFINITY;

	for (int j = 0; j < c->wh.n; j++) {
		const float f =
		    fminf(c->f_max_n[j], c->wh.b[j] * c->u_max_v - c->e[j] * c->wh.row[j][2] * w);

		T = fminf(T, f / c->wh.split[j][2]);
	}
	return (T - c->B[2] * w - c->C[2]) / c->J;
}

/* The speed in (0, top] with the largest acc(v) v; its acceleration. */
static void best_box(const struct traj *tr, float top, bool rot, float *speed, float *acc)
{
	*speed = 0.0f;
	*acc = 0.0f;
	for (int i = 1; i <= GOAL_FIXED_SPEEDS; i++) {
		const float v = top * (float)i / GOAL_FIXED_SPEEDS;
		float a, t;

		if (rot)
			a = rotation_acc(&tr->c, v);
		else
			worst_direction(tr, v, &a, &t);
		if (a > 0.0f && a * v > *acc * *speed) {
			*speed = v;
			*acc = a;
		}
	}
}

int goal_fixed_limits(const struct traj *tr, struct goal_fixed *fx)
{
	const struct traj_coef *c = &tr->c;
	float a0, top;

	worst_direction(tr, 0.0f, &a0, &top);
	best_box(tr, top, false, &fx->speed_m_s, &fx->acc_m_s2);
	/* the heading's top rate: where its acceleration reaches 0 (linear in w), or the cap */
	const float a_w0 = rotation_acc(c, 0.0f), a_w1 = rotation_acc(c, 1.0f);
	float w_top = a_w1 < a_w0 ? a_w0 / (a_w0 - a_w1) : c->omega_cap_rad_s;

	w_top = fminf(w_top, c->omega_cap_rad_s);
	for (int j = 0; j < c->wh.n; j++) /* wheel j's rim turns d_j w (eq 2) */
		w_top = fminf(w_top, c->rim_max[j] / fabsf(c->wh.row[j][2]));
	best_box(tr, w_top, true, &fx->rate_rad_s, &fx->acc_rad_s2);
	fx->rot_share = c->rot_share;
	if (!(fx->acc_m_s2 > 0.0f && fx->speed_m_s > 0.0f && fx->acc_rad_s2 > 0.0f &&
	      fx->rate_rad_s > 0.0f))
		return -EINVAL;
	return 0;
}

/* x and y share the box: angle alpha gives x cos(alpha), y sin(alpha) of it; bisection until
 * both take as long (TIGERs' 2D bang-bang). */
static float plan_xy(struct traj *tr, const struct traj_ref *from, const float goal[3], float acc,
                     float speed)
{
	float lo = 0.0f, hi = 0.5f * PI_F, tx = 0.0f, ty = 0.0f;

	for (int it = 0; it < GOAL_FIXED_ALPHA_ITERS; it++) {
		const float al = 0.5f * (lo + hi), ca = cosf(al), sa = cosf(al - 0.5f * PI_F);

		tx = traj_1d_plan(&tr->axis[0], from->pose[0], from->vel[0], goal[0], acc * ca,
		                  acc * ca, speed * ca);
		ty = traj_1d_plan(&tr->axis[1], from->pose[1], from->vel[1], goal[1], acc * sa,
		                  acc * sa, speed * sa);
		if (tx > ty)
			hi = al; /* x needs more: a smaller angle */
		else
			lo = al;
	}
	return fmaxf(tx, ty);
}

static bool finite3(const float v[3])
{
	return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static bool idle(float p0, float v0, float goal)
{
	return fabsf(goal - p0) < IDLE_POS && fabsf(v0) < IDLE_POS;
}

int goal_fixed_plan(const struct goal_fixed *fx, struct traj *tr, const struct traj_ref *from,
                    const float goal[3])
{
	if (!finite3(from->pose) || !finite3(from->vel) || !finite3(goal))
		return -EINVAL;
	const float th = from->pose[2] + model_wrap_pi_f32(goal[2] - from->pose[2]);
	const bool rot = !idle(from->pose[2], from->vel[2], th);
	const bool lin = !idle(from->pose[0], from->vel[0], goal[0]) ||
	                 !idle(from->pose[1], from->vel[1], goal[1]);
	const float kr = rot && lin ? fx->rot_share : 1.0f, kt = rot && lin ? 1.0f - kr : 1.0f;
	const float t_xy = plan_xy(tr, from, goal, fx->acc_m_s2 * kt, fx->speed_m_s * kt);
	const float t_w =
	    traj_1d_plan(&tr->axis[2], from->pose[2], from->vel[2], th, fx->acc_rad_s2 * kr,
	                 fx->acc_rad_s2 * kr, fx->rate_rad_s * kr);

	tr->duration_s = fmaxf(t_xy, t_w);
	tr->t_s = 0.0f;
	return 0;
}
