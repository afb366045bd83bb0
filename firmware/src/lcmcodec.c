/* lcmcodec.c - the controller's messages as LCM bytes (lcmcodec.h): command_t in, motors_t,
 * pose_t and calibration notices out, through the generated types. */
#include "omni4/firmware/lcmcodec.h"

#include "omni4/firmware/goalcodec.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "omni4_adapt_t.h"
#include "omni4_robot_t.h"
#include "omni4_command_t.h"
#include "omni4_motors_t.h"
#include "omni4_param_changed_t.h"
#include "omni4_pose_t.h"
#include "omni4_sim_truth_t.h"
#include "omni4_state_t.h"

/* The controller's modes and fault bits go out unchanged as motors_t's (lcmtypes/), command_t's
 * modes come in unchanged, the estimator's flags go out as state_t's: every row of vocab.def
 * must agree with the LCM constant of its name (the Python package's tests check the other way:
 * every LCM constant has its row). */
#define SAME(a, b) _Static_assert((a) == (b), #a " != " #b);
#define WIRE_CMD(name) SAME(CTL_##name, OMNI4_COMMAND_T_MODE_##name)
#define WIRE_STATE(name) SAME(CTL_##name, OMNI4_MOTORS_T_MODE_##name)
#define WIRE_BOTH(name) WIRE_CMD(name) WIRE_STATE(name)
#define OMNI4_MODE(name, value, wire, ...) WIRE_##wire(name)
#define OMNI4_FAULT(name, ...) SAME(CTL_FAULT_##name, OMNI4_MOTORS_T_FAULT_##name)
#define OMNI4_FLAG(name, ...) SAME(EST_FLAG_##name, OMNI4_STATE_T_FLAG_##name)
#include "omni4/core/vocab.def"
SAME(ADAPT_FLAG_ON, OMNI4_ADAPT_T_FLAG_ON)
SAME(ADAPT_FLAG_FED, OMNI4_ADAPT_T_FLAG_FED)
SAME(ADAPT_FLAG_FROZEN, OMNI4_ADAPT_T_FLAG_FROZEN)
SAME(ADAPT_FLAG_ADAPTED, OMNI4_ADAPT_T_FLAG_ADAPTED)
SAME(ADAPT_FLAG_WATCH, OMNI4_ADAPT_T_FLAG_WATCH)
SAME(ADAPT_FLAG_ACCEPTED, OMNI4_ADAPT_T_FLAG_ACCEPTED)
SAME(ADAPT_FLAG_REVERTED, OMNI4_ADAPT_T_FLAG_REVERTED)
SAME(ADAPT_FLAG_RESTART, OMNI4_ADAPT_T_FLAG_RESTART)
#undef WIRE_CMD
#undef WIRE_STATE
#undef WIRE_BOTH
#undef SAME

int lcmio_decode_command(const void *data, size_t len, struct ctl_command *out)
{
	omni4_command_t m;

	if (len > INT32_MAX || omni4_command_t_decode(data, 0, (int)len, &m) != (int)len)
		return -EINVAL;
	out->utime = m.utime;
	out->seq = m.seq;
	out->mode = m.mode;
	memcpy(out->velocity, m.velocity, sizeof(out->velocity));
	memcpy(out->voltage, m.voltage, sizeof(out->voltage));
	out->ramp_s = m.ramp_s;
	omni4_command_t_decode_cleanup(&m);
	return 0;
}

void lcmio_fault_channels(uint32_t mask, char out[8])
{
	char *p = out;

	for (int j = 0; j < 4; j++)
		if (mask & (1u << j)) {
			if (p != out)
				*p++ = ',';
			*p++ = (char)('0' + j);
		}
	*p = '\0';
}

/* A change the controller made itself (source) as param_changed_t: n keys with their values
 * now and before, VAL bytes each (lcmio.h). */
enum { CHANGED_KEYS_MAX = 6, CHANGED_VAL = 32 };
static int encode_changed(const struct log_entry *e, const char *source, const char *const *names,
                          char (*now)[CHANGED_VAL], char (*before)[CHANGED_VAL], int n, void *buf,
                          size_t cap)
{
	char *keys[CHANGED_KEYS_MAX], *values[CHANGED_KEYS_MAX], *old_values[CHANGED_KEYS_MAX];

	for (int k = 0; k < n; k++) {
		keys[k] = (char *)names[k];
		values[k] = now[k];
		old_values[k] = before[k];
	}
	const omni4_param_changed_t m = {.utime = e->utime,
	                                 .seq = e->seq,
	                                 .request_id = 0,
	                                 .source = (char *)source,
	                                 .path = (char *)"",
	                                 .n = n,
	                                 .keys = keys,
	                                 .old_values = old_values,
	                                 .values = values};

	if ((size_t)omni4_param_changed_t_encoded_size(&m) > cap)
		return -ENOSPC;
	return omni4_param_changed_t_encode(buf, 0, (int)cap, &m);
}

