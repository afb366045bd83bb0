/* simrun.c - lockstep firmware + plant, logging to an LCM event log (see simrun.h). */
#include "omni4/sil/simrun.h"

#include <errno.h>
#include <lcm/eventlog.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "omni4/lcmtypes/eventlog.h"
#include "omni4/firmware/goalcodec.h"
#include "omni4/firmware/lcmcodec.h"
#include "omni4/firmware/robot.h"
#include "omni4_motors_t.h"
#include "omni4_sim_plant_t.h"

struct simrun_channel {
	const char *id; /* the pointer last seen for it (channel names are constants) */
	uint64_t *part; /* its field of simrun_stats */
	char name[SIMRUN_CHANNEL_NAME_MAX];
	uint64_t n;
};

struct simrun {
	struct robot robot; /* large: the controller's rings */
	lcm_eventlog_t *log;
	int64_t utime0;
	int64_t period_us;
	int64_t next_plant_us; /* the tick time (since utime0) of the next OMNI4_SIM_PLANT */
	struct simrun_stats st;
	simrun_tap_fn tap;
	void *tap_ctx;
	struct simrun_channel chan[SIMRUN_CHANNELS_MAX]; /* in the order first written */
	size_t n_chan;
	size_t wlen;                  /* bytes waiting in wbuf */
	unsigned char wbuf[1u << 20]; /* the log's events, written 1 MiB at a time */
};

/* The field of simrun_stats a channel is counted in. */
static uint64_t *stats_part(struct simrun_stats *st, const char *channel)
{
	static const char *const names[] = {OMNI4_CHANNEL_MOTORS,        OMNI4_CHANNEL_POSE,
	                                    OMNI4_CHANNEL_CMD,           OMNI4_CHANNEL_STATE,
	                                    OMNI4_CHANNEL_SIM_TRUTH,     OMNI4_CHANNEL_EXPERIMENT,
	                                    OMNI4_CHANNEL_PARAM_CHANGED, OMNI4_CHANNEL_GOAL,
	                                    OMNI4_CHANNEL_GOAL_STATUS,   OMNI4_CHANNEL_SIM_PLANT};
	uint64_t *const parts[] = {&st->motors,      &st->pose,       &st->cmd,          &st->state,
	                           &st->truth,       &st->experiment, &st->calibrations, &st->goal,
	                           &st->goal_status, &st->plant};

	for (size_t k = 0; k < sizeof(names) / sizeof(names[0]); k++)
		if (!strcmp(channel, names[k]))
			return parts[k];
	return &st->other;
}

/* The row of channel in the per-channel count: the same pointer as last time, else the same
 * name, else a new row (beyond SIMRUN_CHANNELS_MAX - 1 names, or a name too long, the last row
 * counts them all as "(other)"). */
static struct simrun_channel *channel_row(struct simrun *sr, const char *channel)
{
	size_t k;

	for (k = 0; k < sr->n_chan; k++)
		if (sr->chan[k].id == channel)
			return &sr->chan[k];
	for (k = 0; k < sr->n_chan; k++)
		if (!strcmp(sr->chan[k].name, channel))
			break;
	if (k == sr->n_chan) {
		const size_t len = strlen(channel);

		if (k < SIMRUN_CHANNELS_MAX - 1 && len < SIMRUN_CHANNEL_NAME_MAX) {
			memcpy(sr->chan[k].name, channel, len + 1);
			sr->chan[k].part = stats_part(&sr->st, channel);
			sr->n_chan++;
		} else { /* the catch-all row */
			k = SIMRUN_CHANNELS_MAX - 1;
			memcpy(sr->chan[k].name, "(other)", sizeof("(other)"));
			sr->chan[k].part = &sr->st.other;
			sr->n_chan = SIMRUN_CHANNELS_MAX;
		}
	}
	sr->chan[k].id = channel;
	return &sr->chan[k];
}

/* One more event written on channel. */
static void count_channel(struct simrun *sr, const char *channel)
{
	struct simrun_channel *c = channel_row(sr, channel);

	c->n++;
	(*c->part)++;
	sr->st.messages++;
}

