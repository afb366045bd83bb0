/*
 * est_camera.c - the camera pose as a late measurement (est.h, est_camera): gated on the
 * Mahalanobis distance of its innovation, applied at its capture tick by the replay
 * (est_replay.c), or at arrival when replay is off.
 */
#include <errno.h>
#include <math.h>

#include "est_priv.h"
#include "omni4/core/est_replay.h"
#include "omni4/model/consts.h"
#include "omni4/core/la_f32.h"

/* Mahalanobis distance^2 of the pose innovation nu against the pose block of P + R. */
static float mahalanobis2(const struct est *e, const float nu[3])
{
	const float S[6] = {e->P[0][0] + e->rc[0], e->P[0][1], e->P[0][2],
	                    e->P[1][1] + e->rc[1], e->P[1][2], e->P[2][2] + e->rc[2]};
	float L[6];

	if (la_chol3_f32(S, 0.0f, L))
		return INFINITY;
	return la_chol3_norm2_f32(L, nu);
}

/* Gate the pose z against the current state; apply it if it passes. The EST_CAM_RESYNC-th
 * frame refused in a row is taken after all, the pose variance widened by its innovation (the
 * estimate, not the camera, is what went wrong). */
static int gate_and_apply(struct est *e, const float z[3])
{
	float nu[3] = {z[0] - e->s[0], z[1] - e->s[1], model_wrap_pi_f32(z[2] - e->s[2])};
	const float g = e->set.gate_sigmas;

	if (!(mahalanobis2(e, nu) <= g * g)) {
		if (e->cam_gate_run + 1 < EST_CAM_RESYNC)
			return -EINVAL;
		for (int k = 0; k < 3; k++)
			e->P[k][k] += nu[k] * nu[k];
	}
	for (int k = 0; k < 3; k++)
		e->out.cam_innov[k] = nu[k];
	est_pose_update(e, z);
	est_symmetrise(e);
	return 0;
}

static int camera_refused(struct est *e)
{
	e->cam_gate_run++;
	e->out.cam_gated++;
	return -EINVAL;
}

int est_camera(struct est *e, int64_t capture_us, const double pose[3], int64_t now_us)
{
	const float z[3] = {(float)pose[0], (float)pose[1], model_wrap_pi_f32((float)pose[2])};
	uint32_t k;

	if (!est_all_finite(z, 3) || !isfinite(pose[2])) {
		e->out.cam_gated++;
		return -EINVAL;
	}
	if (est_replay_find(e, capture_us, &k)) {
		e->out.cam_too_old++;
		return -ERANGE;
	}
	est_slip_camera(e, k, z, capture_us);
	if (e->set.replay ? est_replay_at(e, k, EST_LATE_POSE, z, gate_and_apply)
	                  : gate_and_apply(e, z))
		return camera_refused(e);
	e->cam_gate_run = 0;
	e->out.cam_taken++;
	e->out.cam_latency_us = now_us - capture_us;
	if (!e->have_cam || capture_us > e->last_cam_us)
		e->last_cam_us = capture_us;
	e->have_cam = true;
	if (now_us - e->last_cam_us <= EST_CAMERA_STALE_US)
		e->out.flags &= ~EST_FLAG_CAMERA_STALE;
	est_publish(e, e->out.utime);
	return 0;
}
