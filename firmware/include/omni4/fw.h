/*
 * fw.h - one controller instance: the controller (ctl), its HAL devices, the command mailbox
 * (LCM receive thread -> loop) and the log ring (loop -> logger thread). fw_tick is the body
 * of the fixed-rate loop; the same function runs in the robot binary and in the simulator.
 */
#ifndef OMNI4_FW_H
#define OMNI4_FW_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "omni4/config.h"
#include "omni4/ctl.h"
#include "omni4/hal.h"
#include "omni4/ring.h"
#include "omni4/sim_motor.h"

#define FW_LOG_RING_SLOTS 8192 /* 8 s of samples at 1 kHz */
#define FW_CMD_RING_SLOTS 64

enum log_kind { LOG_MOTORS = 1, LOG_POSE = 2 };

/* One log ring entry: a motors_t or a pose_t sample, not yet encoded. */
struct log_entry {
	int64_t utime;
	int64_t seq;
	uint8_t kind;
	int8_t mode;
	int32_t faults;
	float voltage[4];
	float current[4];
	float wheel_speed[4];
	double pose[3];
};

struct fw_counters {
	uint64_t ticks;
	uint64_t log_dropped;   /* ring full: samples lost (never blocks the loop) */
	_Atomic uint64_t cmd_dropped; /* command mailbox full */
	uint64_t read_errors;
	uint64_t write_errors;
};

struct fw {
	struct ctl ctl;
	struct motor_hal motor;
	struct line_hal lines;
	struct spsc_ring cmd_ring;
	struct spsc_ring log_ring;
	int64_t seq;
	bool hw_enabled;
	atomic_bool halted; /* fw_emergency_off was called: the loop writes nothing but 0 V */
	struct ctl_output last_out;
	struct motor_sample last_sample;
	struct fw_counters n;
	struct ctl_command cmd_buf[FW_CMD_RING_SLOTS];
	struct log_entry log_buf[FW_LOG_RING_SLOTS];
};

/* Start-up. Settings of the sim backend from the INI: the plant of `plant`, the [sim] sensor
 * noise (or exact sensors when noise is false), the loop period and supply. */
struct sim_motor_config fw_sim_motor_config(const struct omni4_config *cfg,
					    const struct model_params *plant, bool noise);

/* Start-up. Outputs are switched off. -EINVAL for a bad configuration. */
int fw_init(struct fw *fw, const struct omni4_config *cfg, struct motor_hal motor,
	    struct line_hal lines);

/* Fast loop. One tick at controller time now_us. */
void fw_tick(struct fw *fw, int64_t now_us);

/* Receive thread. false if the mailbox is full (counted). */
bool fw_post_command(struct fw *fw, const struct ctl_command *cmd);

/* Loop thread (e.g. a simulated camera called from the HAL read). */
void fw_push_pose(struct fw *fw, int64_t utime, const double pose[3]);

/* Logger thread. */
bool fw_pop_log(struct fw *fw, struct log_entry *e);

/* Shutdown / any exit path: outputs off (voltages 0, bridges and enable line off). */
void fw_outputs_off(struct fw *fw);
/* Crash handlers (any thread): outputs off now, and the loop stops driving for good. */
void fw_emergency_off(struct fw *fw);

#endif /* OMNI4_FW_H */
