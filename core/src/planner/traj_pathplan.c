/*
 * traj_pathplan.c - plans on a path (docs/trajectory.md, "Paths"): traj_plan_path through
 * intermediate poses without stopping, and re-timing a path plan from its reference.
 * Single precision, fixed sizes, no allocation.
 */
#include "omni4/core/planner/traj.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#include "traj_int.h"

#define VIA_MIN_M 0.02f /* the start velocity's corner: at least this far ahead */
static void take_path(struct traj *tr, const struct traj_path *pa, float t)
{
	tr->path = *pa;
	tr->on_path = 1;
	tr->pre_s = 0.0f;
	tr->duration_s = t;
	tr->t_s = 0.0f;
	for (int i = 0; i < 3; i++)
		traj_1d_hold(&tr->axis[i], pa->goal[i]);
}

int traj_path_retime(struct traj *tr)
{
	struct traj_path cand = tr->path;
	struct traj_ref now;

	traj_path_eval(&tr->path, tr->t_s, &now);
	if (!(tr->t_s < tr->duration_s))
		return 0;
	int lo = 0;
	while (lo < cand.n_grid - 1 && !(tr->t_s < cand.grid_t[lo + 1]))
		lo++;
	float s, v;
	traj_grid_at(&cand, lo, tr->t_s - cand.grid_t[lo], &s, &v);
	const float t = traj_topp_retime(&tr->c, &cand, s, v);
	if (!(t < INFINITY))
		return -ERANGE; /* e.g. faster there than new limits allow: the caller plans anew */
	take_path(tr, &cand, t);
	return 0;
}

/* The start velocity's corner: ahead along it by about its stopping distance at the
 * envelope's acceleration against it from rest (traj_envelope, robot frame). */
static bool via_point(const struct traj *tr, const struct traj_ref *from, const float first[3],
                      float via[2])
{
	const float vx = from->vel[0], vy = from->vel[1];
	const float sp = sqrtf(vx * vx + vy * vy);
	const float dx = first[0] - from->pose[0], dy = first[1] - from->pose[1];
	const float len = sqrtf(dx * dx + dy * dy);

	if (!(sp > TRAJ_IDLE_VEL) || !(len > 0.0f))
		return false;
	if (fabsf(vx * dy - vy * dx) < 1e-3f * sp * len && vx * dx + vy * dy > 0.0f)
		return false; /* along the first leg already */
	const float c = cosf(from->pose[2]), s = cosf(from->pose[2] - 0.5f * PI_F);
	const float back[2] = {-(c * vx + s * vy) / sp, -(-s * vx + c * vy) / sp};
	float acc = 0.0f, top;
	if (traj_envelope(tr, back, 0.0f, &acc, &top) || !(acc > 0.0f))
		return false;
	float k = sp * sp / (2.0f * acc);
	k = minf(maxf(k, VIA_MIN_M), 0.5f * len);
	via[0] = from->pose[0] + vx / sp * k;
	via[1] = from->pose[1] + vy / sp * k;
	return true;
}

int traj_plan_path(struct traj *tr, const struct traj_ref *from, const float (*poses)[3], int n,
                   float radius_m)
{
	struct traj_path pa;
	float via[2];

	if (n < 1 || n > TRAJ_PATH_MAX || !(radius_m > 0.0f) || !isfinite(radius_m))
		return -EINVAL;
	for (int i = 0; i < 3; i++)
		if (!isfinite(from->pose[i]) || !isfinite(from->vel[i]))
			return -EINVAL;
	for (int k = 0; k < n; k++)
		for (int i = 0; i < 3; i++)
			if (!isfinite(poses[k][i]))
				return -EINVAL;
	if (fabsf(from->vel[2]) > TRAJ_IDLE_VEL)
		return -ERANGE; /* the heading's rate at the start: a path starts with none */
	const bool has_via = via_point(tr, from, poses[0], via);
	if (traj_path_build(&pa, from->pose, poses, n, radius_m, has_via ? via : NULL))
		return -EINVAL;
	const float v0 = sqrtf(from->vel[0] * from->vel[0] + from->vel[1] * from->vel[1]);
	const float t = traj_topp(&tr->c, &pa, 0.0f, v0);
	if (!(t < INFINITY))
		return -ERANGE;
	take_path(tr, &pa, t);
	return 0;
}
