/*
 * traj_curve.c - a move as one curve in (x, y, theta) (docs/trajectory.md, "One curve"): a
 * cubic Bezier from the start to the goal whose first tangent follows the start's velocity,
 * timed by the path timing (traj_topp.c: every wheel's rows at each grid point), its free
 * control points chosen by a bounded Nelder-Mead search on the timed duration; a moving
 * start also as the brake prelude and the curve from rest where it stops. Single precision,
 * fixed sizes, no allocation.
 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

#define DIMS_MAX 6      /* free parameters: from rest 6, moving 4 */
#define SPEED_MIN 1e-4f /* [m/s] (the turn rate at the wheels' distance): a slower start rests */
#define OFFSET_MAX 0.6f
/* The search's estimates: a timing on a grid of SEARCH_GRID segments, over a limit by at most
 * SEARCH_OVER taken as it is; the shape kept is timed on the full grid and checked (over 100
 * random moves from rest with 40 timings: 2.5 times cheaper than the full checked timing for
 * plans 0.3 % later on average; moving starts 1.2 % later). */
#define SEARCH_GRID 32
#define SEARCH_OVER 0.01f /* a control point's offset across the chord, in chord lengths */

/* The search's problem: the start, the goal, and the parameters' box. */
struct curve_prob {
	const struct traj *tr;
	float p0[3], g[3], v0[3]; /* start pose, goal (heading unwrapped), start velocity */
	float d[2], n[2];         /* the chord and its normal (the chord's length) */
	float dm;                 /* the wheels' mean distance from the centre [m] */
	bool moving;              /* the first control point follows the start velocity */
	int dims;
	float lo[DIMS_MAX], hi[DIMS_MAX];
};

/*
 * The control points of parameters x. From rest, x = (f1, f2, o1, o2, a1, a2): P1 = P0 + f1 d +
 * o1 n with the heading P0's + a1, P2 = G - f2 d + o2 n with the heading G's - a2. Moving,
 * x = (k, f2, o2, a2): P1 = P0 + k v0 (k [s]: the first tangent along the start velocity, its
 * turn rate included).
 */
static void points(const struct curve_prob *pr, const float *x, float P[4][3])
{
	const float f2 = x[1], o2 = pr->moving ? x[2] : x[3], a2 = pr->moving ? x[3] : x[5];

	for (int i = 0; i < 3; i++) {
		P[0][i] = pr->p0[i];
		P[3][i] = pr->g[i];
		if (pr->moving)
			P[1][i] = pr->p0[i] + x[0] * pr->v0[i];
	}
	if (!pr->moving) {
		for (int i = 0; i < 2; i++)
			P[1][i] = pr->p0[i] + x[0] * pr->d[i] + x[2] * pr->n[i];
		P[1][2] = pr->p0[2] + x[4];
	}
	for (int i = 0; i < 2; i++)
		P[2][i] = pr->g[i] - f2 * pr->d[i] + o2 * pr->n[i];
	P[2][2] = pr->g[2] - a2;
}

/* The path of control points P into pa, its progress s over the control polygon's length with
 * the heading weighted by the wheels' distance (about the wheels' travel); false if none. */
static bool curve_path(struct traj_path *pa, const float P[4][3], float dm)
{
	float L = 0.0f;

	for (int k = 0; k < 3; k++) {
		const float dx = P[k + 1][0] - P[k][0], dy = P[k + 1][1] - P[k][1];
		const float dt = dm * (P[k + 1][2] - P[k][2]);
		L += sqrtf(dx * dx + dy * dy + dt * dt);
	}
	if (!(L > TRAJ_IDLE_POS))
		return false;
	*pa = (struct traj_path){.curve = 1, .len_m = L, .n_poses = 1, .pass_s = {L}};
	for (int k = 0; k < 4; k++)
		for (int i = 0; i < 3; i++)
			pa->bez[k][i] = P[k][i];
	for (int i = 0; i < 3; i++)
		pa->goal[i] = P[3][i];
	return true;
}

/* The duration of parameters x (INFINITY: none), pa its timed path (checked inside the
 * envelope). */
static float cost(const struct curve_prob *pr, const float *x, struct traj_path *pa, float over,
                  int grid)
{
	float P[4][3];

	points(pr, x, P);
	if (!curve_path(pa, P, pr->dm))
		return INFINITY;
	/* moving: B'(0) = 3 k v0 per unit of u = s / L, so s'(0) = L / (3 k) */
	const float v = pr->moving ? pa->len_m / (3.0f * x[0]) : 0.0f;
	return traj_topp_within(&pr->tr->c, pa, 0.0f, v, over, grid);
}

