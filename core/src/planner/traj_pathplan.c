/*
 * traj_pathplan.c - plans on a path (docs/trajectory.md, "Paths" and "The heading swing"):
 * traj_plan_path through intermediate poses without stopping, the straight move whose heading
 * swings toward the robot's diagonal and back, the arc for a move that turns (docs/trajectory.md
 * "An arc for a turning move"), and re-timing a path plan from its reference.
 * Single precision, fixed sizes, no allocation.
 */
#include "omni4/core/planner/traj.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#include "traj_int.h"

/* Fractions of the length over which the heading swings to the best one and back. */
#define SWING_FRACS 2
static const float swing_frac[SWING_FRACS] = {0.25f, 0.45f};
#define VIA_MIN_M 0.02f /* the start velocity's corner: at least this far ahead */
/* The arc of a turning move from rest: its two shapes (the tangent's share k of the turn, the
 * heading's share lin linear in s) by a compass search in [ARC_K_MIN, 1] x [0, 1], from
 * (ARC_K0, 1) with steps ARC_STEP0 halved when no neighbour is sooner, ARC_EVALS timings in
 * all (docs/trajectory.md "An arc for a turning move"). */
#define ARC_EVALS 4
#define ARC_K0 0.4f
#define ARC_K_MIN (-0.2f)
#define ARC_STEP0 0.2f
/* A turn smaller than this is made over the first or the last SMALL_TURN_FRAC of a straight
 * move alone (no arc: one would hardly bend). */
#define SMALL_TURN_RAD 0.2f
#define SMALL_TURN_FRAC 0.1f
#define TURN_RUN_M 8.0f /* a long move's turns onto and off the diagonal: over this [m] */

/* The heading nearest th with the robot's diagonal along the direction dir (the envelope is
 * widest there: all four wheels push). */
static float diagonal_heading(float dir, float th)
{
	const float q = 0.5f * PI_F;

	return dir - 0.25f * PI_F + q * floorf((th - dir + 0.25f * PI_F) / q + 0.5f);
}

static void take_path(struct traj *tr, const struct traj_path *pa, float t)
{
	tr->path = *pa;
	tr->on_path = 1;
	tr->pre_s = 0.0f;
	tr->duration_s = t;
	tr->t_s = 0.0f;
	tr->flags = 0;
	tr->alpha_rad = 0.0f;
	for (int i = 0; i < 3; i++)
		traj_1d_hold(&tr->axis[i], pa->goal[i]);
}

/* Times cand (its grid) from the start at speed v0 along it (a timed path keeps inside the
 * envelope: flags 0); kept in best if it wins over the best so far (traj_sooner). */
static void try_path(const struct traj *tr, struct traj_path *cand, float v0,
                     struct traj_path *best, float *best_t, uint32_t *best_f, bool *found)
{
	const float t = traj_topp(&tr->c, cand, 0.0f, v0);

	if (traj_sooner(t, 0u, *best_t, *best_f)) {
		*best_f = 0u;
		*best_t = t;
		*best = *cand;
		*found = true;
	}
}

static bool arc_in_box(float k, float lin)
{
	return k >= ARC_K_MIN && k <= 1.0f && lin >= 0.0f && lin <= 1.0f;
}

/* One arc shape timed (arc_search); INFINITY if it has none. */
static float arc_time(const struct traj *tr, const float start[3], const float goal[3], float k,
                      float lin, struct traj_path *cand)
{
	if (traj_path_arc(cand, start, goal, k, lin))
		return INFINITY;
	return traj_topp(&tr->c, cand, 0.0f, 0.0f);
}

/* The arc's shapes (k, lin) by a compass search of ARC_EVALS timings: each round moves to the
 * first of the four neighbours at the step (inside the box) that is sooner, or halves the
 * step. The soonest is kept in best if it wins (traj_sooner). */
static void arc_search(const struct traj *tr, const float start[3], const float goal[3],
                       struct traj_path *best, float *best_t, uint32_t *best_f, bool *found)
{
	struct traj_path cand, here;
	float k = ARC_K0, lin = 1.0f, step = ARC_STEP0;
	float t = arc_time(tr, start, goal, k, lin, &here);
	int n = 1;

	while (n < ARC_EVALS) {
		const float nb[4][2] = {
		    {k + step, lin}, {k - step, lin}, {k, lin + step}, {k, lin - step}};
		bool moved = false;
		for (int q = 0; q < 4 && n < ARC_EVALS && !moved; q++) {
			if (!arc_in_box(nb[q][0], nb[q][1]))
				continue;
			n++;
			const float tc = arc_time(tr, start, goal, nb[q][0], nb[q][1], &cand);
			if (tc < t) {
				t = tc;
				k = nb[q][0];
				lin = nb[q][1];
				here = cand;
				moved = true;
			}
		}
		if (!moved)
			step *= 0.5f;
	}
	if (traj_sooner(t, 0u, *best_t, *best_f)) {
		*best_f = 0u;
		*best_t = t;
		*best = here;
		*found = true;
	}
}

