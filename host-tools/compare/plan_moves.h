/* plan_moves.h - the planner's time of a move for omni4-compare (C: the goal mode's headers are
 * C only). */
#ifndef OMNI4_COMPARE_PLAN_MOVES_H
#define OMNI4_COMPARE_PLAN_MOVES_H

#include "omni4/core/ctl_settings.h"
#include "omni4/model/wheels.h"

/* The duration [s] of traj_plan from rest at the origin to rest at goal (x [m], y [m], theta
 * [rad]) with the goal mode's limits of s (goal_limits) and the layout g, into *duration_s.
 * 0; -EINVAL if the planner refuses the limits (traj_init), -ERANGE if it refuses the move. */
int compare_plan_move(const struct ctl_settings *s, const struct wheel_geom *g,
                      const double goal[3], double *duration_s);

#endif /* OMNI4_COMPARE_PLAN_MOVES_H */
