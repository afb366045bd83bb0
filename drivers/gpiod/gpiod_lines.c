/* gpiod_lines.c - line HAL on libgpiod 1.6 (the only file that calls libgpiod). */
#include "omni4/drivers/gpiod_lines.h"

#include <errno.h>
#include <gpiod.h>
#include <string.h>

#define CONSUMER "omni4"

static void release(struct gpiod_lines *g)
{
	if (g->enable) {
		gpiod_line_set_value(g->enable, 0);
		gpiod_line_release(g->enable);
	}
	if (g->led) {
		gpiod_line_set_value(g->led, 0);
		gpiod_line_release(g->led);
	}
	if (g->estop)
		gpiod_line_release(g->estop);
	if (g->chip)
		gpiod_chip_close(g->chip);
	memset(g, 0, sizeof(*g));
}

static int request(struct gpiod_lines *g, int offset, bool output, int flags,
                   struct gpiod_line **out)
{
	if (offset < 0)
		return 0;
	struct gpiod_line *l = gpiod_chip_get_line(g->chip, (unsigned)offset);

	if (!l)
		return errno ? -errno : -EINVAL;
	const int rc = output ? gpiod_line_request_output_flags(l, CONSUMER, flags, 0)
	                      : gpiod_line_request_input_flags(l, CONSUMER, flags);

	if (rc)
		return errno ? -errno : -EBUSY;
	*out = l;
	return 0;
}

int gpiod_lines_open(struct gpiod_lines *g, const struct gpiod_settings *cfg)
{
	int rc;

	memset(g, 0, sizeof(*g));
	g->chip = gpiod_chip_open_lookup(cfg->chip);
	if (!g->chip)
		return errno ? -errno : -ENODEV;
	rc = request(g, cfg->estop_line, false,
	             cfg->estop_active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0, &g->estop);
	if (rc)
		goto err;
	rc = request(g, cfg->enable_line, true, 0, &g->enable);
	if (rc)
		goto err;
	rc = request(g, cfg->led_line, true, 0, &g->led);
	if (rc)
		goto err;
	return 0;
err:
	release(g);
	return rc;
}

static int read_estop(void *ctx, bool *active)
{
	struct gpiod_lines *g = ctx;

	if (!g->estop) {
		*active = false;
		return 0;
	}
	const int v = gpiod_line_get_value(g->estop);

	if (v < 0) {
		g->pressed = true; /* unreadable = pressed */
		g->inactive_ticks = 0;
		*active = true;
		return -EIO;
	}
	if (v) {
		g->pressed = true;
		g->inactive_ticks = 0;
	} else if (g->pressed && ++g->inactive_ticks >= GPIOD_ESTOP_RELEASE_TICKS) {
		g->pressed = false;
	}
	*active = g->pressed;
	return 0;
}

static int set_line(struct gpiod_line *l, bool on)
{
	if (!l)
		return 0;
	return gpiod_line_set_value(l, on) ? -EIO : 0;
}

static int set_enable(void *ctx, bool on)
{
	return set_line(((struct gpiod_lines *)ctx)->enable, on);
}

static int set_led(void *ctx, bool on)
{
	return set_line(((struct gpiod_lines *)ctx)->led, on);
}

static void close_lines(void *ctx)
{
	release(ctx);
}

const struct line_hal_ops gpiod_lines_ops = {
    .read_estop = read_estop,
    .set_enable = set_enable,
    .set_led = set_led,
    .close = close_lines,
};
