/*
 * traj_topp.c - timing a path plan (docs/trajectory.md, "Paths"): on a grid of the arc length
 * s, every wheel's force, voltage and rim speed is affine in s'' and s'^2 plus the velocity
 * terms in s' (Newton in the world frame, the feedforward's sharing, Coulomb friction with its
 * sign where the motion fixes it, else the worse one). A forward pass at the largest s'' and a
 * backward pass at the smallest (phase plane, as Bobrow's method), each step checked at both
 * ends of its segment, then a checked pass over the grid points, the segments' midpoints and
 * points inside them against the unscaled limits: where a wheel is over, the limits are scaled
 * down at that segment's ends (after a few tries, everywhere) and the timing redone. Single
 * precision, fixed sizes, no allocation.
 */
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

#define TOPP_BISECT 10 /* bisection steps of the largest s' at a point */
#define TOPP_TRIES 6   /* timings with limits scaled down until the check passes, */
#define TOPP_LOCAL 3   /* the first of them only where a segment is over (then all of them) */
/* The traction bound the timing keeps to: a little under the limit, for the load's changes
 * between the checked points (measured up to 0.1 % of it inside a 0.5 m segment of a turn) */
#define TRACTION_HELD 0.999f

/* A timing held closer than this to the limits (not a search's estimate) is checked inside
 * each segment too: at a quarter and three quarters of its time, a segment longer than
 * FINE_LONG_M or than twice the segments' mean time at FINE_LONG_PARTS points (the usage can
 * peak between them: up to 0.1 % of a limit near a segment's start, seen in a long turning
 * move; 0.47 % inside a 0.16 s segment from rest on a grid by length) */
#define FINE_OVER 1e-3f
#define FINE_LONG_M 0.1f /* [m] */
#define FINE_LONG_PARTS 16
/* Such a timing is first made on a grid of half the segments, taken up to this over a limit:
 * its times place the grid of the timing itself (time_grid) */
#define COARSE_OVER 0.01f
#define SIGN_MIN 1e-3f  /* a body velocity component below this (per unit s') has no sign */
#define SIGN_ZERO 2e-7f /* ... and below this is 0: a unit vector's rounding, rotated */
#define SPEED_BIG 20.0f /* [m/s] above any speed the drives allow */
#define SIDE_M 1e-5f    /* [m] short of a point: the piece and knot before it */
#define USAGE_LIFT 1e6f /* a wheel the acceleration lifts off the floor: no scaling saves it */

struct geo {
	float q[2], c[2], ths, thss; /* body tangent and curvature vector, heading's slopes */
	float a[2];                  /* the centre of mass's acceleration per s'^2, body frame */
	float qn;                    /* |q|: the speed per s' (1 on a path by arc length) */
};

/* Wheel j's force A s'' + Q s'^2 + L s' + Coulomb (dlo..dhi), rim speed K s'; its traction
 * bound f_max_n - NA s'' - NQ s'^2 (the load the acceleration takes off it). */
struct topp_rows {
	float A[4], Q[4], L[4], K[4], dlo[4], dhi[4], NA[4], NQ[4];
};

/* Every row at a point in the form that the timing asks (limits scaled by k): s'' at most
 * c0 + cx s'^2 + cs s' (the first nu rows), at least that (the next nl), or 0 at most that
 * (the rest, n in all: a row that s'' does not enter). Built once per timing, so the many
 * questions a timing asks of a point cost a few multiply-adds each. */
#define LIN_ROWS 20 /* four rows per wheel, five with a load transfer (its floor) */
struct topp_lin {
	float c[LIN_ROWS][3];
	unsigned char nu, nl, n;
};

struct topp_work {
	struct geo g[2][TRAJ_GRID + 1];        /* [0]: the segment after point i, [1]: before it */
	signed char sg[TRAJ_GRID][3];          /* the signs on each segment (signs) */
	struct topp_rows r[2][TRAJ_GRID + 1];  /* each point's rows, sides as g */
	struct geo gm[TRAJ_GRID];              /* each segment's midpoint (checked) */
	struct topp_rows rm[TRAJ_GRID];        /* and its rows (its segment's signs) */
	struct topp_lin lin[2][TRAJ_GRID + 1]; /* the rows at the timing's k, sides as g */
	float top[2][TRAJ_GRID + 1];           /* the caps' and rims' largest s', sides as g */
	float k[TRAJ_GRID + 1];                /* the timing's scale of the limits at each point */
	float seg[TRAJ_GRID];                  /* the check's largest use on each segment */
	float xmax[TRAJ_GRID + 1], xf[TRAJ_GRID + 1], xb[TRAJ_GRID + 1];
	int n;
};

