/*
 * drive_consts_for.h - the numbers a current- or torque-commanding drive backend takes from the
 * controller's settings (struct drive_consts): the gearbox and each wheel's drive constants in
 * force (ctl_settings_wheels). The adapter computes them, so the driver knows nothing of the
 * settings. And the VESC and ODrive backends' whole configurations from their INI sections, as
 * the robot opens them (robot_vesc.c, robot_odrive.c) and the tests' lockstep does.
 */
#ifndef OMNI4_DRIVE_CONSTS_FOR_H
#define OMNI4_DRIVE_CONSTS_FOR_H

#include "omni4/core/ctl_settings.h"
#include "omni4/drivers/drive_consts.h"
#include "omni4/drivers/odrive_motor.h"
#include "omni4/drivers/odrive_settings.h"
#include "omni4/drivers/vesc_motor.h"
#include "omni4/drivers/vesc_settings.h"

static inline struct drive_consts drive_consts_for(const struct ctl_settings *s)
{
	struct drive_consts c = {.gear = s->model.l};

	ctl_settings_wheels(s, &c.w);
	return c;
}

/* The VESC backend's configuration of [vesc] vs and the controller's settings s. */
static inline struct vesc_motor_config vesc_config_for(const struct vesc_settings *vs,
                                                       const struct ctl_settings *s)
{
	struct vesc_motor_config cfg = {.iface = vs->iface,
	                                .host_id = VESC_HOST_ID,
	                                .pole_pairs = vs->pole_pairs,
	                                .mode = (enum vesc_mode)vs->mode,
	                                .status_timeout_ms = vs->status_timeout_ms,
	                                .consts = drive_consts_for(s)};

	for (int j = 0; j < 4; j++)
		cfg.id[j] = (uint8_t)vs->id[j];
	return cfg;
}

/* The ODrive backend's configuration of [odrive] os and the controller's settings s. */
static inline struct odrive_motor_config odrive_config_for(const struct odrive_settings *os,
                                                           const struct ctl_settings *s)
{
	struct odrive_motor_config cfg = {.iface = os->iface,
	                                  .mode = (enum odrive_mode)os->mode,
	                                  .status_timeout_ms = os->status_timeout_ms,
	                                  .consts = drive_consts_for(s)};

	for (int j = 0; j < 4; j++)
		cfg.node[j] = (uint8_t)os->node[j];
	return cfg;
}

#endif /* OMNI4_DRIVE_CONSTS_FOR_H */
