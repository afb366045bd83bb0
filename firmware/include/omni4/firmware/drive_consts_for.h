/*
 * drive_consts_for.h - the numbers a current- or torque-commanding drive backend takes from the
 * controller's settings (struct drive_consts): the gearbox and each wheel's drive constants in
 * force (ctl_settings_wheels). The adapter computes them, so the driver knows nothing of the
 * settings.
 */
#ifndef OMNI4_DRIVE_CONSTS_FOR_H
#define OMNI4_DRIVE_CONSTS_FOR_H

#include "omni4/core/ctl_settings.h"
#include "omni4/drivers/drive_consts.h"

static inline struct drive_consts drive_consts_for(const struct ctl_settings *s)
{
	struct drive_consts c = {.gear = s->model.l};

	ctl_settings_wheels(s, &c.w);
	return c;
}

#endif /* OMNI4_DRIVE_CONSTS_FOR_H */
