/*
 * traj_path.c - the geometry of a path plan (traj.h struct traj_path, docs/trajectory.md
 * "Paths"): lines joined by arcs that pass each intermediate pose within a radius, by arc
 * length s, and the heading as a function of s (smoothstep between knots, so its slope is 0 at
 * each knot and its rate continuous); or one curve (traj_curve.c): a cubic Bezier in (x, y)
 * and its heading's cubic Beziers. Single precision, fixed sizes.
 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"
#include "omni4/model/consts.h"

#define TURN_MIN_RAD 1e-4f /* a corner turning less than this is no corner */
#define CURV_RADIUS_MIN_M 1e-3f
#define PASS_SHARE 0.999f /* an arc passes its pose at this share of the radius: within it */

/* sin as a shifted cos: sinf and cosf of one argument become sincosf, which the core may not
 * call. */
static float sin_f(float a)
{
	return cosf(a - 0.5f * PI_F);
}

static float dist2(const float a[2], const float b[2])
{
	return sqrtf((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]));
}

/* Position, tangent and curvature vector on piece pc at sigma [m] from its start. */
static void piece_at(const struct traj_piece *pc, float sigma, float p[2], float ps[2],
                     float pss[2])
{
	const float k = pc->curv, half = 0.5f * k * sigma;
	/* chord: 2 sin(k sigma / 2) / k along the mean tangent (exact, stable as k -> 0) */
	const float chord = k != 0.0f ? 2.0f * sin_f(half) / k : sigma;
	const float mid = pc->dir0_rad + half, psi = pc->dir0_rad + k * sigma;
	const float c = cosf(psi), s = sin_f(psi);

	p[0] = pc->p0[0] + chord * cosf(mid);
	p[1] = pc->p0[1] + chord * sin_f(mid);
	ps[0] = c;
	ps[1] = s;
	pss[0] = -k * s;
	pss[1] = k * c;
}

/* Heading, its first and second derivatives by s at s. */
static void heading_at(const struct traj_path *pa, float s, float th[3])
{
	int k = 0;

	while (k < pa->n_knots - 2 && !(s < pa->knot_s[k + 1]))
		k++;
	const float len = pa->knot_s[k + 1] - pa->knot_s[k];
	const float dth = pa->knot_th[k + 1] - pa->knot_th[k];
	if (!(len > 0.0f)) {
		th[0] = pa->knot_th[k + 1];
		th[1] = 0.0f;
		th[2] = 0.0f;
		return;
	}
	float x = (s - pa->knot_s[k]) / len;
	x = x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x);
	th[0] = pa->knot_th[k] + dth * x * x * (3.0f - 2.0f * x);
	th[1] = dth * 6.0f * x * (1.0f - x) / len;
	th[2] = dth * (6.0f - 12.0f * x) / (len * len);
}

/* The cubic Bezier of control points c0..c3 at t in [0, 1], scaled to a parameter running
 * len per unit of t: its value, first and second derivatives into out. */
static void bezier_at(float c0, float c1, float c2, float c3, float t, float len, float out[3])
{
	const float v = 1.0f - t;

	out[0] = v * v * v * c0 + 3.0f * v * v * t * c1 + 3.0f * v * t * t * c2 + t * t * t * c3;
	out[1] =
	    (3.0f * v * v * (c1 - c0) + 6.0f * v * t * (c2 - c1) + 3.0f * t * t * (c3 - c2)) / len;
	out[2] =
	    (6.0f * v * (c2 - 2.0f * c1 + c0) + 6.0f * t * (c3 - 2.0f * c2 + c1)) / (len * len);
}

/* A curve's heading and its derivatives by s at s: inside a turn q (knot_s[2q] to
 * knot_s[2q + 1]) the cubic Bezier head[q] in its share tau, else held: the first turn's
 * start before it, its end up to the second's start, the second's end after it. */
static void curve_heading(const struct traj_path *pa, float s, float th[3])
{
	for (int q = 1; q >= 0; q--) {
		const float *h = pa->head[q], a = pa->knot_s[2 * q], w = pa->knot_s[2 * q + 1] - a;
		if (!(w > 0.0f) || !(s >= a) || !(s < a + w))
			continue;
		bezier_at(h[0], h[1], h[2], h[3], (s - a) / w, w, th);
		return;
	}
	th[0] = s < pa->knot_s[0]   ? pa->head[0][0]
	        : s < pa->knot_s[2] ? pa->head[0][3]
	                            : pa->head[1][3];
	th[1] = th[2] = 0.0f;
}

/* A curve's point and derivatives by s at s: the Bezier over its span of the progress (u =
 * (s / len_m - a) / (b - a)), still outside it. */
static void curve_at(const struct traj_path *pa, float s, float p[2], float ps[2], float pss[2],
                     float th[3])
{
	const float (*b)[2] = pa->bez;
	const float a = pa->bez_span[0] * pa->len_m,
	            w = (pa->bez_span[1] - pa->bez_span[0]) * pa->len_m;
	/* the ends of the way keep the Bezier's tangent (a grid point's side beyond them too) */
	const bool in = (s >= a || !(a > 0.0f)) && (s < a + w || pa->bez_span[1] >= 1.0f);
	float u = (s - a) / w, q[3];
	u = u < 0.0f ? 0.0f : (u > 1.0f ? 1.0f : u);

	for (int i = 0; i < 2; i++) {
		bezier_at(b[0][i], b[1][i], b[2][i], b[3][i], u, w, q);
		p[i] = q[0];
		ps[i] = in ? q[1] : 0.0f;
		pss[i] = in ? q[2] : 0.0f;
	}
	curve_heading(pa, s, th);
}

