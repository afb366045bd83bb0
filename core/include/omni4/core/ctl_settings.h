/*
 * ctl_settings.h - the controller's settings: the model, the loop rate, control and limits, in
 * SI units. Nothing else: the adapters' settings (LCM, backends, lines) are theirs. Defaults and
 * the INI keys that hold these settings are listed once, in ctl_keys.def.
 */
#ifndef OMNI4_CTL_SETTINGS_H
#define OMNI4_CTL_SETTINGS_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/est_keys.h"
#include "omni4/model/params.h"
#include "omni4/model/wheels.h"

struct ctl_settings {
	struct model_params model;
	/* Each drive's own r, Kv, Kt, R ([model] r_0 .. R_3): wheels.X[j] counts where bit
	 * CTL_WHEEL_KEY(q, j) of wheel_keys is set (the configuration gives that wheel its own
	 * key); elsewhere the scalar model.X does (ctl_settings_wheels). */
	struct model_wheels wheels;
	uint16_t wheel_keys;
	/* The wheels' layout ([model] wheels, wheel_angle_j, d_j; docs/model.md "Layouts"): wheel j
	 * at angle_deg[j] from the v axis, counter-clockwise, at d[j] from the centre, driving
	 * perpendicular to its radius (eq 2's rows); d[j] counts where bit j of layout_keys is set,
	 * elsewhere model.d does (ctl_settings_wheels_follow). Default: the paper's. */
	struct {
		int wheels;          /* 3 or 4 */
		double angle_deg[4]; /* [deg] */
		double d[4];         /* [m] */
	} layout;
	uint8_t layout_keys;
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
		double traction_mu;     /* floor's friction coefficient; 0 = no traction limit */
		double traction_margin; /* share of mu N_j kept in reserve */
		double com_height;      /* centre of mass above the floor [m] (load transfer) */
	} limits;
	struct {
		bool enable;          /* online estimation of the motors' constants */
		bool resistance;      /* each motor's R_j estimated and, once certain, in use */
		double forget;        /* RLS forgetting factor per sample taken [-] */
		double current_min_a; /* a motor is fed only beyond this |current| [A] */
		double variance_gate; /* (sigma_R / R)^2 below which an estimate is taken [-] */
		bool friction; /* each body axis's B, C estimated and, once certain, in use */
		double friction_forget;        /* forgetting factor per friction sample [-] */
		double friction_variance_gate; /* (sigma_C / C)^2 below which it is taken [-] */
	} adapt;                               /* core/ adapt.h */
	struct est_keys est; /* the state estimator's noise figures and thresholds (est_keys.def) */
	struct {
		int feedforward; /* enum ctl_goal_ff: the tracker's feedforward */
		int limits;      /* enum ctl_goal_limits: the planner's limits */
		double floor_mu; /* the planner's mu while limits.traction_mu is 0 */
		double margin_v; /* supply kept for the feedback [V] (<= supply_v / 4 in use) */
		double motor_speed_max; /* motor shaft speed limit of the plans [rad/s] */
		double rot_share;       /* the heading's share when the position moves too */
	} goal;
};

/* [goal] feedforward: the reference's velocity and acceleration through the model, or its
 * velocity only (kinematic: velocity reference + PI, a peer). */
enum ctl_goal_ff { CTL_GOAL_FF_MODEL = 0, CTL_GOAL_FF_KINEMATIC = 1 };
/* [goal] limits: the model's envelope per direction and speed, or one fixed box (a peer). */
enum ctl_goal_limits { CTL_GOAL_LIMITS_MODEL = 0, CTL_GOAL_LIMITS_FIXED = 1 };

/* The defaults of ctl_keys.def: the paper's Table III robot at 1 kHz. */
void ctl_settings_defaults(struct ctl_settings *s);

/* Bit of wheel_keys for quantity q (0 r, 1 Kv, 2 Kt, 3 R: struct model_wheels' order), wheel j. */
#define CTL_WHEEL_KEY(q, j) ((uint16_t)(1u << (4 * (q) + (j))))
#define CTL_WHEEL_KEYS 16
/* The row of [model] wheels in ctl_keys.def (after the model's and the wheels' rows): what
 * ctl_settings_check names for a layout that does not drive the body. */
#define CTL_KEY_WHEELS (MODEL_PARAMS_COUNT + CTL_WHEEL_KEYS)

/* The layout in force (each d_j its own or model.d) as eq 2's rows and their maps: the paper's
 * closed forms (wheel_geom_paper) when it is the paper's layout, to the last bit. -EINVAL for a
 * layout that does not drive v, vn and w. */
int ctl_settings_geom(const struct ctl_settings *s, struct wheel_geom *g);
/* True for the paper's layout: four wheels at 0, 90, 180, 270 deg, all at d. */
bool ctl_settings_paper_layout(const struct ctl_settings *s);
/* The layout as model/'s prepares take it: *use NULL for the paper's (their closed forms, to
 * the bit), else g filled and *use = g. -EINVAL as ctl_settings_geom. */
int ctl_settings_layout(const struct ctl_settings *s, struct wheel_geom *g,
                        const struct wheel_geom **use);

/* Wheel j's distance from the centre in force: its own d_j, else model.d [m]. */
static inline double ctl_settings_wheel_distance(const struct ctl_settings *s, int j)
{
	return s->layout_keys & (1u << j) ? s->layout.d[j] : s->model.d;
}

/* The drives in force: wheel j's own value where it has its own key, else the scalar. With no
 * wheel keys, model_wheels_from_params(&s->model) bit for bit. */
void ctl_settings_wheels(const struct ctl_settings *s, struct model_wheels *w);
/* s->wheels = ctl_settings_wheels(s): a wheel without its own key takes the scalar (after the
 * scalar or a wheel key changed), so every wheel key reads as the value in force. */
void ctl_settings_wheels_follow(struct ctl_settings *s);

/* 0 if s can run a controller: the model physically meaningful (*bad_key = its index in
 * model_params_names; a wheel's own value: MODEL_PARAMS_COUNT + 4 q + j), rate_hz > 0 and
 * supply_min_v < supply_v (*bad_key = -1). why: the rule. */
int ctl_settings_check(const struct ctl_settings *s, int *bad_key, const char **why);

#endif /* OMNI4_CTL_SETTINGS_H */
