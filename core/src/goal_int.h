/* goal_int.h - what goal.c (the tick) and goal_plan.c (the plans, beside the loop) share. */
#ifndef OMNI4_GOAL_INT_H
#define OMNI4_GOAL_INT_H

#include "omni4/core/goal.h"

/* A plan from `from` to `to` in tr under the limits in force: the envelope's (traj_plan) or,
 * if fixed, the box fx (its speed within tr's cap: a goal's speed_max). 0 or -EINVAL. */
int goal_plan_to(bool fixed, const struct goal_fixed *fx, struct traj *tr,
                 const struct traj_ref *from, const float to[3]);

#endif /* OMNI4_GOAL_INT_H */
