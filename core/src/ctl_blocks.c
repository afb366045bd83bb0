/* ctl_blocks.c - PI, ramp and reference shaper (see ctl_blocks.h). */
#include "omni4/ctl_blocks.h"

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
