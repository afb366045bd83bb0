/* scenario_goal.h - the goal mode's scenario (scenario_goal.c) and what it takes from the
 * scenarios' robot (scenarios.c): the same robot, ticks and lines as the others. */
#ifndef OMNI4_SCENARIO_GOAL_H
#define OMNI4_SCENARIO_GOAL_H

#include <stdbool.h>

#include "omni4/firmware/robot.h"
#include "scenarios.h"

/* From scenarios.c: a fresh robot (0, or -1), one tick at the scenarios' clock (its metered
 * cost: fw_tick alone, not the wait for the tick; 0 without a meter), the clock [us], one
 * result line, the meter (NULL: none). */
int scenario_start(void);
/* The wheels' layout of a scenario: n wheels at angle_deg[j] from the v axis, at d_m[j]. */
struct scenario_layout {
	int wheels;
	double angle_deg[4], d_m[4];
};
/* scenario_start with that layout in the controller's settings (and so in the sim's plant). */
int scenario_start_layout(const struct scenario_layout *lay);
uint32_t scenario_tick(void);
uint32_t scenario_last_ctl_cost(void); /* that tick's cost less the sim plant's HAL part */
struct robot *scenario_robot(void);
int64_t scenario_now_us(void);
void scenario_say(const char *name, bool ok, const char *figures);
const struct scenario_meter *scenario_meter(void);
void scenario_print(const char *line);

/* A goal from rest (a move with a turn), replaced on the way by a second one, kept alive until
 * REACHED: the line "goal ok|FAILED" with the tick the second was handed over at, the
 * reference's step there, the tick it was reached at and the final pose's error; then
 * (metered) one cost line: the ticks' instructions and the plans' beside the loop (mean, max).
 * 0 if it passed. */
int scenario_goal(void);

#endif /* OMNI4_SCENARIO_GOAL_H */
