/* kinematics.c - eqs 1-5, double. The Q16.16 twins live in kinematics_q16.c. */
#include "omni4/model/kinematics.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "omni4/model/wheels.h"

void ik_wheel_speeds(double d, const double x[3], double v_wheel[4])
{
	const double dw = d * x[2];

	v_wheel[0] = x[1] + dw;
	v_wheel[1] = -x[0] + dw;
	v_wheel[2] = -x[1] + dw;
	v_wheel[3] = x[0] + dw;
}

void fk_robot_velocity(double d, const double v_wheel[4], double x[3])
{
	x[0] = 0.5 * (v_wheel[3] - v_wheel[1]);
	x[1] = 0.5 * (v_wheel[0] - v_wheel[2]);
	x[2] = (v_wheel[0] + v_wheel[1] + v_wheel[2] + v_wheel[3]) / (4.0 * d);
}

void frame_world_to_robot(double theta, const double x_world[3], double x_robot[3])
{
	const double c = cos(theta), s = sin(theta);
	const double vx = x_world[0], vy = x_world[1];

	x_robot[0] = c * vx + s * vy;
	x_robot[1] = -s * vx + c * vy;
	x_robot[2] = x_world[2];
}

void frame_robot_to_world(double theta, const double x_robot[3], double x_world[3])
{
	const double c = cos(theta), s = sin(theta);
	const double v = x_robot[0], vn = x_robot[1];

	x_world[0] = c * v - s * vn;
	x_world[1] = s * v + c * vn;
	x_world[2] = x_robot[2];
}

void ik_wheel_rates(double d, const double r[4], const double x[3], double wheel_rad_s[4])
{
	double v[4];

	ik_wheel_speeds(d, x, v);
	for (int j = 0; j < 4; j++)
		wheel_rad_s[j] = v[j] / r[j];
}

void fk_robot_velocity_rates(double d, const double r[4], const double wheel_rad_s[4], double x[3])
{
	double v[4];

	for (int j = 0; j < 4; j++)
		v[j] = wheel_rad_s[j] * r[j];
	fk_robot_velocity(d, v, x);
}

int kin_wheels_q16_init(struct kin_wheels_q16 *k, double d, const double r[4])
{
	const double r_min = 1.0 / 32768.0; /* 1/r_j must stay below the Q16.16 maximum */

	if (!(isfinite(d) && d > 0.0 && 1.0 / (4.0 * d) < 32768.0))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		if (!(r[j] >= r_min && r[j] < 1.0))
			return -EINVAL;
	k->d = q16_from_double(d);
	k->inv_4d = q16_from_double(1.0 / (4.0 * d));
	for (int j = 0; j < 4; j++) {
		const double q = r[j] * 2147483648.0 + 0.5; /* Q0.31, rounded; r < 1 */

		k->inv_r[j] = q16_from_double(1.0 / r[j]);
		k->r_q31[j] = q >= 2147483647.0 ? INT32_MAX : (int32_t)q;
	}
	return 0;
}

/* The layout's Q16.16 rows and inverse (kinematics.h), off the loop: the integer-only
 * evaluation is in kinematics_q16.c. */
int kin_rows_q16_init(struct kin_rows_q16 *k, double d, const struct wheel_geom *g)
{
	struct wheel_geom paper;
	struct wheel_phys ph;

	memset(k, 0, sizeof(*k));
	k->paper = g == NULL;
	if (!g) {
		if (!(d > 1.0 / 16384.0 && d < 32767.0))
			return -EINVAL;
		wheel_geom_paper(d, &paper);
		g = &paper;
		k->d = q16_from_double(d);
		k->inv_4d = q16_from_double(1.0 / (4.0 * d));
	}
	if (wheel_phys_layout(&ph, g))
		return -EINVAL;
	k->n = ph.n;
	for (int j = 0; j < ph.n; j++)
		for (int m = 0; m < 3; m++) {
			k->row[j][m] = q16_from_double(ph.row[j][m]);
			k->fk[m][j] = q16_from_double(ph.fk[m][j]);
		}
	return 0;
}
