/*
 * traj.c - trajectory generator (traj.h, docs/trajectory.md): 1D bang-bang profiles, the x/y
 * share found by bisection, the heading's own profile, and the drive envelope they are planned
 * in. Single precision after traj_init; every loop has a fixed bound.
 */
#include "omni4/core/traj.h"
#include "traj_int.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#define PI_F 3.14159265f
/* Headings sampled over a turn: one per this step at most (cos(step/2) = 0.98 of the budget),
 * TRAJ_HEADINGS_MAX at most (a turn of 2 pi: cos(pi/8) = 0.92). */
#define HEADING_STEP_RAD (PI_F / 8.0f)
/* Acceleration planned with when the start velocity leaves none (TRAJ_F_BEYOND_ENVELOPE). */
#define ACC_FLOOR 0.05f
#define ROWS_MAX (TRAJ_HEADINGS_MAX * 4 * 3)

/* Wheel j's direction in the robot frame (eq 2 without the d term): g_j = [gx, gy, d]. */
static const float g_xy[4][2] = {{0.0f, 1.0f}, {-1.0f, 0.0f}, {0.0f, -1.0f}, {1.0f, 0.0f}};

/* Top speeds tried, as fractions of the largest the envelope allows (acceleration 0 there). */
static const float speed_frac[TRAJ_SPEED_STEPS] = {0.3f,  0.5f,  0.65f, 0.75f,
                                                   0.82f, 0.88f, 0.93f, 0.97f};