static void geo_at(const struct traj_path *pa, float s, struct geo *g)
{
	float p[2], ps[2], pss[2], th[3];

	traj_path_at(pa, s, p, ps, pss, th);
	const float ct = cosf(th[0]), st = cosf(th[0] - 0.5f * PI_F);
	g->q[0] = ct * ps[0] + st * ps[1];
	g->q[1] = -st * ps[0] + ct * ps[1];
	g->c[0] = ct * pss[0] + st * pss[1];
	g->c[1] = -st * pss[0] + ct * pss[1];
	g->ths = th[1];
	g->thss = th[2];
	g->a[0] = g->c[0];
	g->a[1] = g->c[1];
	g->qn = pa->curve ? sqrtf(g->q[0] * g->q[0] + g->q[1] * g->q[1]) : 1.0f;
	/* the body-frame velocity q s' turns at w = ths s': the model's axes (eq 23) need
	 * M w x v more, quadratic in s' as the curvature is (the feedforward's w vn, -w v) */
	g->c[0] += g->ths * g->q[1];
	g->c[1] -= g->ths * g->q[0];
}

/* The signs a velocity component may take, as a set: NEG | ZERO | POS. A component 0 to
 * float rounding (the heading held; a body axis along the path, whose rotation by a heading
 * leaves ~4e-8 of a unit across it) has no Coulomb friction; one too small to trust may take
 * any sign. */
#define S_NEG 1
#define S_ZERO 2
#define S_POS 4

/* The geometry at s on both sides: [0][i] after s, [1][i] before it (just short of s). */
static void geo_both(const struct traj_path *pa, float s, struct geo g[2][TRAJ_GRID + 1], int i)
{
	geo_at(pa, s, &g[0][i]);
	geo_at(pa, s - SIDE_M, &g[1][i]);
}

static signed char sign_set(float v)
{
	if (v > SIGN_MIN)
		return S_POS;
	if (v < -SIGN_MIN)
		return S_NEG;
	return fabsf(v) <= SIGN_ZERO ? S_ZERO : S_NEG | S_ZERO | S_POS;
}

/* The signs a velocity component of geometry g may take. */
static void geo_signs(const struct geo *g, signed char sg[3])
{
	sg[0] |= sign_set(g->q[0]);
	sg[1] |= sign_set(g->q[1]);
	sg[2] |= sign_set(g->ths);
}

/* The signs on each segment: those at its ends and its midpoint (a component changes sign
 * only where one of them sees it, or where it is small); at rest at the end, the last
 * segment's brake without friction's help too. */
static void signs(struct topp_work *w)
{
	for (int i = 0; i < w->n; i++) {
		signed char *sg = w->sg[i];

		sg[0] = sg[1] = sg[2] = 0;
		geo_signs(&w->g[0][i], sg);
		geo_signs(&w->gm[i], sg);
		geo_signs(&w->g[1][i + 1], sg);
	}
	for (int k = 0; k < 3; k++)
		w->sg[w->n - 1][k] |= S_ZERO;
}

/* Smallest and largest of t sigma over the signs in set. */
static void coulomb_range(float t, signed char set, float *lo, float *hi)
{
	float a = INFINITY, b = -INFINITY;

	if (set & S_NEG) {
		a = minf(a, -t);
		b = maxf(b, -t);
	}
	if (set & S_ZERO) {
		a = minf(a, 0.0f);
		b = maxf(b, 0.0f);
	}
	if (set & S_POS) {
		a = minf(a, t);
		b = maxf(b, t);
	}
	*lo += a;
	*hi += b;
}

static void rows_at(const struct traj_coef *c, const struct geo *g, const signed char sg[3],
                    struct topp_rows *r)
{
	for (int j = 0; j < c->wh.n; j++) {
		const float *sp = c->wh.split[j], *row = c->wh.row[j], *fl = c->f_load[j];
		const float t[3] = {sp[0] * c->C[0], sp[1] * c->C[1], sp[2] * c->C[2]};
		/* wheel j's force: the split of (M q, J theta') s'' + (M c, J theta'') s'^2 +
		 * (B q, Bw theta') s' (wheels.h) */
		r->A[j] = c->M * (sp[0] * g->q[0] + sp[1] * g->q[1]) + c->J * g->ths * sp[2];
		r->Q[j] = c->M * (sp[0] * g->c[0] + sp[1] * g->c[1]) + c->J * g->thss * sp[2];
		r->L[j] = sp[0] * c->B[0] * g->q[0] + sp[1] * c->B[1] * g->q[1] +
		          c->B[2] * g->ths * sp[2];
		r->K[j] = row[0] * g->q[0] + row[1] * g->q[1] + row[2] * g->ths; /* eq 2 */
		/* the centre of mass's acceleration q s'' + a s'^2 unloads wheel j (wheels.h) */
		r->NA[j] = fl[0] * g->q[0] + fl[1] * g->q[1];
		r->NQ[j] = fl[0] * g->a[0] + fl[1] * g->a[1];
		r->dlo[j] = r->dhi[j] = 0.0f;
		for (int k = 0; k < 3; k++)
			coulomb_range(t[k], sg[k], &r->dlo[j], &r->dhi[j]);
	}
}

