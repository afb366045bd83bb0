/*
 * traj_brake.c - the brake prelude of a plan from a moving start (docs/trajectory.md, "A moving
 * start"): the translation stops along its velocity and the heading's rate falls to 0 together,
 * inside the envelope; the plan from rest at that pose follows it. Single precision.
 */
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

/* One axis' stop projected on the world's axes from p0 along sign/direction e[0..m-1]. */
static void project_stop(const struct traj_1d *o, const float *e, const float *p0, int m,
                         struct traj_1d *out, float *stop)
{
	for (int i = 0; i < m; i++) {
		stop[i] = p0[i] + e[i] * o->goal;
		traj_line_project(o, e[i], p0[i], stop[i], &out[i]);
	}
}

/* The prelude's start to the bit: the projection rounds v0 / |v0| x |v0|. */
static void start_exact(struct traj_1d pre[3], const struct traj_ref *from)
{
	for (int i = 0; i < 3; i++) {
		pre[i].p0 = from->pose[i];
		if (pre[i].n > 0) {
			pre[i].v0 = from->vel[i];
			pre[i].vs[0] = from->vel[i];
		}
	}
}

float traj_brake_share(const struct traj *tr, const struct traj_ref *from, float share,
                       struct traj_1d pre[3], float stop[3], float *t_rot)
{
	const float vx = from->vel[0], vy = from->vel[1], w0 = from->vel[2];
	const float sp = sqrtf(vx * vx + vy * vy);
	struct row r[TRAJ_ROWS_MAX];
	struct traj_1d o;
	float t_xy = 0.0f;

	*t_rot = 0.0f;
	for (int i = 0; i < 3; i++) {
		stop[i] = from->pose[i];
		traj_1d_hold(&pre[i], from->pose[i]);
	}
	if (fabsf(w0) >= TRAJ_IDLE_VEL) {
		const float sg = w0 > 0.0f ? 1.0f : -1.0f;
		const int n = traj_rows_rotation(&tr->c, share, r);
		*t_rot = traj_line_stop(r, n, 1.0f, 0.0f, fabsf(w0), &o);
		if (!(*t_rot < INFINITY))
			return INFINITY;
		project_stop(&o, &sg, &from->pose[2], 1, &pre[2], &stop[2]);
	}
	if (sp >= TRAJ_IDLE_VEL) {
		const float e[2] = {vx / sp, vy / sp};
		float phi[TRAJ_HEADINGS_MAX], cos_h;
		const int nh = traj_heading_samples(minf(from->pose[2], stop[2]),
		                                    maxf(from->pose[2], stop[2]), phi, &cos_h);
		int n = 0;
		for (int k = 0; k < nh; k++)
			n += traj_rows_translation(&tr->c, phi[k], 1.0f - share, cos_h,
			                           fabsf(w0) >= TRAJ_IDLE_VEL ? fabsf(w0) : 0.0f,
			                           r + n);
		t_xy = traj_line_stop(r, n, e[0], e[1], sp, &o);
		if (!(t_xy < INFINITY))
			return INFINITY;
		project_stop(&o, e, from->pose, 2, pre, stop);
	}
	start_exact(pre, from);
	return maxf(*t_rot, t_xy);
}

float traj_brake_prelude(const struct traj *tr, const struct traj_ref *from, struct traj_1d pre[3],
                         float stop[3])
{
	const bool turns = fabsf(from->vel[2]) >= TRAJ_IDLE_VEL;
	const bool moves =
	    fabsf(from->vel[0]) >= TRAJ_IDLE_VEL || fabsf(from->vel[1]) >= TRAJ_IDLE_VEL;
	struct traj_1d cand[3];
	float lo = 0.0f, hi = 1.0f, best = INFINITY, at[3], t_rot;

	if (!(turns && moves))
		return traj_brake_share(tr, from, turns ? 1.0f : 0.0f, pre, stop, &t_rot);
	/* both: the heading's share by bisection until both stop together (the heading's stop
	 * falls with its share, the translation's rises), the soonest kept; first none (the turn
	 * braked by its own friction, where that stops it: the translation's stop rises steeply
	 * with the share there, 7.5 s at 5 % against 2.9 s at 0 for a slow turn) */
	for (int it = -1; it < TRAJ_SHARE_ITERS; it++) {
		const float share = it < 0 ? 0.0f : 0.5f * (lo + hi);
		const float t = traj_brake_share(tr, from, share, cand, at, &t_rot);
		if (t < best) {
			best = t;
			for (int i = 0; i < 3; i++) {
				pre[i] = cand[i];
				stop[i] = at[i];
			}
		}
		if (it < 0)
			continue;
		if (!(t_rot < t)) /* the heading's stop is the longer (or has none) */
			lo = share;
		else
			hi = share;
	}
	return best;
}

float traj_turn_in_place(const struct traj *tr, struct traj_1d pre[3], float t_pre, float th_goal)
{
	struct row r[12];
	struct traj_1d turn;
	const int n = traj_rows_rotation(&tr->c, 1.0f, r);
	const float th0 = pre[2].goal;

	if (traj_1d_idle(th0, 0.0f, th_goal))
		return t_pre;
	const float t_turn =
	    traj_line_plan(r, n, 1.0f, 0.0f, th0, 0.0f, th_goal, tr->c.omega_cap_rad_s, &turn);
	if (!(t_turn < INFINITY) || pre[2].n + 1 + turn.n > TRAJ_PHASES)
		return INFINITY; /* (the stop, a wait and the turn fit TRAJ_PHASES by construction)
		                  */
	/* after the stop (a wait while the heading is at rest and the translation still stops) */
	float t = traj_1d_duration(&pre[2]), p = th0, v = 0.0f;
	if (pre[2].n == 0)
		pre[2] = (struct traj_1d){.p0 = th0, .p1 = th0};
	if (t < t_pre)
		traj_ph_add(&pre[2], &t, &p, &v, 0.0f, t_pre - t);
	t = t_pre;
	for (int k = 0; k < turn.n; k++) {
		const float dt = turn.t_end_s[k] - (k ? turn.t_end_s[k - 1] : 0.0f);
		traj_ph_add(&pre[2], &t, &p, &v, turn.acc[k], dt);
	}
	pre[2].v1 = turn.v1;
	pre[2].goal = th_goal;
	return t;
}
