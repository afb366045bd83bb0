/* ctl_blocks.c - PI, ramp, reference shaper and offset calibration (see ctl_blocks.h). */
#include "omni4/core/ctl_blocks.h"

#include <math.h>
#include <string.h>

static float clampf(float x, float lim)
{
	return x > lim ? lim : (x < -lim ? -lim : x);
}

void ctl_pi_set_gains(struct ctl_pi *s, float kp, float ki, float dt, float limit)
{
	s->kp = kp;
	s->ki_dt = ki * dt;
	s->limit = limit;
}

void ctl_pi_init(struct ctl_pi *s, float kp, float ki, float dt, float limit)
{
	ctl_pi_set_gains(s, kp, ki, dt, limit);
	ctl_pi_reset(s);
}

void ctl_pi_reset(struct ctl_pi *s)
{
	s->integ = 0.0f;
}

float ctl_pi_step(struct ctl_pi *s, float ff, float e)
{
	const float p = s->kp * e;
	const float unsat = ff + p + s->integ;

	/* Anti-windup: integrate unless it would push further into saturation. */
	if (!(fabsf(unsat) >= s->limit && e * unsat > 0.0f))
		s->integ = clampf(s->integ + s->ki_dt * e, s->limit);
	return clampf(ff + p + s->integ, s->limit);
}

void ctl_ramp_start(struct ctl_ramp *r, const float from[4], const float to[4], float len_s,
                    int64_t now_us)
{
	memcpy(r->from, from, sizeof(r->from));
	memcpy(r->to, to, sizeof(r->to));
	r->t0_us = now_us;
	r->len_us = (int64_t)lroundf(len_s * 1e6f);
}

void ctl_ramp_reset(struct ctl_ramp *r, const float hold[4])
{
	ctl_ramp_start(r, hold, hold, 0.0f, 0);
}

bool ctl_ramp_step(const struct ctl_ramp *r, int64_t now_us, float out[4])
{
	const int64_t el = now_us - r->t0_us;
	const bool done = r->len_us <= 0 || el >= r->len_us;
	const float frac = done ? 1.0f : (float)el / (float)r->len_us;

	for (int j = 0; j < 4; j++)
		out[j] = done ? r->to[j] : r->from[j] + (r->to[j] - r->from[j]) * frac;
	return done;
}

void ctl_shaper_init(struct ctl_shaper *s, const float acc_max[3], float dt)
{
	for (int k = 0; k < 3; k++)
		s->max_step[k] = acc_max[k] * dt;
	s->inv_dt = 1.0f / dt;
	memset(s->ref, 0, sizeof(s->ref));
	memset(s->acc, 0, sizeof(s->acc));
}

void ctl_shaper_reset(struct ctl_shaper *s, const float ref[3])
{
	memcpy(s->ref, ref, sizeof(s->ref));
	memset(s->acc, 0, sizeof(s->acc));
}

void ctl_shaper_step(struct ctl_shaper *s, const float target[3])
{
	for (int k = 0; k < 3; k++) {
		const float step = clampf(target[k] - s->ref[k], s->max_step[k]);

		s->ref[k] += step;
		s->acc[k] = step * s->inv_dt;
	}
}

void ctl_cal_init(struct ctl_cal *c, const struct ctl_cal_cfg *cfg)
{
	memset(c, 0, sizeof(*c));
	c->cfg = *cfg;
}

void ctl_cal_restart(struct ctl_cal *c)
{
	c->n = 0;
}

/* The measurement of c->n readings is complete: its means and variances; true if they come
 * into force. */
static bool cal_finish(struct ctl_cal *c)
{
	const float n = (float)c->n;
	float mean[4], var[4];
	bool take = c->gen == 0;

	for (int j = 0; j < 4; j++) {
		mean[j] = c->ref[j] + c->sum[j] / n;
		var[j] = fmaxf(0.0f, (c->sum2[j] - c->sum[j] * c->sum[j] / n) / (n - 1.0f));
		const float d = mean[j] - c->offset[j];
		const float k = c->cfg.change_sigmas;
		const float min2 = c->cfg.change_min_a * c->cfg.change_min_a;
		const float thr2 = fmaxf(min2, k * k * (var[j] + c->var[j]) / n);

		if (d * d > thr2)
			take = true;
	}
	c->n = 0;
	if (!take)
		return false;
	memcpy(c->prev, c->offset, sizeof(c->prev));
	c->prev_fault_mask = c->fault_mask;
	c->fault_mask = 0;
	for (int j = 0; j < 4; j++) {
		c->offset[j] = mean[j];
		c->var[j] = var[j];
		if (fabsf(mean[j]) > c->cfg.limit_a)
			c->fault_mask |= 1u << j;
	}
	c->gen++;
	return true;
}

bool ctl_cal_step(struct ctl_cal *c, int64_t now_us, bool bridges_off, const float *current)
{
	if (!bridges_off) {
		c->off = false;
		c->n = 0;
		return false;
	}
	if (!c->off) {
		c->off = true;
		c->off_since_us = now_us;
	}
	if (!current || now_us - c->off_since_us < c->cfg.settle_us)
		return false;
	if (c->n == 0) {
		memcpy(c->ref, current, sizeof(c->ref));
		memset(c->sum, 0, sizeof(c->sum));
		memset(c->sum2, 0, sizeof(c->sum2));
	}
	for (int j = 0; j < 4; j++) {
		const float x = current[j] - c->ref[j];

		c->sum[j] += x;
		c->sum2[j] += x * x;
	}
	if (++c->n < c->cfg.samples)
		return false;
	return cal_finish(c);
}
