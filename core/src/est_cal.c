/*
 * est_cal.c - the wheels' scale errors from the null space (est.h, EST_CAL_*): every reading
 * that fits a rigid body gives one linear equation in them; the equations, exponentially
 * forgotten, are solved by least squares (normal equations, a ridge prior, Cholesky).
 * Another four-wheel layout: the same with its null vector (e->nvec) for the signs; three
 * wheels have no null space and no equation: off.
 */
#include <math.h>

#include "est_priv.h"
#include "omni4/core/la_f32.h"

/* The scale errors k = N a with N's columns (1,-1,1,-1)/2, (1,1,-1,-1)/2, (1,-1,-1,1)/2: the
 * three patterns orthogonal to the common scale (1,1,1,1), which no equation fixes (k_j = -1 for
 * all j, every wheel read as 0, satisfies them all). */
static const float cal_N[4][3] = {
    {0.5f, 0.5f, 0.5f}, {-0.5f, 0.5f, -0.5f}, {0.5f, -0.5f, -0.5f}, {-0.5f, -0.5f, 0.5f}};

/* One reading's null-space equation sum_j s_j g_j k_j = -sum_j s_j g_j (g_j = r w_j, signs
 * s = +, -, +, -), in a, added to the forgotten normal equations. */
static void cal_accumulate(struct est *e, const float g[4])
{
	float phi[4] = {g[0], -g[1], g[2], -g[3]};

	for (int j = 0; e->layout && j < 4; j++) /* the layout's null vector */
		phi[j] = e->nvec[j] * g[j];
	const float y = -(phi[0] + phi[1] + phi[2] + phi[3]);
	const float lam = e->cal_forget;
	float q[3];
	int m = 0;

	for (int i = 0; i < 3; i++)
		q[i] = cal_N[0][i] * phi[0] + cal_N[1][i] * phi[1] + cal_N[2][i] * phi[2] +
		       cal_N[3][i] * phi[3];
	for (int i = 0; i < 3; i++) {
		e->cal_b[i] = lam * e->cal_b[i] + q[i] * y;
		for (int j = i; j < 3; j++, m++)
			e->cal_A[m] = lam * e->cal_A[m] + q[i] * q[j];
	}
}

/* a = (A + prior I)^-1 b (A + prior I is positive definite); k = N a, clamped. */
static void cal_solve(struct est *e)
{
	float L[6], a[3];

	if (la_chol3_f32(e->cal_A, EST_CAL_PRIOR, L))
		return;
	la_chol3_solve_f32(L, e->cal_b, a);
	for (int j = 0; j < 4; j++) {
		const float k = cal_N[j][0] * a[0] + cal_N[j][1] * a[1] + cal_N[j][2] * a[2];

		e->cal[j] = fminf(fmaxf(k, -EST_CAL_MAX), EST_CAL_MAX);
	}
}

void est_cal_step(struct est *e, const struct est_tick *t, uint32_t n)
{
	if (!e->set.calibrate || e->wh.n < 4)
		return; /* three wheels: no null space, no equation (docs/estimator.md) */
	/* a wheel flagged (the model's or the camera's witness) teaches nothing either (a slip
	 * that the null space sees only in part, the diagonal's, would be learnt as a scale
	 * error) */
	if (t->have_wheels && e->slip_run == 0 && e->collision_run == 0 && !t->untrusted)
		cal_accumulate(e, t->wheel);
	if (n % EST_CAL_EVERY == EST_CAL_EVERY - 1)
		cal_solve(e);
}
