/* goal_int.h - what goal.c (the tick) and goal_plan.c (the plans, beside the loop) share. */
#ifndef OMNI4_GOAL_INT_H
#define OMNI4_GOAL_INT_H

#include <math.h>

#include "omni4/core/goal.h"
#include "omni4/model/consts.h"

#define GOAL_PI_F MODEL_PI_F

/* cos and sin of a (sin as a shifted cos: no sincosf, which the core's objects may not call). */
static inline void goal_cos_sin(float a, float *c, float *s)
{
	*c = cosf(a);
	*s = cosf(a - 0.5f * GOAL_PI_F);
}

/* A plan from `from` to `to` in tr under the limits in force: the envelope's (traj_plan) or,
 * if fixed, the box fx (its speed within tr's cap: a goal's speed_max). 0 or -EINVAL. */
int goal_plan_to(bool fixed, const struct goal_fixed *fx, struct traj *tr,
                 const struct traj_ref *from, const float to[3]);

#endif /* OMNI4_GOAL_INT_H */