/* The speed the caps and rims allow at a point, as s'. */
static float speed_top(const struct traj_coef *c, const struct geo *g, const struct topp_rows *r)
{
	float v = SPEED_BIG;

	if (g->qn > 0.0f) /* a curve's s' is not its speed */
		v = minf(v, c->speed_cap_m_s / g->qn);

	if (fabsf(g->ths) > 0.0f)
		v = minf(v, c->omega_cap_rad_s / fabsf(g->ths));
	for (int j = 0; j < c->wh.n; j++)
		if (fabsf(r->K[j]) > 0.0f)
			v = minf(v, c->rim_max[j] / fabsf(r->K[j]));
	return v;
}

/* Row a s'' <= b0 + bx s'^2 + bs s' into l (sorted by its kind: upper, lower, free). */
static void lin_add(struct topp_lin *l, float a, float b0, float bx, float bs, float (*tmp)[3],
                    unsigned char kind[LIN_ROWS], int *m)
{
	const float inv = (a > 1e-6f || a < -1e-6f) ? 1.0f / a : 1.0f;

	tmp[*m][0] = b0 * inv;
	tmp[*m][1] = bx * inv;
	tmp[*m][2] = bs * inv;
	kind[*m] = a > 1e-6f ? 0 : (a < -1e-6f ? 1 : 2);
	l->nu += kind[*m] == 0;
	l->nl += kind[*m] == 1;
	++*m;
}

/* The rows at a point with the limits scaled by k: the traction -k hold <= f <= k hold, hold =
 * f_max_n - NA s'' - NQ s'^2 (two one-sided rows), the voltage |f + e K s'| <= k u_max b. */
static void lin_build(const struct traj_coef *c, const struct topp_rows *r, float k,
                      struct topp_lin *l)
{
	float tmp[LIN_ROWS][3];
	unsigned char kind[LIN_ROWS];
	int m = 0;

	l->nu = l->nl = 0;
	for (int j = 0; j < c->wh.n; j++) {
		const float A = r->A[j], na = k * r->NA[j], kf = TRACTION_HELD * k * c->f_max_n[j];
		const float kq = k * r->NQ[j], ku = k * c->u_max_v * c->wh.b[j];
		const float Lu = r->L[j] + c->e[j] * r->K[j];
		lin_add(l, A + na, kf - r->dhi[j], -kq - r->Q[j], -r->L[j], tmp, kind, &m);
		lin_add(l, na - A, kf + r->dlo[j], r->Q[j] - kq, r->L[j], tmp, kind, &m);
		lin_add(l, A, ku - r->dhi[j], -r->Q[j], -Lu, tmp, kind, &m);
		lin_add(l, -A, ku + r->dlo[j], r->Q[j], Lu, tmp, kind, &m);
		if (na != 0.0f || kq != 0.0f) /* the load's floor: NA s'' + NQ s'^2 <= lift_max */
			lin_add(l, na, k * c->lift_max[j], -kq, 0.0f, tmp, kind, &m);
	}
	l->n = (unsigned char)m;
	int q = 0;
	for (int want = 0; want < 3; want++)
		for (int i = 0; i < m; i++)
			if (kind[i] == want) {
				l->c[q][0] = tmp[i][0];
				l->c[q][1] = tmp[i][1];
				l->c[q][2] = tmp[i][2];
				q++;
			}
}