/* LOG_CALIBRATION -> param_changed_t (lcmio.h). */
static int encode_calibration(const struct log_entry *e, void *buf, size_t cap)
{
	enum { KEYS = 6, VAL = CHANGED_VAL };
	static const char *const names[KEYS] = {
	    "calibration.current_offset_a0", "calibration.current_offset_a1",
	    "calibration.current_offset_a2", "calibration.current_offset_a3",
	    "calibration.samples",           "calibration.fault_channels",
	};
	char now[KEYS][VAL], before[KEYS][VAL];
	const struct log_calibration *c = &e->cal;
	const bool first = c->prev_over_limit < 0;
	const uint32_t prev_faults = first ? 0 : (uint32_t)c->prev_over_limit;
	int n = 5;

	for (int j = 0; j < 4; j++) {
		snprintf(now[j], VAL, "%.6f", (double)c->offset[j]);
		snprintf(before[j], VAL, "%.6f", (double)c->prev_offset[j]);
	}
	snprintf(now[4], VAL, "%u", (unsigned)c->samples);
	/* Before the first set nothing was measured; every set has the same count. */
	snprintf(before[4], VAL, "%u", first ? 0u : (unsigned)c->samples);
	if (c->over_limit) {
		lcmio_fault_channels(c->over_limit, now[5]);
		lcmio_fault_channels(prev_faults, before[5]);
		n = 6;
	}
	return encode_changed(e, "calibration", names, now, before, n, buf, cap);
}

/* LOG_ADAPT_CHANGE -> param_changed_t (lcmio.h). */
static int encode_adapt_change(const struct log_entry *e, void *buf, size_t cap)
{
	enum { KEYS = 5, VAL = CHANGED_VAL };
	static const char *const names[KEYS] = {"adapt.R_0", "adapt.R_1", "adapt.R_2", "adapt.R_3",
	                                        "adapt.event"};
	char now[KEYS][VAL], before[KEYS][VAL];
	const struct log_adapt *a = &e->adapt;

	for (int j = 0; j < 4; j++) {
		snprintf(now[j], VAL, "%.6f", (double)a->R[j]);
		snprintf(before[j], VAL, "%.6f", (double)a->R_before[j]);
	}
	snprintf(now[4], VAL, "%s", a->flags & ADAPT_FLAG_REVERTED ? "reverted" : "accepted");
	before[4][0] = '\0';
	return encode_changed(e, "adapt", names, now, before, KEYS, buf, cap);
}

/* LOG_ADAPT -> adapt_t. */
static int encode_adapt(const struct log_entry *e, void *buf, size_t cap)
{
	const struct log_adapt *a = &e->adapt;
	omni4_adapt_t m = {.utime = e->utime,
	                   .seq = e->seq,
	                   .supply_v = a->supply_v,
	                   .Cv = a->C[0],
	                   .Cvn = a->C[1],
	                   .Cw = a->C[2],
	                   .track_rms = a->track_rms,
	                   .flags = (int32_t)a->flags};

	for (int j = 0; j < 4; j++) {
		m.R[j] = a->R[j];
		m.R_estimate[j] = a->R_est[j];
		m.R_variance[j] = a->R_var[j];
	}
	return omni4_adapt_t_encode(buf, 0, (int)cap, &m);
}

/* LOG_ROBOT -> robot_t. */
static int encode_robot(const struct log_entry *e, void *buf, size_t cap)
{
	omni4_robot_t m = {.utime = e->utime, .wheels = e->robot.wheels, .l = e->robot.l};

	memcpy(m.wheel_angle, e->robot.angle_rad, sizeof(m.wheel_angle));
	memcpy(m.wheel_distance, e->robot.dist_m, sizeof(m.wheel_distance));
	memcpy(m.wheel_radius, e->robot.radius_m, sizeof(m.wheel_radius));
	return omni4_robot_t_encode(buf, 0, (int)cap, &m);
}

