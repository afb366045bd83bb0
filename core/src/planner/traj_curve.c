/*
 * traj_curve.c - a move as one curve (docs/trajectory.md, "One curve"): a cubic Bezier in (x,
 * y) from the start to the goal whose first tangent follows the start's velocity, the heading
 * a cubic Bezier over a span of the way (held outside it) or a cruise at the heading where the
 * robot is fastest along the chord; timed by the path timing (traj_topp.c: every wheel's rows
 * at each grid point), its free parameters chosen by a bounded Nelder-Mead search on estimated
 * timings, the shape kept timed in full and checked; a moving start also as the brake prelude
 * and the curve from rest where it stops. Single precision, fixed sizes, no allocation.
 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

#define DIMS_MAX 12     /* a shape's parameters (decode) */
#define SPEED_MIN 1e-4f /* [m/s] (the turn rate at the wheels' distance): a slower start rests */
#define OFFSET_MAX 0.6f /* a control point's offset across the chord, in chord lengths */
/* The search's estimates: a timing on a grid of SEARCH_GRID segments, over a limit by at most
 * SEARCH_OVER taken as it is; the shape kept is timed on the full grid and checked (over 100
 * random moves from rest with 40 timings: 2.5 times cheaper than the full checked timing for
 * plans 0.3 % later on average; moving starts 1.2 % later). */
#define SEARCH_GRID 32
#define SEARCH_OVER 0.01f
/* From rest with a turn (over SEED_TURN), the search starts at the soonest of SEEDS shapes (the
 * heading turning early, late or at both ends; the way bulging either side), and the way may
 * start after the heading has turned a share of up to WAY_LATE_MAX of the progress (a turn in
 * place first: the translation's Coulomb friction not paid while it turns). */
#define SEEDS 6
#define SEED_TURN 0.05f /* [rad] */
#define WAY_LATE_MAX 0.5f
/* Then the finish (estimated as the search does, the soonest timed in full): the heading's
 * turn over a part of the way only, at the start or at the end, over these shares (held
 * otherwise, where its Coulomb friction would cost the whole way: a start a few mrad off the
 * goal's heading) ... */
#define SPANS 4
static const float spans[SPANS][2] = {{0.0f, 0.05f}, {1.0f, 0.05f}, {0.0f, 0.2f}, {1.0f, 0.2f}};
#define SPAN_SHORT_M 1.0f /* [m] the short ones at most this long: a long move turns while slow */
#define SPAN_BREAKS 3 /* grid points inside each of the heading's turns (a short one is sharp) */
/* ... and a cruise at the two fastest headings along the chord, turning to it and back over
 * these shares of the way */
#define CRUISE_SHARES 2
static const float cruise_share[CRUISE_SHARES] = {0.03f, 0.1f};
#define CRUISES (2 * CRUISE_SHARES)
#define CRUISE_HEADINGS 16 /* headings a turn whose top speeds along the chord are compared */
#define CRUISE_REFINE 8    /* golden sections of the cruise's heading */
#define CRUISE_GAIN 1.02f  /* a cruise only at a heading this much faster than the ends' */
#define TOP_TIE 1.001f     /* top speeds this close are one */

/* The search's problem: the start, the goal, and the parameters' box. */
struct curve_prob {
	const struct traj *tr;
	float p0[3], g[3], v0[3]; /* start pose, goal (heading unwrapped), start velocity */
	float d[2], n[2];         /* the chord and its normal (the chord's length) */
	float dm;                 /* the wheels' mean distance from the centre [m] */
	float reach;              /* the chord and the turn at dm: |(d, dm dtheta)| [m] */
	bool moving;              /* the first control point follows the start velocity */
	bool turning;             /* moving with a turn rate: the heading turns from the start */
	int dims, keep[DIMS_MAX]; /* the searched parameters: the shape's entries keep[0..dims) */
	float base[DIMS_MAX];     /* the shape's other entries */
	float lo[DIMS_MAX], hi[DIMS_MAX];
	float cruise[2]; /* the headings fastest along the chord (NaN: none) */
};

