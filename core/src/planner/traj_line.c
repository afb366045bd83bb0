/*
 * traj_line.c - a straight profile in speed steps (docs/trajectory.md, "Straight moves"): along
 * a line every wheel's acceleration and velocity terms have one sign, so each row is exact in
 * (a, s) instead of over a box, the speed-up takes each step's acceleration at the step's top
 * speed (the room only shrinks with speed) and stopping gets the velocity's help at the step's
 * lowest speed (friction and back-EMF brake too). Single precision, fixed loops.
 */
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

/* Top speeds tried, as fractions of the largest the rows allow (acceleration 0 there). */
#define LINE_FRACS 6
static const float line_frac[LINE_FRACS] = {0.5f, 0.7f, 0.82f, 0.9f, 0.95f, 0.98f};

/* The rows along a line, divided by their acceleration coefficient: speeding up at speed s
 * a <= cu - k s, braking |a| <= cd + k s (the velocity terms oppose the acceleration); the
 * rows without an acceleration term (rim speed) only bound the top speed. */
#define LINE_ROWS_MAX (TRAJ_HEADINGS_MAX * 12)
struct line_rows {
	int n;
	float cu[LINE_ROWS_MAX], cd[LINE_ROWS_MAX], k[LINE_ROWS_MAX];
	float kd[LINE_ROWS_MAX]; /* braking: k less the turning body's term (either sign) */
	/* braking, traction rows: the velocity terms within what the load transfer leaves */
	float cl[LINE_ROWS_MAX], kl[LINE_ROWS_MAX];
	int nl;
	float top; /* largest speed with every row met at zero acceleration */
};

struct steps {
	float s[TRAJ_ACC_STEPS + 1];                  /* speed levels, s[0] = 0, s[K] = the top */
	float up[TRAJ_ACC_STEPS], dn[TRAJ_ACC_STEPS]; /* accelerations between them */
};

static void line_rows(const struct row *r, int n, float ex, float ey, struct line_rows *l)
{
	l->n = l->nl = 0;
	l->top = INFINITY;
	for (int k = 0; k < n; k++) {
		const float pl = fabsf(r[k].sl[0] * ex + r[k].sl[1] * ey);
		const float sa = r[k].sa[0] * ex + r[k].sa[1] * ey;
		const float sv = r[k].sv[0] * ex + r[k].sv[1] * ey;
		const float pa = fabsf(sa) + pl, pv0 = fabsf(sv);
		const float pv = pv0 + r[k].kc;
		/* a wheel whose velocity terms do not oppose its braking (another layout's split
		 * can give the force and the rim speed opposite signs along e) brakes without
		 * credit */
		const bool credit = r[k].credit && sa * sv >= 0.0f;
		if (pv > 0.0f)
			l->top = minf(l->top, r[k].c / pv);
		else if (r[k].c < 0.0f)
			l->top = 0.0f;
		if (pa > 0.0f) {
			const float ia = 1.0f / pa;
			l->cu[l->n] = r[k].c * ia;
			l->cd[l->n] = (credit ? r[k].c0 : r[k].c) * ia;
			l->kd[l->n] = credit ? (pv0 - r[k].kc) * ia : -pv * ia;
			l->k[l->n++] = pv * ia;
		}
		if (pl > 0.0f) {
			l->cl[l->nl] = r[k].c / pl;
			l->kl[l->nl++] = pv / pl;
		}
	}
	l->top = maxf(l->top, 0.0f);
}

/* Speeding up at speed s (up) and braking at speed s (dn). */
static void line_acc(const struct line_rows *l, float s, float *up, float *dn)
{
	float u = INFINITY, d = INFINITY;

	for (int k = 0; k < l->n; k++) {
		u = minf(u, l->cu[k] - l->k[k] * s);
		d = minf(d, l->cd[k] + l->kd[k] * s);
	}
	for (int k = 0; k < l->nl; k++)
		d = minf(d, l->cl[k] - l->kl[k] * s);
	*up = u;
	*dn = d;
}

/* Braking from |w| to rest: each step's acceleration (the top one also above the top). */
static float brake_dist(const struct steps *st, float w)
{
	float d = 0.0f;

	for (int k = 0; k < TRAJ_ACC_STEPS && w > st->s[k]; k++) {
		const float hi = k == TRAJ_ACC_STEPS - 1 ? w : minf(w, st->s[k + 1]);
		d += (hi * hi - st->s[k] * st->s[k]) / (2.0f * st->dn[k]);
	}
	return d;
}

