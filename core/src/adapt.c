/* adapt.c - each motor's resistance estimated online (RLS on eq 21), accepted into the
 * feedforward once certain, reverted if tracking worsens (adapt.h). */
#include "omni4/core/adapt.h"

#include "omni4/core/vocab.h"

#include <math.h>
#include <string.h>

void adapt_settings_from_keys(const struct ctl_settings *cfg, struct adapt_settings *s)
{
	s->on = cfg->adapt.enable && cfg->adapt.resistance;
	s->forget = (float)cfg->adapt.forget;
	s->current_min_a = (float)cfg->adapt.current_min_a;
	s->variance_gate = (float)cfg->adapt.variance_gate;
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

uint32_t adapt_retune(struct adapt *a, const struct ctl_settings *cfg)
{
	struct adapt fresh;
	uint32_t mask = 0;

	adapt_init(&fresh, cfg);
	if (memcmp(fresh.R_id, a->R_id, sizeof(a->R_id)) ||
	    memcmp(fresh.kvl, a->kvl, sizeof(a->kvl)) || fresh.bin_len != a->bin_len) {
		*a = fresh;
		return 0;
	}
	a->set = fresh.set;
	a->holdoff_ticks = fresh.holdoff_ticks;
	if (!a->set.on) {
		a->watch = false;
		(void)use(a, a->R_id);
	}
	for (int j = 0; j < 4; j++)
		if (a->R_use[j] != a->R_id[j])
			mask |= 1u << j;
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

uint32_t adapt_accept(struct adapt *a, const float R[4])
{
	float next[4];

	for (int j = 0; j < 4; j++) {
		const float lo = ADAPT_R_MIN * a->R_id[j], hi = ADAPT_R_MAX * a->R_id[j];

		next[j] = isfinite(R[j]) ? fminf(hi, fmaxf(lo, R[j])) : a->R_use[j];
	}
	memcpy(a->R_prev, a->R_use, sizeof(a->R_prev));
	a->before_ms = window_ms(a);
	a->watch = true;
	a->after_e2 = 0.0f;
	a->after_n = 0;
	a->flags |= ADAPT_FLAG_ACCEPTED;
	a->accepted++;
	return use(a, next);
}

/* The estimates certain enough and far enough from the R in use, taken all at once. */
static uint32_t maybe_accept(struct adapt *a)
{
	float next[4];
	bool any = false;

	if (a->watch || a->holdoff || window_ms(a) < 0.0f)
		return 0;
	for (int j = 0; j < 4; j++) {
		const float R = a->m[j].R, v = variance(a, j);

		next[j] = a->R_use[j];
		if (v < a->set.variance_gate * R * R &&
		    fabsf(R - a->R_use[j]) > ADAPT_ACCEPT_SHARE * a->R_use[j]) {
			next[j] = R;
			any = true;
		}
	}
	return any ? adapt_accept(a, next) : 0;
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
	return use(a, a->R_prev);
}

uint32_t adapt_step(struct adapt *a, const struct adapt_input *in)
{
	uint32_t mask = 0;

	if (in->supply_v > 0.0f)
		a->supply_v = in->supply_v;
	if (!a->set.on) {
		a->mode_prev = in->mode;
		if (in->tracking && isfinite(in->track_e2)) {
			a->rep_e2 += in->track_e2;
			a->rep_n++;
		}
		return 0;
	}
	if (in->reading && may_take(a, in))
		take(a, in);
	else if (in->reading)
		a->flags |= ADAPT_FLAG_FROZEN;
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
