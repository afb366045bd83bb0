/*
 * fw_settings.h - omni4-fw's own settings (the Linux adapter around the core): the loop
 * thread's real-time set-up, the LCM URL, which backends drive the robot, the parameter
 * service's token. Keys, defaults and ranges: fw_keys.def.
 */
#ifndef OMNI4_FW_SETTINGS_H
#define OMNI4_FW_SETTINGS_H

#include <stdbool.h>

#include "omni4/drivers/backends.h"

struct fw_settings {
	struct {
		bool sched_fifo;
		int priority;
		bool mlockall;
		int cpu_dma_latency_us; /* -1 = leave the CPU idle states alone; 0 = no deep C-state
		                         */
	} loop;
	char lcm_url[128];
	int motor;        /* enum omni4_motor_backend */
	int lines;        /* enum omni4_lines_backend */
	char secret[128]; /* "" = parameter changes over LCM need no token */
};

#endif /* OMNI4_FW_SETTINGS_H */