/* Phases braking from speed w (velocity sign sg) to rest. */
static void brake_phases(struct traj_1d *o, const struct steps *st, float sg, float *t, float *p,
                         float *v)
{
	const float w = fabsf(*v);

	for (int k = TRAJ_ACC_STEPS - 1; k >= 0; k--) {
		const float hi = k == TRAJ_ACC_STEPS - 1 ? w : minf(w, st->s[k + 1]);
		if (hi > st->s[k])
			traj_ph_add(o, t, p, v, -sg * st->dn[k], (hi - st->s[k]) / st->dn[k]);
	}
	*v = 0.0f;
}

/* From speed u (toward the goal, 0 <= u <= top, able to stop) to the goal D away. */
static void go_phases(struct traj_1d *o, const struct steps *st, float sg, float u, float D,
                      float *t, float *p, float *v)
{
	float tot = brake_dist(st, u), vp = st->s[TRAJ_ACC_STEPS], cruise = 0.0f;
	int k = 0;

	for (; k < TRAJ_ACC_STEPS; k++) {
		if (st->s[k + 1] <= u)
			continue;
		const float lo = maxf(st->s[k], u), hi = st->s[k + 1];
		const float per = 0.5f / st->up[k] + 0.5f / st->dn[k];
		const float next = tot + (hi * hi - lo * lo) * per;
		if (next >= D) {
			vp = sqrtf(maxf(lo * lo + (D - tot) / per, lo * lo));
			break;
		}
		tot = next;
	}
	if (k == TRAJ_ACC_STEPS)
		cruise = maxf(D - tot, 0.0f);
	for (int j = 0; j < TRAJ_ACC_STEPS; j++) {
		const float lo = maxf(st->s[j], u), hi = minf(st->s[j + 1], vp);
		if (hi > lo)
			traj_ph_add(o, t, p, v, sg * st->up[j], (hi - lo) / st->up[j]);
	}
	o->p1 = *p;
	o->v1 = sg * vp;
	*v = o->v1;
	if (cruise > 0.0f && vp > 0.0f)
		traj_ph_add(o, t, p, v, 0.0f, cruise / vp);
	brake_phases(o, st, sg, t, p, v);
}

/* One profile with the steps st: stop first if moving away or too fast to stop in time. */
static float steps_plan(const struct steps *st, float p0, float v0, float goal, struct traj_1d *o)
{
	float t = 0.0f, p = p0, v = v0;
	const float d0 = goal - p0;

	*o = (struct traj_1d){.p0 = p0, .v0 = v0, .p1 = p0, .goal = goal};
	if (fabsf(v0) > st->s[TRAJ_ACC_STEPS])
		return INFINITY;
	if (v0 * d0 < 0.0f || brake_dist(st, fabsf(v0)) > fabsf(d0))
		brake_phases(o, st, v0 > 0.0f ? 1.0f : -1.0f, &t, &p, &v);
	const float D = fabsf(goal - p), sg = goal - p >= 0.0f ? 1.0f : -1.0f;
	if (D > 0.0f || v != 0.0f)
		go_phases(o, st, sg, fabsf(v), D, &t, &p, &v);
	return t;
}

/* The steps up to vmax: each level's accelerations from the rows; false if one is not > 0
 * (brake_only: only the braking ones are asked for, a stop from vmax). */
static bool line_steps(const struct line_rows *l, float vmax, bool brake_only, struct steps *st)
{
	float up, dn;

	for (int k = 0; k <= TRAJ_ACC_STEPS; k++) {
		st->s[k] = vmax * (float)k / (float)TRAJ_ACC_STEPS;
		line_acc(l, st->s[k], &up, &dn);
		if (k > 0)
			st->up[k - 1] = up;
		if (k > 0) /* braking may be weakest at either end of a step (kd of either sign) */
			st->dn[k - 1] = minf(st->dn[k - 1], dn);
		if (k < TRAJ_ACC_STEPS)
			st->dn[k] = dn;
		if ((!brake_only && k > 0 && !(up > 0.0f)) || !(dn > 0.0f))
			return false;
	}
	return true;
}