/* The s'' every row of l allows at s'^2 = x into [lo, hi]; false if none. */
static bool interval(const struct topp_lin *l, float x, float *lo, float *hi)
{
	const float sd = sqrtf(x);
	const int nu = l->nu, nul = l->nu + l->nl;
	float a = -INFINITY, b = INFINITY;

	for (int i = nul; i < l->n; i++)
		if (l->c[i][0] + l->c[i][1] * x + l->c[i][2] * sd < 0.0f)
			return false;
	for (int i = 0; i < nu; i++)
		b = minf(b, l->c[i][0] + l->c[i][1] * x + l->c[i][2] * sd);
	for (int i = nu; i < nul; i++)
		a = maxf(a, l->c[i][0] + l->c[i][1] * x + l->c[i][2] * sd);
	*lo = a;
	*hi = b;
	return a <= b;
}

/* The largest use of a limit (1: at it) at s'^2 = x, s'' = u. */
static float usage(const struct traj_coef *c, const struct geo *g, const struct topp_rows *r,
                   float x, float u)
{
	const float sd = sqrtf(x);
	float w = g->qn * sd / c->speed_cap_m_s;

	w = maxf(w, fabsf(g->ths) * sd / c->omega_cap_rad_s);
	for (int j = 0; j < c->wh.n; j++) {
		const float bound[2] = {c->f_max_n[j], c->u_max_v * c->wh.b[j]};
		const float lin[2] = {r->L[j], r->L[j] + c->e[j] * r->K[j]};
		w = maxf(w, fabsf(r->K[j]) * sd / c->rim_max[j]);
		for (int q = 0; q < 2; q++) {
			const float v = r->A[j] * u + r->Q[j] * x + lin[q] * sd;
			const float hold = bound[q] - (q ? 0.0f : r->NA[j] * u + r->NQ[j] * x);
			const float f = maxf(fabsf(v + r->dlo[j]), fabsf(v + r->dhi[j]));
			/* no load: only a wheel that pushes is over */
			w = maxf(w, hold > 1e-6f ? f / hold : (f > 1e-6f ? USAGE_LIFT : 0.0f));
		}
		const float lift = r->NA[j] * u + r->NQ[j] * x; /* the load's floor */
		if (lift > 0.0f)
			w = maxf(w, c->lift_max[j] > 0.0f ? lift / c->lift_max[j] : USAGE_LIFT);
	}
	return w;
}

/* The largest s'^2 with room for some s'' at point i on one side (the timing's rows); -1 if
 * none at 0. */
static float max_x_side(const struct topp_work *w, int i, int side)
{
	const struct topp_lin *l = &w->lin[side][i];
	float lo, hi, a = 0.0f;

	if (!interval(l, 0.0f, &lo, &hi))
		return -1.0f;
	float b = w->k[i] * w->top[side][i];
	if (interval(l, b * b, &lo, &hi))
		return b * b;
	for (int it = 0; it < TOPP_BISECT; it++) {
		const float m = 0.5f * (a + b);
		if (interval(l, m * m, &lo, &hi))
			a = m;
		else
			b = m;
	}
	return a * a;
}

static float max_x(const struct topp_work *w, int i)
{
	const float x0 = i < w->n ? max_x_side(w, i, 0) : INFINITY;
	const float x1 = i > 0 ? max_x_side(w, i, 1) : INFINITY;

	return minf(x0, x1);
}

/* x within the largest s'^2 at point i: x itself if the caps and every row there allow it, else
 * the largest (bisected when first asked, then kept; xmax[i] < 0: not yet). */
static float cap_x(struct topp_work *w, int i, float x)
{
	float lo, hi;

	if (w->xmax[i] >= 0.0f)
		return minf(x, w->xmax[i]);
	if (!(x > 0.0f))
		return x;
	bool ok = true;
	for (int side = 0; side < 2 && ok; side++)
		if (side ? i > 0 : i < w->n)
			ok = x <= w->k[i] * w->k[i] * w->top[side][i] * w->top[side][i] &&
			     interval(&w->lin[side][i], x, &lo, &hi);
	if (ok)
		return x;
	w->xmax[i] = max_x(w, i);
	return minf(x, w->xmax[i]);
}

/* Steps of the bisection for a segment's end speed when a row's closed form does not hold
 * (below): within 2^-SOLVE_STEPS of the first guess. */
#define SOLVE_STEPS 10

/* The largest y >= 0 with a y^2 + b y + c <= 0 (a > 0, and some y >= 0 meets it). */
static float root_hi(float a, float b, float c)
{
	const float d = sqrtf(maxf(b * b - 4.0f * a * c, 0.0f));

	return b > 0.0f ? -2.0f * c / (b + d) : (d - b) / (2.0f * a);
}