static bool finite3(const float v[3])
{
	return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static float wrap_pi(float a)
{
	a = fmodf(a + PI_F, 2.0f * PI_F);
	if (a < 0.0f)
		a += 2.0f * PI_F;
	return a - PI_F;
}

/* ---- 1D bang-bang -------------------------------------------------------------------------- */

static void bb_hold(struct traj_1d *o, float p)
{
	*o = (struct traj_1d){.p0 = p, .p1 = p, .goal = p};
}

static bool bb_idle(float p0, float v0, float goal)
{
	return fabsf(goal - p0) < TRAJ_IDLE_POS && fabsf(v0) < TRAJ_IDLE_VEL;
}

float traj_1d_duration(const struct traj_1d *o)
{
	return o->n > 0 ? o->t_end_s[o->n - 1] : 0.0f;
}

void traj_ph_add(struct traj_1d *o, float *t, float *p, float *v, float a, float dt)
{
	if (o->n >= TRAJ_PHASES)
		return; /* not reached: every plan has at most TRAJ_PHASES phases */
	const int k = o->n++;

	o->ps[k] = *p;
	o->vs[k] = *v;
	o->acc[k] = a;
	*t += dt;
	o->t_end_s[k] = *t;
	*p += *v * dt + 0.5f * a * dt * dt;
	*v += a * dt;
}

/* Mirrored so that the move is positive: s is the side the goal lies on from where braking
 * now would stop. */
float traj_1d_plan(struct traj_1d *o, float p0, float v0, float goal, float a_up, float a_dn,
                   float vmax)
{
	if (bb_idle(p0, v0, goal)) {
		bb_hold(o, goal);
		return 0.0f;
	}
	if (!(a_up > 0.0f) || !(a_dn > 0.0f) || !(vmax > 0.0f))
		return INFINITY;
	const float stop = v0 * fabsf(v0) / (2.0f * a_dn);
	const float s = goal - p0 - stop >= 0.0f ? 1.0f : -1.0f;
	const float dist = s * (goal - p0), u = s * v0;
	float t0, vc, a0;

	if (u > vmax) { /* too fast: brake to vmax, cruise, stop */
		vc = vmax;
		a0 = -a_dn;
		t0 = (u - vmax) / a_dn;
	} else { /* speed up (through 0 if moving away) to the peak or to vmax, then stop:
	          * (vp^2 - u^2) / (2 a_up) + vp^2 / (2 a_dn) = dist */
		const float vp2 = (2.0f * dist * a_up * a_dn + u * u * a_dn) / (a_up + a_dn);
		vc = minf(sqrtf(maxf(vp2, 0.0f)), vmax);
		a0 = a_up;
		t0 = maxf((vc - u) / a_up, 0.0f);
	}
	const float d0 = (vc * vc - u * u) / (2.0f * a0);
	const float dc = maxf(dist - d0 - vc * vc / (2.0f * a_dn), 0.0f);
	const float tc = vc > 0.0f ? dc / vc : 0.0f;
	float t = 0.0f, p = p0, v = v0;

	*o = (struct traj_1d){.p0 = p0, .v0 = v0, .goal = goal};
	traj_ph_add(o, &t, &p, &v, s * a0, t0);
	o->p1 = p;
	o->v1 = s * vc;
	v = o->v1;
	traj_ph_add(o, &t, &p, &v, 0.0f, tc);
	traj_ph_add(o, &t, &p, &v, -s * a_dn, vc / a_dn);
	return t;
}

void traj_1d_eval(const struct traj_1d *o, float t, float *p, float *v, float *a)
{
	const int n = o->n;

	if (t <= 0.0f || n == 0) {
		*p = n ? o->p0 : o->goal;
		*v = n ? o->v0 : 0.0f;
		*a = n ? o->acc[0] : 0.0f;
		return;
	}
	if (!(t < o->t_end_s[n - 1])) {
		*p = o->goal;
		*v = 0.0f;
		*a = 0.0f;
		return;
	}
	int k = 0;
	while (k < n - 1 && !(t < o->t_end_s[k]))
		k++;
	if (k == n - 1) { /* anchored at the goal: arrives exactly */
		const float tau = t - o->t_end_s[k];
		*p = o->goal + 0.5f * o->acc[k] * tau * tau;
		*v = o->acc[k] * tau;
		*a = o->acc[k];
		return;
	}
	const float tau = t - (k ? o->t_end_s[k - 1] : 0.0f);
	*p = o->ps[k] + o->vs[k] * tau + 0.5f * o->acc[k] * tau * tau;
	*v = o->vs[k] + o->acc[k] * tau;
	*a = o->acc[k];
}

/* Smallest and largest position the profile passes through (phase ends and turning points). */
static void bb_range(const struct traj_1d *o, float *lo, float *hi)
{
	*lo = minf(o->goal, o->p0);
	*hi = maxf(o->goal, o->p0);
	for (int k = 0; k < o->n; k++) {
		float q = o->ps[k];
		*lo = minf(*lo, q);
		*hi = maxf(*hi, q);
		if (o->acc[k] != 0.0f) {
			const float tz = -o->vs[k] / o->acc[k];
			const float len = o->t_end_s[k] - (k ? o->t_end_s[k - 1] : 0.0f);
			if (tz > 0.0f && tz < len) {
				q = o->ps[k] - o->vs[k] * o->vs[k] / (2.0f * o->acc[k]);
				*lo = minf(*lo, q);
				*hi = maxf(*hi, q);
			}
		}
	}
}

/* ---- the envelope as rows ----------------------------------------------------------------- */

/* Largest A with every row met (velocity half widths wx, wy); -1 if a velocity-only row fails. */
static float rows_acc(const struct row *r, int n, float ca, float sa, float wx, float wy)
{
	float best = INFINITY;

	for (int k = 0; k < n; k++) {
		const float room = r[k].c - r[k].kv[0] * wx - r[k].kv[1] * wy;
		const float per = r[k].ka[0] * ca + r[k].ka[1] * sa;
		if (per > 0.0f)
			best = minf(best, room / per);
		else if (room < 0.0f)
			return -1.0f;
	}
	return best;
}

/*
 * Largest stopping acceleration: while a wheel's acceleration term opposes its velocity terms
 * (friction, back-EMF: both along the velocity), |a + v| <= max(|a|, |v|), so the acceleration
 * alone must fit (c0) and the velocity alone (rows_acc >= 0 at that speed).
 */
static float rows_stop(const struct row *r, int n, float ca, float sa)
{
	float best = INFINITY;

	for (int k = 0; k < n; k++) {
		const float per = r[k].ka[0] * ca + r[k].ka[1] * sa;
		if (per > 0.0f)
			best = minf(best, r[k].c0 / per);
	}
	return best;
}

/* Largest V with a velocity box (V ca, V sa) meeting every row at zero acceleration. */
static float rows_top(const struct row *r, int n, float ca, float sa)
{
	float best = INFINITY;

	for (int k = 0; k < n; k++) {
		const float per = r[k].kv[0] * ca + r[k].kv[1] * sa;
		if (per > 0.0f)
			best = minf(best, r[k].c / per);
		else if (r[k].c < 0.0f)
			return 0.0f;
	}
	return maxf(best, 0.0f);
}

/*
 * Translation rows at heading phi: wheel j's force, voltage and rim speed in the world frame
 * (k_w = R(phi) k_robot), a share `share` of the budgets, Coulomb friction with its worst
 * sign, the room scaled by cos_h (the headings between two samples: docs/trajectory.md).
 */
static int rows_translation(const struct traj_coef *c, float phi, float share, float cos_h,
                            struct row *r)
{
	const float cp = cosf(phi), sp = cosf(phi - 0.5f * PI_F);
	int n = 0;

	for (int j = 0; j < 4; j++) {
		const float gx = g_xy[j][0], gy = g_xy[j][1];
		const float fa[2] = {0.5f * c->M * gx, 0.5f * c->M * gy};
		const float fv[2] = {0.5f * c->B[0] * gx, 0.5f * c->B[1] * gy};
		const float coul = 0.5f * (fabsf(gx) * c->C[0] + fabsf(gy) * c->C[1]);
		const float uv[2] = {(fv[0] + c->e[j] * gx) / c->b[j],
		                     (fv[1] + c->e[j] * gy) / c->b[j]};
		const float *ka[3] = {fa, fa, NULL}, *kv[3] = {fv, uv, g_xy[j]};
		const float kscale[3] = {1.0f, 1.0f / c->b[j], 0.0f};
		const float room[3] = {share * c->f_max_n - coul,
		                       share * c->u_max_v - coul / c->b[j], share * c->rim_max[j]};
		const float room0[3] = {share * c->f_max_n, share * c->u_max_v,
		                        share * c->rim_max[j]};
		for (int q = 0; q < 3; q++, n++) {
			const float ax = ka[q] ? ka[q][0] * kscale[q] : 0.0f;
			const float ay = ka[q] ? ka[q][1] * kscale[q] : 0.0f;
			r[n].sa[0] = cp * ax - sp * ay;
			r[n].sa[1] = sp * ax + cp * ay;
			r[n].sv[0] = cp * kv[q][0] - sp * kv[q][1];
			r[n].sv[1] = sp * kv[q][0] + cp * kv[q][1];
			for (int i = 0; i < 2; i++) {
				r[n].ka[i] = fabsf(r[n].sa[i]);
				r[n].kv[i] = fabsf(r[n].sv[i]);
			}
			r[n].c = room[q] * cos_h;
			r[n].c0 = room0[q] * cos_h;
		}
	}
	return n;
}

/* Rotation rows: T = J a + Bw w + Cw sgn w shared as T / (4 d) per wheel, plus back-EMF e_j d w. */
static int rows_rotation(const struct traj_coef *c, float share, struct row *r)
{
	const float q = 1.0f / (4.0f * c->d);

	for (int j = 0; j < 4; j++) {
		const float ib = 1.0f / c->b[j];
		r[3 * j] = (struct row){
		    {c->J * q, 0.0f},   {c->B[2] * q, 0.0f}, share * c->f_max_n - c->C[2] * q,
		    share * c->f_max_n, {0.0f, 0.0f},        {0.0f, 0.0f}};
		r[3 * j + 1] = (struct row){{c->J * q * ib, 0.0f},
		                            {(c->B[2] * q + c->e[j] * c->d) * ib, 0.0f},
		                            share * c->u_max_v - c->C[2] * q * ib,
		                            share * c->u_max_v,
		                            {0.0f, 0.0f},
		                            {0.0f, 0.0f}};
		r[3 * j + 2] =
		    (struct row){{0.0f, 0.0f},          {c->d, 0.0f}, share * c->rim_max[j],
		                 share * c->rim_max[j], {0.0f, 0.0f}, {0.0f, 0.0f}};
	}
	for (int k = 0; k < 12; k++) /* one axis, every coefficient >= 0: signed = box */
		for (int i = 0; i < 2; i++) {
			r[k].sa[i] = r[k].ka[i];
			r[k].sv[i] = r[k].kv[i];
		}
	return 12;
}

/* ---- choosing the limits ------------------------------------------------------------------- */

struct axes {
	int n;     /* 1 (heading) or 2 (x, y) */
	bool stop; /* stopping opposes the velocity in every wheel: rows_stop applies */
	float p0[2], v0[2], goal[2];
	float cap; /* on V */
	struct traj_1d *out[2];
};

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
static float choose_limits(const struct row *r, int n, const struct axes *ax, float ca, float sa,
                           uint32_t *flags)
{
	const float vtop = minf(rows_top(r, n, ca, sa), ax->cap);
	float best_t = INFINITY, best_a = 0.0f, best_d = 0.0f, best_v = 0.0f;

	for (int k = 0; k < TRAJ_SPEED_STEPS; k++) {
		const float v = vtop * speed_frac[k];
		const float wx = maxf(v * ca, fabsf(ax->v0[0]));
		const float wy = ax->n > 1 ? maxf(v * sa, fabsf(ax->v0[1])) : 0.0f;
		const float acc = rows_acc(r, n, ca, sa, wx, wy);
		if (!(acc > 0.0f) || !(v > 0.0f))
			continue;
		const float dec = ax->stop ? maxf(rows_stop(r, n, ca, sa), acc) : acc;
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
		best_a = maxf(0.1f * rows_acc(r, n, ca, sa, 0.0f, 0.0f), ACC_FLOOR);
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
static float plan_translation(struct traj *tr, const struct row *r, int n, struct axes *ax)
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
		return choose_limits(r, n, ax, dx / dist, dy / dist, &tr->flags);
	}
	ax->out[0] = &cur[0];
	ax->out[1] = &cur[1];
	for (int it = 0; it < TRAJ_ALPHA_ITERS + 2; it++) {
		/* first the two ends (an axis that does not move gets nothing), then bisection */
		const float alpha = it == 0 ? 0.0f : it == 1 ? 0.5f * PI_F : 0.5f * (lo + hi);
		const float ca = it == 1 ? 0.0f : cosf(alpha);
		const float sa = it == 0 ? 0.0f : sqrtf(maxf(1.0f - ca * ca, 0.0f));
		uint32_t flags = 0;
		const float t = choose_limits(r, n, ax, ca, sa, &flags);
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

/* ---- the instance -------------------------------------------------------------------------- */

/* The limits in single precision; 0 if each is in its range (NaN fails every comparison). */
struct limits_f {
	float supply, margin, mu, tmargin, wmax, vcap, wcap, share;
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
	                       (float)l->rot_share};
	return f->supply - f->margin > 0.0f && f->margin >= 0.0f && isfinite(f->supply) &&
	       f->mu > 0.0f && isfinite(f->mu) && f->tmargin >= 0.0f && f->tmargin < 1.0f &&
	       f->wmax > 0.0f && isfinite(f->wmax) && f->vcap > 0.0f && f->wcap > 0.0f &&
	       f->share > 0.0f && f->share < 1.0f;
}

int traj_init(struct traj *tr, const struct traj_limits *l)
{
	struct limits_f f;

	if (!limits_ok(l, &f))
		return -EINVAL;
	const float gear = (float)l->p.l, M = (float)l->p.M;
	struct traj_coef c = {
	    .d = (float)l->p.d,
	    .M = M,
	    .J = (float)l->p.J,
	    .B = {(float)l->p.Bv, (float)l->p.Bvn, (float)l->p.Bw},
	    .C = {(float)l->p.Cv, (float)l->p.Cvn, (float)l->p.Cw},
	    .u_max_v = f.supply - f.margin,
	    .f_max_n = f.mu * M * TRAJ_G_M_S2 / 4.0f * (1.0f - f.tmargin),
	    .speed_cap_m_s = f.vcap,
	    .omega_cap_rad_s = f.wcap,
	    .rot_share = f.share,
	};
	for (int j = 0; j < 4; j++) {
		const float r = (float)l->w.r[j], Kv = (float)l->w.Kv[j], Kt = (float)l->w.Kt[j];
		const float R = (float)l->w.R[j];
		c.b[j] = gear * Kt / (R * r);
		c.e[j] = gear * gear * Kt * Kv / (R * r * r);
		c.rim_max[j] = f.wmax * r / gear;
	}
	/* at rest, each axis and the heading alone must have room to accelerate */
	struct row r[12];
	const int nt = rows_translation(&c, 0.0f, 1.0f, 1.0f, r);
	if (!(rows_acc(r, nt, 1.0f, 0.0f, 0.0f, 0.0f) > 0.0f) ||
	    !(rows_acc(r, nt, 0.0f, 1.0f, 0.0f, 0.0f) > 0.0f) ||
	    !(rows_acc(r, rows_rotation(&c, 1.0f, r), 1.0f, 0.0f, 0.0f, 0.0f) > 0.0f))
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
		bb_hold(&tr->axis[i], pose[i]);
	tr->t_s = 0.0f;
	tr->duration_s = 0.0f;
	tr->alpha_rad = 0.0f;
	tr->flags = 0;
	return 0;
}

/* The heading's profile with its share; returns its duration. */
static float plan_heading(struct traj *tr, const struct traj_ref *from, float goal, float share)
{
	struct row r[12];
	const int n = rows_rotation(&tr->c, share, r);
	struct axes ax = {.n = 1,
	                  .stop = true,
	                  .p0 = {from->pose[2]},
	                  .v0 = {from->vel[2]},
	                  .goal = {goal},
	                  .cap = tr->c.omega_cap_rad_s,
	                  .out = {&tr->axis[2]}};
	const float t = traj_line_plan(r, n, 1.0f, 0.0f, from->pose[2], from->vel[2], goal,
	                               tr->c.omega_cap_rad_s, &tr->axis[2]);
	return t < INFINITY ? t : choose_limits(r, n, &ax, 1.0f, 0.0f, &tr->flags);
}

/* Headings sampled over [lo, hi] (a whole turn at most) and cos of half their spacing. */
static int heading_samples(float lo, float hi, float phi[TRAJ_HEADINGS_MAX], float *cos_h)
{
	const float span = minf(hi - lo, 2.0f * PI_F);
	int n = 1;

	*cos_h = 1.0f;
	phi[0] = lo;
	if (span > 1e-4f) {
		n = 1 + (int)ceilf(span / HEADING_STEP_RAD);
		n = n > TRAJ_HEADINGS_MAX ? TRAJ_HEADINGS_MAX : n;
		const float step = span / (float)(n - 1);
		for (int k = 0; k < n; k++)
			phi[k] = lo + step * (float)k;
		*cos_h = cosf(0.5f * step);
	}
	return n;
}

/* The translation is a straight line: the start velocity along the line to the goal (either
 * way) or none. e: the unit direction, dist: the distance. */
static bool on_line(const struct traj_ref *from, const float goal[3], float e[2], float *dist)
{
	const float dx = goal[0] - from->pose[0], dy = goal[1] - from->pose[1];

	*dist = sqrtf(dx * dx + dy * dy);
	if (!(*dist >= TRAJ_IDLE_POS))
		return false;
	e[0] = dx / *dist;
	e[1] = dy / *dist;
	return fabsf(from->vel[0] * e[1] - from->vel[1] * e[0]) < TRAJ_IDLE_VEL;
}

/* One plan with the heading's share of every wheel's budget; returns its duration. */
static float plan_share(struct traj *tr, const struct traj_ref *from, const float goal[3],
                        float share, bool rot_idle, bool tr_idle)
{
	const float th_goal = from->pose[2] + wrap_pi(goal[2] - from->pose[2]);
	float t_rot = 0.0f, t_xy = 0.0f, lo = from->pose[2], hi = from->pose[2];

	tr->flags = 0;
	tr->alpha_rad = 0.0f;
	if (rot_idle) {
		bb_hold(&tr->axis[2], th_goal);
	} else {
		t_rot = plan_heading(tr, from, th_goal, share);
		bb_range(&tr->axis[2], &lo, &hi);
	}
	if (tr_idle) {
		bb_hold(&tr->axis[0], goal[0]);
		bb_hold(&tr->axis[1], goal[1]);
		return t_rot;
	}
	struct row r[ROWS_MAX];
	float phi[TRAJ_HEADINGS_MAX], cos_h;
	const int nh = heading_samples(lo, hi, phi, &cos_h);
	int n = 0;
	for (int k = 0; k < nh; k++)
		n += rows_translation(&tr->c, phi[k], 1.0f - share, cos_h, r + n);
	float e[2], dist;
	if (on_line(from, goal, e, &dist)) {
		struct traj_1d line;
		const float v0 = from->vel[0] * e[0] + from->vel[1] * e[1];
		t_xy = traj_line_plan(r, n, e[0], e[1], 0.0f, v0, dist, tr->c.speed_cap_m_s, &line);
		if (t_xy < INFINITY) {
			for (int i = 0; i < 2; i++)
				traj_line_project(&line, e[i], from->pose[i], goal[i],
				                  &tr->axis[i]);
			tr->alpha_rad = atan2f(fabsf(e[1]), fabsf(e[0]));
			return maxf(t_rot, t_xy);
		}
	}
	struct traj_1d bg[2];
	const float tb =
	    traj_line_brake_go(r, n, from->pose, from->vel, goal, tr->c.speed_cap_m_s, bg);
	const uint32_t flags = tr->flags;
	struct axes ax = {.n = 2,
	                  .stop = fabsf(from->vel[0]) < TRAJ_IDLE_VEL &&
	                          fabsf(from->vel[1]) < TRAJ_IDLE_VEL,
	                  .p0 = {from->pose[0], from->pose[1]},
	                  .v0 = {from->vel[0], from->vel[1]},
	                  .goal = {goal[0], goal[1]},
	                  .cap = tr->c.speed_cap_m_s};
	t_xy = plan_translation(tr, r, n, &ax);
	if (tb < t_xy) { /* stopping first is sooner */
		tr->axis[0] = bg[0];
		tr->axis[1] = bg[1];
		tr->flags = flags;
		t_xy = tb;
	}
	return maxf(t_rot, t_xy);
}

/* Both move: the heading's share among three, the earliest arrival kept. */
static void share_three(struct traj *tr, const struct traj_ref *from, const float goal[3], float s)
{
	const float shares[TRAJ_SHARES] = {0.5f * s, s, 0.5f * (1.0f + s)};
	struct traj cand = *tr;

	tr->duration_s = INFINITY;
	for (int k = 0; k < TRAJ_SHARES; k++) {
		cand.duration_s = plan_share(&cand, from, goal, shares[k], false, false);
		if (cand.duration_s < tr->duration_s)
			*tr = cand;
	}
}

/* Both move on a straight line: the heading's share by bisection until the heading and the
 * translation arrive together (the heading's time falls with its share, the translation's
 * rises), the earliest arrival kept. */
static void share_bisect(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	struct traj cand = *tr;
	float lo = 0.0f, hi = 1.0f;

	tr->duration_s = INFINITY;
	for (int it = 0; it < TRAJ_SHARE_ITERS; it++) {
		const float share = 0.5f * (lo + hi);
		cand.duration_s = plan_share(&cand, from, goal, share, false, false);
		if (cand.duration_s < tr->duration_s)
			*tr = cand;
		const float t_rot = traj_1d_duration(&cand.axis[2]);
		if (t_rot > maxf(traj_1d_duration(&cand.axis[0]), traj_1d_duration(&cand.axis[1])))
			lo = share;
		else
			hi = share;
	}
}

int traj_plan(struct traj *tr, const struct traj_ref *from, const float goal[3])
{
	if (!finite3(from->pose) || !finite3(from->vel) || !finite3(goal))
		return -EINVAL;
	const float th_goal = from->pose[2] + wrap_pi(goal[2] - from->pose[2]);
	const bool rot_idle = bb_idle(from->pose[2], from->vel[2], th_goal);
	const bool tr_idle = bb_idle(from->pose[0], from->vel[0], goal[0]) &&
	                     bb_idle(from->pose[1], from->vel[1], goal[1]);
	const float s = tr->c.rot_share;

	if (rot_idle || tr_idle) {
		tr->duration_s =
		    plan_share(tr, from, goal, tr_idle ? 1.0f : 0.0f, rot_idle, tr_idle);
	} else {
		float e[2], dist;
		if (on_line(from, goal, e, &dist))
			share_bisect(tr, from, goal);
		else
			share_three(tr, from, goal, s);
	}
	tr->t_s = 0.0f;
	return 0;
}

void traj_eval(const struct traj *tr, float t_s, struct traj_ref *out)
{
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

	traj_eval(tr, tr->t_s, &now);
	return traj_plan(tr, &now, goal);
}

/* Wheel j's limit on a along dir: value p a + q within +-bound (p > 0 or p < 0). */
static float acc_room(float p, float q, float bound)
{
	if (p > 0.0f)
		return (bound - q) / p;
	if (p < 0.0f)
		return (bound + q) / -p;
	return fabsf(q) <= bound ? INFINITY : -INFINITY;
}

int traj_envelope(const struct traj *tr, const float dir[2], float speed_m_s, float *acc_m_s2,
                  float *speed_max_m_s)
{
	if (!isfinite(dir[0]) || !isfinite(dir[1]) || !isfinite(speed_m_s) || speed_m_s < 0.0f ||
	    fabsf(dir[0] * dir[0] + dir[1] * dir[1] - 1.0f) > 1e-3f)
		return -EINVAL;
	const struct traj_coef *c = &tr->c;
	const float sg[2] = {dir[0] > 0.0f   ? 1.0f
	                     : dir[0] < 0.0f ? -1.0f
	                                     : 0.0f,
	                     dir[1] > 0.0f   ? 1.0f
	                     : dir[1] < 0.0f ? -1.0f
	                                     : 0.0f};
	float acc = INFINITY, top = c->speed_cap_m_s;

	for (int j = 0; j < 4; j++) {
		const float gx = g_xy[j][0], gy = g_xy[j][1];
		const float ge = gx * dir[0] + gy * dir[1]; /* rim speed per unit speed */
		/* f_j = p a + q0 + q1 s (the feedforward's shares Fv/2, Fvn/2), u_j = (f_j + e_j ge
		 * s)/b_j */
		const float p = 0.5f * c->M * ge;
		const float q0 = 0.5f * (gx * c->C[0] * sg[0] + gy * c->C[1] * sg[1]);
		const float q1 = 0.5f * (gx * c->B[0] * dir[0] + gy * c->B[1] * dir[1]);
		const float s = speed_m_s;
		acc = minf(acc, acc_room(p, q0 + q1 * s, c->f_max_n));
		acc = minf(acc, acc_room(p, q0 + (q1 + c->e[j] * ge) * s, c->u_max_v * c->b[j]));
		/* top speed: where the room reaches 0 (room falls linearly with s) */
		const float k_u = p >= 0.0f ? q1 + c->e[j] * ge : -(q1 + c->e[j] * ge);
		const float r_u = c->u_max_v * c->b[j] - (p >= 0.0f ? q0 : -q0);
		const float k_f = p >= 0.0f ? q1 : -q1, r_f = c->f_max_n - (p >= 0.0f ? q0 : -q0);
		if (ge == 0.0f)
			continue;
		top = minf(top, k_u > 0.0f ? r_u / k_u : r_u < 0.0f ? 0.0f : INFINITY);
		top = minf(top, k_f > 0.0f ? r_f / k_f : r_f < 0.0f ? 0.0f : INFINITY);
		top = minf(top, c->rim_max[j] / fabsf(ge));
	}
	*acc_m_s2 = acc;
	*speed_max_m_s = maxf(top, 0.0f);
	return 0;
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
