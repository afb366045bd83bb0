/* adapt.c - each motor's resistance estimated online (RLS on eq 21), accepted into the
 * feedforward once certain, reverted if tracking worsens (adapt.h). */
#include "omni4/core/adapt.h"

#include "omni4/core/vocab.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/kinematics.h"

#include <math.h>
#include <string.h>

void adapt_settings_from_keys(const struct ctl_settings *cfg, struct adapt_settings *s)
{
	s->on = cfg->adapt.enable && cfg->adapt.resistance;
	s->forget = (float)cfg->adapt.forget;
	s->current_min_a = (float)cfg->adapt.current_min_a;
	s->variance_gate = (float)cfg->adapt.variance_gate;
	s->friction = cfg->adapt.enable && cfg->adapt.friction;
	s->friction_forget = (float)cfg->adapt.friction_forget;
	s->friction_variance_gate = (float)cfg->adapt.friction_variance_gate;
}

/* Axis k's fit from the values in use (B, C) again, under the prior about the identified. */
static void fric_restart(struct adapt_fric *f, float B, float C)
{
	f->th[0] = B;
	f->th[1] = C;
	/* the prior alone: I = I0, b = I0 theta with theta the values in use */
	memcpy(f->I, f->I0, sizeof(f->I));
	f->b[0] = f->I0[0] * B + f->I0[1] * C;
	f->b[1] = f->I0[1] * B + f->I0[2] * C;
	f->s2 = 0.0025f * C * C; /* (5 % of C)^2 before any sample */
	f->n = 0;
}

/* Axis k's prior information (adapt.h) from the identified B, C; off the fast loop. */
static void fric_prior(struct adapt_fric *f, double B, double C)
{
	const double p00 = B * B * (1.0 + ADAPT_FRIC_EPS), p01 = B * C,
	             p11 = C * C * (1.0 + ADAPT_FRIC_EPS);
	const double det = p00 * p11 - p01 * p01,
	             w = det > 0.0 ? ADAPT_FRIC_PRIOR * C * C / det : 0.0;

	f->I0[0] = (float)(w * p11);
	f->I0[1] = (float)(-w * p01);
	f->I0[2] = (float)(w * p00);
	f->b0[0] = (float)(w * (p11 * B - p01 * C));
	f->b0[1] = (float)(w * (p00 * C - p01 * B));
}

/* The model's maps from wheel currents to body force (eqs 12-13, 9-11) and from wheel speeds
 * to body velocity (eqs 3-5), column by column; off the fast loop. */
static void fric_maps(struct adapt *a, const struct ctl_settings *cfg, const struct model_wheels *w)
{
	struct wheel_geom geom;
	const struct wheel_geom *g = NULL;
	struct wheel_phys ph;

	/* (checked at the door: a layout that drives the body) */
	if (ctl_settings_layout(cfg, &geom, &g) || (g && wheel_phys_layout(&ph, g)))
		g = NULL;
	for (int j = 0; j < 4; j++) {
		double e[4] = {0.0, 0.0, 0.0, 0.0}, f[4], F[3], x[3], rim[4] = {0, 0, 0, 0};

		e[j] = 1.0;
		dyn_wheel_forces_wheels(&cfg->model, w, e, f);
		if (g) { /* the layout's G^T and eqs 3-5 (the paper's: their closed forms) */
			wheel_body_force(&ph, f, F);
			rim[j] = w->r[j];
			wheel_body(&ph, rim, x);
		} else {
			dyn_robot_forces(cfg->model.d, f, F);
			fk_robot_velocity_rates(cfg->model.d, w->r, e, x);
		}
		for (int k = 0; k < 3; k++) {
			a->Gi[k][j] = (float)F[k];
			a->Gw[k][j] = (float)x[k];
		}
	}
}