/* A segment of length ds from s'^2 = x at a constant s'' to s'^2 = x1 at its end, where the
 * end's rows l allow that s'' (dir 1: forward, s'' at most the upper rows: x1 <= x + 2 ds
 * hi(x1); dir -1: backward from the end at x to the start at x1 >= x, s'' at least the lower
 * rows: x1 <= x - 2 ds lo(x1)), and within x1_hi: the largest such x1. Each row is a
 * quadratic in s' there, so its bound is a root; a row whose s'^2 term outgrows the segment's
 * own (a segment too long for its curvature) is bisected instead. */
static float segment_end(const struct topp_lin *l, int dir, float x, float ds, float x1_hi)
{
	const int r0 = dir > 0 ? 0 : l->nu, r1 = dir > 0 ? l->nu : l->nu + l->nl;
	const float h = 2.0f * ds * (float)dir;
	float y = sqrtf(x1_hi);

	for (int i = r0; i < r1; i++) {
		const float a = 1.0f - h * l->c[i][1];
		if (!(a > 1e-3f)) {
			float lo, hi, u = x, v = x1_hi;
			for (int it = 0; it < SOLVE_STEPS; it++) {
				const float m = 0.5f * (u + v);
				const bool ok =
				    interval(l, m, &lo, &hi) && m <= x + h * (dir > 0 ? hi : lo);
				u = ok ? m : u;
				v = ok ? v : m;
			}
			return u;
		}
		y = minf(y, root_hi(a, -h * l->c[i][2], -(x + h * l->c[i][0])));
	}
	return maxf(y * y, x);
}

/* Forward: the largest x1 in [x, x1_hi] with x1 <= x + 2 ds min(hi, hi(x1)), hi(x1) the end's
 * largest s'' at s'^2 = x1 (l: the end's rows). x itself holds (hi >= 0, and the end's rows
 * allow x with hi(x) >= 0), else the single correction of before. */
static float forward_end(const struct topp_lin *l, float x, float ds, float hi, float x1_hi,
                         float hi1)
{
	float lo, h;

	if (!(hi >= 0.0f) || !interval(l, x, &lo, &h) || !(h >= 0.0f))
		return x + 2.0f * ds * hi1;
	return segment_end(l, 1, x, ds, x1_hi);
}

/* Forward at the largest s'' (checked at the segment's end too), within the largest s'. */
static void forward(const struct traj_path *pa, struct topp_work *w)
{
	float lo, hi, hi1;

	for (int i = 0; i < w->n; i++) {
		const float ds = pa->grid_s[i + 1] - pa->grid_s[i], x = w->xf[i];
		if (!interval(&w->lin[0][i], x, &lo, &hi))
			hi = 0.0f;
		float x1 = cap_x(w, i + 1, x + 2.0f * ds * hi);
		const struct topp_lin *end = &w->lin[1][i + 1];
		if (interval(end, maxf(x1, 0.0f), &lo, &hi1) && hi1 < hi)
			x1 = cap_x(w, i + 1, forward_end(end, x, ds, hi, maxf(x1, 0.0f), hi1));
		w->xf[i + 1] = maxf(x1, 0.0f);
	}
}

/* Backward, the mirror of forward_end: the largest x0 in [x, x0_hi] with x0 <= x - 2 ds
 * max(lo, lo(x0)), lo(x0) the start's smallest s'' at s'^2 = x0. */
static float backward_start(const struct topp_lin *l, float x, float ds, float lo, float x0_hi,
                            float lo0)
{
	float lw, h;

	if (!(lo <= 0.0f) || !interval(l, x, &lw, &h) || !(lw <= 0.0f))
		return x - 2.0f * ds * maxf(lo0, lo);
	return segment_end(l, -1, x, ds, x0_hi);
}

/* Backward from rest at the end at the smallest s'' (checked at both ends). */
static void backward(const struct traj_path *pa, struct topp_work *w)
{
	float lo, hi, lo0;

	w->xb[w->n] = 0.0f;
	for (int i = w->n - 1; i >= 0; i--) {
		const float ds = pa->grid_s[i + 1] - pa->grid_s[i], x = w->xb[i + 1];
		if (!interval(&w->lin[1][i + 1], x, &lo, &hi))
			lo = 0.0f;
		float x0 = cap_x(w, i, x - 2.0f * ds * lo);
		const struct topp_lin *start = &w->lin[0][i];
		if (interval(start, maxf(x0, 0.0f), &lo0, &hi) && lo0 > lo)
			x0 = cap_x(w, i, backward_start(start, x, ds, lo, maxf(x0, 0.0f), lo0));
		w->xb[i] = maxf(x0, 0.0f);
	}
}

