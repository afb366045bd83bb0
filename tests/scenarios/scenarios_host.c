/* scenarios_host.c - the microcontroller image's scenarios on the host (the MCU runs the same:
 * mcu/). */
#include <stdio.h>

#include "omni4/base/clock.h"
#include "scenarios.h"

static void print_line(const char *line)
{
	puts(line);
	fflush(stdout);
}

static uint32_t now_ns(void)
{
	return (uint32_t)omni4_monotonic_ns();
}

int main(int argc, char **argv)
{
	static const struct scenario_meter meter = {.read = now_ns, .unit = "ns (wall clock)"};

	/* --no-cost: results only, for comparing with another build's output line by line. */
	if (!(argc > 1 && argv[1][0] == '-'))
		scenarios_set_meter(&meter);
	return scenarios_run(print_line, NULL) ? 1 : 0;
}