static void fric_init(struct adapt *a, const struct ctl_settings *cfg, const struct model_wheels *w)
{
	const struct model_params *p = &cfg->model;
	const double B[3] = {p->Bv, p->Bvn, p->Bw}, C[3] = {p->Cv, p->Cvn, p->Cw};
	const double inertia[3] = {p->M, p->M, p->J};
	const double blk = ADAPT_FRIC_BLOCK_S * cfg->rate_hz;

	fric_maps(a, cfg, w);
	a->blk_len = blk < 1.0 ? 1u : (uint32_t)lround(blk);
	for (int k = 0; k < 3; k++) {
		a->B_id[k] = a->B_use[k] = a->B_prev[k] = (float)B[k];
		a->C_id[k] = a->C_use[k] = a->C_prev[k] = (float)C[k];
		a->v_min[k] = k < 2 ? ADAPT_FRIC_V_MIN_LIN : ADAPT_FRIC_V_MIN_ROT;
		/* the steady bound and the inertia force over the span of ADAPT_FRIC_SPAN blocks */
		const double span_s = (double)ADAPT_FRIC_SPAN * a->blk_len / cfg->rate_hz;

		a->dv_max[k] = (float)(ADAPT_FRIC_STEADY * C[k] / inertia[k] * span_s);
		a->m_dt[k] = (float)(inertia[k] / span_s);
		a->df_max[k] = (float)(ADAPT_FRIC_F_STEADY * C[k]);
		fric_prior(&a->f[k], B[k], C[k]);
		fric_restart(&a->f[k], a->B_id[k], a->C_id[k]);
	}
}

/* Motor j's estimate from R (its prior) again. */
static void rls_restart(struct adapt_rls *m, float R)
{
	m->R = R;
	m->P = ADAPT_P0;
	m->s2 = ADAPT_S2_0;
	m->n = 0;
}

static void clear_window(struct adapt *a)
{
	memset(a->bin_e2, 0, sizeof(a->bin_e2));
	memset(a->bin_n, 0, sizeof(a->bin_n));
	a->bin = 0;
	a->after_e2 = 0.0f;
	a->after_n = 0;
	a->watch = false;
}

void adapt_init(struct adapt *a, const struct ctl_settings *cfg)
{
	struct model_wheels w;

	memset(a, 0, sizeof(*a));
	ctl_settings_wheels(cfg, &w);
	adapt_settings_from_keys(cfg, &a->set);
	for (int j = 0; j < 4; j++) {
		a->R_id[j] = (float)w.R[j];
		a->R_use[j] = a->R_id[j];
		a->R_prev[j] = a->R_id[j];
		a->kvl[j] = (float)(w.Kv[j] * cfg->model.l);
		rls_restart(&a->m[j], a->R_id[j]);
	}
	fric_init(a, cfg, &w);
	const double ticks = ADAPT_WINDOW_S * cfg->rate_hz / ADAPT_BINS;

	a->bin_len = ticks < 1.0 ? 1u : (uint32_t)lround(ticks);
	a->holdoff_ticks = (uint32_t)lround(ADAPT_HOLDOFF_S * cfg->rate_hz);
	a->mode_prev = -1;
	clear_window(a);
}

/* The R in use back to R (each motor), as a mask of the motors that changed. */
static uint32_t use(struct adapt *a, const float R[4])
{
	uint32_t mask = 0;

	for (int j = 0; j < 4; j++) {
		if (a->R_use[j] != R[j])
			mask |= 1u << j;
		a->R_use[j] = R[j];
	}
	return mask;
}

/* The friction in use to B, C: ADAPT_CHANGED_FRICTION if any value changed. */
static uint32_t use_friction(struct adapt *a, const float B[3], const float C[3])
{
	uint32_t mask = 0;

	for (int k = 0; k < 3; k++) {
		if (a->B_use[k] != B[k] || a->C_use[k] != C[k])
			mask = ADAPT_CHANGED_FRICTION;
		a->B_use[k] = B[k];
		a->C_use[k] = C[k];
	}
	return mask;
}

