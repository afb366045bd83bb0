/* robot.c - a robot built from its settings (robot.h): the rows of backends.def as one table
 * per HAL from the backend enums onto their code (struct robot_backend, each in its own file). */
#include "omni4/firmware/robot.h"

#include <stdio.h>
#include <string.h>

#define ROBOT_ENTRY(HAL, hal, name, word, keys, member, settings, state, header, os, ...)          \
	BACKEND_##HAL##_##hal(BACKEND_OS_##os([OMNI4_##HAL##_##name] = &robot_backend_##member, ))

static const struct robot_backend *const motor_backends[OMNI4_MOTOR_COUNT] = {
#define OMNI4_BACKEND(...) ROBOT_ENTRY(MOTOR, __VA_ARGS__)
#include OMNI4_BACKENDS_DEF
};

static const struct robot_backend *const line_backends[OMNI4_LINES_COUNT] = {
#define OMNI4_BACKEND(...) ROBOT_ENTRY(LINES, __VA_ARGS__)
#include OMNI4_BACKENDS_DEF
};

/* The entry of kind in table (n entries), or NULL with the reason in why. */
static const struct robot_backend *find(const struct robot_backend *const *table, int n, int kind,
                                        const char *hal, char *why, size_t len)
{
	if (kind >= 0 && kind < n && table[kind])
		return table[kind];
	snprintf(why, len, "[hal] %s backend %d is not available in this build", hal, kind);
	return NULL;
}

/* The controller on the opened backends, then the backends' own start (hooks, clock). */
static int start_controller(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	const struct motor_hal motor = spec->wrap ? spec->wrap(spec->wrap_ctx, r->motor) : r->motor;
	if (fw_init(&r->fw, spec->ctl, motor, r->lines)) {
		snprintf(why, n, "invalid controller settings");
		return -1;
	}
	if (r->motor_backend->started)
		r->motor_backend->started(r, spec);
	if (r->lines_backend->started)
		r->lines_backend->started(r, spec);
	return 0;
}

void robot_sim_follow_clock(struct robot *r, int64_t now_us)
{
	if (r->motor_backend && r->motor_backend->follow_clock)
		r->motor_backend->follow_clock(r, now_us);
}

void robot_summary(const struct robot *r)
{
	if (r->motor_backend && r->motor_backend->summary)
		r->motor_backend->summary(r);
	if (r->lines_backend && r->lines_backend->summary)
		r->lines_backend->summary(r);
}

int robot_open(struct robot *r, const struct robot_spec *spec, char *why, size_t n)
{
	memset(r, 0, sizeof(*r));
	r->motor_kind = spec->motor;
	r->motor_backend =
	    find(motor_backends, OMNI4_MOTOR_COUNT, (int)spec->motor, "motor", why, n);
	if (!r->motor_backend)
		return -1;
	r->lines_backend =
	    find(line_backends, OMNI4_LINES_COUNT, (int)spec->lines, "lines", why, n);
	if (!r->lines_backend)
		return -1;
	if (r->motor_backend->open(r, spec, why, n))
		return -1;
	if (r->lines_backend->open(r, spec, why, n)) {
		hal_motor_close(&r->motor);
		return -1;
	}
	if (start_controller(r, spec, why, n)) {
		hal_line_close(&r->lines);
		hal_motor_close(&r->motor);
		return -1;
	}
	return 0;
}

void robot_close(struct robot *r)
{
	if (r->fw.motor.ops)
		fw_outputs_off(&r->fw);
	hal_line_close(&r->lines);
	hal_motor_close(&r->motor);
}
