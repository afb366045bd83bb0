/* scenario_goal.c - the goal mode on the scenarios' robot (scenario_goal.h): a goal from rest,
 * kept alive as a client does, replaced on the way by a second one (handed over a lead ahead
 * of the reference: no jump), a live parameter change while the second one moves (taken by a
 * tick that plans nothing: its plan is asked again beside the loop), to REACHED; the cost per
 * tick beside it, and the plans' cost beside the loop (fw_background after each tick, as a main
 * loop would run it). */
#include "scenario_goal.h"

#include <math.h>
#include <stdio.h>

#include "omni4/model/consts.h"

#define GOAL_TICKS_MAX 6000 /* 6 s at 1 kHz: far beyond the plans' duration */
#define KEEP_TICKS 50       /* keep-alive every 50 ms, as omni4-goto */
#define REPLACE_TICK 400    /* the second goal, while the first one moves */
#define PARAM_TICK 900      /* a live change of the floor while the second one moves */
#define PARAM_MU 0.5        /* [limits] traction_mu then (before: [goal] floor_mu, 0.55) */
#define POS_TOL_M 0.01      /* issue 37: 1 cm and 1 degree of the goal */
#define TH_TOL_RAD (MODEL_PI / 180.0)
#define JUMP_TOL_M 0.002 /* the reference's step at the hand-over: at 1 m/s a tick is 1 mm */

static const double goals[2][3] = {{0.6, 0.3, 1.0}, {0.1, 0.5, -0.5}};

struct cost {
	uint64_t sum;
	uint32_t max, n;
};

static void cost_add(struct cost *c, uint32_t d)
{
	c->sum += d;
	c->max = d > c->max ? d : c->max;
	c->n++;
}

static void post(int64_t id)
{
	const double *p = goals[id - 1];
	const struct goal_cmd g = {.utime = scenario_now_us(),
	                           .id = id,
	                           .action = GOAL_GO,
	                           .n = 1,
	                           .poses = {{p[0], p[1], p[2]}}};

	fw_post_goal(&scenario_robot()->fw, &g);
}

/* One tick (metered: fw_tick alone), then the work beside the loop (metered apart). */
static void step(struct cost *tick, struct cost *plan)
{
	const struct scenario_meter *m = scenario_meter();
	const uint32_t d = scenario_tick();

	if (m)
		cost_add(tick, d);
	const uint32_t t0 = m ? m->read() : 0;
	const bool did = fw_background(&scenario_robot()->fw);

	if (m && did)
		cost_add(plan, m->read() - t0);
}

static void print_costs(const struct cost *tick, const struct cost *plan)
{
	const struct scenario_meter *m = scenario_meter();
	char fig[320];

	if (!m || !tick->n || !plan->n)
		return;
	/* Not compared between builds: a cost, not a result. */
	snprintf(fig, sizeof(fig),
	         "goal cost: whole tick mean %lu max %lu %s over %lu ticks; plans beside the loop "
	         "mean %lu max %lu %s over %lu (the lead %.0f ms)",
	         (unsigned long)(tick->sum / tick->n), (unsigned long)tick->max, m->unit,
	         (unsigned long)tick->n, (unsigned long)(plan->sum / plan->n),
	         (unsigned long)plan->max, m->unit, (unsigned long)plan->n,
	         1e3 * (double)GOAL_PLAN_LEAD_S);
	scenario_print(fig);
}

/* The parameter side's change, prepared beside the loop (not metered as a tick) and offered
 * to it; the loop takes it whole between two ticks. false if it could not be prepared. */
static bool offer_params(struct fw_param_update *u)
{
	struct fw *fw = &scenario_robot()->fw;
	struct ctl_settings set = fw->ctl.set;
	char why[96];

	set.limits.traction_mu = PARAM_MU;
	if (fw_param_prepare(fw, &set, false, u, why, sizeof(why)))
		return false;
	fw_param_offer(fw, u);
	return true;
}

int scenario_goal(void)
{
	static struct fw_param_update u;
	struct fw_param_result pr = {0};
	bool param_taken = false;
	struct cost tick = {0}, plan = {0};
	bool ok = scenario_start() == 0;
	long reached = -1, taken = -1;
	int64_t id = 1;
	double jump = 0.0, last[2] = {0.0, 0.0};
	const struct goal *g = &scenario_robot()->fw.goal;

	for (long i = 0; i < GOAL_TICKS_MAX && ok && reached < 0; i++) {
		if (i == REPLACE_TICK)
			id = 2;
		if (i % KEEP_TICKS == 0 || i == REPLACE_TICK)
			post(id);
		if (i == PARAM_TICK)
			ok &= offer_params(&u);
		step(&tick, &plan);
		if (i >= PARAM_TICK && !param_taken)
			param_taken = fw_param_done(&scenario_robot()->fw, &u, &pr) && pr.rc == 0;
		if (taken < 0 && g->rep.id == 2) {
			taken = i;
			jump = hypot(g->rep.ref[0] - last[0], g->rep.ref[1] - last[1]);
		}
		last[0] = g->rep.ref[0];
		last[1] = g->rep.ref[1];
		if (g->rep.id == 2 && g->rep.status == GOAL_REACHED)
			reached = i;
	}
	const double *x = scenario_robot()->sim.plant.pose, *p = goals[1];
	const double e = hypot(x[0] - p[0], x[1] - p[1]);
	const double a = fabs(remainder(x[2] - p[2], 6.2831853));
	char fig[200];

	ok &= reached > 0 && taken > REPLACE_TICK && e < POS_TOL_M && a < TH_TOL_RAD &&
	      jump < JUMP_TOL_M && param_taken && reached > PARAM_TICK;
	snprintf(fig, sizeof(fig),
	         "taken_tick=%ld ref_step_mm=%.2f param_taken=%d reached_tick=%ld pos_err_mm=%.1f "
	         "th_err_mdeg=%.0f",
	         taken, 1e3 * jump, param_taken, reached, 1e3 * e, 1e3 * a * 180.0 / MODEL_PI);
	scenario_say("goal", ok, fig);
	print_costs(&tick, &plan);
	return ok ? 0 : 1;
}
