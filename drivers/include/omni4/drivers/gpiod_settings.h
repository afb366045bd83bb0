/*
 * gpiod_settings.h - the "gpiod" line backend's settings ([gpio]): the chip and the line
 * offsets. Keys, defaults and ranges: gpiod_keys.def.
 */
#ifndef OMNI4_GPIOD_SETTINGS_H
#define OMNI4_GPIOD_SETTINGS_H

#include <stdbool.h>

struct gpiod_settings {
	char chip[64];  /* name, path or number ("gpiochip0", "/dev/gpiochip0", "0") */
	int estop_line; /* offset, -1 = none */
	bool estop_active_low;
	int enable_line; /* -1 = none */
	int led_line;    /* -1 = none */
};

#endif /* OMNI4_GPIOD_SETTINGS_H */
