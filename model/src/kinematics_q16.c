/* kinematics_q16.c - eqs 2-5 in Q16.16 (integer only: this file is the fixed-point path). */
#include "omni4/model/kinematics.h"

void ik_wheel_speeds_q16(q16_t d, const q16_t x[3], q16_t v_wheel[4])
{
	/* d*w stays in int64_t (|.| <= 2^46): each wheel saturates once, and x is read once
	 * (v_wheel may alias x). */
	const int64_t dw = q16_mul_wide(d, x[2]);
	const int64_t v = x[0], vn = x[1];

	v_wheel[0] = q16_sat(vn + dw);
	v_wheel[1] = q16_sat(dw - v);
	v_wheel[2] = q16_sat(dw - vn);
	v_wheel[3] = q16_sat(v + dw);
}

/* Halve a 64-bit Q16.16 value, rounding to nearest, and saturate. */
static q16_t half_round(int64_t s)
{
	return q16_sat(s >= 0 ? (s + 1) / 2 : -((-s + 1) / 2));
}

void fk_robot_velocity_q16(q16_t inv_4d, const q16_t v_wheel[4], q16_t x[3])
{
	const int64_t sum = (int64_t)v_wheel[0] + v_wheel[1] + v_wheel[2] + v_wheel[3];
	const int64_t half = (int64_t)1 << 15;
	int64_t p; /* Q32.32 */

	if (__builtin_mul_overflow(sum, (int64_t)inv_4d, &p))
		p = (sum < 0) != (inv_4d < 0) ? INT64_MIN / 2 : INT64_MAX / 2; /* saturates below */

	x[0] = half_round((int64_t)v_wheel[3] - v_wheel[1]);
	x[1] = half_round((int64_t)v_wheel[0] - v_wheel[2]);
	p = p >= 0 ? (p + half) >> 16 : -((-p + half) >> 16);
	x[2] = q16_sat(p);
}

void ik_wheel_rates_q16(const struct kin_wheels_q16 *k, const q16_t x[3], q16_t wheel_rad_s[4])
{
	q16_t v[4];

	ik_wheel_speeds_q16(k->d, x, v);
	for (int j = 0; j < 4; j++)
		wheel_rad_s[j] = q16_mul(v[j], k->inv_r[j]);
}

void fk_robot_velocity_rates_q16(const struct kin_wheels_q16 *k, const q16_t wheel_rad_s[4],
                                 q16_t x[3])
{
	const int64_t half = (int64_t)1 << 30;
	q16_t v[4];

	for (int j = 0; j < 4; j++) {
		const int64_t p = (int64_t)wheel_rad_s[j] * k->r_q31[j]; /* Q16.47 */

		v[j] = (q16_t)(p >= 0 ? (p + half) >> 31 : -((-p + half) >> 31));
	}
	fk_robot_velocity_q16(k->inv_4d, v, x);
}

void ik_rows_q16(const struct kin_rows_q16 *k, const q16_t x[3], q16_t v_wheel[4])
{
	if (k->paper) {
		ik_wheel_speeds_q16(k->d, x, v_wheel);
		return;
	}
	for (int j = 0; j < 4; j++) {
		int64_t s = 0;

		for (int m = 0; m < 3 && j < k->n; m++)
			s += q16_mul_wide(k->row[j][m], x[m]);
		v_wheel[j] = q16_sat(s);
	}
}

void fk_rows_q16(const struct kin_rows_q16 *k, const q16_t v_wheel[4], q16_t x[3])
{
	if (k->paper) {
		fk_robot_velocity_q16(k->inv_4d, v_wheel, x);
		return;
	}
	for (int m = 0; m < 3; m++) {
		int64_t s = 0;

		for (int j = 0; j < k->n; j++)
			s += q16_mul_wide(k->fk[m][j], v_wheel[j]);
		x[m] = q16_sat(s);
	}
}
