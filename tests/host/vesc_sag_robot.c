/* vesc_sag_robot.c - test_vesc_sag's controller side (vesc_sag_robot.h). */
#include "vesc_sag_robot.h"

#include <errno.h>
#include <stdbool.h>
#include <string.h>

#include "omni4/config/config.h"
#include "omni4/drivers/sc_os.h"
#include "omni4/firmware/robot.h"

#include "can_queue.h"

static int64_t clock_us;

const int32_t sag_fault_driver = CTL_FAULT_DRIVER;

static struct robot robot; /* large (the log ring) */
static struct omni4_config cfg;

void sag_bus_reset(int64_t now_us)
{
	can_queue_reset();
	clock_us = now_us;
}

void sag_bus_set_clock(int64_t now_us)
{
	clock_us = now_us;
}

int64_t __wrap_sc_os_now_us(void)
{
	return clock_us;
}

void sag_robot_model(struct model_params *out)
{
	config_defaults(&cfg);
	*out = cfg.ctl.model;
}

int sag_robot_open(char *why, size_t n)
{
	config_defaults(&cfg);
	cfg.fw.motor = OMNI4_MOTOR_VESC;
	cfg.fw.lines = OMNI4_LINES_NONE;
	cfg.vesc.mode = VESC_MODE_DUTY;
	const struct robot_spec spec = {.ctl = &cfg.ctl,
	                                .motor = OMNI4_MOTOR_VESC,
	                                .lines = OMNI4_LINES_NONE,
#define SPEC_SETTINGS(member, settings) .member = &cfg.member,
	                                OMNI4_BACKEND_SETTINGS(SPEC_SETTINGS)
#undef SPEC_SETTINGS
	};
	return robot_open(&robot, &spec, why, n);
}

void sag_robot_tick(int64_t now_us, int64_t seq, const double v[3], int32_t *faults,
                    int *in_velocity)
{
	struct ctl_command cmd = {.utime = now_us, .seq = seq, .mode = CTL_VELOCITY};
	struct log_entry e;

	memcpy(cmd.velocity, v, sizeof(cmd.velocity));
	fw_post_command(&robot.fw, &cmd);
	clock_us = now_us;
	fw_tick(&robot.fw, now_us);
	*faults = 0;
	while (fw_pop_log(&robot.fw, &e))
		if (e.kind == LOG_MOTORS)
			*faults |= e.sample.faults;
	*in_velocity = robot.fw.ctl.mode == CTL_VELOCITY;
}

const char *sag_robot_fault_text(char *buf, size_t n)
{
	return vesc_motor_fault_text(&robot.vesc, buf, n);
}

void sag_robot_close(void)
{
	robot_close(&robot);
}
