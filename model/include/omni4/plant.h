/*
 * plant.h - simulator of the robot of eq 23 with Coulomb friction and stiction.
 *
 * The axes of eq 23 are decoupled (A, K diagonal), so each axis is integrated exactly over a
 * step with zero-order-hold input: x' = a x + b - c sgn(x). A velocity that would cross zero
 * stops at zero for the rest of the step; at zero it stays while |b| <= c (stiction) and
 * breaks away in the direction of b otherwise. With the channels disabled (null traction,
 * the paper's experiment 2) there is no drive and no back-EMF braking: a = -B/M (-Bw/J).
 * The world pose integrates eq 1 inverted, with the mid-step heading.
 */
#ifndef OMNI4_PLANT_H
#define OMNI4_PLANT_H

#include <stdbool.h>

#include "omni4/dynamics.h"
#include "omni4/params.h"

struct plant {
	struct model_params p;
	struct model_ss ss;
	double x[3];          /* robot velocity [v m/s, vn m/s, w rad/s] */
	double pose[3];       /* world pose [x m, y m, theta rad] */
	double current_a[4];  /* motor currents [A] */
	double voltage_v[4];  /* voltages applied in the last step [V] */
	bool driven;          /* H-bridges on in the last step */
};

/* -EINVAL if p fails model_params_check. Starts at rest at the origin. */
int plant_init(struct plant *pl, const struct model_params *p);
void plant_reset(struct plant *pl);

/*
 * Advance by dt [s] with voltages u [V] held (driven) or with the H-bridges off
 * (driven = false: u ignored, currents 0).
 */
void plant_step(struct plant *pl, const double u[4], bool driven, double dt);

/* Wheel angular speeds after the gearbox [rad/s]: v_j / r. */
void plant_wheel_speeds(const struct plant *pl, double wheel_rad_s[4]);

#endif /* OMNI4_PLANT_H */
