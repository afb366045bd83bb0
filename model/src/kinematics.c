/* kinematics.c - eqs 1-5, double. The Q16.16 twins live in kinematics_q16.c. */
#include "omni4/kinematics.h"

#include <math.h>

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
