/*
 * drive_consts.h - what a CAN drive backend that takes currents or torques needs of the robot's
 * model to turn the HAL's voltages into them: the gearbox and each wheel's Kv, Kt and R, plain
 * numbers the robot's opener hands in (firmware/ robot_vesc.c, robot_odrive.c) and replaces
 * when the settings change. The physics is the model's (motor_currents_wheels, eq 21).
 */
#ifndef OMNI4_DRIVE_CONSTS_H
#define OMNI4_DRIVE_CONSTS_H

#include <math.h>

#include "omni4/model/dynamics.h"
#include "omni4/model/params.h"

struct drive_consts {
	double gear;           /* gearbox reduction l: motor speed = l x wheel speed */
	struct model_wheels w; /* each wheel's r, Kv, Kt, R */
};

/* Fast loop. Each wheel's motor current for its voltage at the wheel's measured speed
 * [rad/s, after the gearbox]: eq 21 (L neglected) solved for i, i_j = (u_j - Kv_j l w_j) / R_j.
 * NaN where the speed is NaN (not measured). */
static inline void drive_currents(const struct drive_consts *c, const float volts[4],
                                  const float wheel_rad_s[4], float current_a[4])
{
	double u[4], wm[4], i[4];

	for (int j = 0; j < 4; j++) {
		u[j] = volts[j];
		wm[j] = c->gear * (double)wheel_rad_s[j];
	}
	motor_currents_wheels(&c->w, u, wm, i);
	for (int j = 0; j < 4; j++)
		current_a[j] = (float)i[j];
}

#endif /* OMNI4_DRIVE_CONSTS_H */
