/* simrun.c - lockstep firmware + plant, logging to an LCM event log (see simrun.h). */
#include "omni4/simrun.h"

#include <errno.h>
#include <lcm/eventlog.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/eventlog.h"
#include "omni4/fw.h"
#include "omni4/lcmio.h"
#include "omni4/sim_motor.h"
#include "omni4_motors_t.h"

struct simrun {
	struct fw fw; /* large: holds the rings */
	struct sim_motor sim;
	struct sim_lines lines;
	lcm_eventlog_t *log;
	int64_t utime0;
	int64_t period_us;
	struct simrun_stats st;
};

static int write_event(struct simrun *sr, const char *channel, int64_t utime, const void *data,
		       size_t len)
{
	return sr->log ? omni4_eventlog_write(sr->log, channel, utime, data, len) : 0;
}

static int sink_emit(void *ctx, const char *channel, int64_t utime, const void *data, size_t len)
{
	struct simrun *sr = ctx;
	const int rc = write_event(sr, channel, utime, data, len);

	if (rc == 0) {
		sr->st.messages++;
		if (!strcmp(channel, OMNI4_CHANNEL_MOTORS))
			sr->st.motors++;
		else if (!strcmp(channel, OMNI4_CHANNEL_POSE))
			sr->st.pose++;
		else
			sr->st.calibrations++; /* OMNI4_PARAM_CHANGED, source "calibration" */
	}
	return rc;
}

static void on_pose(void *user, int64_t utime, const double pose[3])
{
	fw_push_pose(user, utime, pose);
}

struct simrun *simrun_create(const struct omni4_config *cfg, const struct model_params *plant_params,
			     bool noise, const char *log_path, char *err, size_t errlen)
{
	struct simrun *sr = calloc(1, sizeof(*sr));
	struct timespec now;

	if (!sr) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	const struct sim_motor_config sc = sim_motor_config_from(cfg, plant_params, noise);

	if (sim_motor_init(&sr->sim, &sc)) {
		snprintf(err, errlen, "invalid simulated robot (parameters or [sim] settings)");
		goto err_free;
	}
	if (fw_init(&sr->fw, cfg, sim_motor_hal(&sr->sim), sim_line_hal(&sr->lines))) {
		snprintf(err, errlen, "invalid firmware configuration");
		goto err_free;
	}
	clock_gettime(CLOCK_REALTIME, &now);
	sr->utime0 = (int64_t)now.tv_sec * 1000000 + now.tv_nsec / 1000;
	sr->period_us = sr->sim.period_us;
	/* The plant state after the step in tick k is the one sampled at tick k's time. */
	sim_motor_set_pose_cb(&sr->sim, on_pose, &sr->fw, sr->utime0 - sr->period_us);
	if (log_path) {
		sr->log = lcm_eventlog_create(log_path, "w");
		if (!sr->log) {
			snprintf(err, errlen, "%s: cannot create log: %s", log_path, strerror(errno));
			goto err_free;
		}
	}
	return sr;

err_free:
	free(sr);
	return NULL;
}

void simrun_destroy(struct simrun *sr)
{
	if (!sr)
		return;
	fw_outputs_off(&sr->fw);
	if (sr->log)
		lcm_eventlog_destroy(sr->log);
	free(sr);
}

int64_t simrun_now_us(const struct simrun *sr)
{
	return sr->utime0 + (int64_t)sr->st.ticks * sr->period_us;
}

double simrun_period_s(const struct simrun *sr)
{
	return (double)sr->period_us * 1e-6;
}

int simrun_command(struct simrun *sr, const void *data, size_t len)
{
	struct ctl_command cmd;
	const int rc = lcmio_decode_command(data, len, &cmd);

	if (write_event(sr, OMNI4_CHANNEL_CMD, simrun_now_us(sr), data, len) == 0) {
		sr->st.messages++;
		sr->st.cmd++;
	} else {
		sr->st.log_errors++;
	}
	if (rc)
		return rc;
	fw_post_command(&sr->fw, &cmd);
	return 0;
}

int simrun_publish(struct simrun *sr, const char *channel, const void *data, size_t len)
{
	const int rc = write_event(sr, channel, simrun_now_us(sr), data, len);

	if (rc == 0) {
		sr->st.messages++;
		sr->st.other++;
	} else {
		sr->st.log_errors++;
	}
	return rc;
}

void simrun_tick(struct simrun *sr)
{
	const struct lcmio_sink sink = {.emit = sink_emit, .ctx = sr};

	fw_tick(&sr->fw, simrun_now_us(sr));
	sr->st.faults |= sr->fw.last_out.faults;
	lcmio_drain(&sr->fw, &sink, &sr->st.log_errors);
	sr->st.ticks++;
}

void simrun_get_stats(const struct simrun *sr, struct simrun_stats *out)
{
	*out = sr->st;
	out->log_dropped = sr->fw.n.log_dropped;
	out->cmd_rejected = sr->fw.ctl.n.cmd_rejected;
	out->mode = sr->fw.last_out.mode;
}

void simrun_truth(const struct simrun *sr, double x[3], double pose[3])
{
	memcpy(x, sr->sim.plant.x, 3 * sizeof(double));
	memcpy(pose, sr->sim.plant.pose, 3 * sizeof(double));
}

void simrun_set_estop(struct simrun *sr, bool pressed)
{
	atomic_store(&sr->lines.estop, pressed);
}

struct sim_motor_faults *simrun_faults(struct simrun *sr)
{
	return &sr->sim.inject;
}

void simrun_reference(const struct simrun *sr, double ref[3])
{
	for (int k = 0; k < 3; k++)
		ref[k] = sr->fw.ctl.shaper.ref[k];
}

uint64_t simrun_watchdog_trips(const struct simrun *sr)
{
	return sr->fw.ctl.n.watchdog_trips;
}