/* A curve's shape: its control points in (x, y), its heading's two turns (cubic Beziers in
 * the share of their spans, span[q] from and to as shares of the progress; held outside). */
struct shape {
	float P[4][2], H[2][4];
	float span[2][2];
	float xspan[2]; /* the way's span: shares of the progress */
	float k;        /* moving: P1 = P0 + k v0 [s] */
};

/*
 * The shape of parameters x: [k moving | f1], f2, o1, o2, a1, a2, pos, wd, psi, w, xa, xb. From
 * rest P1 = P0 + f1 d + o1 n; moving P1 = P0 + k v0 (the first tangent along the start
 * velocity, k [s]); P2 = G - f2 d + o2 n. The way runs over the shares [xa, xb] of the progress
 * (from rest; moving: all of it), still outside; where it starts after the start (ends before
 * the end) P1 = P0 (P2 = G): its tangent starts (ends) at 0. The heading (psi NaN) turns once,
 * over a share wd of the progress starting at (1 - wd) pos, its control points theta0,
 * theta0 + a1, theta_goal - a2, theta_goal; a1 (a2) counts only where the span starts at the
 * start (ends at the end):
 * inside the path the heading starts (ends) its turn at rate 0. Or it turns to psi over the
 * first share w, holds it, and turns to theta_goal over the last w (a cruise at a heading
 * where the robot is faster). Moving, a1 is the start's rate: d theta / du = 3 a1 / w there,
 * du/dt = 1 / (3 k) (a turning start's span starts at the start).
 */
static void decode(const struct curve_prob *pr, const float *x, struct shape *sh)
{
	const float a = x[0], f2 = x[1], o1 = x[2], o2 = x[3], a1 = x[4], a2 = x[5];
	const float pos = pr->turning ? 0.0f : x[6], psi = x[8];
	const bool cruise = isfinite(psi);
	const float wd = cruise ? x[9] : x[7], th0 = pr->p0[2], thg = pr->g[2];

	const float xa = pr->moving ? 0.0f : x[10], xb = pr->moving ? 1.0f : x[11];
	const float in1 = xa > 0.0f ? 0.0f : 1.0f, in2 = xb < 1.0f ? 0.0f : 1.0f;

	sh->k = pr->moving ? a : 0.0f;
	sh->xspan[0] = xa;
	sh->xspan[1] = xb;
	for (int q = 0; q < 2; q++) {
		sh->P[0][q] = pr->p0[q];
		sh->P[1][q] = pr->moving ? pr->p0[q] + a * pr->v0[q]
		                         : pr->p0[q] + in1 * (a * pr->d[q] + o1 * pr->n[q]);
		sh->P[2][q] = pr->g[q] + in2 * (-f2 * pr->d[q] + o2 * pr->n[q]);
		sh->P[3][q] = pr->g[q];
	}
	const float ua = cruise ? 0.0f : (1.0f - wd) * pos, ub = ua + wd;
	const float e1 = pr->moving ? sh->k * wd * pr->v0[2] : (ua > 0.0f ? 0.0f : a1);
	const float mid = cruise ? psi : thg, e2 = cruise || ub >= 1.0f ? a2 : 0.0f;
	const float H[2][4] = {{th0, th0 + e1, cruise ? psi : thg - e2, mid},
	                       {mid, mid, thg - (cruise ? e2 : 0.0f), thg}};
	for (int q = 0; q < 2; q++)
		for (int i = 0; i < 4; i++)
			sh->H[q][i] = H[q][i];
	sh->span[0][0] = ua;
	sh->span[0][1] = ub;
	sh->span[1][0] = cruise ? 1.0f - wd : 1.0f;
	sh->span[1][1] = 1.0f;
}

