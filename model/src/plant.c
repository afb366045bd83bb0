/* plant.c - exact per-axis integration of eq 23 with Coulomb friction and stiction. */
#include "omni4/plant.h"

#include "omni4/kinematics.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

static double sgn(double x)
{
	return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0);
}

/* Solution of x' = a x + f from x0 after t (zero-order hold). */
static double lin_solve(double a, double f, double x0, double t)
{
	if (fabs(a) < 1e-12)
		return x0 + f * t;
	const double xss = -f / a;

	return xss + (x0 - xss) * exp(a * t);
}

/* Time for x' = a x + f to go from x0 to 0 (the caller knows it does within the step). */
static double lin_time_to_zero(double a, double f, double x0)
{
	if (fabs(a) < 1e-12)
		return -x0 / f;
	const double xss = -f / a;

	return log(xss / (xss - x0)) / a;
}

/* One axis x' = a x + b - c sgn(x) over dt, with stiction at zero. */
static double axis_step(double a, double b, double c, double x, double dt)
{
	double s = sgn(x);

	if (s == 0.0) {
		if (fabs(b) <= c)
			return 0.0;
		s = sgn(b);
	}
	const double f = b - c * s;
	const double xn = lin_solve(a, f, x, dt);

	if (x == 0.0 || sgn(xn) == s)
		return xn;
	/* Friction stopped the axis inside the step: stop at zero, maybe break away again. */
	double t0 = lin_time_to_zero(a, f, x);

	if (!(t0 >= 0.0) || t0 > dt)
		t0 = dt;
	if (fabs(b) <= c)
		return 0.0;
	return lin_solve(a, b - c * sgn(b), 0.0, dt - t0);
}

int plant_init(struct plant *pl, const struct model_params *p)
{
	if (model_params_check(p, NULL))
		return -EINVAL;
	pl->p = *p;
	dyn_state_space(p, &pl->ss);
	plant_reset(pl);
	return 0;
}

void plant_reset(struct plant *pl)
{
	for (int k = 0; k < 3; k++) {
		pl->x[k] = 0.0;
		pl->pose[k] = 0.0;
	}
	for (int j = 0; j < 4; j++) {
		pl->current_a[j] = 0.0;
		pl->voltage_v[j] = 0.0;
	}
	pl->driven = false;
}

void plant_step(struct plant *pl, const double u[4], bool driven, double dt)
{
	const struct model_ss *ss = &pl->ss;
	const double x_old[3] = {pl->x[0], pl->x[1], pl->x[2]};

	for (int k = 0; k < 3; k++) {
		double b = 0.0;

		if (driven)
			for (int j = 0; j < 4; j++)
				b += ss->B[k][j] * u[j];
		pl->x[k] = axis_step(driven ? ss->A[k] : ss->A_coast[k], b, -ss->K[k], pl->x[k], dt);
	}

	/* World pose: eq 1 inverted with the mid-step heading and mean velocity. */
	const double x_mid[3] = {0.5 * (x_old[0] + pl->x[0]), 0.5 * (x_old[1] + pl->x[1]),
				 0.5 * (x_old[2] + pl->x[2])};
	double xw[3];

	frame_robot_to_world(pl->pose[2] + 0.5 * dt * x_mid[2], x_mid, xw);
	for (int k = 0; k < 3; k++)
		pl->pose[k] += dt * xw[k];

	double vw[4];

	ik_wheel_speeds(pl->p.d, pl->x, vw);
	for (int j = 0; j < 4; j++) {
		pl->voltage_v[j] = driven ? u[j] : 0.0;
		pl->current_a[j] =
			driven ? motor_current(&pl->p, u[j], motor_speed_rad_s(&pl->p, vw[j])) : 0.0;
	}
	pl->driven = driven;
}

void plant_wheel_speeds(const struct plant *pl, double wheel_rad_s[4])
{
	double vw[4];

	ik_wheel_speeds(pl->p.d, pl->x, vw);
	for (int j = 0; j < 4; j++)
		wheel_rad_s[j] = vw[j] / pl->p.r;
}
