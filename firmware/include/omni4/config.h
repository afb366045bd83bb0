/*
 * config.h - the one INI file of a robot (inih): model parameters and firmware settings.
 *
 * Sections and keys (SI units; defaults in config_defaults):
 *   [model]   d r l Kv Kt R M J Bv Bvn Bw Cv Cvn Cw   (all 14 required if the section is present)
 *   [loop]    rate_hz sched_fifo priority mlockall cpu_dma_latency_us
 *   [control] kp ki feedforward feedback cmd_timeout_ms stop_ramp_s
 *   [limits]  supply_v supply_min_v vel_lin_max vel_rot_max acc_lin_max acc_rot_max current_max_a
 *             current_sensor_max_a
 *   [lcm]     url
 *   [hal]     motor (sim|socketcan)  lines (none|sim|gpiod)
 *   [sim]     current_noise_a encoder_cpr camera_rate_hz camera_pos_noise_m
 *             camera_theta_noise_rad seed
 *   [can]     iface bitrate status_timeout_ms
 *   [gpio]    chip estop_line estop_active_low enable_line led_line
 * Unknown sections or keys, duplicate keys, malformed or out-of-range values are errors.
 */
#ifndef OMNI4_CONFIG_H
#define OMNI4_CONFIG_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "omni4/params.h"

#define CONFIG_STR_MAX 128

struct omni4_config {
	struct model_params model;
	struct {
		double rate_hz;
		bool sched_fifo;
		int priority;
		bool mlockall;
		int cpu_dma_latency_us; /* -1 = leave the CPU idle states alone; 0 = no deep C-state */
	} loop;
	struct {
		double kp;          /* PI on wheel linear speed [V/(m/s)] */
		double ki;          /* [V/m] */
		bool feedforward;
		bool feedback;
		int cmd_timeout_ms; /* watchdog: no valid command for this long -> ramp to 0 -> IDLE */
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
		double current_sensor_max_a; /* a reading at or beyond this is a saturated sensor [A] */
	} limits;
	struct {
		char url[CONFIG_STR_MAX];
	} lcm;
	struct {
		char motor[CONFIG_STR_MAX]; /* "sim" | "socketcan" */
		char lines[CONFIG_STR_MAX]; /* "none" | "sim" | "gpiod" */
	} hal;
	struct {
		double current_noise_a;        /* std dev [A] */
		int encoder_cpr;               /* counts per wheel revolution; 0 = ideal */
		double camera_rate_hz;
		double camera_pos_noise_m;     /* std dev [m] */
		double camera_theta_noise_rad; /* std dev [rad] */
		int seed;
	} sim;
	struct {
		char iface[CONFIG_STR_MAX];
		int bitrate;
		int status_timeout_ms;
	} can;
	struct {
		char chip[CONFIG_STR_MAX];
		int estop_line; /* -1 = not wired */
		bool estop_active_low;
		int enable_line;
		int led_line;
	} gpio;
};

struct config_error {
	int line;      /* 0 when the error is not tied to a line */
	char msg[256]; /* "PATH:LINE: what is wrong" */
};

void config_defaults(struct omni4_config *cfg);

/*
 * Load PATH over the defaults. 0 on success; -ENOENT if the file cannot be opened; -EINVAL on
 * any error in it, described in err (first error only).
 */
int config_load(const char *path, struct omni4_config *cfg, struct config_error *err);
/* Same, from a string in memory; name is used in messages. */
int config_load_string(const char *text, const char *name, struct omni4_config *cfg,
		       struct config_error *err);

/*
 * Like config_load, but [model] may hold any subset of its keys (e.g. a BASE.ini with only the
 * measured d r l M) and is not checked for physical sense. *model_seen gets bit i set for each
 * model_params_names[i] present.
 */
int config_load_partial(const char *path, struct omni4_config *cfg, uint32_t *model_seen,
			struct config_error *err);

/* Write a [model] section that config_load reads back exactly (%.17g). Returns 0 or -EIO. */
int config_write_model(FILE *f, const struct model_params *p);

#endif /* OMNI4_CONFIG_H */
