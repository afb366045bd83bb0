/* traj_cost.h - the trajectory generator's cost on the Cortex-M4 (traj_cost.c). */
#ifndef OMNI4_MCU_TRAJ_COST_H
#define OMNI4_MCU_TRAJ_COST_H

#include <stdint.h>

/* Meters plans, re-plans and steps over a course of goals with read() (instructions) and
 * prints one "planner cost:" line. */
void traj_cost(uint32_t (*read)(void), const char *unit, void (*print)(const char *line));

#endif /* OMNI4_MCU_TRAJ_COST_H */
