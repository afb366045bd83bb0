/* goal_rig.h - the goal mode's HIL rig: goals as goal_t bytes into a lockstep simrun, what the
 * controller said about them read back from its goal_status_t messages. */
#ifndef OMNI4_GOAL_RIG_H
#define OMNI4_GOAL_RIG_H

#include <stdio.h>

#include "hil_util.h"
#include "omni4/core/goal.h"
#include "omni4_goal_status_t.h"
#include "omni4_goal_t.h"
#include "omni4_sim_truth_t.h"
#include "omni4_state_t.h"
#include "omni4_test.h"

/* What the controller said about goals, from its messages. */
#define HEARD_CHANGES 256
struct heard {
	omni4_goal_status_t last;
	int n;
	int refused; /* goal_status_t with STATUS_REFUSED */
	/* every change of (goal_id, status, reason, index) from one message to the next */
	struct heard_change {
		int64_t utime, goal_id;
		int8_t status, reason;
		int32_t index;
	} change[HEARD_CHANGES];
	int n_change;
	long slip_ticks; /* OMNI4_SIM_TRUTH samples with a wheel beyond its traction */
	float cov[6];    /* the last OMNI4_STATE's covariance diagonal (x y theta v vn w) */
	/* at the last change to REACHED: distance and heading still to go, and the estimate's own
	 * standard deviations then, sqrt(var x + var y) [m] and sqrt(var theta) [rad] */
	float reached_dist, reached_angle, reached_sd_pos, reached_sd_th;
};

static inline void tap(void *ctx, const char *channel, int64_t utime, const void *data, size_t len)
{
	struct heard *h = ctx;
	omni4_goal_status_t m;

	(void)utime;
	if (!strcmp(channel, "OMNI4_STATE")) {
		omni4_state_t st;

		if (omni4_state_t_decode(data, 0, (int)len, &st) == (int)len)
			memcpy(h->cov, st.covariance, sizeof(h->cov));
		return;
	}
	if (!strcmp(channel, "OMNI4_SIM_TRUTH")) {
		omni4_sim_truth_t t;

		if (omni4_sim_truth_t_decode(data, 0, (int)len, &t) == (int)len && (t.flags & 0x0f))
			h->slip_ticks++;
		return;
	}
	if (strcmp(channel, "OMNI4_GOAL_STATUS") ||
	    omni4_goal_status_t_decode(data, 0, (int)len, &m) != (int)len)
		return;
	const struct heard_change now = {m.utime, m.goal_id, m.status, m.reason, m.index};
	const struct heard_change *was = h->n_change ? &h->change[h->n_change - 1] : NULL;

	if ((!was || was->goal_id != now.goal_id || was->status != now.status ||
	     was->reason != now.reason || was->index != now.index) &&
	    h->n_change < HEARD_CHANGES)
		h->change[h->n_change++] = now;
	if (m.status == OMNI4_GOAL_STATUS_T_STATUS_REACHED &&
	    (!was || was->status != m.status || was->goal_id != m.goal_id)) {
		h->reached_dist = m.distance_m;
		h->reached_angle = fabsf(m.angle_rad);
		h->reached_sd_pos = sqrtf(h->cov[0] + h->cov[1]);
		h->reached_sd_th = sqrtf(h->cov[2]);
	}
	h->last = m;
	h->n++;
	h->refused += m.status == OMNI4_GOAL_STATUS_T_STATUS_REFUSED;
}

static inline struct simrun *make(bool noise, struct heard *h)
{
	struct omni4_config cfg;
	char err[256];

	config_defaults(&cfg);
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, noise, NULL, err, sizeof(err));

	if (!sr)
		fail_msg("simrun_create: %s", err);
	memset(h, 0, sizeof(*h));
	simrun_set_tap(sr, tap, h);
	hil_run(sr, 0.3); /* the first camera poses reach the estimator */
	return sr;
}

static inline int8_t mode_of(struct simrun *sr)
{
	struct simrun_stats st;

	simrun_get_stats(sr, &st);
	return st.mode;
}

/* One goal_t: n poses (x, y, theta) in p. */
static inline void send_goal(struct simrun *sr, int64_t id, int8_t action, int n,
                             const double (*p)[3], double speed_max)
{
	static int64_t seq;
	double rows[GOAL_POSES_MAX + 1][3];
	double *ptrs[GOAL_POSES_MAX + 1];

	for (int i = 0; i < n; i++) {
		memcpy(rows[i], p[i], sizeof(rows[i]));
		ptrs[i] = rows[i];
	}
	omni4_goal_t g = {.utime = simrun_now_us(sr),
	                  .seq = seq++,
	                  .goal_id = id,
	                  .action = action,
	                  .n = n,
	                  .poses = ptrs,
	                  .speed_max = speed_max};
	uint8_t buf[2048];
	const int len = omni4_goal_t_encode(buf, 0, sizeof(buf), &g);

	assert_true(len > 0);
	assert_int_equal(simrun_goal(sr, buf, (size_t)len), 0);
}

/* Keeps goal id alive every 50 ms until it is no longer ACTIVE or limit_s passes; seconds. */
static inline double drive_until_done(struct simrun *sr, struct heard *h, int64_t id, int n,
                                      const double (*p)[3], double limit_s)
{
	double t = 0.0;

	for (; t < limit_s; t += 0.05) {
		send_goal(sr, id, OMNI4_GOAL_T_ACTION_GO, n, p, 0.0);
		hil_run(sr, 0.05);
		if (h->last.goal_id == id && h->last.status != OMNI4_GOAL_STATUS_T_STATUS_ACTIVE)
			break;
	}
	return t;
}

#endif /* OMNI4_GOAL_RIG_H */
