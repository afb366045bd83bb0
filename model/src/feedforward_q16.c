/* feedforward_q16.c - the feedforward in Q16.16 (integer only: the fixed-point path). */
#include "omni4/feedforward.h"

#include "omni4/kinematics.h"

/* Dead-banded sign in Q16.16: clamp(x * gain, -1, 1). */
static q16_t sgn_q16(q16_t x, int32_t gain)
{
	return q16_clamp(q16_mul_int(x, gain), -Q16_ONE, Q16_ONE);
}

void ff_voltages_q16(const struct ff_q16 *ff, const q16_t vel[3], const q16_t acc[3], q16_t u[4])
{
	q16_t g[3]; /* per-axis drive share, already in volts */
	q16_t vw[4], uf[4];

	for (int k = 0; k < 3; k++) {
		q16_t s = q16_mul(ff->k_acc[k], acc[k]);

		s = q16_add(s, q16_mul(ff->k_visc[k], vel[k]));
		s = q16_add(s, q16_mul(ff->k_coul[k], sgn_q16(vel[k], ff->sgn_gain[k])));
		g[k] = s;
	}
	/* f_j = IK(d)[Fv/2, Fvn/2, T/(4d^2)] with d * T/(4d^2) = T/(4d): the w column is 1 here. */
	uf[0] = q16_add(g[1], g[2]);
	uf[1] = q16_sub(g[2], g[0]);
	uf[2] = q16_sub(g[2], g[1]);
	uf[3] = q16_add(g[0], g[2]);

	ik_wheel_speeds_q16(ff->d, vel, vw);
	for (int j = 0; j < 4; j++)
		u[j] = q16_clamp(q16_add(uf[j], q16_mul(ff->k_emf, vw[j])), q16_neg(ff->u_max),
				 ff->u_max);
}
