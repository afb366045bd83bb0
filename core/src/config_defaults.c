/* config_defaults.c - the documented defaults of every setting (no I/O, no libc beyond
 * memset): the start of a robot's configuration before its INI file, and the whole of it on a
 * microcontroller. */
#include "omni4/config_types.h"

#include <string.h>

/* Copy a literal that fits (all of them do: CONFIG_STR_MAX is 128). */
#define copy(dst, lit)                                                        \
	do {                                                                  \
		_Static_assert(sizeof(lit) <= sizeof(dst), "default too long"); \
		memcpy((dst), (lit), sizeof(lit));                            \
	} while (0)

void config_defaults(struct omni4_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->model = model_params_table3;
	cfg->loop.rate_hz = 1000.0;
	cfg->loop.sched_fifo = false;
	cfg->loop.priority = 80;
	cfg->loop.mlockall = false;
	cfg->loop.cpu_dma_latency_us = -1;
	cfg->control.kp = 20.0;
	cfg->control.ki = 200.0;
	cfg->control.feedforward = true;
	cfg->control.feedback = true;
	cfg->control.cmd_timeout_ms = 200;
	cfg->control.stop_ramp_s = 0.2;
	cfg->limits.supply_v = 12.0;
	cfg->limits.supply_min_v = 9.0;
	cfg->limits.vel_lin_max = 3.0;
	cfg->limits.vel_rot_max = 20.0;
	cfg->limits.acc_lin_max = 3.0;
	cfg->limits.acc_rot_max = 30.0;
	cfg->limits.current_max_a = 5.0;
	cfg->limits.current_sensor_max_a = 10.2; /* the CAN STATUS current range ends at 10.235 A */
	copy(cfg->lcm.url, "udpm://239.255.76.67:7667?ttl=0");
	copy(cfg->hal.motor, "sim");
	copy(cfg->hal.lines, "sim");
	cfg->sim.current_noise_a = 0.02;
	cfg->sim.encoder_cpr = 10240; /* 2048 counts per motor turn x gearbox 5 */
	cfg->sim.camera_rate_hz = 25.0;
	cfg->sim.camera_pos_noise_m = 0.01;
	cfg->sim.camera_theta_noise_rad = 3.0 * 3.14159265358979323846 / 180.0;
	cfg->sim.seed = 1;
	/* sim.current_offset_a[0..3]: 0 A (the memset above): no sensor offsets */
	cfg->sim.encoder_eccentricity = 0.0;
	copy(cfg->can.iface, "can0");
	cfg->can.bitrate = 1000000;
	cfg->can.status_timeout_ms = 5;
	copy(cfg->gpio.chip, "gpiochip0");
	cfg->gpio.estop_line = -1;
	cfg->gpio.estop_active_low = true;
	cfg->gpio.enable_line = -1;
	cfg->gpio.led_line = -1;
}
