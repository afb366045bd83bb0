/* feedforward_q16.c - the feedforward in Q16.16 (integer only: the fixed-point path). */
#include "omni4/model/feedforward.h"

/*
 * Per axis k, in volts (Q16.16 held in int64_t, never saturated on the way):
 *   h_k = k_acc[k] a_k + k_vel[k] v_k + k_coul[k] sgn(v_k)
 * and per wheel (eq 2 with the w column folded into the gains):
 *   u = [h1 + h2, h2 - h0, h2 - h1, h0 + h2], clamped to +-u_max.
 * Bounds: every coefficient and input is an int32_t, so each rounded product is below 2^46 in
 * magnitude (the sign term below 2^31), h_k below 2^48 and u_j below 2^49: int64_t cannot
 * overflow for any input, and the one clamp at the end is the only saturation.
 */
static int64_t axis_volts(const struct ff_q16 *ff, int k, q16_t v, q16_t a)
{
	int64_t sgn = (int64_t)v * ff->sgn_gain[k]; /* dead-banded sign, Q16.16 in [-1, 1] */

	sgn = sgn > Q16_ONE ? Q16_ONE : (sgn < -Q16_ONE ? -Q16_ONE : sgn);
	return q16_mul_wide(ff->k_acc[k], a) + q16_mul_wide(ff->k_vel[k], v) +
	       q16_mul_wide(ff->k_coul[k], (q16_t)sgn);
}

static q16_t clamp_volts(int64_t u, q16_t u_max)
{
	return (q16_t)(u > u_max ? u_max : (u < -(int64_t)u_max ? -u_max : u));
}

void ff_voltages_q16(const struct ff_q16 *ff, const q16_t vel[3], const q16_t acc[3], q16_t u[4])
{
	const int64_t h0 = axis_volts(ff, 0, vel[0], acc[0]);
	const int64_t h1 = axis_volts(ff, 1, vel[1], acc[1]);
	const int64_t h2 = axis_volts(ff, 2, vel[2], acc[2]);

	u[0] = clamp_volts(h1 + h2, ff->u_max);
	u[1] = clamp_volts(h2 - h0, ff->u_max);
	u[2] = clamp_volts(h2 - h1, ff->u_max);
	u[3] = clamp_volts(h0 + h2, ff->u_max);
}

/* The dead-banded sign of v on axis k, Q16.16 in [-1, 1]. */
static q16_t axis_sign(const struct ff_q16_wheels *ff, int k, q16_t v)
{
	const int64_t sgn = (int64_t)v * ff->sgn_gain[k];

	return (q16_t)(sgn > Q16_ONE ? Q16_ONE : (sgn < -Q16_ONE ? -Q16_ONE : sgn));
}

/* axis_volts with wheel j's gains and the axis' sign s computed once per tick. */
static int64_t wheel_axis_volts(const struct ff_q16_wheels *ff, int j, int k, q16_t v, q16_t a,
                                q16_t s)
{
	return q16_mul_wide(ff->k_acc[j][k], a) + q16_mul_wide(ff->k_vel[j][k], v) +
	       q16_mul_wide(ff->k_coul[j][k], s);
}

void ff_voltages_q16_wheels(const struct ff_q16_wheels *ff, const q16_t vel[3], const q16_t acc[3],
                            q16_t u[4])
{
	const q16_t s[3] = {axis_sign(ff, 0, vel[0]), axis_sign(ff, 1, vel[1]),
	                    axis_sign(ff, 2, vel[2])};

	/* Each wheel's axis terms with their signs (the paper's layout: wheel 0 = vn + w,
	 * 1 = w - v, 2 = w - vn, 3 = v + w); integer sums, exact in any order. */
	for (int j = 0; j < 4; j++) {
		int64_t uj = 0;

		for (int k = 0; k < 3 && j < ff->n; k++)
			if (ff->sign[j][k])
				uj += ff->sign[j][k] *
				      wheel_axis_volts(ff, j, k, vel[k], acc[k], s[k]);
		u[j] = clamp_volts(uj, ff->u_max);
	}
}
