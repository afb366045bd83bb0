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

/* Golden sections of the top speed between the start's speed and the largest the rows allow
 * (acceleration 0 there; the cap tried as it is): a lower top leaves larger steps of
 * acceleration below it. */
#define LINE_TOP_SECTIONS 12
#define LINE_AXIS_ZERO 2e-7f /* a unit direction's component below this is 0 (its rounding), */
#define LINE_AXIS_SURE 1e-3f /* below this of either sign (as the path timing's SIGN_MIN) */

/* The rows along a line, divided by their acceleration coefficient: speeding up at speed s
 * a <= cu - k s, braking |a| <= cd + k s (the velocity terms oppose the acceleration); the
 * rows without an acceleration term (rim speed) only bound the top speed. */
#define LINE_ROWS_MAX TRAJ_ROWS_MAX
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

/* A row's room along the unit direction (ex, ey) and whether braking along it gets the
 * velocity terms' credit. At a fixed heading both are exact: the Coulomb friction of each body
 * axis with the sign the line gives it (none where the line does not move along the axis),
 * and the credit where the acceleration term, the velocity terms and that friction all have
 * one sign along the line. Else the row's own: the worst sign, its credit flag. */
static float line_room(const struct row *r, float ex, float ey, float sa, float sv, bool *credit)
{
	*credit = r->credit && sa * sv >= 0.0f;
	if (!r->fixed)
		return r->c;
	const float b[2] = {r->ph[0] * ex + r->ph[1] * ey, -r->ph[1] * ex + r->ph[0] * ey};
	float ce = 0.0f, unsure = 0.0f;
	for (int i = 0; i < 2; i++) {
		if (fabsf(b[i]) >= LINE_AXIS_SURE)
			ce += b[i] > 0.0f ? r->cs[i] : -r->cs[i];
		else if (fabsf(b[i]) > LINE_AXIS_ZERO) /* too small to trust its sign: either */
			unsure += fabsf(r->cs[i]);
	}
	*credit = unsure == 0.0f && ((sa >= 0.0f && sv >= 0.0f && ce >= 0.0f) ||
	                             (sa <= 0.0f && sv <= 0.0f && ce <= 0.0f));
	return r->c0 - fabsf(ce) - unsure;
}

static void line_rows(const struct row *r, int n, float ex, float ey, struct line_rows *l)
{
	l->n = l->nl = 0;
	l->top = INFINITY;
	for (int k = 0; k < n; k++) {
		const float pl = fabsf(r[k].sl[0] * ex + r[k].sl[1] * ey);
		const float sa = r[k].sa[0] * ex + r[k].sa[1] * ey;
		const float sv = r[k].sv[0] * ex + r[k].sv[1] * ey;
		bool credit; /* a wheel whose velocity terms do not oppose its braking (another
		              * layout's split can give the force and the rim speed opposite signs
		              * along e) brakes without credit */
		const float c = line_room(&r[k], ex, ey, sa, sv, &credit);
		const float pa = fabsf(sa) + pl, pv0 = fabsf(sv);
		const float pv = pv0 + r[k].kc;
		if (pv > 0.0f)
			l->top = minf(l->top, c / pv);
		else if (c < 0.0f)
			l->top = 0.0f;
		if (pa > 0.0f) {
			const float ia = 1.0f / pa;
			l->cu[l->n] = c * ia;
			l->cd[l->n] = (credit ? r[k].c0 : c) * ia;
			l->kd[l->n] = credit ? (pv0 - r[k].kc) * ia : -pv * ia;
			l->k[l->n++] = pv * ia;
		}
		if (pl > 0.0f) {
			l->cl[l->nl] = c / pl;
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

/* A search of the top speed: the profile with top speed vmax, the soonest kept in o. */
struct line_search {
	const struct line_rows *l;
	float p0, v0, goal;
	float best;
	struct traj_1d *o;
};

static float line_try(struct line_search *ls, float vmax)
{
	struct steps st;
	struct traj_1d cand;
	float t = INFINITY;

	if (line_steps(ls->l, vmax, false, &st))
		t = steps_plan(&st, ls->p0, ls->v0, ls->goal, &cand);
	if (t < ls->best) {
		ls->best = t;
		*ls->o = cand;
	}
	return t;
}

float traj_line_plan(const struct row *r, int n, float ex, float ey, float p0, float v0, float goal,
                     float cap, struct traj_1d *o)
{
	const float gr = 0.618034f; /* (sqrt(5) - 1) / 2 */
	struct line_rows l;
	struct line_search ls = {
	    .l = &l, .p0 = p0, .v0 = v0, .goal = goal, .best = INFINITY, .o = o};

	line_rows(r, n, ex, ey, &l);
	float a = fabsf(v0), b = minf(l.top, cap);
	if (!(a <= b) || !(b > 0.0f))
		return INFINITY; /* beyond the top speed, or no speed at all */
	/* the duration falls, then rises, with the top speed (no time) where a step has no room */
	if (cap < l.top) /* the cap itself (the search only comes near it) */
		line_try(&ls, b);
	float x1 = b - gr * (b - a), x2 = a + gr * (b - a);
	float f1 = line_try(&ls, x1), f2 = line_try(&ls, x2);
	for (int it = 0; it < LINE_TOP_SECTIONS; it++) {
		if (f1 <= f2) {
			b = x2;
			x2 = x1;
			f2 = f1;
			x1 = b - gr * (b - a);
			f1 = line_try(&ls, x1);
		} else {
			a = x1;
			x1 = x2;
			f1 = f2;
			x2 = a + gr * (b - a);
			f2 = line_try(&ls, x2);
		}
	}
	return ls.best;
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
