/* plan_moves.c - the planner's time of a move for omni4-compare (plan_moves.h). */
#include "plan_moves.h"

#include <errno.h>
#include <stdlib.h>

#include "omni4/core/goal.h"
#include "omni4/core/planner/traj.h"

int compare_plan_move(const struct ctl_settings *s, const struct wheel_geom *g,
                      const double goal[3], double *duration_s)
{
	struct traj_limits lim;
	struct traj *tr = malloc(sizeof(*tr));         /* large: off the stack */
	const struct traj_ref from = {.pose = {0.0f}}; /* at rest at the origin */
	const float to[3] = {(float)goal[0], (float)goal[1], (float)goal[2]};
	int rc = -ENOMEM;

	if (!tr)
		return rc;
	goal_limits(s, &lim);
	lim.geom = g;
	rc = traj_init(tr, &lim) ? -EINVAL : traj_plan(tr, &from, to) ? -ERANGE : 0;
	if (!rc)
		*duration_s = tr->duration_s;
	free(tr);
	return rc;
}