/* The path of shape sh into pa, its progress s over the length of the control polygon in (x,
 * y, theta), the heading weighted by the wheels' distance (about the wheels' travel); false
 * if none. */
static bool curve_path(struct traj_path *pa, const struct curve_prob *pr, const struct shape *sh)
{
	float L = 0.0f;

	for (int k = 0; k < 3; k++) {
		const float dx = sh->P[k + 1][0] - sh->P[k][0], dy = sh->P[k + 1][1] - sh->P[k][1];
		const float ta = pr->dm * (sh->H[0][k + 1] - sh->H[0][k]);
		const float tb = pr->dm * (sh->H[1][k + 1] - sh->H[1][k]);
		L += sqrtf(dx * dx + dy * dy + ta * ta + tb * tb);
	}
	if (!(L > TRAJ_IDLE_POS))
		return false;
	*pa = (struct traj_path){.curve = 1,
	                         .len_m = L,
	                         .n_poses = 1,
	                         .pass_s = {L},
	                         .n_knots = 6 + 2 * SPAN_BREAKS,
	                         .bez_span = {sh->xspan[0], sh->xspan[1]},
	                         .goal = {pr->g[0], pr->g[1], pr->g[2]}};
	for (int k = 0; k < 4; k++)
		for (int i = 0; i < 2; i++)
			pa->bez[k][i] = sh->P[k][i];
	for (int q = 0; q < 2; q++) {
		for (int i = 0; i < 4; i++)
			pa->head[q][i] = sh->H[q][i];
		const float a = sh->span[q][0], b = sh->span[q][1];
		pa->knot_s[2 * q] = a * L;
		pa->knot_s[2 * q + 1] = b * L;
		for (int k = 1; k <= SPAN_BREAKS; k++) /* grid points inside the turns */
			pa->knot_s[3 + q * SPAN_BREAKS + k] =
			    (a + (b - a) * (float)k / (SPAN_BREAKS + 1)) * L;
	}
	pa->knot_s[4 + 2 * SPAN_BREAKS] = sh->xspan[0] * L;
	pa->knot_s[5 + 2 * SPAN_BREAKS] = sh->xspan[1] * L;
	return true;
}

/* The duration of shape x (INFINITY: none), pa its timed path, a timing over a limit by at
 * most over taken as it is, on a grid of grid segments. */
static float cost(const struct curve_prob *pr, const float *x, struct traj_path *pa, float over,
                  int grid)
{
	struct shape sh;

	decode(pr, x, &sh);
	if (!curve_path(pa, pr, &sh))
		return INFINITY;
	/* moving: B'(0) = 3 k v0 per unit of u = s / L, so s'(0) = L / (3 k) */
	const float v = pr->moving ? pa->len_m / (3.0f * sh.k) : 0.0f;
	return traj_topp_within(&pr->tr->c, pa, 0.0f, v, over, grid);
}

/* The shape of the searched parameters x into full. */
static void unpack(const struct curve_prob *pr, const float *x, float *full)
{
	for (int i = 0; i < DIMS_MAX; i++)
		full[i] = pr->base[i];
	for (int i = 0; i < pr->dims; i++)
		full[pr->keep[i]] = x[i];
}

/* One evaluation inside the box: its duration into *f. (The timing's first pass alone, as an
 * estimate, is about 1.7 times cheaper, but a search on it finds shapes whose checked timing
 * is later: 40 estimates gave plans 1.5 % later than 40 checked timings over 60 random moves,
 * and 80 estimates later still.) */
