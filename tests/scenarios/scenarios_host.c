/* scenarios_host.c - the core's HIL scenarios on the host (the MCU runs the same: mcu/). */
#include <stdio.h>
#include <time.h>

#include "scenarios.h"

static void print_line(const char *line)
{
	puts(line);
	fflush(stdout);
}

static uint32_t now_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (uint32_t)((uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec);
}

int main(int argc, char **argv)
{
	static const struct scenario_meter meter = {.read = now_ns, .unit = "ns (wall clock)"};

	/* --no-cost: results only, for comparing with another build's output line by line. */
	if (!(argc > 1 && argv[1][0] == '-'))
		scenarios_set_meter(&meter);
	return scenarios_run(print_line, NULL) ? 1 : 0;
}
