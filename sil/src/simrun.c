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
#include "omni4/lcmcodec.h"
#include "omni4/robot.h"
#include "omni4_motors_t.h"

struct simrun {
	struct robot robot; /* large: the controller's rings */
	lcm_eventlog_t *log;
	int64_t utime0;
	int64_t period_us;
	struct simrun_stats st;
	simrun_tap_fn tap;
	void *tap_ctx;
};

static int write_event(struct simrun *sr, const char *channel, int64_t utime, const void *data,
                       size_t len)
{
	const int rc = sr->log ? omni4_eventlog_write(sr->log, channel, utime, data, len) : 0;

	if (rc && !sr->st.log_errno)
		sr->st.log_errno = -rc;
	return rc;
}

static int sink_emit(void *ctx, const char *channel, int64_t utime, const void *data, size_t len)
{
	struct simrun *sr = ctx;
	const int rc = write_event(sr, channel, utime, data, len);

	if (sr->tap)
		sr->tap(sr->tap_ctx, channel, utime, data, len);
	if (rc == 0) {
		sr->st.messages++;
		if (!strcmp(channel, OMNI4_CHANNEL_MOTORS))
			sr->st.motors++;
		else if (!strcmp(channel, OMNI4_CHANNEL_POSE))
			sr->st.pose++;
		else if (!strcmp(channel, OMNI4_CHANNEL_STATE))
			sr->st.state++;
		else if (!strcmp(channel, OMNI4_CHANNEL_SIM_TRUTH))
			sr->st.other++; /* the plant's true state, one per tick */
		else
			sr->st.calibrations++; /* OMNI4_PARAM_CHANGED, source "calibration" */
	}
	return rc;
}

struct simrun *simrun_create(const struct omni4_config *cfg,
                             const struct model_params *plant_params, bool noise,
                             const char *log_path, char *err, size_t errlen)
{
	struct simrun *sr = calloc(1, sizeof(*sr));
	struct timespec now;

	if (!sr) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	clock_gettime(CLOCK_REALTIME, &now);
	sr->utime0 = (int64_t)now.tv_sec * 1000000 + now.tv_nsec / 1000;
	/* The plant state after the step in tick k is the one sampled at tick k's time. */
	const struct robot_spec spec = {
	    .ctl = &cfg->ctl,
	    .motor = OMNI4_MOTOR_SIM,
	    .lines = OMNI4_LINES_SIM,
	    .sim = &cfg->sim,
	    .sim_exact = !noise,
	    .plant = plant_params,
	    .utime0 = sr->utime0,
	};

	if (robot_open(&sr->robot, &spec, err, errlen))
		goto err_free;
	sr->period_us = sr->robot.sim.period_us;
	if (log_path) {
		sr->log = lcm_eventlog_create(log_path, "w");
		if (!sr->log) {
			snprintf(err, errlen, "%s: cannot create log: %s", log_path,
			         strerror(errno));
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
	robot_close(&sr->robot);
	if (sr->log)
		lcm_eventlog_destroy(sr->log);
	free(sr);
}

int simrun_flush_log(struct simrun *sr)
{
	if (!sr->log || !fflush(sr->log->f))
		return 0;
	const int e = errno ? errno : EIO;

	sr->st.log_errors++;
	if (!sr->st.log_errno)
		sr->st.log_errno = e;
	return -e;
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
	fw_post_command(&sr->robot.fw, &cmd);
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

	fw_tick(&sr->robot.fw, simrun_now_us(sr));
	sr->st.faults |= sr->robot.fw.last_out.faults;
	lcmio_drain(&sr->robot.fw, &sink, &sr->st.log_errors);
	sr->st.ticks++;
}

void simrun_get_stats(const struct simrun *sr, struct simrun_stats *out)
{
	*out = sr->st;
	out->log_dropped = sr->robot.fw.n.log_dropped;
	out->cmd_rejected = sr->robot.fw.ctl.n.cmd_rejected;
	out->mode = sr->robot.fw.last_out.mode;
}

void simrun_truth(const struct simrun *sr, double x[3], double pose[3])
{
	memcpy(x, sr->robot.sim.plant.x, 3 * sizeof(double));
	memcpy(pose, sr->robot.sim.plant.pose, 3 * sizeof(double));
}

void simrun_set_estop(struct simrun *sr, bool pressed)
{
	atomic_store(&sr->robot.sim_lines.estop, pressed);
}

struct sim_motor_faults *simrun_faults(struct simrun *sr)
{
	return &sr->robot.sim.inject;
}

void simrun_reference(const struct simrun *sr, double ref[3])
{
	for (int k = 0; k < 3; k++)
		ref[k] = sr->robot.fw.ctl.shaper.ref[k];
}

uint64_t simrun_watchdog_trips(const struct simrun *sr)
{
	return sr->robot.fw.ctl.n.watchdog_trips;
}

void simrun_set_tap(struct simrun *sr, simrun_tap_fn fn, void *ctx)
{
	sr->tap = fn;
	sr->tap_ctx = ctx;
}

const struct est_output *simrun_estimate(const struct simrun *sr)
{
	return est_get(&sr->robot.fw.est);
}
