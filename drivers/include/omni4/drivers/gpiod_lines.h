/*
 * gpiod_lines.h - the "gpiod" backend of the line HAL (libgpiod 1.6): e-stop input (active
 * level configurable), enable output, status LED. The e-stop asserts on the first active
 * sample and releases only after GPIOD_ESTOP_RELEASE_TICKS inactive samples in a row
 * (debounce that can only delay a release, never a stop). A failed read is a pressed e-stop.
 * All lines are released, outputs low, on close.
 */
#ifndef OMNI4_GPIOD_LINES_H
#define OMNI4_GPIOD_LINES_H

#include <stdbool.h>

#include "omni4/drivers/gpiod_settings.h"
#include "omni4/core/hal.h"

#define GPIOD_ESTOP_RELEASE_TICKS 20

struct gpiod_chip;
struct gpiod_line;

struct gpiod_lines {
	struct gpiod_chip *chip;
	struct gpiod_line *estop, *enable, *led;
	int inactive_ticks;
	bool pressed;
};

extern const struct line_hal_ops gpiod_lines_ops;

/* Start-up. -ENODEV (chip), -EINVAL (offset), -EBUSY (line in use) ...; nothing held on error. */
int gpiod_lines_open(struct gpiod_lines *g, const struct gpiod_settings *cfg);

static inline struct line_hal gpiod_lines_hal(struct gpiod_lines *g)
{
	return (struct line_hal){.ops = &gpiod_lines_ops, .ctx = g};
}

#endif /* OMNI4_GPIOD_LINES_H */
