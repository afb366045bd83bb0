/* robot_gpiod.c - the libgpiod line backend as the robot opens it (robot.h). Linux only. */
#include "omni4/firmware/robot.h"

#include <stdio.h>
#include <string.h>

static int open_gpiod_lines(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const int rc = gpiod_lines_open(&r->gpio, spec->gpio);

	if (rc) {
		snprintf(why, n, "GPIO chip '%s': %s", spec->gpio->chip, strerror(-rc));
		return -1;
	}
	r->lines = gpiod_lines_hal(&r->gpio);
	return 0;
}
const struct robot_backend robot_backend_gpio = {.open = open_gpiod_lines};