/* The largest use of a limit over the grid points and the segments' midpoints; fine: also
 * inside them (a curve's force can peak between, where its tangent turns fast). Each
 * segment's own (its ends' sides and the points inside it) into w->seg. */
static float check(const struct traj_coef *c, const struct traj_path *pa, struct topp_work *w,
                   bool fine)
{
	const float dt_long = 2.0f * pa->grid_t[w->n] / (float)w->n; /* twice the mean's */
	float worst = 0.0f;

	for (int i = 0; i < w->n; i++) {
		const float x = pa->grid_v[i] * pa->grid_v[i],
		            x1 = pa->grid_v[i + 1] * pa->grid_v[i + 1];
		const float ds = pa->grid_s[i + 1] - pa->grid_s[i], a = pa->grid_a[i];
		float u = usage(c, &w->g[0][i], &w->r[0][i], x, a);
		u = maxf(u, usage(c, &w->g[1][i + 1], &w->r[1][i + 1], x1, a));
		u = maxf(u, usage(c, &w->gm[i], &w->rm[i], x + ds * a, a));
		const float dt = pa->grid_t[i + 1] - pa->grid_t[i];
		/* fine: at a quarter and three of its time (a long one's at FINE_LONG_PARTS) */
		const int parts = ds > FINE_LONG_M || dt > dt_long ? FINE_LONG_PARTS : 4;
		for (int q = 1; fine && q < parts; q++) {
			if (2 * q == parts) /* the midpoint's (by s) above */
				continue;
			struct geo g;
			struct topp_rows r;
			float sq, sd;
			traj_grid_at(pa, i, (float)q / (float)parts * dt, &sq, &sd);
			geo_at(pa, sq, &g);
			rows_at(c, &g, w->sg[i], &r);
			u = maxf(u, usage(c, &g, &r, sd * sd, a));
		}
		w->seg[i] = u;
		worst = maxf(worst, u);
	}
	return worst;
}

/* One timing with the limits scaled by w->k into pa's grid; its duration or INFINITY. */
static float timing(const struct traj_coef *c, struct traj_path *pa, struct topp_work *w, float v0)
{
	float lo, hi;

	for (int i = 0; i <= w->n; i++) {
		w->xmax[i] = -1.0f; /* bisected when a pass first goes beyond what it allows */
		for (int side = 0; side < 2; side++)
			if (side ? i > 0 : i < w->n) {
				lin_build(c, &w->r[side][i], w->k[i], &w->lin[side][i]);
				if (!interval(&w->lin[side][i], 0.0f, &lo, &hi))
					return INFINITY; /* no room at rest */
			}
	}
	w->xf[0] = v0 * v0;
	forward(pa, w);
	backward(pa, w);
	if (w->xb[0] < v0 * v0 * (1.0f - 1e-3f) - 1e-6f)
		return INFINITY; /* too fast to stay on the path */
	float t = 0.0f;
	pa->grid_t[0] = 0.0f;
	pa->grid_v[0] = v0;
	for (int i = 0; i < w->n; i++) {
		const float x1 = i + 1 == w->n ? 0.0f : minf(w->xf[i + 1], w->xb[i + 1]);
		const float ds = pa->grid_s[i + 1] - pa->grid_s[i];
		const float x0 = pa->grid_v[i] * pa->grid_v[i];
		pa->grid_v[i + 1] = sqrtf(x1);
		pa->grid_a[i] = (x1 - x0) / (2.0f * ds);
		const float sum = pa->grid_v[i] + pa->grid_v[i + 1];
		if (!(sum > 0.0f))
			return INFINITY;
		t += 2.0f * ds / sum;
		pa->grid_t[i + 1] = t;
	}
	return t;
}

/* Grid points at these distances from the start and from the end [m]: a long path's speed-up
 * and brake (a metre or two) on segments short enough to hold them, whatever the length. */
#define RAMP_BREAKS 7
static const float ramp_m[RAMP_BREAKS] = {0.02f, 0.07f, 0.25f, 0.5f, 1.0f, 2.0f, 4.0f};
#define BREAKS_MAX (TRAJ_PIECES + TRAJ_KNOTS + 2 * RAMP_BREAKS + 1)

/* Where a piece or a heading knot ends after s0 (ramps: and the ramps' points), sorted, each
 * once; returns how many. */