void traj_path_at(const struct traj_path *pa, float s, float p[2], float ps[2], float pss[2],
                  float th[3])
{
	int k = 0;

	if (pa->curve) {
		curve_at(pa, s, p, ps, pss, th);
		return;
	}

	while (k < pa->n_pieces - 1 && !(s < pa->pc[k + 1].s0_m))
		k++;
	piece_at(&pa->pc[k], s - pa->pc[k].s0_m, p, ps, pss);
	heading_at(pa, s, th);
}

/* Appends a piece from where the last one ends (or p0 if none) with the given tangent. */
static void add_piece(struct traj_path *pa, const float p0[2], float dir, float curv, float len)
{
	struct traj_piece *pc = &pa->pc[pa->n_pieces++];

	*pc = (struct traj_piece){
	    .s0_m = pa->len_m, .len_m = len, .p0 = {p0[0], p0[1]}, .dir0_rad = dir, .curv = curv};
	pa->len_m += len;
}

/* The end point of the last piece. */
static void last_end(const struct traj_path *pa, float p[2])
{
	float ps[2], pss[2];
	const struct traj_piece *pc = &pa->pc[pa->n_pieces - 1];

	piece_at(pc, pc->len_m, p, ps, pss);
}

/* Corner at w between legs of angles a_in, a_out and lengths: a line up to the arc, the arc
 * (radius from the pass radius, the tangent length at most half of each leg). Returns the s
 * where the path is closest to w. */
static float corner(struct traj_path *pa, const float w[2], float a_in, float a_out, float l_in,
                    float l_out, float radius)
{
	const float phi = model_wrap_pi_f32(a_out - a_in), h = 0.5f * fabsf(phi);
	float p[2];

	last_end(pa, p);
	if (h < 0.5f * TURN_MIN_RAD) {
		add_piece(pa, p, a_in, 0.0f, dist2(p, w));
		return pa->len_m;
	}
	const float ch = cosf(h), th = sin_f(h) / ch;
	float R = PASS_SHARE * radius * ch / (1.0f - ch);
	float T = R * th;
	const float t_max = 0.5f * (l_in < l_out ? l_in : l_out);
	if (T > t_max) {
		T = t_max;
		R = T / th;
	}
	R = R > CURV_RADIUS_MIN_M ? R : CURV_RADIUS_MIN_M;
	const float a[2] = {w[0] - cosf(a_in) * T, w[1] - sin_f(a_in) * T};
	add_piece(pa, p, a_in, 0.0f, dist2(p, a));
	const float k = phi > 0.0f ? 1.0f / R : -1.0f / R;
	float ps[2], pss[2], m[2];
	/* the arc in two halves: its middle (the heading's knot) is a grid point */
	add_piece(pa, a, a_in, k, R * h);
	piece_at(&pa->pc[pa->n_pieces - 1], R * h, m, ps, pss);
	add_piece(pa, m, a_in + 0.5f * phi, k, R * h);
	return pa->len_m - R * h;
}

int traj_path_build(struct traj_path *pa, const float start[3], const float (*wp)[3], int n,
                    float radius, const float via[2])
{
	float pts[TRAJ_PATH_MAX + 2][2], ang[TRAJ_PATH_MAX + 1], len[TRAJ_PATH_MAX + 1];
	int m = 0;

	if (n < 1 || n > TRAJ_PATH_MAX)
		return -EINVAL;
	pts[m][0] = start[0];
	pts[m++][1] = start[1];
	if (via) {
		pts[m][0] = via[0];
		pts[m++][1] = via[1];
	}
	for (int k = 0; k < n; k++) {
		pts[m][0] = wp[k][0];
		pts[m++][1] = wp[k][1];
	}
	for (int k = 0; k + 1 < m; k++) {
		len[k] = dist2(pts[k], pts[k + 1]);
		if (!(len[k] >= TRAJ_IDLE_POS))
			return -EINVAL; /* two poses at one place: no direction between them */
		ang[k] = atan2f(pts[k + 1][1] - pts[k][1], pts[k + 1][0] - pts[k][0]);
	}
	*pa = (struct traj_path){.n_poses = n, .goal = {wp[n - 1][0], wp[n - 1][1], 0.0f}};
	const int first = via ? 1 : 0;
	float p_end[2], th = start[2];
	add_piece(pa, pts[0], ang[0], 0.0f, 0.0f);
	pa->knot_s[0] = 0.0f;
	pa->knot_th[0] = start[2];
	pa->n_knots = 1;
	for (int k = 1; k + 1 < m; k++) {
		const float r = k == first && via ? len[0] : radius;
		/* the first and the last leg have one corner only: it may use all of them */
		const float l_in = k == 1 ? 2.0f * len[0] : len[k - 1];
		const float l_out = k + 2 == m ? 2.0f * len[k] : len[k];
		const float s = corner(pa, pts[k], ang[k - 1], ang[k], l_in, l_out, r);
		if (k > first) {
			th += model_wrap_pi_f32(wp[k - 1 - first][2] - th);
			pa->pass_s[k - 1 - first] = s;
			pa->knot_s[pa->n_knots] = s;
			pa->knot_th[pa->n_knots++] = th;
		}
	}
	last_end(pa, p_end);
	add_piece(pa, p_end, ang[m - 2], 0.0f, dist2(p_end, pts[m - 1]));
	th += model_wrap_pi_f32(wp[n - 1][2] - th);
	pa->pass_s[n - 1] = pa->len_m;
	pa->knot_s[pa->n_knots] = pa->len_m;
	pa->knot_th[pa->n_knots++] = th;
	pa->goal[2] = th;
	return 0;
}
