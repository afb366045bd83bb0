/*
 * traj_box.c - the translation off a straight line (docs/trajectory.md, "Translation off the
 * line"): two 1D bang-bang profiles (x, y) sharing the acceleration and top speed by an angle
 * alpha, checked over a box of accelerations and velocities; the top speed among fractions of
 * the largest, alpha by bisection so both axes arrive together.
 */
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

/* Acceleration planned with when the start velocity leaves none (TRAJ_F_BEYOND_ENVELOPE). */
#define ACC_FLOOR 0.05f

/* Top speeds tried, as fractions of the largest the envelope allows (acceleration 0 there). */
static const float speed_frac[TRAJ_SPEED_STEPS] = {0.3f,  0.5f,  0.65f, 0.75f,
                                                   0.82f, 0.88f, 0.93f, 0.97f};

static float axes_time(const struct axes *ax, float ca, float sa, float acc, float dec, float v)
{
	const float share[2] = {ca, sa};
	float t = 0.0f;

	for (int i = 0; i < ax->n; i++)
		t = maxf(t, traj_1d_plan(ax->out[i], ax->p0[i], ax->v0[i], ax->goal[i],
		                         acc * share[i], dec * share[i], v * share[i]));
	return t;
}

/*
 * For the share (ca, sa): the top speed V among TRAJ_SPEED_STEPS fractions of the largest that
 * gives the earliest arrival, each with the acceleration the rows allow over the velocity box
 * that also holds the start velocity. Plans into ax->out; returns the arrival time.
 */
float traj_box_limits(const struct row *r, int n, const struct axes *ax, float ca, float sa,
                      uint32_t *flags)
{
	const float vtop = minf(traj_rows_top(r, n, ca, sa), ax->cap);
	float best_t = INFINITY, best_a = 0.0f, best_d = 0.0f, best_v = 0.0f;

	for (int k = 0; k < TRAJ_SPEED_STEPS; k++) {
		const float v = vtop * speed_frac[k];
		const float wx = maxf(v * ca, fabsf(ax->v0[0]));
		const float wy = ax->n > 1 ? maxf(v * sa, fabsf(ax->v0[1])) : 0.0f;
		const float acc = traj_rows_acc(r, n, ca, sa, wx, wy);
		if (!(acc > 0.0f) || !(v > 0.0f))
			continue;
		const float dec = ax->stop ? maxf(traj_rows_stop(r, n, ca, sa, wx, wy), acc) : acc;
		const float t = axes_time(ax, ca, sa, acc, dec, v);
		if (t < best_t) {
			best_t = t;
			best_a = acc;
			best_d = dec;
			best_v = v;
		}
	}
	if (!(best_t < INFINITY)) { /* the start velocity leaves no room */
		*flags |= TRAJ_F_BEYOND_ENVELOPE;
		best_a = maxf(0.1f * traj_rows_acc(r, n, ca, sa, 0.0f, 0.0f), ACC_FLOOR);
		best_d = best_a;
		best_v = maxf(0.5f * vtop, ACC_FLOOR);
	}
	return axes_time(ax, ca, sa, best_a, best_d, best_v);
}

/*
 * x and y. From rest: the share of the straight line, so both profiles are the same in time
 * and the acceleration is along (speeding up) or against (stopping) the velocity throughout.
 * Moving: alpha in (0, pi/2) by bisection until both arrive together (the earliest kept), with
 * the stopping acceleration the same as the speeding-up one.
 */
float traj_box_plan(struct traj *tr, const struct row *r, int n, struct axes *ax)
{
	struct traj_1d best[2], cur[2];
	float lo = 0.0f, hi = 0.5f * PI_F, best_t = INFINITY, best_alpha = 0.0f;
	uint32_t best_flags = 0;

	if (ax->stop) {
		const float dx = fabsf(ax->goal[0] - ax->p0[0]),
		            dy = fabsf(ax->goal[1] - ax->p0[1]);
		const float dist = sqrtf(dx * dx + dy * dy);
		ax->out[0] = &tr->axis[0];
		ax->out[1] = &tr->axis[1];
		tr->alpha_rad = atan2f(dy, dx);
		return traj_box_limits(r, n, ax, dx / dist, dy / dist, &tr->flags);
	}
	ax->out[0] = &cur[0];
	ax->out[1] = &cur[1];
	for (int it = 0; it < TRAJ_ALPHA_ITERS + 2; it++) {
		/* first the two ends (an axis that does not move gets nothing), then bisection */
		const float alpha = it == 0 ? 0.0f : it == 1 ? 0.5f * PI_F : 0.5f * (lo + hi);
		const float ca = it == 1 ? 0.0f : cosf(alpha);
		const float sa = it == 0 ? 0.0f : sqrtf(maxf(1.0f - ca * ca, 0.0f));
		uint32_t flags = 0;
		const float t = traj_box_limits(r, n, ax, ca, sa, &flags);
		if (t < best_t) {
			best_t = t;
			best_alpha = alpha;
			best_flags = flags;
			best[0] = cur[0];
			best[1] = cur[1];
		}
		if (it >= 2) {
			const float tx = traj_1d_duration(&cur[0]), ty = traj_1d_duration(&cur[1]);
			if (tx > ty)
				hi = alpha; /* x needs a larger share */
			else
				lo = alpha;
		}
	}
	tr->axis[0] = best[0];
	tr->axis[1] = best[1];
	tr->alpha_rad = best_alpha;
	tr->flags |= best_flags;
	return best_t;
}
