/* hal_none.c - the line backend for a robot with no e-stop / enable / LED lines wired. */
#include "omni4/core/hal.h"

#include <stddef.h>

static int none_read_estop(void *ctx, bool *active)
{
	(void)ctx;
	*active = false;
	return 0;
}

static int none_set(void *ctx, bool on)
{
	(void)ctx;
	(void)on;
	return 0;
}

const struct line_hal_ops line_none_ops = {
    .read_estop = none_read_estop,
    .set_enable = none_set,
    .set_led = none_set,
    .close = NULL,
};