/* The estimator's output as a state_t. */
static int encode_state(const struct log_entry *e, void *buf, size_t cap)
{
	const struct est_output *o = &e->state;
	omni4_state_t m = {.utime = e->utime,
	                   .seq = e->seq,
	                   .flags = (int32_t)o->flags,
	                   .null_residual = o->null_residual,
	                   .camera_latency_us = o->cam_latency_us,
	                   .camera_taken = (int32_t)o->cam_taken,
	                   .camera_gated = (int32_t)o->cam_gated,
	                   .camera_too_old = (int32_t)o->cam_too_old};

	for (int k = 0; k < 3; k++) {
		m.pose[k] = o->pose[k];
		m.velocity[k] = o->vel[k];
		m.camera_innovation[k] = o->cam_innov[k];
	}
	memcpy(m.covariance, o->cov, sizeof(m.covariance));
	memcpy(m.wheel_scale, o->wheel_scale, sizeof(m.wheel_scale));
	return omni4_state_t_encode(buf, 0, (int)cap, &m);
}

int lcmio_encode_log(const struct log_entry *e, void *buf, size_t cap, const char **channel)
{
	int n;

	if (e->kind == LOG_STATE) {
		*channel = OMNI4_CHANNEL_STATE;
		n = encode_state(e, buf, cap);
	} else if (e->kind == LOG_GOAL) {
		*channel = OMNI4_CHANNEL_GOAL_STATUS;
		n = lcmio_encode_goal_status(e, buf, cap);
	} else if (e->kind == LOG_ADAPT) {
		*channel = OMNI4_CHANNEL_ADAPT;
		n = encode_adapt(e, buf, cap);
	} else if (e->kind == LOG_ROBOT) {
		*channel = OMNI4_CHANNEL_ROBOT;
		n = encode_robot(e, buf, cap);
	} else if (e->kind == LOG_ADAPT_CHANGE) {
		*channel = OMNI4_CHANNEL_PARAM_CHANGED;
		n = encode_adapt_change(e, buf, cap);
	} else if (e->kind == LOG_CALIBRATION) {
		*channel = OMNI4_CHANNEL_PARAM_CHANGED;
		n = encode_calibration(e, buf, cap);
	} else if (e->kind == LOG_TRUTH) {
		omni4_sim_truth_t t = {
		    .utime = e->utime, .seq = e->seq, .flags = (int32_t)e->truth.flags};

		memcpy(t.pose, e->truth.pose, sizeof(t.pose));
		memcpy(t.vel, e->truth.vel, sizeof(t.vel));
		memcpy(t.wheel_slip, e->truth.wheel_slip, sizeof(t.wheel_slip));
		*channel = OMNI4_CHANNEL_SIM_TRUTH;
		n = omni4_sim_truth_t_encode(buf, 0, (int)cap, &t);
	} else if (e->kind == LOG_POSE) {
		const double *q = e->camera.pose;
		const omni4_pose_t p = {.utime = e->utime, .x = q[0], .y = q[1], .theta = q[2]};

		*channel = OMNI4_CHANNEL_POSE;
		n = omni4_pose_t_encode(buf, 0, (int)cap, &p);
	} else {
		const struct log_sample *s = &e->sample;
		omni4_motors_t m = {
		    .utime = e->utime, .seq = e->seq, .mode = s->mode, .faults = s->faults};

		memcpy(m.voltage, s->voltage, sizeof(m.voltage));
		memcpy(m.current, s->current, sizeof(m.current));
		memcpy(m.wheel_speed, s->wheel_speed, sizeof(m.wheel_speed));
		*channel = OMNI4_CHANNEL_MOTORS;
		n = omni4_motors_t_encode(buf, 0, (int)cap, &m);
	}
	return n > 0 ? n : -ENOSPC;
}

size_t lcmio_drain(struct fw *fw, const struct lcmio_sink *sink, uint64_t *sink_errors)
{
	struct log_entry e;
	unsigned char buf[LCMIO_MAX_MSG];
	const char *channel;
	size_t n = 0;

	while (fw_pop_log(fw, &e)) {
		const int len = lcmio_encode_log(&e, buf, sizeof(buf), &channel);

		if ((e.kind == LOG_CALIBRATION || e.kind == LOG_ADAPT_CHANGE) && sink->note)
			sink->note(sink->note_ctx, &e);

		if (len < 0 || sink->emit(sink->ctx, channel, e.utime, e.seq, buf, (size_t)len) < 0)
			(*sink_errors)++;
		n++;
	}
	return n;
}
