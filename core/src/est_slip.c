/*
 * est_slip.c - slip seen on every wheel, and the wheels named (est.h, EST_FLAG_SLIP_0..3;
 * docs/estimator.md, "Slip on every wheel").
 *
 * The null space (est.c) sees one wheel disagreeing with the rest; all four wheels slipping
 * alike (a rotation step that spins them all) leave it at 0. Two witnesses that do not need
 * the wheels to disagree:
 * - the model: each wheel's reading minus the model's prediction from the last estimate under
 *   the applied voltages (IK_j of the predicted velocity), averaged over EST_INNOV_AVG_TICKS,
 *   signed along the wheel's force (u_j - Kv_j l / r_j rim_j): a slipping wheel spins up on its
 *   own inertia, ahead of the body along the force that drives it (braking: behind it, and the
 *   force is reversed). Beyond slip_model_threshold for slip_ticks ticks: that wheel slips. A
 *   blocked or pushed-back body leaves the wheels behind the prediction: COLLISION, not this.
 *   A push along the motion looks the same to it (the camera does not confirm it).
 * - the camera: the wheels' distance between two frames (the ring of past ticks, from each
 *   frame's capture tick: its latency replayed; eqs 3-5) against the body's displacement the
 *   two poses give (in the robot frame at the mid heading), over the longest baseline still in
 *   the ring (up to EST_SLIP_FRAMES frames back), per axis v, vn, w in units of the camera's
 *   noise over that baseline. Beyond slip_camera_sigmas for two comparisons in a row (a single
 *   outlier frame spoils two that are never consecutive): the wheels that carry that axis
 *   (v: 1 and 3, vn: 0 and 2, w: all four) and whose rims are off the ground's (eq 2) by half
 *   the most of them or more slip, until a comparison says otherwise or the camera goes
 *   stale. Every finite frame counts, gated or not: the camera is the witness.
 * A flagged wheel is not trusted until it grips again (est_tick.untrusted, from the flags of
 * the tick before): its reading leaves the wheel update (the others one scalar update each;
 * none when all four slip: the model and the camera carry the state), its force in the
 * prediction is its motor's at the speed its rim spins (the voltage less the back-EMF of the
 * rim's lead over the ground), and when it is first flagged the ticks since the witnesses'
 * onset are re-run without it (the estimate keeps nothing the spinning wheel gave it). So the
 * estimate follows the body, the wheel stays ahead of the prediction and the flag holds until
 * the wheel grips.
 * Fast loop: no allocation, a few dozen operations per wheel.
 */
#include <math.h>
#include <string.h>

#include "est_priv.h"
#include "omni4/core/la_f32.h"
#include "omni4/model/consts.h"
#include "omni4/model/kinematics.h"

#define SLIP_CAM_RUN 2 /* comparisons in a row beyond the threshold */

void est_slip_reset(struct est *e)
{
	memset(&e->slip, 0, sizeof(e->slip));
	e->slip.null_wheel = -1;
}

void est_slip_model(struct est *e, const struct est_tick *t, const float wh[4])
{
	struct est_slip *s = &e->slip;
	float pred[4];

	wheel_rims_f32(&e->wh, &e->s[3], pred); /* eq 2 */
	for (int j = 0; j < 4; j++) {
		const float f = t->volts[j] - e->wh.kemf[j] * wh[j];
		const float sg = f > 0.0f ? 1.0f : (f < 0.0f ? -1.0f : 0.0f);

		s->nu_avg[j] += (wh[j] - pred[j] - s->nu_avg[j]) * (1.0f / EST_INNOV_AVG_TICKS);
		/* another layout (no null space behind it on three wheels): a wheel flagged stays
		 * flagged while its rim is off the ground either way (a spinning wheel that its
		 * motor now brakes still slips) */
		const bool held = e->layout && (t->untrusted >> j & 1);

		e->out.slip_model[j] =
		    t->driven ? (held ? fabsf(s->nu_avg[j]) : sg * s->nu_avg[j]) : 0.0f;
		if (e->out.slip_model[j] > e->set.slip_model_threshold)
			s->model_run[j]++;
		else
			s->model_run[j] = 0;
	}
}

/* Each rim's distance over ticks k0+1 .. k1 [m] (scale-corrected); false if a tick had no
 * reading. */
static bool rim_distance(const struct est *e, uint32_t k0, uint32_t k1, float dist[4])
{
	const float c0 = 1.0f + e->cal[0], c1 = 1.0f + e->cal[1], c2 = 1.0f + e->cal[2],
	            c3 = 1.0f + e->cal[3], dt = e->dt;
	float d0 = 0.0f, d1 = 0.0f, d2 = 0.0f, d3 = 0.0f; /* in registers, not through dist */
	bool all = true;

	for (uint32_t n = k0 + 1; n <= k1 && all; n++) {
		const struct est_tick *t = &e->hist[n % EST_HISTORY];

		all = t->have_wheels;
		d0 += t->wheel[0] * c0 * dt;
		d1 += t->wheel[1] * c1 * dt;
		d2 += t->wheel[2] * c2 * dt;
		d3 += t->wheel[3] * c3 * dt;
	}
	dist[0] = d0;
	dist[1] = d1;
	dist[2] = d2;
	dist[3] = d3;
	return all;
}

