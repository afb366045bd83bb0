/* scenario_goal.c - the goal mode on the scenarios' robot (scenario_goal.h): one goal from rest,
 * kept alive as a client does, to REACHED; the planner's cost per tick beside it. */
#include "scenario_goal.h"

#include <math.h>
#include <stdio.h>

#define GOAL_TICKS_MAX 5000 /* 5 s at 1 kHz: far beyond the plan's duration */
#define KEEP_TICKS 50       /* keep-alive every 50 ms, as omni4-goto */
#define POS_TOL_M 0.01      /* issue 37: 1 cm and 1 degree of the goal */
#define TH_TOL_RAD (3.14159265358979 / 180.0)

struct goal_cost {
	uint64_t sum;
	uint32_t max, n;
};

static void post(int64_t id)
{
	const struct goal_cmd g = {.utime = scenario_now_us(),
	                           .id = id,
	                           .action = GOAL_GO,
	                           .n = 1,
	                           .poses = {{0.6, 0.3, 1.0}}};

	fw_post_goal(&scenario_robot()->fw, &g);
}

/* One metered tick (fw_tick: the goal's plan runs in it). */
static void tick_cost(struct goal_cost *c)
{
	const uint32_t d = scenario_tick();

	if (!scenario_meter())
		return;
	c->sum += d;
	c->max = d > c->max ? d : c->max;
	c->n++;
}

int scenario_goal(void)
{
	struct goal_cost cost = {0};
	bool ok = scenario_start() == 0;
	long reached = -1;

	for (long i = 0; i < GOAL_TICKS_MAX && ok && reached < 0; i++) {
		if (i % KEEP_TICKS == 0)
			post(1);
		tick_cost(&cost);
		if (scenario_robot()->fw.goal.rep.status == GOAL_REACHED)
			reached = i;
	}
	const double *x = scenario_robot()->sim.plant.pose;
	const double e = hypot(x[0] - 0.6, x[1] - 0.3), a = fabs(remainder(x[2] - 1.0, 6.2831853));
	char fig[160];

	ok &= reached > 0 && e < POS_TOL_M && a < TH_TOL_RAD;
	snprintf(fig, sizeof(fig), "reached_tick=%ld pos_err_mm=%.1f th_err_mdeg=%.0f", reached,
	         1e3 * e, 1e3 * a * 180.0 / 3.14159265358979);
	scenario_say("goal", ok, fig);
	if (scenario_meter() && cost.n) {
		/* Not compared between builds: a cost, not a result. */
		snprintf(fig, sizeof(fig),
		         "goal cost: whole tick mean %lu max %lu %s over %lu ticks",
		         (unsigned long)(cost.sum / cost.n), (unsigned long)cost.max,
		         scenario_meter()->unit, (unsigned long)cost.n);
		scenario_print(fig);
	}
	return ok ? 0 : 1;
}