uint32_t adapt_retune(struct adapt *a, const struct adapt *fresh)
{
	uint32_t mask = 0;

	if (memcmp(fresh->R_id, a->R_id, sizeof(a->R_id)) ||
	    memcmp(fresh->kvl, a->kvl, sizeof(a->kvl)) || fresh->bin_len != a->bin_len ||
	    memcmp(fresh->B_id, a->B_id, sizeof(a->B_id)) ||
	    memcmp(fresh->C_id, a->C_id, sizeof(a->C_id)) ||
	    memcmp(fresh->Gi, a->Gi, sizeof(a->Gi)) || memcmp(fresh->Gw, a->Gw, sizeof(a->Gw)) ||
	    memcmp(fresh->m_dt, a->m_dt, sizeof(a->m_dt)) || fresh->blk_len != a->blk_len) {
		*a = *fresh;
		return 0;
	}
	a->set = fresh->set;
	a->holdoff_ticks = fresh->holdoff_ticks;
	if (!a->set.on) {
		a->watch = false;
		(void)use(a, a->R_id);
	}
	if (!a->set.friction) {
		a->watch = false;
		(void)use_friction(a, a->B_id, a->C_id);
	}
	for (int j = 0; j < 4; j++)
		if (a->R_use[j] != a->R_id[j])
			mask |= 1u << j;
	for (int k = 0; k < 3; k++)
		if (a->B_use[k] != a->B_id[k] || a->C_use[k] != a->C_id[k])
			mask |= ADAPT_CHANGED_FRICTION;
	return mask;
}

/* One sample of motor j: y = R i (eq 21, L neglected), RLS with forgetting lambda. */
static void rls_step(struct adapt *a, int j, float i, float y)
{
	struct adapt_rls *m = &a->m[j];
	const float lambda = a->set.forget;
	const float e = y - m->R * i;
	const float Pi = m->P * i;
	const float g = Pi / (lambda + i * Pi);
	const float lo = ADAPT_R_MIN * a->R_id[j], hi = ADAPT_R_MAX * a->R_id[j];
	/* the residual's variance: a running mean until 1 / (1 - lambda) samples, then forgotten */
	const float n_mem = lambda < 1.0f ? 1.0f / (1.0f - lambda) : 4294967295.0f;

	m->R += g * e;
	m->P = (m->P - g * Pi) / lambda;
	if (m->n < 4294967295u)
		m->n++;
	m->s2 += (e * e - m->s2) / fminf((float)m->n, n_mem);
	if (!isfinite(m->R) || !isfinite(m->P) || !isfinite(m->s2) || !(m->P > 0.0f)) {
		rls_restart(m, a->R_use[j]);
		a->flags |= ADAPT_FLAG_RESTART;
		return;
	}
	m->R = fminf(hi, fmaxf(lo, m->R));
	a->flags |= ADAPT_FLAG_FED;
}

static float variance(const struct adapt *a, int j)
{
	return a->m[j].s2 * a->m[j].P / (1.0f + a->set.forget);
}

/* Whether this tick's reading may be taken at all (not motor by motor). */
static bool may_take(const struct adapt *a, const struct adapt_input *in)
{
	if (in->faulted || !in->driven || !mode_drives(in->mode) || in->mode != a->mode_prev)
		return false;
	if (in->est_flags & EST_FLAG_SLIP)
		return false;                         /* a wheel's current does not turn it */
	return !(in->est_flags & EST_FLAG_COLLISION); /* pushed or blocked */
}

static void take(struct adapt *a, const struct adapt_input *in)
{
	const float u_lim = in->supply_v > 0.0f ? ADAPT_U_SHARE * in->supply_v : INFINITY;

	for (int j = 0; j < 4; j++) {
		const float u = in->volts[j], i = in->current_a[j], w = in->wheel_rad_s[j];

		if (!isfinite(u) || !isfinite(i) || !isfinite(w))
			continue;
		if (fabsf(i) <= a->set.current_min_a || fabsf(u) >= u_lim ||
		    fabsf(u - a->u_prev[j]) > ADAPT_DU_MAX_V)
			continue;
		rls_step(a, j, i, u - a->kvl[j] * w);
	}
}

/* One sample of axis k: F = B x + C sgn(x) (eq 23, steady), least squares with forgetting in
 * information form, forgotten toward the prior. */
