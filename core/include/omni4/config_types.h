/*
 * config_types.h - a robot's settings as the controller core sees them: the model, the loop,
 * control gains and limits, and the Linux adapter's own sections (LCM, HAL backends, CAN,
 * GPIO, the simulator), kept in one plain struct so that the INI loader (config/), the
 * parameter service and the core share one definition. No I/O here: the INI file is read and
 * written by config.h's functions; on a microcontroller config_defaults() is the start.
 */
#ifndef OMNI4_CONFIG_TYPES_H
#define OMNI4_CONFIG_TYPES_H

#include <stdbool.h>
#include <stdint.h>

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
		/* Sensor faults (0: none) */
		double current_offset_a[4];    /* added to each channel's current readings [A] */
		double encoder_eccentricity;   /* motor-shaft encoder reads theta + e sin(theta - phi) */
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
	struct {
		char secret[CONFIG_STR_MAX]; /* "" = parameter changes over LCM need no token */
	} params;
};


/* The documented defaults: the paper's Table III robot, 1 kHz, the sim backend. */
void config_defaults(struct omni4_config *cfg);

#endif /* OMNI4_CONFIG_TYPES_H */