static void put_be32(unsigned char *p, uint32_t v)
{
	p[0] = (unsigned char)(v >> 24);
	p[1] = (unsigned char)(v >> 16);
	p[2] = (unsigned char)(v >> 8);
	p[3] = (unsigned char)v;
}

static void put_be64(unsigned char *p, int64_t v)
{
	put_be32(p, (uint32_t)((uint64_t)v >> 32));
	put_be32(p + 4, (uint32_t)(uint64_t)v);
}

/* The events waiting in wbuf to the log's stream; 0 or -errno (they are dropped then). */
static int put_pending(struct simrun *sr)
{
	const size_t n = sr->wlen;

	sr->wlen = 0;
	errno = 0;
	if (n && fwrite_unlocked(sr->wbuf, 1, n, sr->log->f) != n) /* this thread only writes it */
		return errno ? -errno : -EIO;
	return 0;
}

/* One event, as omni4_eventlog_write (liblcm's lcm_eventlog_write_event) lays it out: sync word,
 * event number, time, channel length, data length, channel, data. The lockstep run writes
 * ~400000 events per simulated experiment sequence: each is laid out in wbuf, which goes to the
 * stream in one fwrite when full (instead of liblcm's seven fwrites, or one, per event). Larger
 * than an event may be: liblcm's own writer, after the events before it. */
static int put_event(struct simrun *sr, const char *channel, int64_t utime, const void *data,
                     size_t len)
{
	const size_t clen = strlen(channel);
	const size_t n = OMNI4_EVENT_HEADER_BYTES + clen + len;

	if (!sr->log)
		return 0;
	if (clen >= SIMRUN_CHANNEL_NAME_MAX || len > LCMIO_MAX_MSG) {
		const int rc = put_pending(sr);

		return rc ? rc : omni4_eventlog_write(sr->log, channel, utime, data, len);
	}
	if (sr->wlen + n > sizeof(sr->wbuf)) {
		const int rc = put_pending(sr);

		if (rc)
			return rc;
	}
	unsigned char *buf = sr->wbuf + sr->wlen;

	put_be32(buf, 0xEDA1DA01u);
	put_be64(buf + 4, sr->log->eventcount);
	put_be64(buf + 12, utime);
	put_be32(buf + 20, (uint32_t)clen);
	put_be32(buf + 24, (uint32_t)len);
	memcpy(buf + OMNI4_EVENT_HEADER_BYTES, channel, clen);
	memcpy(buf + OMNI4_EVENT_HEADER_BYTES + clen, data, len);
	sr->wlen += n;
	sr->log->eventcount++;
	return 0;
}

static int write_event(struct simrun *sr, const char *channel, int64_t utime, const void *data,
                       size_t len)
{
	const int rc = put_event(sr, channel, utime, data, len);

	if (rc && !sr->st.log_errno)
		sr->st.log_errno = -rc;
	return rc;
}

static int sink_emit(void *ctx, const char *channel, int64_t utime, int64_t seq, const void *data,
                     size_t len)
{
	struct simrun *sr = ctx;
	const int rc = write_event(sr, channel, utime, data, len);

	(void)seq;
	if (sr->tap)
		sr->tap(sr->tap_ctx, channel, utime, data, len);
	if (rc == 0)
		count_channel(sr, channel);
	return rc;
}

struct simrun *simrun_create(const struct omni4_config *cfg,
                             const struct model_params *plant_params, bool noise,
                             const char *log_path, char *err, size_t errlen)
{
	return simrun_create_wrapped(cfg, plant_params, noise, log_path, NULL, NULL, err, errlen);
}

struct simrun *simrun_create_wrapped(const struct omni4_config *cfg,
                                     const struct model_params *plant_params, bool noise,
                                     const char *log_path,
                                     struct motor_hal (*wrap)(void *ctx, struct motor_hal sim),
                                     void *wrap_ctx, char *err, size_t errlen)
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
	    .wrap = wrap,
	    .wrap_ctx = wrap_ctx,
	};

	if (robot_open(&sr->robot, &spec, err, errlen))
		goto err_free;
	sr->period_us = sr->robot.sim.period_us;
	sr->robot.fw.no_estimate = !cfg->sim.estimate; /* no OMNI4_STATE */
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
	if (sr->log) {
		put_pending(sr); /* (a caller that wants to know flushes first) */
		lcm_eventlog_destroy(sr->log);
	}
	free(sr);
}

