/*
 * traj_1d.c - one axis of the trajectory generator (traj.h): the time-optimal bang-bang profile
 * with a top speed, its evaluation, and the phases the other planners append to it.
 */
#include <math.h>
#include <stdbool.h>

#include "traj_int.h"

void traj_1d_hold(struct traj_1d *o, float p)
{
	*o = (struct traj_1d){.p0 = p, .p1 = p, .goal = p};
}

bool traj_1d_idle(float p0, float v0, float goal)
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
	if (traj_1d_idle(p0, v0, goal)) {
		traj_1d_hold(o, goal);
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
