/*
 * can_limits.h - the SocketCAN backend's plausibility limits (struct sc_limits: plain numbers)
 * from a robot's controller settings. The adapter computes them, so the driver knows nothing
 * of the controller or the model (derivation in docs/faults.md):
 * current_step = 2 supply / R + SC_CURRENT_NOISE_MARGIN_A + 1 LSB (L neglected: a full-scale
 * voltage reversal moves the current by 2 supply / R at once); speed_step = a_max dt / r + 2 LSB
 * with a_max = f_max (2/M + 4 d^2/J), f_max = l Kt (2 supply / R) / r (all four wheels at the
 * largest force, worst-case signs: the largest linear acceleration of one wheel's rim); the
 * current limit is limits.current_max_a; N = 3. With each drive's own R_j, Kt_j, r_j
 * (ctl_settings_wheels) the worst wheel sets each: the largest 2 supply / R_j and l Kt_j i_j / r_j,
 * the smallest r_j. The STATUS period is the loop period.
 */
#ifndef OMNI4_CAN_LIMITS_H
#define OMNI4_CAN_LIMITS_H

#include "omni4/core/ctl_settings.h"
#include "omni4/drivers/socketcan_motor.h"

struct sc_limits can_limits_for(const struct ctl_settings *s);
/* can_limits_for(the default settings): the Table III robot at 1 kHz. */
struct sc_limits can_limits_default(void);

#endif /* OMNI4_CAN_LIMITS_H */