float traj_line_paths_try(struct traj *tr, const struct traj_ref *from, const float goal[3],
                          float v0)
{
	struct traj_path base, cand, best;
	const float wp[1][3] = {{goal[0], goal[1], goal[2]}};
	float best_t = tr->duration_s;
	uint32_t best_f = tr->flags;
	bool found = false;

	if (traj_path_build(&base, from->pose, wp, 1, 0.0f, NULL))
		return best_t;
	const float dir = base.pc[base.n_pieces - 1].dir0_rad;
	const float th0 = base.knot_th[0], th1 = base.knot_th[base.n_knots - 1];
	const float mids[2] = {diagonal_heading(dir, th0), diagonal_heading(dir, th1)};
	const bool small = fabsf(th1 - th0) < SMALL_TURN_RAD;
	/* a turning move from rest gets the arc's search, the others the heading swings */
	const bool arcs = !small && !(v0 > TRAJ_IDLE_VEL);
	for (int m = 0; !arcs && m < 2 * SWING_FRACS + 1; m++) {
		const int which = m == 0 ? 0 : (m - 1) / SWING_FRACS;
		const float f = m == 0 ? 0.0f : swing_frac[(m - 1) % SWING_FRACS];
		if (which == 1 && fabsf(mids[1] - mids[0]) < 1e-4f)
			break;
		cand = base;
		traj_path_swing(&cand, mids[which], f, f);
		try_path(tr, &cand, v0, &best, &best_t, &best_f, &found);
	}
	/* A long move turns onto the diagonal over its first TURN_RUN_M and off it over its last:
	 * swung over a quarter of the length, the heading would hold the robot off its fastest
	 * heading for tens of metres. */
	const float f_run = TURN_RUN_M / maxf(base.len_m, 1e-3f);
	/* the diagonal nearest the start's heading, the goal's, and halfway: a large turn shared
	 * between the speed-up and the brake */
	const float runs[3] = {mids[0], mids[1], diagonal_heading(dir, 0.5f * (th0 + th1))};
	for (int q = 0; f_run < swing_frac[0] && q < 3; q++) {
		if ((q == 1 && fabsf(runs[1] - runs[0]) < 1e-4f) ||
		    (q == 2 &&
		     (fabsf(runs[2] - runs[0]) < 1e-4f || fabsf(runs[2] - runs[1]) < 1e-4f)))
			continue;
		cand = base;
		traj_path_swing(&cand, runs[q], f_run, f_run);
		try_path(tr, &cand, v0, &best, &best_t, &best_f, &found);
	}
	const float g3[3] = {goal[0], goal[1], th1};
	for (int m = 0; small && th1 != th0 && m < 2; m++) {
		/* a small turn (often the estimate's few mrad): at the end, or the start, alone; */
		/* over the whole length it would pay the turn's Coulomb friction all the way */
		cand = base;
		traj_path_swing(&cand, m ? th1 : th0, m ? SMALL_TURN_FRAC : 0.0f,
		                m ? 0.0f : SMALL_TURN_FRAC);
		try_path(tr, &cand, v0, &best, &best_t, &best_f, &found);
	}
	if (arcs)
		arc_search(tr, from->pose, g3, &best, &best_t, &best_f, &found);
	if (found)
		take_path(tr, &best, best_t);
	return best_t;
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
	const float tau = tr->t_s - cand.grid_t[lo], a = cand.grid_a[lo];
	const float s = cand.grid_s[lo] + (cand.grid_v[lo] + 0.5f * a * tau) * tau;
	const float v = maxf(cand.grid_v[lo] + a * tau, 0.0f);
	const float t = traj_topp(&tr->c, &cand, minf(s, cand.grid_s[lo + 1]), v);
	if (!(t < INFINITY))
		return -ERANGE; /* e.g. faster there than new limits allow: the caller plans anew */
	take_path(tr, &cand, t);
	return 0;
}

/* The start velocity's corner: ahead along it, about its stopping distance at 1.5 m/s^2. */
static bool via_point(const struct traj_ref *from, const float first[3], float via[2])
{
	const float vx = from->vel[0], vy = from->vel[1];
	const float sp = sqrtf(vx * vx + vy * vy);
	const float dx = first[0] - from->pose[0], dy = first[1] - from->pose[1];
	const float len = sqrtf(dx * dx + dy * dy);

	if (!(sp > TRAJ_IDLE_VEL) || !(len > 0.0f))
		return false;
	if (fabsf(vx * dy - vy * dx) < 1e-3f * sp * len && vx * dx + vy * dy > 0.0f)
		return false; /* along the first leg already */
	float k = sp * sp / 3.0f;
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
	const bool has_via = via_point(from, poses[0], via);
	if (traj_path_build(&pa, from->pose, poses, n, radius_m, has_via ? via : NULL))
		return -EINVAL;
	const float v0 = sqrtf(from->vel[0] * from->vel[0] + from->vel[1] * from->vel[1]);
	const float t = traj_topp(&tr->c, &pa, 0.0f, v0);
	if (!(t < INFINITY))
		return -ERANGE;
	take_path(tr, &pa, t);
	return 0;
}
