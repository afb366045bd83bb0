/* traction.c - the traction limit of the reference shaping and its slip back-off (traction.h). */
#include "omni4/core/traction.h"

#include <math.h>

static float sgnf(float x)
{
	return x > 0.0f ? 1.0f : (x < 0.0f ? -1.0f : 0.0f);
}

void traction_reset(struct traction *t)
{
	t->backoff = 1.0f;
	t->scale = 1.0f;
}

void traction_set(struct traction *t, const struct model_params *p, const struct model_wheels *w,
                  const struct wheel_geom *g, double mu, double margin, double com_height, float dt)
{
	const float keep_backoff = t->backoff > 0.0f ? t->backoff : 1.0f;
	struct wheel_geom paper;
	struct wheel_phys ph;

	if (!g) {
		wheel_geom_paper(p->d, &paper);
		g = &paper;
	}
	const bool wheels_ok = wheel_phys_init(&ph, g, p, w, com_height) == 0;

	if (wheels_ok) /* (the forces and holds asked of a limit that is off too) */
		wheel_phys_to_f32(&ph, &t->ph);
	t->on = mu > 0.0 && wheels_ok;
	t->mu = (float)mu;
	t->keep = (float)(1.0 - margin);
	t->M = (float)p->M;
	t->J = (float)p->J;
	t->B[0] = (float)p->Bv;
	t->B[1] = (float)p->Bvn;
	t->B[2] = (float)p->Bw;
	t->C[0] = (float)p->Cv;
	t->C[1] = (float)p->Cvn;
	t->C[2] = (float)p->Cw;
	t->recover = dt / TRACTION_RECOVER_S;
	t->backoff = keep_backoff;
	t->scale = 1.0f;
}

void traction_clamp_volts(const struct traction *t, const float ref[3], const float acc[3],
                          const float rim_m_s[4], float volts[4], float taken[4])
{
	float hold[4];

	for (int j = 0; j < 4; j++)
		taken[j] = 0.0f;
	if (!t->on)
		return;
	traction_wheel_holds(t, ref, acc, hold);
	for (int j = 0; j < 4; j++) {
		const float emf = t->ph.kemf[j] * rim_m_s[j], span = hold[j] * t->ph.vpn[j];
		const float u = fminf(fmaxf(volts[j], emf - span), emf + span);

		taken[j] = volts[j] - u;
		volts[j] = u;
	}
}

/* The friction the reference must overcome at x (at rest: against the acceleration a). */
static void friction(const struct traction *t, const float x[3], const float a[3], float F[3])
{
	for (int k = 0; k < 3; k++) {
		const float s = x[k] != 0.0f ? sgnf(x[k]) : sgnf(a[k]);

		F[k] = t->B[k] * x[k] + t->C[k] * s;
	}
}

void traction_wheel_forces(const struct traction *t, const float x[3], const float a[3], float f[4])
{
	float F[3];

	friction(t, x, a, F);
	F[0] += t->M * a[0];
	F[1] += t->M * a[1];
	F[2] += t->J * a[2];
	wheel_split_f32(&t->ph, F, f);
}

void traction_wheel_holds(const struct traction *t, const float x[3], const float a[3],
                          float hold[4])
{
	const float c = t->backoff * t->keep * t->mu;
	float ac[2];

	wheel_com_accel_f32(x, a, ac);
	wheel_loads_f32(&t->ph, ac, hold);
	for (int j = 0; j < 4; j++)
		hold[j] *= c;
}

/* Largest s in [0, 1] with |fa s + ff| <= c (n0 - k s) for every wheel (two linear bounds
 * each; a bound that larger s relaxes never binds below 1). */
static float largest_scale(const float fa[4], const float ff[4], const float n0[4],
                           const float k[4], float c)
{
	float s = 1.0f;

	for (int j = 0; j < 4; j++) {
		const float coef[2] = {fa[j] + c * k[j], c * k[j] - fa[j]};
		const float rhs[2] = {c * n0[j] - ff[j], c * n0[j] + ff[j]};

		for (int i = 0; i < 2; i++) {
			if (coef[i] > 0.0f && rhs[i] < s * coef[i])
				s = rhs[i] / coef[i];
		}
	}
	return s > 0.0f ? s : 0.0f;
}

void traction_step(struct traction *t, const float prev[3], float ref[3], float acc[3],
                   bool slipping)
{
	t->scale = 1.0f;
	if (!t->on)
		return;
	if (slipping)
		t->backoff = fmaxf(TRACTION_BACKOFF_MIN, t->backoff * TRACTION_BACKOFF);
	else
		t->backoff = fminf(1.0f, t->backoff + t->recover);

	const float zero[3] = {0.0f, 0.0f, 0.0f};
	const float wa[3] = {t->M * acc[0], t->M * acc[1], t->J * acc[2]};
	float fa[4], ff[4], Ff[3], n0[4], k[4], ac0[2];
	const struct wheel_phys_f32 *ph = &t->ph;

	wheel_split_f32(ph, wa, fa);
	friction(t, prev, acc, Ff);
	wheel_split_f32(ph, Ff, ff);
	wheel_com_accel_f32(prev, zero, ac0); /* the centripetal part: not scaled */
	for (int j = 0; j < 4; j++) {         /* the load, linear in s: n0 - k s */
		n0[j] = ph->load0[j] + ph->load_a[j][0] * ac0[0] + ph->load_a[j][1] * ac0[1];
		k[j] = -(ph->load_a[j][0] * acc[0] + ph->load_a[j][1] * acc[1]);
	}
	const float s = largest_scale(fa, ff, n0, k, t->backoff * t->keep * t->mu);

	if (s >= 1.0f)
		return;
	t->scale = s;
	for (int i = 0; i < 3; i++) {
		ref[i] = prev[i] + s * (ref[i] - prev[i]);
		acc[i] *= s;
	}
}