/* One evaluation inside the box: its duration into *f. (The timing's first pass alone, as an
 * estimate, is about 1.7 times cheaper, but a search on it finds shapes whose checked timing
 * is later: 40 estimates gave plans 1.5 % later than 40 checked timings over 60 random moves,
 * and 80 estimates later still.) */
static void eval(const struct curve_prob *pr, float *x, float *f, int *used)
{
	struct traj_path pa;

	for (int i = 0; i < pr->dims; i++)
		x[i] = x[i] < pr->lo[i] ? pr->lo[i] : (x[i] > pr->hi[i] ? pr->hi[i] : x[i]);
	*f = cost(pr, x, &pa, SEARCH_OVER, SEARCH_GRID);
	++*used;
}

/* Simplex vertices sorted by their durations, the best first. */
static void sort_simplex(int n, float xs[][DIMS_MAX], float *fs)
{
	for (int a = 1; a <= n; a++)
		for (int b = a; b > 0 && fs[b] < fs[b - 1]; b--) {
			const float t = fs[b];
			fs[b] = fs[b - 1];
			fs[b - 1] = t;
			for (int i = 0; i < n; i++) {
				const float q = xs[b][i];
				xs[b][i] = xs[b - 1][i];
				xs[b - 1][i] = q;
			}
		}
}

/* Bounded Nelder-Mead (reflection, expansion, contraction, shrink) from x with the initial
 * steps step, at most evals timings; the final simplex into xs, the best first. */
static void search(const struct curve_prob *pr, const float *x, const float *step, int evals,
                   float xs[DIMS_MAX + 1][DIMS_MAX])
{
	const int n = pr->dims;
	float fs[DIMS_MAX + 1], xr[DIMS_MAX], xe[DIMS_MAX], c[DIMS_MAX];
	int used = 0;

	for (int k = 0; k <= n; k++) {
		for (int i = 0; i < n; i++)
			xs[k][i] = x[i] + (k == i + 1 ? step[i] : 0.0f);
		eval(pr, xs[k], &fs[k], &used);
	}
	while (used < evals) {
		sort_simplex(n, xs, fs);
		float fr, fe;
		for (int i = 0; i < n; i++) {
			c[i] = 0.0f;
			for (int k = 0; k < n; k++)
				c[i] += xs[k][i] / (float)n;
			xr[i] = 2.0f * c[i] - xs[n][i];
		}
		eval(pr, xr, &fr, &used);
		if (fr < fs[0]) { /* expand */
			for (int i = 0; i < n; i++)
				xe[i] = 3.0f * c[i] - 2.0f * xs[n][i];
			eval(pr, xe, &fe, &used);
			const bool e = fe < fr;
			for (int i = 0; i < n; i++)
				xs[n][i] = e ? xe[i] : xr[i];
			fs[n] = e ? fe : fr;
			continue;
		}
		if (fr < fs[n - 1]) {
			for (int i = 0; i < n; i++)
				xs[n][i] = xr[i];
			fs[n] = fr;
			continue;
		}
		/* contract toward the better of the worst and its reflection */
		const bool out = fr < fs[n];
		for (int i = 0; i < n; i++)
			xe[i] = c[i] + 0.5f * ((out ? xr[i] : xs[n][i]) - c[i]);
		eval(pr, xe, &fe, &used);
		if (fe < (out ? fr : fs[n])) {
			for (int i = 0; i < n; i++)
				xs[n][i] = xe[i];
			fs[n] = fe;
			continue;
		}
		for (int k = 1; k <= n && used < evals; k++) { /* shrink toward the best */
			for (int i = 0; i < n; i++)
				xs[k][i] = xs[0][i] + 0.5f * (xs[k][i] - xs[0][i]);
			eval(pr, xs[k], &fs[k], &used);
		}
	}
	sort_simplex(n, xs, fs);
}

/* The curve from `from` to goal (heading unwrapped from the start's), searched, then timed
 * and checked into pa; its duration or INFINITY. */
