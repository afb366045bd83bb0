/*
 * traj_cost.c - the trajectory generator's cost on the Cortex-M4 (core/ traj.h), metered like
 * the controller's tick (main.c's instruction meter): a course of goals (straight moves from
 * rest, turns while translating), each followed at 1 kHz with traj_step and a re-plan toward
 * its goal every RE_PLAN_EVERY ticks, and a goal that moves (every re-plan from a velocity off
 * the line to the goal: the curve from it and the brake prelude's, the dearest case). Then the
 * same goals planned as one curve (traj_plan_curve, CURVE_EVALS timings in its search:
 * docs/trajectory.md "One curve"), from rest and from a moving start, and with traj_plan on a
 * floor too slippery to turn and move at once (no curve is timed: the search's timings, the
 * prelude, the turn in place and the translation's curve). Prints three lines of figures (a
 * line is left out if its limits do not initialise): a cost, not a result (left out of the host
 * comparison).
 */
#include "traj_cost.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>

#include "omni4/core/ctl_settings.h"
#include "omni4/core/goal.h"
#include "omni4/core/planner/traj.h"

#define RE_PLAN_EVERY 10 /* ticks between re-plans while a goal is followed */
#define MOVING_GOAL_PLANS 40
#define CURVE_EVALS 40    /* the one-curve plan's search, as bench/traj_optimal.py runs it */
#define SLIPPERY_MU 0.25f /* Table III's robot turns or moves there, not both at once */

struct meter_sum {
	uint64_t sum;
	uint32_t max, n;
};

static void meter_add(struct meter_sum *s, uint32_t c)
{
	s->sum += c;
	s->max = c > s->max ? c : s->max;
	s->n++;
}

static const float course[][6] = {
    /* x0 y0 th0 vx0: goal x y th */
    {0, 0, 0, 1.0f, 0, 0},       {0, 0, 0, 0.7f, 0.7f, 0}, {0, 0, 0, 2.0f, -1.0f, 0},
    {0, 0, 0, 1.5f, 0.5f, 2.0f}, {0, 0, 0, 0, 0, 3.1f},    {0, 0, 0.7f, -0.5f, 3.0f, 0.7f},
};

static struct traj g_tr; /* 1.2 kB: static, not on the image's small stack */

/* One goal of the course from rest: planned, then followed to the end with re-plans. */
static void follow(const float *m, uint32_t (*read)(void), struct meter_sum *plan,
                   struct meter_sum *replan, struct meter_sum *step)
{
	const float pose[3] = {m[0], m[1], m[2]}, goal[3] = {m[3], m[4], m[5]};
	struct traj_ref r;

	traj_reset(&g_tr, pose);
	uint32_t t0 = read();
	traj_replan(&g_tr, goal);
	meter_add(plan, read() - t0);
	for (int k = 1; g_tr.t_s < g_tr.duration_s && k < 20000; k++) {
		if (k % RE_PLAN_EVERY == 0) {
			t0 = read();
			traj_replan(&g_tr, goal);
			meter_add(replan, read() - t0);
		}
		t0 = read();
		traj_step(&g_tr, 1e-3f, &r);
		meter_add(step, read() - t0);
	}
}

/* The course's goals planned as one curve, from rest and moving: one line. */
static void curve_cost(uint32_t (*read)(void), const char *unit, void (*print)(const char *line))
{
	char line[320];
	struct meter_sum curve = {0}, curve_moving = {0};
	for (unsigned i = 0; i < 2 * sizeof(course) / sizeof(course[0]); i++) {
		const unsigned n = sizeof(course) / sizeof(course[0]);
		const float *m = course[i % n];
		const bool go = i >= n; /* then at 0.85 m/s, askew to most goals */
		const struct traj_ref from = {.pose = {m[0], m[1], m[2]},
		                              .vel = {go ? 0.8f : 0.0f, go ? -0.3f : 0.0f}};
		const uint32_t t0 = read();
		traj_plan_curve(&g_tr, &from, m + 3, CURVE_EVALS);
		meter_add(go ? &curve_moving : &curve, read() - t0);
	}
	snprintf(line, sizeof(line),
	         "curve cost: traj_plan_curve (%d timings) from rest mean %lu max %lu over %lu "
	         "goals; moving (0.8, -0.3 m/s) mean %lu max %lu %s",
	         CURVE_EVALS, (unsigned long)(curve.sum / curve.n), (unsigned long)curve.max,
	         (unsigned long)curve.n, (unsigned long)(curve_moving.sum / curve_moving.n),
	         (unsigned long)curve_moving.max, unit);
	print(line);
}

