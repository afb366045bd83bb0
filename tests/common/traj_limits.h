/* traj_limits.h - the planner's limits the tests start from: the goal mode's (goal_limits) from
 * the key table's defaults (Table III, the floor not identified), without the speed caps. */
#ifndef OMNI4_TEST_TRAJ_LIMITS_H
#define OMNI4_TEST_TRAJ_LIMITS_H

#include <math.h>

#include "omni4/core/ctl_settings.h"
#include "omni4/core/goal.h"
#include "omni4/core/planner/traj.h"

static inline struct traj_limits test_traj_limits(void)
{
	struct ctl_settings s;
	struct traj_limits l;

	ctl_settings_defaults(&s);
	goal_limits(&s, &l);
	l.speed_cap_m_s = INFINITY;
	l.omega_cap_rad_s = INFINITY;
	return l;
}

#endif /* OMNI4_TEST_TRAJ_LIMITS_H */