static void fric_sample(struct adapt *a, int k, float x, float sgn, float F)
{
	struct adapt_fric *f = &a->f[k];
	const float lambda = a->set.friction_forget, mu = 1.0f - lambda;
	const float e = F - f->th[0] * x - f->th[1] * sgn;
	const float n_mem = mu > 0.0f ? 1.0f / mu : 4294967295.0f;

	f->I[0] = lambda * f->I[0] + x * x + mu * f->I0[0];
	f->I[1] = lambda * f->I[1] + x * sgn + mu * f->I0[1];
	f->I[2] = lambda * f->I[2] + sgn * sgn + mu * f->I0[2];
	f->b[0] = lambda * f->b[0] + x * F + mu * f->b0[0];
	f->b[1] = lambda * f->b[1] + sgn * F + mu * f->b0[1];
	const float det = f->I[0] * f->I[2] - f->I[1] * f->I[1];
	const float B = (f->I[2] * f->b[0] - f->I[1] * f->b[1]) / det;
	const float C = (f->I[0] * f->b[1] - f->I[1] * f->b[0]) / det;

	if (f->n < 4294967295u)
		f->n++;
	f->s2 += (e * e - f->s2) / fminf((float)f->n, n_mem);
	if (!isfinite(B) || !isfinite(C) || !isfinite(f->s2) || !(det > 0.0f)) {
		fric_restart(f, a->B_use[k], a->C_use[k]);
		a->flags |= ADAPT_FLAG_RESTART;
		return;
	}
	f->th[0] = fminf(ADAPT_F_MAX * a->B_id[k], fmaxf(ADAPT_F_MIN * a->B_id[k], B));
	f->th[1] = fminf(ADAPT_F_MAX * a->C_id[k], fmaxf(ADAPT_F_MIN * a->C_id[k], C));
	a->flags |= ADAPT_FLAG_FED;
}

/* A block's means as samples of the axes that moved one way throughout it and the
 * ADAPT_FRIC_SPAN blocks before, and whose mean velocity changed over that span by less than the
 * steady bound (over one block the encoders' counts hide a small acceleration). */
static void fric_block(struct adapt *a)
{
	const float inv_n = 1.0f / (float)a->blk_n;
	const int oldest = (a->blk_i + 1) % (ADAPT_FRIC_SPAN + 1);
	bool steady = true; /* every axis's force and velocity held over the span */

	for (int k = 0; k < 3; k++) {
		const float F = a->blk_F[k] * inv_n, x = a->blk_x[k] * inv_n;

		a->blk_hist[k][a->blk_i] = x;
		a->blk_fhist[k][a->blk_i] = F;
		steady = steady && fabsf(x - a->blk_hist[k][oldest]) < a->dv_max[k];
		for (int i = 0; i <= ADAPT_FRIC_SPAN; i++)
			steady = steady && fabsf(a->blk_fhist[k][i] - F) < a->df_max[k];
	}
	for (int k = 0; k < 3; k++) {
		const float x = a->blk_hist[k][a->blk_i];
		const bool moving = a->blk_ok && a->blk_sgn[k] != 0.0f &&
		                    (a->blk_run[k] == 0 || a->blk_sgn[k] == a->blk_sgn_run[k]);

		a->blk_run[k] = moving && a->blk_run[k] < 65535u ? a->blk_run[k] + 1u : 0u;
		a->blk_sgn_run[k] = a->blk_sgn[k];
		if (!steady || a->blk_run[k] <= ADAPT_FRIC_SPAN ||
		    !(a->C_id[k] > 0.0f && a->B_id[k] > 0.0f))
			continue;
		const float dx = x - a->blk_hist[k][oldest];

		/* the inertia force M a left in is at most ADAPT_FRIC_STEADY of C; taken out */
		fric_sample(a, k, x, a->blk_sgn[k], a->blk_fhist[k][a->blk_i] - a->m_dt[k] * dx);
	}
	a->blk_i = oldest;
}

/* This tick's body force and velocity into the block (24 products); a tick that may not be
 * taken spoils its block. */
static void fric_tick(struct adapt *a, const struct adapt_input *in, bool ok)
{
	float F[3] = {0.0f, 0.0f, 0.0f}, x[3] = {0.0f, 0.0f, 0.0f};

	for (int j = 0; j < 4; j++) {
		ok = ok && isfinite(in->current_a[j]) && isfinite(in->wheel_rad_s[j]);
		for (int k = 0; k < 3; k++) {
			F[k] += a->Gi[k][j] * in->current_a[j];
			x[k] += a->Gw[k][j] * in->wheel_rad_s[j];
		}
	}
	if (a->blk_n == 0) {
		a->blk_ok = true;
		for (int k = 0; k < 3; k++) {
			a->blk_F[k] = a->blk_x[k] = 0.0f;
			a->blk_sgn[k] = x[k] > 0.0f ? 1.0f : -1.0f;
		}
	}
	a->blk_ok = a->blk_ok && ok;
	for (int k = 0; k < 3; k++) {
		if (!(x[k] * a->blk_sgn[k] > a->v_min[k]))
			a->blk_sgn[k] = 0.0f; /* not moving, or turned */
		a->blk_F[k] += F[k];
		a->blk_x[k] += x[k];
	}
	if (++a->blk_n < a->blk_len)
		return;
	fric_block(a);
	a->blk_n = 0;
}