static float curve_from(const struct traj *tr, const struct traj_ref *from, const float goal[3],
                        int evals, struct traj_path *pa)
{
	struct curve_prob pr = {.tr = tr};
	float x[DIMS_MAX], step[DIMS_MAX];

	for (int i = 0; i < 3; i++) {
		pr.p0[i] = from->pose[i];
		pr.v0[i] = from->vel[i];
		pr.g[i] = goal[i];
	}
	for (int i = 0; i < 2; i++)
		pr.d[i] = pr.g[i] - pr.p0[i];
	pr.n[0] = -pr.d[1];
	pr.n[1] = pr.d[0];
	for (int j = 0; j < tr->c.wh.n; j++)
		pr.dm += fabsf(tr->c.wh.row[j][2]) / (float)tr->c.wh.n; /* eq 2's d_j */
	const float dth = pr.g[2] - pr.p0[2], dm = pr.dm;
	const float span = sqrtf(pr.d[0] * pr.d[0] + pr.d[1] * pr.d[1] + dm * dm * dth * dth);
	const float speed =
	    sqrtf(pr.v0[0] * pr.v0[0] + pr.v0[1] * pr.v0[1] + dm * dm * pr.v0[2] * pr.v0[2]);
	pr.moving = speed > SPEED_MIN;
	/* the start: a third of the way each (the straight line, the heading linear) */
	if (pr.moving) {
		const float k0 = span / (3.0f * speed);
		const float x0[4] = {k0, 1.0f / 3.0f, 0.0f, dth / 3.0f};
		const float st[4] = {0.5f * k0, 0.2f, 0.2f, 0.3f};
		const float lo[4] = {1e-3f * k0, 0.0f, -OFFSET_MAX, -PI_F};
		const float hi[4] = {10.0f * k0, 1.0f, OFFSET_MAX, PI_F};
		pr.dims = 4;
		for (int i = 0; i < 4; i++) {
			x[i] = x0[i], step[i] = st[i], pr.lo[i] = lo[i], pr.hi[i] = hi[i];
		}
	} else {
		const float x0[6] = {1.0f / 3.0f, 1.0f / 3.0f, 0.0f, 0.0f, dth / 3.0f, dth / 3.0f};
		const float st[6] = {0.2f, 0.2f, 0.2f, 0.2f, 0.3f, 0.3f};
		const float lo[6] = {0.0f, 0.0f, -OFFSET_MAX, -OFFSET_MAX, -PI_F, -PI_F};
		const float hi[6] = {1.0f, 1.0f, OFFSET_MAX, OFFSET_MAX, PI_F, PI_F};
		pr.dims = 6;
		for (int i = 0; i < 6; i++) {
			x[i] = x0[i], step[i] = st[i], pr.lo[i] = lo[i], pr.hi[i] = hi[i];
		}
	}
	float xs[DIMS_MAX + 1][DIMS_MAX];
	search(&pr, x, step, evals, xs);
	for (int k = 0; k <= pr.dims; k++) { /* the best vertex that the full timing takes */
		const float t = cost(&pr, xs[k], pa, 1e-5f, TRAJ_GRID);
		if (t < INFINITY)
			return t;
	}
	return INFINITY;
}

static bool finite3(const float v[3])
{
	return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

int traj_plan_curve(struct traj *tr, const struct traj_ref *from, const float goal[3], int evals)
{
	static const struct traj_ref rest0;

	if (!finite3(from->pose) || !finite3(from->vel) || !finite3(goal) ||
	    evals < CURVE_EVALS_MIN || evals > CURVE_EVALS_MAX)
		return -EINVAL;
	const float g[3] = {goal[0], goal[1],
	                    from->pose[2] + model_wrap_pi_f32(goal[2] - from->pose[2])};
	const bool still = traj_1d_idle(from->pose[0], from->vel[0], g[0]) &&
	                   traj_1d_idle(from->pose[1], from->vel[1], g[1]) &&
	                   traj_1d_idle(from->pose[2], from->vel[2], g[2]);
	if (still) {
		traj_reset(tr, g);
		return 0;
	}
	/* moving: half the timings each to the curve from the start and to the brake's */
	const bool moving = fabsf(from->vel[0]) >= TRAJ_IDLE_VEL ||
	                    fabsf(from->vel[1]) >= TRAJ_IDLE_VEL ||
	                    fabsf(from->vel[2]) >= TRAJ_IDLE_VEL;
	struct traj_path pa, pb;
	const float t_a = curve_from(tr, from, g, moving ? evals / 2 : evals, &pa);
	float t_pre = INFINITY, t_b = INFINITY;
	struct traj_1d pre[3];
	struct traj_ref rest = rest0;
	if (moving) {
		t_pre = traj_brake_prelude(tr, from, pre, rest.pose);
		if (t_pre < INFINITY) {
			const float gb[3] = {g[0], g[1],
			                     rest.pose[2] + model_wrap_pi_f32(g[2] - rest.pose[2])};
			t_b = t_pre + curve_from(tr, &rest, gb, evals - evals / 2, &pb);
		}
	}
	if (!(t_a < INFINITY) && !(t_b < INFINITY))
		return -ERANGE;
	const bool braked = t_b < t_a;
	tr->path = braked ? pb : pa;
	tr->on_path = 1;
	tr->pre_s = braked ? t_pre : 0.0f;
	for (int i = 0; i < 3; i++) {
		if (braked)
			tr->pre[i] = pre[i];
		traj_1d_hold(&tr->axis[i], tr->path.goal[i]);
	}
	tr->duration_s = braked ? t_b : t_a;
	tr->t_s = 0.0f;
	tr->flags = 0;
	tr->alpha_rad = 0.0f;
	return 0;
}