/* The wheels' velocity minus the camera's over ticks k0 .. k1 (poses z0, z1), per axis v, vn,
 * d w [m/s], in units of the camera's noise over that baseline (sqrt 2 cam_pos_noise / T along
 * v and vn, sqrt 2 d cam_theta_noise / T for d w); rim: each rim's distance off the ground's
 * that the poses give it (eq 2) [m]. */
static bool compare(const struct est *e, uint32_t k0, const float z0[3], uint32_t k1,
                    const float z1[3], float res[3], float rim[4])
{
	float g[4], sn, c;

	if (!rim_distance(e, k0, k1, g))
		return false;
	float ground[4], wheels[3];

	if (e->layout) /* the layout's least squares (eqs 3-5 for its rows) */
		wheel_body_f32(&e->wh, g, wheels);
	const float T = (float)(k1 - k0) * e->dt;
	const float wh_rot = e->layout ? e->d * wheels[2] : 0.25f * (g[0] + g[1] + g[2] + g[3]);
	/* the heading's change, unwrapped near the wheels' (a turn beyond pi between frames) */
	const float dth = wh_rot / e->d + model_wrap_pi_f32(z1[2] - z0[2] - wh_rot / e->d);
	const float dx = z1[0] - z0[0], dy = z1[1] - z0[1];

	la_sin_cos_f32(model_wrap_pi_f32(z0[2] + 0.5f * dth), &sn, &c);
	const float sl = 1.41421356f * e->set.cam_pos_noise / T;
	const float sr = 1.41421356f * e->set.cam_theta_noise * e->d / T;

	const float body[3] = {c * dx + sn * dy, -sn * dx + c * dy, dth}; /* eq 1 */

	if (e->layout) {
		wheel_rims_f32(&e->wh, body, ground); /* the layout's eq 2 */
	} else {
		ik_wheel_speeds_f32(e->d, body, ground); /* eq 2 */
		fk_robot_velocity_f32(e->d, g, wheels);  /* eqs 3-4 (the rotation from wh_rot) */
	}
	res[0] = (wheels[0] - body[0]) / T / sl;
	res[1] = (wheels[1] - body[1]) / T / sl;
	res[2] = (wh_rot - e->d * dth) / T / sr;
	for (int j = 0; j < 4; j++)
		rim[j] = fabsf(g[j] - ground[j]);
	return true;
}

/* The wheels the camera names: of each axis beyond the threshold, the wheels carrying it
 * (carry: the paper's v: 1 and 3, vn: 0 and 2, w: all four; eq 2) whose rim is off by at least half
 * the most any of them is (one wheel of a pair slipping names that wheel). */
static uint8_t camera_wheels(const struct est_slip *s, const uint8_t carry[3], const float rim[4])
{
	uint8_t bits = 0;

	for (int a = 0; a < 3; a++) {
		float most = 0.0f;

		if (s->cam_run[a] < SLIP_CAM_RUN)
			continue;
		for (int j = 0; j < 4; j++)
			if ((carry[a] >> j & 1) && rim[j] > most)
				most = rim[j];
		for (int j = 0; j < 4; j++)
			if ((carry[a] >> j & 1) && rim[j] >= 0.5f * most)
				bits |= (uint8_t)(1u << j);
	}
	return bits;
}

/* The frame z of tick k into the kept ones (the oldest dropped when full). */
static void keep_frame(struct est_slip *s, uint32_t k, const float z[3])
{
	if (s->frames == EST_SLIP_FRAMES) {
		memmove(s->frame_tick, s->frame_tick + 1,
		        sizeof(s->frame_tick[0]) * (EST_SLIP_FRAMES - 1));
		memmove(s->frame_z, s->frame_z + 1, sizeof(s->frame_z[0]) * (EST_SLIP_FRAMES - 1));
		s->frames--;
	}
	s->frame_tick[s->frames] = k;
	memcpy(s->frame_z[s->frames], z, sizeof(s->frame_z[0]));
	s->frames++;
}