float traj_line_stop(const struct row *r, int n, float ex, float ey, float sp, struct traj_1d *o)
{
	struct line_rows l;
	struct steps st;
	float t = 0.0f, p = 0.0f, v = sp;

	*o = (struct traj_1d){.v0 = sp};
	line_rows(r, n, ex, ey, &l);
	if (!line_steps(&l, sp, true, &st))
		return INFINITY;
	if (sp > 0.0f)
		brake_phases(o, &st, 1.0f, &t, &p, &v);
	o->p1 = p;
	o->goal = p;
	return t;
}

float traj_line_plan(const struct row *r, int n, float ex, float ey, float p0, float v0, float goal,
                     float cap, struct traj_1d *o)
{
	struct line_rows l;
	struct traj_1d cand;
	float best = INFINITY;

	line_rows(r, n, ex, ey, &l);
	const float top = minf(l.top, cap);
	for (int f = 0; f < LINE_FRACS; f++) {
		const float vmax = maxf(top * line_frac[f], fabsf(v0));
		struct steps st;
		if (!(vmax <= top) || !line_steps(&l, vmax, false, &st))
			continue;
		const float t = steps_plan(&st, p0, v0, goal, &cand);
		if (t < best) {
			best = t;
			*o = cand;
		}
	}
	return best;
}

void traj_line_project(const struct traj_1d *line, float e, float p0, float goal,
                       struct traj_1d *out)
{
	*out = (struct traj_1d){.p0 = p0,
	                        .v0 = e * line->v0,
	                        .p1 = p0 + e * line->p1,
	                        .v1 = e * line->v1,
	                        .goal = goal,
	                        .n = line->n};
	for (int k = 0; k < line->n; k++) {
		out->t_end_s[k] = line->t_end_s[k];
		out->acc[k] = e * line->acc[k];
		out->ps[k] = p0 + e * line->ps[k];
		out->vs[k] = e * line->vs[k];
	}
}

/* Appends line's phases projected on an axis (share e, from p0), shifted by t0 [s]. */
static void append_projected(struct traj_1d *out, const struct traj_1d *line, float e, float p0,
                             float t0)
{
	for (int k = 0; k < line->n && out->n < TRAJ_PHASES; k++, out->n++) {
		out->t_end_s[out->n] = t0 + line->t_end_s[k];
		out->acc[out->n] = e * line->acc[k];
		out->ps[out->n] = p0 + e * line->ps[k];
		out->vs[out->n] = e * line->vs[k];
	}
}

float traj_line_brake_go(const struct row *r, int n, const float p0[2], const float v0[2],
                         const float goal[2], float cap, struct traj_1d out[2])
{
	const float sp = sqrtf(v0[0] * v0[0] + v0[1] * v0[1]);
	struct line_rows l;
	struct steps st;
	struct traj_1d a = {.v0 = sp}, b = {.n = 0};
	float t = 0.0f, p = 0.0f, v = sp, t2 = 0.0f;

	if (!(sp > 0.0f))
		return INFINITY;
	const float ev[2] = {v0[0] / sp, v0[1] / sp};
	line_rows(r, n, ev[0], ev[1], &l);
	if (!(sp <= minf(l.top, cap)) || !line_steps(&l, sp, false, &st))
		return INFINITY;
	brake_phases(&a, &st, 1.0f, &t, &p, &v);
	const float stop[2] = {p0[0] + ev[0] * p, p0[1] + ev[1] * p};
	const float dx = goal[0] - stop[0], dy = goal[1] - stop[1];
	const float D = sqrtf(dx * dx + dy * dy);
	const float eg[2] = {D > 0.0f ? dx / D : 0.0f, D > 0.0f ? dy / D : 0.0f};
	if (D >= TRAJ_IDLE_POS)
		t2 = traj_line_plan(r, n, eg[0], eg[1], 0.0f, 0.0f, D, cap, &b);
	if (!(t2 < INFINITY) || a.n + b.n > TRAJ_PHASES)
		return INFINITY;
	for (int i = 0; i < 2; i++) {
		out[i] = (struct traj_1d){.p0 = p0[i],
		                          .v0 = v0[i],
		                          .p1 = stop[i] + eg[i] * b.p1,
		                          .v1 = eg[i] * b.v1,
		                          .goal = goal[i]};
		append_projected(&out[i], &a, ev[i], p0[i], 0.0f);
		append_projected(&out[i], &b, eg[i], stop[i], t);
	}
	return t + t2;
}