int simrun_flush_log(struct simrun *sr)
{
	if (!sr->log)
		return 0;
	const int rc = put_pending(sr);

	if (!rc && !fflush(sr->log->f))
		return 0;
	const int e = rc ? -rc : errno ? errno : EIO;

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
		count_channel(sr, OMNI4_CHANNEL_CMD);
	} else {
		sr->st.log_errors++;
	}
	if (rc)
		return rc;
	fw_post_command(&sr->robot.fw, &cmd);
	return 0;
}

int simrun_goal(struct simrun *sr, const void *data, size_t len)
{
	struct goal_cmd g;
	const int rc = lcmio_decode_goal(data, len, &g);

	if (write_event(sr, OMNI4_CHANNEL_GOAL, simrun_now_us(sr), data, len) == 0)
		count_channel(sr, OMNI4_CHANNEL_GOAL);
	else
		sr->st.log_errors++;
	if (rc == -EINVAL)
		return rc;
	fw_post_goal(&sr->robot.fw, &g);
	return 0;
}

int simrun_publish(struct simrun *sr, const char *channel, const void *data, size_t len)
{
	const int rc = write_event(sr, channel, simrun_now_us(sr), data, len);

	if (rc == 0) {
		count_channel(sr, channel);
	} else {
		sr->st.log_errors++;
	}
	return rc;
}

/* The plant's changing parameters after the tick's step (sim_plant_t), logged at the tick's
 * time. */
static void log_plant(struct simrun *sr)
{
	struct sim_plant_state ps;
	unsigned char buf[128];

	sim_motor_plant_state(&sr->robot.sim, &ps);
	omni4_sim_plant_t m = {
	    .utime = ps.utime, .supply_v = ps.supply_v, .friction_scale = ps.friction_scale};

	memcpy(m.R, ps.R_ohm, sizeof(m.R));
	memcpy(m.winding_temp, ps.winding_c, sizeof(m.winding_temp));
	const int n = omni4_sim_plant_t_encode(buf, 0, (int)sizeof(buf), &m);

	if (n < 0 || write_event(sr, OMNI4_CHANNEL_SIM_PLANT, ps.utime, buf, (size_t)n))
		sr->st.log_errors++;
	else
		count_channel(sr, OMNI4_CHANNEL_SIM_PLANT);
}

void simrun_tick(struct simrun *sr)
{
	const struct lcmio_sink sink = {.emit = sink_emit, .ctx = sr};

	fw_tick(&sr->robot.fw, simrun_now_us(sr));
	/* In lockstep: a plan asked for is made before the next tick. */
	fw_background(&sr->robot.fw);
	sr->st.faults |= sr->robot.fw.last_out.faults;
	lcmio_drain(&sr->robot.fw, &sink, &sr->st.log_errors);
	if ((int64_t)sr->st.ticks * sr->period_us >= sr->next_plant_us) {
		log_plant(sr);
		sr->next_plant_us += SIMRUN_PLANT_PERIOD_US;
	}
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

struct fw *simrun_fw(struct simrun *sr)
{
	return &sr->robot.fw;
}

void simrun_plant_resistance(const struct simrun *sr, double R_ohm[4])
{
	struct sim_plant_state ps;

	sim_motor_plant_state(&sr->robot.sim, &ps);
	memcpy(R_ohm, ps.R_ohm, sizeof(ps.R_ohm));
}

double simrun_plant_friction_scale(const struct simrun *sr)
{
	struct sim_plant_state ps;

	sim_motor_plant_state(&sr->robot.sim, &ps);
	return ps.friction_scale;
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

size_t simrun_channel_counts(const struct simrun *sr, const char **names, uint64_t *counts,
                             size_t max)
{
	size_t k;

	for (k = 0; k < sr->n_chan && k < max; k++) {
		names[k] = sr->chan[k].name;
		counts[k] = sr->chan[k].n;
	}
	return sr->n_chan;
}

const struct est_output *simrun_estimate(const struct simrun *sr)
{
	return est_get(&sr->robot.fw.est);
}