/* The tracking error of this tick into the window's bins and, under watch, the after sum. */
static void track(struct adapt *a, const struct adapt_input *in)
{
	if (!in->tracking || !isfinite(in->track_e2))
		return;
	a->rep_e2 += in->track_e2;
	a->rep_n++;
	if (a->bin_n[a->bin] >= a->bin_len) {
		a->bin = (a->bin + 1) % ADAPT_BINS;
		a->bin_e2[a->bin] = 0.0f;
		a->bin_n[a->bin] = 0;
	}
	a->bin_e2[a->bin] += in->track_e2;
	a->bin_n[a->bin]++;
	if (a->watch) {
		a->after_e2 += in->track_e2;
		a->after_n++;
	}
}

/* The window before, as a mean square; < 0 until it holds most of a window. */
static float window_ms(const struct adapt *a)
{
	float e2 = 0.0f;
	uint32_t n = 0;

	for (int k = 0; k < ADAPT_BINS; k++) {
		e2 += a->bin_e2[k];
		n += a->bin_n[k];
	}
	return n >= (ADAPT_BINS - 1) * a->bin_len ? e2 / (float)n : -1.0f;
}

/* The values in use now become the ones a revert puts back; the watch starts. */
static void watch_start(struct adapt *a)
{
	memcpy(a->R_prev, a->R_use, sizeof(a->R_prev));
	memcpy(a->B_prev, a->B_use, sizeof(a->B_prev));
	memcpy(a->C_prev, a->C_use, sizeof(a->C_prev));
	a->before_ms = window_ms(a);
	a->watch = true;
	a->after_e2 = 0.0f;
	a->after_n = 0;
	a->flags |= ADAPT_FLAG_ACCEPTED;
	a->accepted++;
}

static float bound(float v, float id, float lo, float hi, float keep)
{
	return isfinite(v) ? fminf(hi * id, fmaxf(lo * id, v)) : keep;
}

uint32_t adapt_accept(struct adapt *a, const float R[4])
{
	float next[4];

	for (int j = 0; j < 4; j++)
		next[j] = bound(R[j], a->R_id[j], ADAPT_R_MIN, ADAPT_R_MAX, a->R_use[j]);
	watch_start(a);
	return use(a, next);
}

uint32_t adapt_accept_friction(struct adapt *a, const float B[3], const float C[3])
{
	float nb[3], nc[3];

	for (int k = 0; k < 3; k++) {
		nb[k] = bound(B[k], a->B_id[k], ADAPT_F_MIN, ADAPT_F_MAX, a->B_use[k]);
		nc[k] = bound(C[k], a->C_id[k], ADAPT_F_MIN, ADAPT_F_MAX, a->C_use[k]);
	}
	watch_start(a);
	return use_friction(a, nb, nc);
}

static float fric_variance(const struct adapt *a, int k)
{
	const struct adapt_fric *f = &a->f[k];
	const float det = f->I[0] * f->I[2] - f->I[1] * f->I[1];

	return f->s2 * f->I[0] / det / (1.0f + a->set.friction_forget); /* C's: (I^-1)_11 */
}

/* The axes whose friction estimate is certain enough and far enough from the one in use. */
static bool fric_candidates(const struct adapt *a, float B[3], float C[3])
{
	bool any = false;

	for (int k = 0; k < 3; k++) {
		const float c = a->f[k].th[1];

		B[k] = a->B_use[k];
		C[k] = a->C_use[k];
		if (a->set.friction &&
		    fric_variance(a, k) < a->set.friction_variance_gate * c * c &&
		    fabsf(c - a->C_use[k]) > ADAPT_FRIC_ACCEPT_SHARE * a->C_use[k]) {
			B[k] = a->f[k].th[0];
			C[k] = c;
			any = true;
		}
	}
	return any;
}