/* traj_plan of the course's goals from rest and moving at 0.3 m/s on a floor too slippery to
 * turn and move at once (mu 0.25): one line. */
static void slippery_cost(struct traj_limits *l, uint32_t (*read)(void), const char *unit,
                          void (*print)(const char *line))
{
	const unsigned n = sizeof(course) / sizeof(course[0]);
	struct meter_sum slip = {0};
	char line[200];

	l->mu = SLIPPERY_MU;
	if (traj_init(&g_tr, l))
		return;
	for (unsigned i = 0; i < 2 * n; i++) {
		const float *m = course[i % n];
		const struct traj_ref from = {.pose = {m[0], m[1], m[2]},
		                              .vel = {i >= n ? 0.3f : 0.0f, 0.0f}};
		const uint32_t t0 = read();
		traj_plan(&g_tr, &from, m + 3);
		meter_add(&slip, read() - t0);
	}
	snprintf(line, sizeof(line),
	         "slippery cost: traj_plan at mu %.2f (a turn in place first) mean %lu max %lu "
	         "over %lu plans %s",
	         (double)SLIPPERY_MU, (unsigned long)(slip.sum / slip.n), (unsigned long)slip.max,
	         (unsigned long)slip.n, unit);
	print(line);
}

void traj_cost(uint32_t (*read)(void), const char *unit, void (*print)(const char *line))
{
	struct ctl_settings s;
	struct traj_limits l;
	struct meter_sum plan = {0}, replan = {0}, step = {0}, moving = {0};
	char line[320];

	ctl_settings_defaults(&s); /* the goal mode's limits, without its speed caps */
	goal_limits(&s, &l);
	l.speed_cap_m_s = INFINITY;
	l.omega_cap_rad_s = INFINITY;
	if (traj_init(&g_tr, &l))
		return;
	for (unsigned i = 0; i < sizeof(course) / sizeof(course[0]); i++)
		follow(course[i], read, &plan, &replan, &step);
	const float start[3] = {0, 0, 0};
	float goal[3] = {1.0f, 0.5f, 1.0f};
	struct traj_ref r;
	traj_reset(&g_tr, start);
	for (int k = 0; k < MOVING_GOAL_PLANS * 20; k++) {
		if (k % 20 == 0) {
			goal[0] = 1.0f - 0.0008f * (float)k;
			goal[1] = 0.5f + 0.0005f * (float)k;
			goal[2] = 1.0f - 0.002f * (float)k;
			const uint32_t t0 = read();
			traj_replan(&g_tr, goal);
			meter_add(&moving, read() - t0);
		}
		traj_step(&g_tr, 1e-3f, &r);
	}
	snprintf(line, sizeof(line),
	         "planner cost: traj_plan from rest mean %lu max %lu over %lu goals; traj_replan "
	         "on the way mean %lu max %lu over %lu; toward a moving goal mean %lu max %lu over "
	         "%lu; traj_step mean %lu max %lu %s; sizeof(struct traj) %lu bytes",
	         (unsigned long)(plan.sum / plan.n), (unsigned long)plan.max, (unsigned long)plan.n,
	         (unsigned long)(replan.sum / replan.n), (unsigned long)replan.max,
	         (unsigned long)replan.n, (unsigned long)(moving.sum / moving.n),
	         (unsigned long)moving.max, (unsigned long)moving.n,
	         (unsigned long)(step.sum / step.n), (unsigned long)step.max, unit,
	         (unsigned long)sizeof(struct traj));
	print(line);
	curve_cost(read, unit, print);
	slippery_cost(&l, read, unit, print);
}
