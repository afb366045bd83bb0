/*
 * ctl_settings.h - the controller's settings: the model, the loop rate, control and limits, in
 * SI units. Nothing else: the adapters' settings (LCM, backends, lines) are theirs. Defaults and
 * the INI keys that hold these settings are listed once, in ctl_keys.def.
 */
#ifndef OMNI4_CTL_SETTINGS_H
#define OMNI4_CTL_SETTINGS_H

#include <stdbool.h>

#include "omni4/params.h"

struct ctl_settings {
	struct model_params model;
	double rate_hz; /* loop rate [Hz] */
	struct {
		double kp; /* PI on wheel linear speed [V/(m/s)] */
		double ki; /* [V/m] */
		bool feedforward;
		bool feedback;
		int cmd_timeout_ms; /* watchdog: no valid command for this long -> ramp to 0 -> IDLE
		                     */
		double stop_ramp_s; /* ramp length of that stop [s] */
	} control;
	struct {
		double supply_v;      /* H-bridge supply; voltages are clamped to +-supply_v [V] */
		double supply_min_v;  /* below this: FAULT_SUPPLY [V] */
		double vel_lin_max;   /* [m/s] */
		double vel_rot_max;   /* [rad/s] */
		double acc_lin_max;   /* reference shaping [m/s^2] */
		double acc_rot_max;   /* [rad/s^2] */
		double current_max_a; /* over-current fault level [A] */
		double current_sensor_max_a; /* a reading at or beyond this is a saturated sensor
		                                [A] */
	} limits;
};

/* The defaults of ctl_keys.def: the paper's Table III robot at 1 kHz. */
void ctl_settings_defaults(struct ctl_settings *s);

/* 0 if s can run a controller: the model physically meaningful (*bad_key = its index in
 * model_params_names), rate_hz > 0 and supply_min_v < supply_v (*bad_key = -1). why: the rule. */
int ctl_settings_check(const struct ctl_settings *s, int *bad_key, const char **why);

#endif /* OMNI4_CTL_SETTINGS_H */