static void eval(const struct curve_prob *pr, float *x, float *f, int *used)
{
	struct traj_path pa;
	float full[DIMS_MAX];

	for (int i = 0; i < pr->dims; i++)
		x[i] = x[i] < pr->lo[i] ? pr->lo[i] : (x[i] > pr->hi[i] ? pr->hi[i] : x[i]);
	unpack(pr, x, full);
	*f = cost(pr, full, &pa, SEARCH_OVER, SEARCH_GRID);
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
	float fs[DIMS_MAX + 1], xr[DIMS_MAX], xe[DIMS_MAX], c[DIMS_MAX] = {0};
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

/* The top speed along the chord at heading th (traj_envelope's; -1 if none). */
static float top_at(const struct curve_prob *pr, float chord, float th)
{
	const float rel = chord - th, dir[2] = {cosf(rel), cosf(rel - 0.5f * PI_F)};
	float acc, top;

	return traj_envelope(pr->tr, dir, 0.0f, &acc, &top) ? -1.0f : top;
}

/* The headings at which the robot is fastest along the chord (out[0]) and next fastest
 * (out[1]), NaN where hardly faster than at the start's or the goal's heading: traj_envelope's top
 * speed at CRUISE_HEADINGS headings a turn from the middle one, the nearest of equal ones, then
 * refined by golden sections between its neighbours (the peak is sharp: Table III's robot 2.86 m/s
 * along its diagonal, 2.89 at 0.6 deg off it, 2.76 at 5 deg). */
static void cruise_headings(const struct curve_prob *pr, float out[2])
{
	const float chord = atan2f(pr->d[1], pr->d[0]), mid = 0.5f * (pr->p0[2] + pr->g[2]);
	const float step = 2.0f * PI_F / CRUISE_HEADINGS;
	float top_best[2] = {-1.0f, -1.0f}, psi[2] = {mid, mid};

	for (int k = 0; k < CRUISE_HEADINGS; k++) {
		/* headings from the middle one, nearest first, alternately either way */
		const float th = mid + (float)((k + 1) / 2) * step * (k % 2 ? 1.0f : -1.0f);
		const float top = top_at(pr, chord, th);
		const int q =
		    top > TOP_TIE * top_best[0] ? 0 : (top > TOP_TIE * top_best[1] ? 1 : -1);
		if (q < 0)
			continue;
		if (q == 0) {
			top_best[1] = top_best[0];
			psi[1] = psi[0];
		}
		top_best[q] = top;
		psi[q] = th;
	}
	for (int side = 0; side < 2; side++) {
		const float gr = 0.618034f;
		float a = psi[side] - step, b = psi[side] + step;
		float c = b - gr * (b - a), d = a + gr * (b - a);
		float fc = top_at(pr, chord, c), fd = top_at(pr, chord, d);
		for (int it = 0; it < CRUISE_REFINE; it++) {
			if (fc > fd) {
				b = d, d = c, fd = fc;
				c = b - gr * (b - a);
				fc = top_at(pr, chord, c);
			} else {
				a = c, c = d, fc = fd;
				d = a + gr * (b - a);
				fd = top_at(pr, chord, d);
			}
		}
		out[side] = maxf(fc, fd) > top_best[side] ? (fc > fd ? c : d) : psi[side];
		top_best[side] = maxf(top_best[side], maxf(fc, fd));
	}
	/* no cruise where the robot is hardly faster than at the start's or the goal's heading */
	const float top_ends = maxf(top_at(pr, chord, pr->p0[2]), top_at(pr, chord, pr->g[2]));
	for (int side = 0; side < 2; side++)
		if (!(top_best[side] > CRUISE_GAIN * top_ends))
			out[side] = NAN;
}

/* The problem's start, goal, chord and the wheels' mean distance into pr. */
static void curve_geometry(struct curve_prob *pr, const struct traj_ref *from, const float goal[3])
{
	const int nw = pr->tr->c.wh.n;

	for (int i = 0; i < 3; i++) {
		pr->p0[i] = from->pose[i];
		pr->v0[i] = from->vel[i];
		pr->g[i] = goal[i];
	}
	for (int i = 0; i < 2; i++)
		pr->d[i] = pr->g[i] - pr->p0[i];
	pr->n[0] = -pr->d[1];
	pr->n[1] = pr->d[0];
	for (int j = 0; j < nw; j++)
		pr->dm += fabsf(pr->tr->c.wh.row[j][2]) / (float)nw; /* eq 2's d_j */
	const float dth = pr->g[2] - pr->p0[2], dm = pr->dm, *d = pr->d;
	pr->reach = sqrtf(d[0] * d[0] + d[1] * d[1] + dm * dm * dth * dth);
}

/* The problem of the curve from `from` to goal (heading unwrapped from the start's) into pr,
 * the search's start x and first steps step. */
static void curve_setup(struct curve_prob *pr, const struct traj_ref *from, const float goal[3],
                        float *x, float *step)
{
	curve_geometry(pr, from, goal);
	const float dth = pr->g[2] - pr->p0[2], dm = pr->dm, *v = pr->v0;
	const float speed = sqrtf(v[0] * v[0] + v[1] * v[1] + dm * dm * v[2] * v[2]);
	pr->moving = speed > SPEED_MIN;
	pr->turning = pr->moving && fabsf(v[2]) >= TRAJ_IDLE_VEL;
	/* the start: a third of the way each (the straight line), the heading linear over the
	 * whole way (pos, wd: held in the search), the way over all of it */
	const float k0 = pr->reach / (3.0f * maxf(speed, SPEED_MIN));
	const bool mv = pr->moving;
	const float x0[DIMS_MAX] = {mv ? k0 : 1.0f / 3.0f,
	                            1.0f / 3.0f,
	                            0.0f,
	                            0.0f,
	                            dth / 3.0f,
	                            dth / 3.0f,
	                            0.0f,
	                            1.0f,
	                            NAN,
	                            0.0f,
	                            0.0f,
	                            1.0f};
	const float st[DIMS_MAX] = {mv ? 0.5f * k0 : 0.2f, 0.2f, 0.2f, 0.2f, 0.3f, 0.3f,
	                            [10] = 0.15f};
	const float lo[DIMS_MAX] = {
	    mv ? 1e-3f * k0 : 0.0f, 0.0f, -OFFSET_MAX, -OFFSET_MAX, -PI_F, -PI_F};
	const float hi[DIMS_MAX] = {
	    mv ? 10.0f * k0 : 1.0f, 1.0f, OFFSET_MAX, OFFSET_MAX, PI_F, PI_F, [10] = WAY_LATE_MAX};
	/* searched: the points, the heading's slopes (o1 and a1 from rest; from rest with a
	 * turn of at most SEED_TURN none: the heading linear), from rest with a turn where the
	 * way starts */
	const bool late = !mv && fabsf(dth) > SEED_TURN;
	pr->dims = 0;
	for (int i = 0; i < DIMS_MAX; i++) {
		pr->base[i] = x0[i];
		if ((i >= 6 && !(i == 10 && late)) || ((i == 2 || i == 4) && mv) ||
		    ((i == 4 || i == 5) && !mv && !late))
			continue;
		x[pr->dims] = x0[i], step[pr->dims] = st[i];
		pr->lo[pr->dims] = lo[i], pr->hi[pr->dims] = hi[i];
		pr->keep[pr->dims++] = i;
	}
}

/* After the search (its simplex xs, the best first): the best vertex the full timing takes,
 * or, if estimated sooner, its heading over a part of the way only or cruising at a heading
 * where the robot is fastest along the chord, the soonest in full into pa; its duration or
 * INFINITY. */
static float curve_finish(const struct curve_prob *pr, float xs[DIMS_MAX + 1][DIMS_MAX],
                          struct traj_path *pa)
{
	float best = INFINITY, kept[DIMS_MAX], pick[DIMS_MAX];
	const float *cruise = pr->cruise;
	struct traj_path pb;

	for (int k = 0; k <= pr->dims && !(best < INFINITY); k++) {
		unpack(pr, xs[k], kept);
		best = cost(pr, kept, pa, 1e-5f, TRAJ_GRID);
	}
	if (!(best < INFINITY))
		return INFINITY;
	/* the candidates estimated as the search does, the soonest then timed in full */
	float est = cost(pr, kept, &pb, SEARCH_OVER, SEARCH_GRID), pick_est = est;
	for (int q = 0; q < SPANS + CRUISES; q++) {
		float full[DIMS_MAX];
		for (int i = 0; i < DIMS_MAX; i++) /* a cruise on the start's shape */
			full[i] = q < SPANS || i >= 6 ? kept[i] : pr->base[i];
		if (q < SPANS) {
			full[6] = spans[q][0];
			full[7] = q < 2 ? minf(spans[q][1], SPAN_SHORT_M / pr->reach) : spans[q][1];
		} else {
			full[8] = cruise[(q - SPANS) / CRUISE_SHARES];
			full[9] = cruise_share[(q - SPANS) % CRUISE_SHARES];
		}
		if (q >= SPANS && !isfinite(full[8]))
			continue;
		const float t = cost(pr, full, &pb, SEARCH_OVER, SEARCH_GRID);
		if (t < pick_est) {
			pick_est = t;
			for (int i = 0; i < DIMS_MAX; i++)
				pick[i] = full[i];
		}
	}
	if (pick_est < est) {
		const float t = cost(pr, pick, &pb, 1e-5f, TRAJ_GRID);
		if (t < best) {
			best = t;
			*pa = pb;
		}
	}
	return best;
}

/* The search's start: the soonest of a few shapes (estimated), into x; the timings used. */
static int seed(const struct curve_prob *pr, float *x)
{
	const float dth = pr->g[2] - pr->p0[2];
	/* the heading's slopes a1, a2 (shares of the turn) and the offsets o1 = o2 */
	static const float sd[SEEDS][3] = {
	    {1.0f / 3, 1.0f / 3, 0.0f}, {0.8f, 0.05f, 0.0f},         {0.05f, 0.8f, 0.0f},
	    {0.9f, 0.9f, 0.0f},         {1.0f / 3, 1.0f / 3, 0.25f}, {1.0f / 3, 1.0f / 3, -0.25f}};
	float best = INFINITY, keep[DIMS_MAX];
	int used = 0;

	if (!(fabsf(dth) > SEED_TURN))
		return 0;
	for (int q = 0; q < SEEDS; q++) {
		float y[DIMS_MAX], f;
		for (int i = 0; i < pr->dims; i++) {
			const int k = pr->keep[i];
			y[i] = k == 4             ? sd[q][0] * dth
			       : k == 5           ? sd[q][1] * dth
			       : k == 2 || k == 3 ? sd[q][2]
			                          : x[i];
		}
		eval(pr, y, &f, &used);
		if (f < best) {
			best = f;
			for (int i = 0; i < pr->dims; i++)
				keep[i] = y[i];
		}
	}
	for (int i = 0; i < pr->dims; i++)
		x[i] = keep[i];
	return used;
}

/* The curve from `from` to goal (heading unwrapped from the start's), searched with evals
 * timings in all, then timed and checked into pa; its duration or INFINITY. */
static float curve_from(const struct traj *tr, const struct traj_ref *from, const float goal[3],
                        int evals, struct traj_path *pa)
{
	struct curve_prob pr = {.tr = tr};
	float x[DIMS_MAX], step[DIMS_MAX], xs[DIMS_MAX + 1][DIMS_MAX];

	curve_setup(&pr, from, goal, x, step);
	cruise_headings(&pr, pr.cruise);
	const int used = pr.moving ? 0 : seed(&pr, x);
	search(&pr, x, step, evals - (SPANS + CRUISES + 2) - used, xs);
	return curve_finish(&pr, xs, pa);
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
	const bool moving = traj_ref_moving(from);
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
	return 0;
}