void est_slip_camera(struct est *e, uint32_t k, const float z[3], int64_t capture_us)
{
	struct est_slip *s = &e->slip;
	const uint32_t oldest = e->seq > EST_HISTORY ? e->seq - EST_HISTORY : 0;
	float res[3], rim[4];

	if (s->frames > 0 && k <= s->frame_tick[s->frames - 1])
		return; /* out of order or the same tick: nothing new to compare */
	for (int i = 0; i < s->frames; i++) {
		if (s->frame_tick[i] < oldest ||
		    !compare(e, s->frame_tick[i], s->frame_z[i], k, z, res, rim))
			continue;
		for (int a = 0; a < 3; a++) {
			e->out.slip_camera[a] = res[a];
			s->cam_run[a] =
			    !(fabsf(res[a]) <= e->set.slip_camera_sigmas)
			        ? (uint8_t)(s->cam_run[a] < 255 ? s->cam_run[a] + 1 : 255)
			        : 0;
		}
		s->cam_bits = camera_wheels(s, e->carry, rim);
		s->cam_us = capture_us;
		break;
	}
	keep_frame(s, k, z);
}

uint32_t est_slip_flags(const struct est *e, int64_t utime)
{
	const struct est_slip *s = &e->slip;
	const bool cam_fresh = utime - s->cam_us <= EST_CAMERA_STALE_US;
	uint32_t f = 0;

	if (cam_fresh)
		f |= (uint32_t)s->cam_bits * EST_FLAG_SLIP_0;
	for (int j = 0; j < 4; j++)
		if (s->model_run[j] >= e->set.slip_ticks)
			f |= (uint32_t)EST_FLAG_SLIP_0 << j;
	return f ? f | EST_FLAG_SLIP : 0;
}

bool est_slip_common(const struct est *e)
{
	for (int j = 0; j < 4; j++)
		if (e->slip.model_run[j] >= e->set.slip_ticks)
			return true;
	return false;
}

void est_slip_volts(const struct est *e, const struct est_tick *t, const float x[3], float volts[4])
{
	float ground[4];

	wheel_rims_f32(&e->wh, x, ground); /* eq 2 */
	for (int j = 0; j < 4; j++) {
		volts[j] = t->volts[j];
		if (!(t->untrusted >> j & 1) || !t->have_wheels)
			continue;
		volts[j] -= e->wh.kemf[j] * (t->wheel[j] * (1.0f + e->cal[j]) - ground[j]);
	}
}

/* One reading h . (v, vn, w) of innovation nu and variance r (the upper triangle). */
static void row_update(struct est *e, const float h[3], float nu, float r)
{
	float (*P)[6] = e->P;
	float ph[6];

	for (int i = 0; i < 3; i++) /* P's velocity columns: the pose rows' upper part */
		ph[i] = P[i][3] * h[0] + P[i][4] * h[1] + P[i][5] * h[2];
	ph[3] = P[3][3] * h[0] + P[3][4] * h[1] + P[3][5] * h[2];
	ph[4] = P[3][4] * h[0] + P[4][4] * h[1] + P[4][5] * h[2];
	ph[5] = P[3][5] * h[0] + P[4][5] * h[1] + P[5][5] * h[2];
	const float S = h[0] * ph[3] + h[1] * ph[4] + h[2] * ph[5] + r;

	if (!(S > 0.0f))
		return;
	const float inv = 1.0f / S;

	for (int i = 0; i < 6; i++) {
		const float ki = ph[i] * inv;

		e->s[i] += ki * nu;
		for (int l = i; l < 6; l++)
			P[i][l] -= ki * ph[l];
	}
}

void est_slip_rows(struct est *e, const float wh[4], uint8_t skip)
{
	const float r = e->set.wheel_noise * e->set.wheel_noise;

	if (e->white && !skip) { /* all four: the three whitened readings y = W wh = U x */
		for (int k = 0; k < 3; k++) {
			const float *w = e->ww[k], *u = e->wu[k];
			const float y = w[0] * wh[0] + w[1] * wh[1] + w[2] * wh[2] + w[3] * wh[3];

			row_update(e, u, y - (u[0] * e->s[3] + u[1] * e->s[4] + u[2] * e->s[5]), r);
		}
		return;
	}

	for (int j = 0; j < e->wh.n; j++) {
		const float *h = e->wh.row[j]; /* eq 2 */

		if (skip >> j & 1)
			continue;
		row_update(e, h, wh[j] - (h[0] * e->s[3] + h[1] * e->s[4] + h[2] * e->s[5]), r);
	}
}

void est_slip_update(struct est *e, const struct est_tick *t, const float wh[4])
{
	est_slip_rows(e, wh, t->untrusted);
}

void est_slip_rewind(struct est *e, uint8_t fresh)
{
	const uint32_t now = e->seq,
	               back = 2u * (EST_INNOV_AVG_TICKS + (uint32_t)e->set.slip_ticks);
	const uint32_t oldest = now > EST_HISTORY ? now - EST_HISTORY : 0;
	uint32_t from = now > back ? now - back : 0;

	from -= from % EST_SNAP_EVERY;
	if (from < oldest)
		from += EST_SNAP_EVERY;
	if (from >= now)
		return;
	for (uint32_t n = from; n < now; n++)
		e->hist[n % EST_HISTORY].untrusted |= fresh;
	est_replay_from(e, from);
}
