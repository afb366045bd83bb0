/*
 * goal_fixed.h - the goal mode's fixed-limits peer ([goal] limits = fixed): limits as TIGERs
 * types them, one acceleration and one speed for every direction of travel (a box inside the
 * model's envelope) and one angular acceleration and rate, and a plan under them: two 1D
 * bang-bang profiles (x, y) sharing the box by an angle found by bisection so both arrive
 * together, the heading its own profile (docs/goal.md "Peers"). Portable like the rest of the
 * core: single precision in the plan, no allocation, no OS.
 */
#ifndef OMNI4_GOAL_FIXED_H
#define OMNI4_GOAL_FIXED_H

#include "omni4/core/planner/traj.h"

#define GOAL_FIXED_DIRS 72   /* directions the envelope is searched over (5 deg apart) */
#define GOAL_FIXED_SPEEDS 64 /* top speeds tried for the box */
#define GOAL_FIXED_ALPHA_ITERS 20

struct goal_fixed {
	float acc_m_s2, speed_m_s;    /* the box: every direction of travel */
	float acc_rad_s2, rate_rad_s; /* the heading's */
	float rot_share;              /* both move: the heading gets this share, x/y the rest */
};

/*
 * goal_fixed_limits - the box from tr's limits (traj_init done): the speed V and the
 * acceleration A(V) the envelope allows in every direction at every speed up to V (the
 * speeding-up side, friction against), V chosen for the largest A V; likewise the heading on
 * its own (pure rotation, every wheel at its voltage and traction). Not for the fast loop.
 * -EINVAL if the envelope leaves no box.
 */
int goal_fixed_limits(const struct traj *tr, struct goal_fixed *fx);

/*
 * goal_fixed_plan - a plan in tr (its clock at 0) from `from` (pose and world velocity) to
 * goal [x m, y m, theta rad], at rest there, under fx. When both the position and the heading
 * move, each limit is scaled by its share (1 - rot_share, rot_share). Fast loop: bounded
 * (GOAL_FIXED_ALPHA_ITERS bisection steps). -EINVAL (tr unchanged) on NaN or infinite input.
 */
int goal_fixed_plan(const struct goal_fixed *fx, struct traj *tr, const struct traj_ref *from,
                    const float goal[3]);

#endif /* OMNI4_GOAL_FIXED_H */