static int breaks(const struct traj_path *pa, float s0, float b[BREAKS_MAX], bool ramps)
{
	const int nk = pa->n_pieces + pa->n_knots + (ramps ? 2 * RAMP_BREAKS : 0);
	int n = 0;

	for (int k = 0; k < nk && n < BREAKS_MAX; k++) {
		const int e = k - pa->n_pieces - pa->n_knots; /* the ramps' points, then */
		float v = k < pa->n_pieces  ? pa->pc[k].s0_m + pa->pc[k].len_m
		          : e < 0           ? pa->knot_s[k - pa->n_pieces]
		          : e < RAMP_BREAKS ? s0 + ramp_m[e]
		                            : pa->len_m - ramp_m[e - RAMP_BREAKS];
		if (!(v > s0 + SIDE_M) || !(v < pa->len_m - SIDE_M))
			continue;
		int q = n++;
		for (; q > 0 && b[q - 1] > v; q--) /* insertion */
			b[q] = b[q - 1];
		b[q] = v;
	}
	int m = 0;
	for (int k = 0; k < n; k++)
		if (m == 0 || b[k] - b[m - 1] > SIDE_M)
			b[m++] = b[k];
	b[m++] = pa->len_m;
	return m;
}

/* The grid over [s0, len]: every piece's and knot's end a point, each interval between them
 * at least one segment, the rest by length. */
static int make_grid(struct traj_path *pa, float s0, int grid)
{
	float b[BREAKS_MAX];
	const int nb = breaks(pa, s0, b, true);
	const int spare = grid - nb;
	const float total = pa->len_m - s0;
	float a = s0;
	int n = 0;

	pa->grid_s[0] = s0;
	for (int k = 0; k < nb; k++) {
		const int m = 1 + (spare > 0 ? (int)((float)spare * (b[k] - a) / total) : 0);
		for (int q = 1; q <= m && n < grid; q++)
			pa->grid_s[++n] = q == m ? b[k] : a + (b[k] - a) * (float)q / (float)m;
		a = b[k];
	}
	pa->grid_s[n] = pa->len_m;
	return n;
}

float traj_topp(const struct traj_coef *c, struct traj_path *pa, float s0, float v0)
{
	return traj_topp_within(c, pa, s0, v0, 1e-5f, TRAJ_GRID);
}

/* The path's own grid from s0 on: s0, then its points beyond it; the segments. */
static int keep_grid(struct traj_path *pa, float s0)
{
	int n = 0;

	for (int i = 0; i <= pa->n_grid; i++)
		if (pa->grid_s[i] > s0 + SIDE_M)
			pa->grid_s[++n] = pa->grid_s[i]; /* in place: n + 1 <= i */
	pa->grid_s[0] = s0;
	return n;
}

/* The limits scaled down where the check found a segment over: at its two ends, by what it
 * is over; not local: all of them by the worst. */
static void scale_down(struct topp_work *w, float over, float worst, bool local)
{
	float f[TRAJ_GRID + 1];

	for (int i = 0; i <= w->n; i++)
		f[i] = local ? 1.0f : 0.997f / worst;
	for (int i = 0; i < w->n && local; i++) {
		if (!(w->seg[i] > 1.0f + over))
			continue;
		for (int q = i; q <= i + 1; q++)
			f[q] = minf(f[q], 0.997f / w->seg[i]);
	}
	for (int i = 0; i <= w->n; i++)
		w->k[i] *= f[i];
}

/* The timing on pa's grid of n segments from v0 (limits over by at most over taken). */
static float topp_grid(const struct traj_coef *c, struct traj_path *pa, float v0, float over, int n)
{
	struct topp_work w;

	if (n < 1 || n > TRAJ_GRID)
		return INFINITY;
	w.n = pa->n_grid = n;
	for (int i = 0; i <= w.n; i++) {
		geo_both(pa, pa->grid_s[i], w.g, i);
		if (i < w.n)
			geo_at(pa, 0.5f * (pa->grid_s[i] + pa->grid_s[i + 1]), &w.gm[i]);
	}
	signs(&w);
	for (int i = 0; i <= w.n; i++) { /* each side's rows with its segment's signs */
		for (int side = 0; side < 2; side++)
			if (side ? i > 0 : i < w.n) {
				rows_at(c, &w.g[side][i], w.sg[side ? i - 1 : i], &w.r[side][i]);
				w.top[side][i] = speed_top(c, &w.g[side][i], &w.r[side][i]);
			}
		if (i < w.n)
			rows_at(c, &w.gm[i], w.sg[i], &w.rm[i]);
	}
	for (int i = 0; i <= n; i++)
		w.k[i] = 1.0f;
	const bool fine = over < FINE_OVER;
	for (int tr = 0; tr < TOPP_TRIES; tr++) {
		const float t = timing(c, pa, &w, v0);
		if (!(t < INFINITY))
			return INFINITY;
		const float worst = check(c, pa, &w, fine);
		if (worst <= 1.0f + over)
			return t;
		scale_down(&w, over, worst, tr < TOPP_LOCAL);
	}
	return INFINITY;
}

