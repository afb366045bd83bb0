/*
 * scenarios.h - the microcontroller image's command source: scripted scenarios in portable C
 * that drive a robot built by the composition root (robot.h: the core on the sim backends, exact
 * sensors), commands handed in as a receive side would, the samples taken from the log ring. No
 * OS, no LCM, no allocation: the same code runs on the Cortex-M4 under qemu (mcu/) and on the
 * host (test_scenarios), and both print the same lines.
 *
 * Each scenario checks its own outcome against the specification (docs/faults.md, the INI
 * defaults) and prints one line of figures: "NAME ok|FAILED key=value ...". Integer figures are
 * ticks; real figures are printed with %.6e so that two builds can be compared number by number.
 */
#ifndef OMNI4_SCENARIOS_H
#define OMNI4_SCENARIOS_H

#include <stdint.h>

/* Where a line goes (printf on the host, semihosting on the MCU). */
typedef void (*scenario_print_fn)(const char *line);

/* Called once per tick before fw_tick runs: the MCU waits for its SysTick here, the host
 * returns at once. May be NULL. */
typedef void (*scenario_wait_fn)(void);

/* Runs every scenario; returns the number that failed. */
int scenarios_run(scenario_print_fn print, scenario_wait_fn wait_tick);

/* Instruction (or cycle) counter for the per-tick cost, and its name; NULL = not measured. */
struct scenario_meter {
	uint32_t (*read)(void); /* monotonic, wraps at 2^32 */
	const char *unit;
};
void scenarios_set_meter(const struct scenario_meter *m);

#endif /* OMNI4_SCENARIOS_H */