/* The estimates certain enough and far enough from the values in use, taken all at once. */
static uint32_t maybe_accept(struct adapt *a)
{
	float next[4], B[3], C[3];
	bool any = false;

	if (a->watch || a->holdoff || window_ms(a) < 0.0f)
		return 0;
	for (int j = 0; j < 4; j++) {
		const float R = a->m[j].R, v = variance(a, j);

		next[j] = a->R_use[j];
		if (a->set.on && v < a->set.variance_gate * R * R &&
		    fabsf(R - a->R_use[j]) > ADAPT_ACCEPT_SHARE * a->R_use[j]) {
			next[j] = R;
			any = true;
		}
	}
	any = fric_candidates(a, B, C) || any;
	if (!any)
		return 0;
	watch_start(a);
	return use(a, next) | use_friction(a, B, C);
}

/* After a whole window of tracking under watch: keep, or put the previous values back. */
static uint32_t judge(struct adapt *a)
{
	if (!a->watch || a->after_n < ADAPT_BINS * a->bin_len)
		return 0;
	const float after = a->after_e2 / (float)a->after_n;

	a->watch = false;
	if (!(a->before_ms >= 0.0f) || after <= ADAPT_REVERT_RATIO * a->before_ms)
		return 0;
	a->flags |= ADAPT_FLAG_REVERTED;
	a->reverted++;
	a->holdoff = a->holdoff_ticks;
	for (int j = 0; j < 4; j++)
		if (a->R_use[j] != a->R_prev[j])
			rls_restart(&a->m[j], a->R_prev[j]);
	for (int k = 0; k < 3; k++)
		if (a->B_use[k] != a->B_prev[k] || a->C_use[k] != a->C_prev[k])
			fric_restart(&a->f[k], a->B_prev[k], a->C_prev[k]);
	return use(a, a->R_prev) | use_friction(a, a->B_prev, a->C_prev);
}

uint32_t adapt_step(struct adapt *a, const struct adapt_input *in)
{
	uint32_t mask = 0;

	if (in->supply_v > 0.0f)
		a->supply_v = in->supply_v;
	if (!a->set.on && !a->set.friction) {
		a->mode_prev = in->mode;
		if (in->tracking && isfinite(in->track_e2)) {
			a->rep_e2 += in->track_e2;
			a->rep_n++;
		}
		return 0;
	}
	const bool ok = in->reading && may_take(a, in);

	if (ok && a->set.on)
		take(a, in);
	else if (in->reading && !ok)
		a->flags |= ADAPT_FLAG_FROZEN;
	if (in->reading && a->set.friction)
		fric_tick(a, in, ok);
	if (in->reading)
		memcpy(a->u_prev, in->volts, sizeof(a->u_prev));
	a->mode_prev = in->mode;
	if (a->holdoff)
		a->holdoff--;
	track(a, in);
	mask |= judge(a);
	mask |= maybe_accept(a);
	return mask;
}

void adapt_report(struct adapt *a, struct adapt_report *out)
{
	uint32_t f = a->flags & (ADAPT_FLAG_FED | ADAPT_FLAG_FROZEN | ADAPT_FLAG_ACCEPTED |
	                         ADAPT_FLAG_REVERTED | ADAPT_FLAG_RESTART);

	if (a->set.on)
		f |= ADAPT_FLAG_ON;
	for (int k = 0; k < 3; k++) {
		out->B[k] = a->B_use[k];
		out->C[k] = a->C_use[k];
		out->C_est[k] = a->f[k].th[1];
		out->C_var[k] = fric_variance(a, k);
		if (a->B_use[k] != a->B_id[k] || a->C_use[k] != a->C_id[k])
			f |= ADAPT_FLAG_ADAPTED;
	}
	if (a->watch)
		f |= ADAPT_FLAG_WATCH;
	for (int j = 0; j < 4; j++) {
		out->R[j] = a->R_use[j];
		out->R_est[j] = a->m[j].R;
		out->var[j] = variance(a, j);
		if (a->R_use[j] != a->R_id[j])
			f |= ADAPT_FLAG_ADAPTED;
	}
	out->supply_v = a->supply_v;
	out->track_rms = a->rep_n ? sqrtf(a->rep_e2 / (4.0f * (float)a->rep_n)) : 0.0f;
	out->flags = f;
	a->flags = 0;
	a->rep_e2 = 0.0f;
	a->rep_n = 0;
}
