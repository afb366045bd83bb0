/* libFuzzer target: raw LCM bytes -> goal_t decoding -> the goal's checks, plans and tracking
 * -> controller ticks. The first byte picks the settings (the floor's traction, the peers); the
 * rest splits into messages (1 length byte + payload) and, for bytes that do not form a goal_t,
 * into structured goals (poses and options of every magnitude, NaN and infinity among them), so
 * the planner sees valid encodings too. The estimate follows the reference, with the camera
 * going stale and collisions now and then.
 * Properties: no crash/UB; the goal in force has finite poses; the report's status and reason are
 * words of the vocabulary and its reference is finite while ACTIVE; every output is finite,
 * within the supply, and 0 when disabled. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/core/goal.h"
#include "omni4/firmware/goalcodec.h"
#include "omni4_goal_t.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(const struct ctl *c, const struct ctl_output *o, const struct goal *g)
{
	for (int j = 0; j < 4; j++) {
		if (!isfinite(o->volts[j]) || fabsf(o->volts[j]) > c->set.limits.supply_v + 1e-3f)
			__builtin_trap();
		if (!o->enable && o->volts[j] != 0.0f)
			__builtin_trap();
	}
	if (g->rep.status < GOAL_NONE || g->rep.status > GOAL_REFUSED ||
	    g->rep.reason < GOAL_R_NONE || g->rep.reason > GOAL_R_CANCELLED)
		__builtin_trap();
	if (g->rep.status == GOAL_ACTIVE) {
		for (int k = 0; k < 3; k++)
			if (!isfinite(g->rep.ref[k]) || !isfinite(g->rep.ref_vel[k]))
				__builtin_trap();
		for (int i = 0; i < g->n; i++) /* the goal in force: every pose taken is finite */
			for (int k = 0; k < 3; k++)
				if (!isfinite(g->poses[i][k]))
					__builtin_trap();
	}
}

/* A goal_t built from n >= 8 bytes, then decoded as the loop would. */
static void structured(const uint8_t *b, size_t n, int64_t now, struct goal_cmd *cmd)
{
	static const double scale[4] = {0.01, 1.0, 100.0, 1e12};
	const double odd[4] = {0.0, NAN, INFINITY, -INFINITY};
	double rows[GOAL_POSES_MAX][3];
	double *ptrs[GOAL_POSES_MAX];
	const int np = 1 + b[0] % 4;

	for (int i = 0; i < np; i++) {
		for (int k = 0; k < 3; k++) {
			const uint8_t v = b[(1 + 3 * i + k) % n];

			rows[i][k] =
			    v == 0xFF ? odd[b[2] & 3] : (int8_t)v * scale[b[(i + k) % n] & 3] / 64;
		}
		ptrs[i] = rows[i];
	}
	omni4_goal_t m = {.utime = now,
	                  .seq = b[1],
	                  .goal_id = b[3] % 5,
	                  .action = (int8_t)(b[4] % 3),
	                  .n = np,
	                  .poses = ptrs,
	                  .blend_m = b[5] == 0xFF ? NAN : b[5] / 100.0,
	                  .speed_max = b[6] == 0xFF ? INFINITY : (int8_t)b[6] / 32.0};
	uint8_t buf[2048];
	const int len = omni4_goal_t_encode(buf, 0, sizeof(buf), &m);

	if (len <= 0 || lcmio_decode_goal(buf, (size_t)len, cmd) != 0)
		__builtin_trap();
}

static void settings(uint8_t b, struct ctl_settings *cfg)
{
	static const double mu[4] = {0.0, 0.3, 0.8, 1.5};

	ctl_settings_defaults(cfg);
	cfg->limits.traction_mu = mu[b & 3];
	cfg->goal.feedforward = (b >> 2) & 1;
	cfg->goal.limits = (b >> 3) & 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct ctl c;
	static struct goal g;
	struct ctl_settings cfg;
	struct ctl_output out;
	struct est_output est;
	int64_t now = 1000000;

	if (size < 1)
		return 0;
	settings(data[0], &cfg);
	memset(&g, 0, sizeof(g));
	memset(&est, 0, sizeof(est));
	if (ctl_init(&c, &cfg))
		__builtin_trap();
	goal_init(&g, &cfg);
	data++;
	size--;
	struct motor_sample s = {{0.1f, 0.1f, 0.1f, 0.1f}, {1, 1, 1, 1}, 12.0f, 0};

	while (size > 1) {
		const size_t n = data[0] < size - 1 ? data[0] : size - 1;
		struct goal_cmd cmd;

		if (lcmio_decode_goal(data + 1, n, &cmd) != 0) {
			if (n < 8)
				break;
			structured(data + 1, n, now, &cmd);
		}
		/* (a repeat of the goal in force is a keep-alive: its poses are not read) */
		goal_command(&g, &c, &cmd, &est, now);
		est.flags = data[n] == 0xEE ? EST_FLAG_CAMERA_STALE
		                            : (data[n] == 0xCC ? EST_FLAG_COLLISION : 0);
		for (int t = 0; t < 20; t++) {
			now += 1000;
			goal_step(&g, &c, &est, now);
			ctl_step(&c, now, &s, 0, false, &out);
			check(&c, &out, &g);
			goal_work(&g); /* a plan asked for, beside the loop */
			memcpy(est.pose, g.rep.ref, sizeof(est.pose));
		}
		data += n + 1;
		size -= n + 1;
	}
	for (int t = 0; t < 300; t++) { /* watchdog and stop ramps run to their end */
		now += 1000;
		goal_step(&g, &c, &est, now);
		ctl_step(&c, now, &s, 0, false, &out);
		check(&c, &out, &g);
	}
	return 0;
}