/* A grid of at most grid segments from s0 at equal times of pa's timing (its grid and times),
 * every piece's and knot's end a point too; returns the segments. Where the speed is low a
 * segment is short: each one's s'' is held at its ends' limits, which change with the speed
 * (the back-EMF's share of the voltage as the robot speeds up from rest), and a segment of the
 * grid by length that starts from rest takes 8 % of a 2 s move. */
static int time_grid(struct traj_path *pa, float s0, int grid)
{
	float b[BREAKS_MAX], q[TRAJ_GRID];
	const int nb = breaks(pa, s0, b, false), n_old = pa->n_grid, m = grid - nb + 1;
	const float T = pa->grid_t[n_old];
	int i = 0, nq = 0;

	for (int k = 1; k < m; k++) { /* the progress at the equal times */
		const float t = T * (float)k / (float)m;
		while (i < n_old - 1 && !(t < pa->grid_t[i + 1]))
			i++;
		float sd;
		traj_grid_at(pa, i, t - pa->grid_t[i], &q[nq++], &sd);
	}
	int n = 0, a = 0, e = 0; /* merged with the breaks (the last: len_m), sorted */
	pa->grid_s[0] = s0;
	while ((a < nq || e < nb) && n < grid) {
		const float v = e >= nb || (a < nq && q[a] < b[e]) ? q[a++] : b[e++];
		if (v > pa->grid_s[n] + SIDE_M && (v < pa->len_m - SIDE_M || e == nb))
			pa->grid_s[++n] = v;
	}
	pa->grid_s[n] = pa->len_m;
	return n;
}

float traj_topp_within(const struct traj_coef *c, struct traj_path *pa, float s0, float v0,
                       float over, int grid)
{
	if (!(pa->len_m - s0 > TRAJ_IDLE_POS) || !(grid >= 1 && grid <= TRAJ_GRID))
		return INFINITY;
	if (over < FINE_OVER && grid >= 2) { /* held to the limits: on a grid of its times */
		const float t = topp_grid(c, pa, v0, COARSE_OVER, make_grid(pa, s0, grid / 2));
		const float t_fine =
		    t < INFINITY ? topp_grid(c, pa, v0, over, time_grid(pa, s0, grid)) : INFINITY;
		if (t_fine < INFINITY)
			return t_fine;
	}
	return topp_grid(c, pa, v0, over, make_grid(pa, s0, grid));
}

float traj_topp_retime(const struct traj_coef *c, struct traj_path *pa, float s0, float v0)
{
	if (!(pa->len_m - s0 > TRAJ_IDLE_POS) || !(s0 >= pa->grid_s[0]))
		return INFINITY;
	return topp_grid(c, pa, v0, 1e-5f, keep_grid(pa, s0));
}

void traj_grid_at(const struct traj_path *pa, int i, float tau, float *s, float *sd)
{
	const float a = pa->grid_a[i], v = pa->grid_v[i];

	*sd = maxf(v + a * tau, 0.0f);
	*s = minf(pa->grid_s[i] + (v + 0.5f * a * tau) * tau, pa->grid_s[i + 1]);
}

void traj_path_eval(const struct traj_path *pa, float t, struct traj_ref *out)
{
	const int n = pa->n_grid;

	if (!(t < pa->grid_t[n])) {
		*out = (struct traj_ref){.pose = {pa->goal[0], pa->goal[1], pa->goal[2]}};
		return;
	}
	t = maxf(t, 0.0f);
	int lo = 0, hi = n;
	while (hi - lo > 1) {
		const int m = (lo + hi) / 2;
		if (t < pa->grid_t[m])
			hi = m;
		else
			lo = m;
	}
	const float a = pa->grid_a[lo];
	float s, sd;
	traj_grid_at(pa, lo, t - pa->grid_t[lo], &s, &sd);
	float p[2], ps[2], pss[2], th[3];
	traj_path_at(pa, s, p, ps, pss, th);
	*out = (struct traj_ref){
	    .pose = {p[0], p[1], th[0]},
	    .vel = {ps[0] * sd, ps[1] * sd, th[1] * sd},
	    .acc = {pss[0] * sd * sd + ps[0] * a, pss[1] * sd * sd + ps[1] * a,
	            th[2] * sd * sd + th[1] * a},
	};
}
