/*
 * est.c - the model-based state estimator (est.h; docs/estimator.md).
 *
 * State s = [x, y, theta, v, vn, w], covariance P (6 x 6, kept symmetric: every operation
 * writes the upper triangle and mirrors it).
 * Predict: each velocity axis of eq 23 integrated exactly over the tick with the voltages held
 * (x+ = phi x + gam (b - c sgn)), the Coulomb term as a dead zone (no sign chatter near zero,
 * stiction at rest); the pose with eq 1 at the mid-step heading and mean velocity.
 * P+ = F P F^T + Q with F = [[I + u e_theta^T, G], [0, diag(phi)]], applied as row and column
 * operations (no 6 x 6 products).
 * Update: the four wheel speeds. The columns of eq 2 are orthogonal, H^T H = diag(2, 2, 4 d^2),
 * so the four readings are exactly the least-squares velocity (eqs 3-5) with the diagonal
 * variance wheel_noise^2 diag(1/2, 1/2, 1/(4 d^2)), plus the null-space residual
 * v0 - v1 + v2 - v3 that says nothing about the state: three scalar updates.
 * Another layout (est_set_model_wheels' g; docs/estimator.md, "Other wheel layouts"): eq 23's
 * full A (every off-diagonal term held over the tick, and in the covariance), one scalar update
 * per wheel reading (exact: the readings' noise is independent; four wheels all read: the
 * readings whitened, three updates for the four), the layout's null vector n (residual n . v;
 * three wheels: none, 0).
 * Camera: gated on the Mahalanobis distance of the pose innovation, then three scalar updates
 * at the frame's tick, and the ticks since re-run from the ring (est_camera.c, est_replay.c).
 * The wheels' scale calibration: est_cal.c.
 */
#include "omni4/core/est.h"
#include "omni4/model/consts.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "est_priv.h"
#include "omni4/model/kinematics.h"
#include "omni4/core/la_f32.h"

/* Per-tick exact solution of x' = a x + f: x+ = phi x + gam f. */
static void discretise(double a, double dt, float *phi, float *gam)
{
	const double p = exp(a * dt);

	*phi = (float)p;
	*gam = (float)(fabs(a) < 1e-12 ? dt : (p - 1.0) / a);
}

static void set_noise(struct est *e)
{
	const float qv = e->set.accel_noise_lin * e->dt, qw = e->set.accel_noise_rot * e->dt;
	const float w2 = e->set.wheel_noise * e->set.wheel_noise;

	e->q[0] = e->q[1] = qv * qv;
	e->q[2] = qw * qw;
	e->rw[0] = e->rw[1] = 0.5f * w2;
	e->rw[2] = w2 / (4.0f * e->d * e->d);
	e->rc[0] = e->rc[1] = e->set.cam_pos_noise * e->set.cam_pos_noise;
	e->rc[2] = e->set.cam_theta_noise * e->set.cam_theta_noise;
	e->qo[0] = EST_ODOM_POS * EST_ODOM_POS * e->dt;
	e->qo[1] = EST_ODOM_THETA * EST_ODOM_THETA * e->dt;
	e->qt = EST_DRIFT_THETA * EST_DRIFT_THETA * e->dt;
}

int est_set_settings(struct est *e, const struct est_settings *s)
{
	if (est_settings_check(s))
		return -EINVAL;
	e->set = *s;
	set_noise(e);
	return 0;
}

/* The wheels that carry each body axis (v, vn: bit j when wheel j's row has at least 0.5 on it;
 * w: every wheel; the paper's v: 1 and 3, vn: 0 and 2, w: all four): est_slip.c's camera check
 * names them. */
static void set_carry(struct est *e)
{
	for (int a = 0; a < 3; a++) {
		e->carry[a] = 0;
		for (int j = 0; j < e->wh.n; j++)
			if (a == 2 || fabsf(e->wh.row[j][a]) >= 0.5f)
				e->carry[a] |= (uint8_t)(1u << j);
	}
}

/* The null vector of G^T (four wheels; wheel_null), scaled to |n| = 2 (the paper's rows give
 * (1, -1, 1, -1)). Three wheels: 0. */
static void set_null_vector(struct est *e, const struct wheel_phys *ph)
{
	double n[4], norm = 0.0;

	wheel_null(ph, n);
	for (int j = 0; j < 4; j++)
		norm += n[j] * n[j];
	for (int j = 0; j < 4; j++)
		e->nvec[j] = norm > 0.0 ? (float)(2.0 * n[j] / sqrt(norm)) : 0.0f;
}

/* Four wheels' rows G (e->white, e->wu, e->ww): G^T G = U^T U, W = U^-T G^T, in double. */
static void set_white(struct est *e, const struct wheel_phys *ph)
{
	double g[3][3] = {{0}}, u[3][3] = {{0}};

	e->white = false;
	if (ph->n != 4)
		return;
	for (int a = 0; a < 3; a++)
		for (int b = 0; b < 3; b++)
			for (int j = 0; j < 4; j++)
				g[a][b] += ph->row[j][a] * ph->row[j][b];
	for (int k = 0; k < 3; k++) { /* Cholesky, row k of U */
		double p = g[k][k];

		for (int m = 0; m < k; m++)
			p -= u[m][k] * u[m][k];
		if (!(p > 0.0))
			return;
		u[k][k] = sqrt(p);
		for (int l = k + 1; l < 3; l++) {
			double q = g[k][l];

			for (int m = 0; m < k; m++)
				q -= u[m][k] * u[m][l];
			u[k][l] = q / u[k][k];
		}
	}
	for (int j = 0; j < 4; j++) { /* U^T w_j = G's row j (forward substitution) */
		double w[3];

		for (int k = 0; k < 3; k++) {
			w[k] = ph->row[j][k];
			for (int m = 0; m < k; m++)
				w[k] -= u[m][k] * w[m];
			w[k] /= u[k][k];
			e->ww[k][j] = (float)w[k];
		}
	}
	for (int k = 0; k < 3; k++)
		for (int l = 0; l < 3; l++)
			e->wu[k][l] = (float)u[k][l];
	e->white = true;
}

/* Each wheel's radius [m]: the wheel speeds' scale to rim speeds. */
static void set_radii(struct est *e, const struct model_wheels *w)
{
	for (int j = 0; j < 4; j++)
		e->r[j] = (float)w->r[j];
}

/* A layout other than the paper's: eq 23's full A (dyn_state_space_layout), the per-axis exact
 * step with the off-diagonal terms held over the tick, the layout's rows. -EINVAL: refused. */
static int set_layout(struct est *e, const struct model_params *p, const struct model_wheels *w,
                      const struct wheel_geom *g)
{
	struct model_ss_wheels ss;
	struct wheel_phys ph;

	if (dyn_state_space_layout(p, w, g, &ss) || wheel_phys_init(&ph, g, p, w, 0.0))
		return -EINVAL;
	for (int k = 0; k < 3; k++) {
		discretise(ss.A[k][k], e->dt, &e->phi[k], &e->gam[k]);
		discretise(ss.A_coast[k], e->dt, &e->phic[k], &e->gamc[k]);
		for (int j = 0; j < 4; j++)
			e->B[k][j] = (float)ss.B[k][j];
		e->C[k] = (float)-ss.K[k];
		for (int l = 0; l < 3; l++) {
			e->Ao[k][l] = k == l ? 0.0f : (float)ss.A[k][l];
			e->Dv[k][l] = e->gam[k] * e->Ao[k][l];
		}
	}
	memset(e->Ax, 0, sizeof(e->Ax));
	e->coupled = false; /* the paper's coupling terms: Ao holds them all */
	double dsum = 0.0;  /* the wheels' mean distance: w's scale as d w [m/s] */

	for (int j = 0; j < ph.n; j++)
		dsum += ph.row[j][2];
	e->d = (float)(dsum / ph.n);
	set_radii(e, w);
	wheel_phys_to_f32(&ph, &e->wh);
	set_null_vector(e, &ph);
	set_white(e, &ph);
	set_carry(e);
	e->layout = true;
	set_noise(e);
	return 0;
}

/* The paper's rows at d (wheel_geom_paper), compared by value. */
static bool paper_rows(const struct wheel_geom *g, double d)
{
	struct wheel_geom paper;

	wheel_geom_paper(d, &paper);
	if (g->n != 4)
		return false;
	for (int j = 0; j < 4; j++)
		for (int k = 0; k < 3; k++)
			if (!(g->row[j][k] == paper.row[j][k]))
				return false;
	return true;
}

void est_set_model_wheels(struct est *e, const struct model_params *p, const struct model_wheels *w,
                          const struct wheel_geom *g)
{
	struct model_ss_wheels ss;

	MODEL_ASSERT_CHECKED(p, w);
	if (g && !paper_rows(g, p->d)) {
		set_layout(e, p, w, g); /* refused: the model in force stays */
		return;
	}
	e->layout = false;
	e->white = false;
	dyn_state_space_wheels(p, w, &ss);
	for (int k = 0; k < 3; k++) {
		discretise(ss.A[k][k], e->dt, &e->phi[k], &e->gam[k]);
		discretise(ss.A_coast[k], e->dt, &e->phic[k], &e->gamc[k]);
		for (int j = 0; j < 4; j++)
			e->B[k][j] = (float)ss.B[k][j];
		e->C[k] = (float)-ss.K[k];
	}
	e->Ax[0] = (float)ss.A[0][2];
	e->Ax[1] = (float)ss.A[1][2];
	e->Ax[2] = (float)ss.A[2][0];
	e->Ax[3] = (float)ss.A[2][1];
	e->coupled = e->Ax[0] != 0.0f || e->Ax[1] != 0.0f || e->Ax[2] != 0.0f || e->Ax[3] != 0.0f;
	e->d = (float)p->d;
	set_radii(e, w);
	struct wheel_geom paper;
	struct wheel_phys ph;

	wheel_geom_paper(p->d, &paper);
	if (wheel_phys_init(&ph, &paper, p, w, 0.0) == 0) /* (checked above: always) */
		wheel_phys_to_f32(&ph, &e->wh);
	static const float paper_null[4] = {1.0f, -1.0f, 1.0f, -1.0f};

	memcpy(e->nvec, paper_null, sizeof(e->nvec));
	set_carry(e);
	set_noise(e);
}

void est_set_model(struct est *e, const struct model_params *p)
{
	struct model_wheels w;

	model_wheels_from_params(p, &w);
	if (model_params_check(p, NULL) || model_wheels_check(&w, NULL))
		return; /* a bad model is ignored: the one in force stays */
	est_set_model_wheels(e, p, &w, NULL);
}

void est_reset(struct est *e, const float pose[3], const float pose_var[3])
{
	memset(e->s, 0, sizeof(e->s));
	memset(e->P, 0, sizeof(e->P));
	for (int k = 0; k < 3; k++) {
		e->s[k] = isfinite(pose[k]) ? pose[k] : 0.0f;
		e->P[k][k] = isfinite(pose_var[k]) && pose_var[k] > 0.0f ? pose_var[k] : 1.0f;
	}
	e->s[2] = model_wrap_pi_f32(e->s[2]);
	/* At rest, give or take a few mm/s. */
	e->P[3][3] = e->P[4][4] = 1e-4f;
	e->P[5][5] = 1e-4f / (e->d * e->d);
	memset(&e->out, 0, sizeof(e->out));
	memset(e->innov_avg, 0, sizeof(e->innov_avg));
	e->seq = 0;
	e->slip_run = e->collision_run = e->cam_gate_run = 0;
	e->last_cam_us = 0;
	e->have_cam = false;
	e->job.on = false;
	est_slip_reset(e);
}

int est_init(struct est *e, const struct est_settings *s, const struct model_params *p,
             double rate_hz)
{
	if (!e || !p || model_params_check(p, NULL) || !(rate_hz >= 1.0 && rate_hz <= 1e5) ||
	    (s && est_settings_check(s)))
		return -EINVAL;
	memset(e, 0, sizeof(*e));
	if (s)
		e->set = *s;
	else
		est_settings_defaults(&e->set);
	e->dt = (float)(1.0 / rate_hz);
	e->cal_forget = 1.0f - e->dt / EST_CAL_TAU_S;
	e->replay_per_tick = EST_REPLAY_PER_TICK;
	est_set_model(e, p);
	static const float pose0[3] = {0.0f, 0.0f, 0.0f}, var0[3] = {1.0f, 1.0f, 10.0f};

	est_reset(e, pose0, var0);
	return 0;
}

void est_symmetrise(struct est *e)
{
	for (int i = 1; i < 6; i++)
		for (int j = 0; j < i; j++)
			e->P[i][j] = e->P[j][i];
}

/* Cross-covariances that decay tick by tick (a coasting axis's factor phi < 1) would reach
 * float's subnormal range; zeroed below EST_COV_TINY. */
void est_flush_tiny(struct est *e)
{
	for (int i = 1; i < 6; i++)
		for (int j = 0; j < i; j++)
			if (fabsf(e->P[j][i]) < EST_COV_TINY) {
				e->P[j][i] = 0.0f;
				e->P[i][j] = 0.0f;
			}
}

/* Velocity axis: x+ = phi x + gam (b - c sgn), the Coulomb term a dead zone around the
 * frictionless prediction (stops at zero rather than crossing it; stays while |b| <= c). */
static float axis(float phi, float gam, float b, float c, float x)
{
	const float xf = phi * x + gam * b, fr = gam * c;

	return xf > fr ? xf - fr : (xf < -fr ? xf + fr : 0.0f);
}

/* P <- T Fth P Fth^T T^T (upper triangle): Fth = I + u e_2^T (the pose's dependence on theta),
 * T = [[I, G], [0, diag(phi)]], G = dt R(theta) (pose on velocity). P is symmetric on entry; the
 * row operations take whole rows (they vectorise), the column operations only the elements that
 * the upper triangle reads (the lower one is left stale for run_tick to mirror). */
static void predict_cov(float P[6][6], float u0, float u1, float gc, float gs, float dt,
                        const float phi_in[3])
{
	const float phi[3] = {phi_in[0], phi_in[1], phi_in[2]}; /* (P may alias phi_in) */

	for (int j = 0; j < 6; j++) {
		P[0][j] += u0 * P[2][j];
		P[1][j] += u1 * P[2][j];
	}
	for (int i = 0; i < 5; i++) {
		if (i == 2)
			continue;
		if (i != 1)
			P[i][0] += u0 * P[i][2];
		P[i][1] += u1 * P[i][2];
	}
	for (int j = 0; j < 6; j++) {
		P[0][j] += gc * P[3][j] - gs * P[4][j];
		P[1][j] += gs * P[3][j] + gc * P[4][j];
		P[2][j] += dt * P[5][j];
		P[3][j] *= phi[0];
		P[4][j] *= phi[1];
		P[5][j] *= phi[2];
	}
	P[0][0] += gc * P[0][3] - gs * P[0][4];
	P[0][1] += gs * P[0][3] + gc * P[0][4];
	P[1][1] += gs * P[1][3] + gc * P[1][4];
	for (int i = 0; i < 3; i++)
		P[i][2] += dt * P[i][5];
	for (int i = 0; i < 6; i++)
		for (int j = i > 3 ? i : 3; j < 6; j++)
			P[i][j] *= phi[j - 3];
}

/* A layout's coupled velocities (driven): P <- L P L^T with L = I + Dv on the velocity rows, so
 * F's velocity block is diag(phi) + Dv diag(phi) (to dt^2: eq 23's exp(A dt)). P's upper
 * triangle in, its upper triangle out: L leaves the pose block alone, mixes the pose-velocity
 * block's columns (P_pv L^T) and takes the velocity block V to (L V) L^T. Dv's diagonal is 0:
 * (L x)_k = x_k + Dv[k][a] x_a + Dv[k][b] x_b, a < b the other two. */
static void predict_cov_coupled(struct est *e)
{
	float (*P)[6] = e->P;
	const float d01 = e->Dv[0][1], d02 = e->Dv[0][2], d10 = e->Dv[1][0], d12 = e->Dv[1][2],
	            d20 = e->Dv[2][0], d21 = e->Dv[2][1];

	for (int i = 0; i < 3; i++) { /* P_pv L^T */
		const float x0 = P[i][3], x1 = P[i][4], x2 = P[i][5];

		P[i][3] = x0 + d01 * x1 + d02 * x2;
		P[i][4] = x1 + d10 * x0 + d12 * x2;
		P[i][5] = x2 + d20 * x0 + d21 * x1;
	}
	const float a = P[3][3], b = P[3][4], c = P[3][5], d = P[4][4], f = P[4][5], g = P[5][5];
	/* L V, V = [[a, b, c], [b, d, f], [c, f, g]] */
	const float y00 = a + d01 * b + d02 * c, y01 = b + d01 * d + d02 * f,
	            y02 = c + d01 * f + d02 * g;
	const float y10 = b + d10 * a + d12 * c, y11 = d + d10 * b + d12 * f,
	            y12 = f + d10 * c + d12 * g;
	const float y20 = c + d20 * a + d21 * b, y21 = f + d20 * b + d21 * d,
	            y22 = g + d20 * c + d21 * f;

	P[3][3] = y00 + d01 * y01 + d02 * y02; /* (L V) L^T, its upper triangle */
	P[3][4] = y01 + d10 * y00 + d12 * y02;
	P[3][5] = y02 + d20 * y00 + d21 * y01;
	P[4][4] = y11 + d10 * y10 + d12 * y12;
	P[4][5] = y12 + d20 * y10 + d21 * y11;
	P[5][5] = y22 + d20 * y20 + d21 * y21;
}

/* Axis k's share of eq 23's off-diagonal A (unequal wheels; dynamics.h): v and vn from w, w
 * from v and vn. */
static float coupling(const struct est *e, int k, const float x[3])
{
	if (k == 2)
		return e->Ax[2] * x[0] + e->Ax[3] * x[1];
	return e->Ax[k] * x[2];
}

static void predict(struct est *e, const struct est_tick *t)
{
	float *s = e->s;
	float (*P)[6] = e->P;
	const bool drv = t->driven;
	const float *phi = drv ? e->phi : e->phic, *gam = drv ? e->gam : e->gamc;
	const float dt = e->dt;
	const float x0[3] = {s[3], s[4], s[5]};
	float xm[3], ue[4];
	const float *u = t->volts;

	if (t->untrusted) { /* a slipping wheel's force at its rim's speed */
		est_slip_volts(e, t, x0, ue);
		u = ue;
	}
	for (int k = 0; k < 3; k++) {
		float b = 0.0f;

		if (drv)
			b = e->B[k][0] * u[0] + e->B[k][1] * u[1] + e->B[k][2] * u[2] +
			    e->B[k][3] * u[3];
		if (drv && e->coupled) /* the back-EMF of unequal wheels: held over the tick */
			b += coupling(e, k, x0);
		if (drv && e->layout) /* a layout's full A: every off-diagonal term, held */
			b += e->Ao[k][0] * x0[0] + e->Ao[k][1] * x0[1] + e->Ao[k][2] * x0[2];
		const float xn = axis(phi[k], gam[k], b, e->C[k], s[3 + k]);

		xm[k] = 0.5f * (s[3 + k] + xn);
		s[3 + k] = xn;
	}
	/* eq 1 inverted at the mid-step heading */
	const float th = s[2] + 0.5f * dt * xm[2];
	float c, sn;

	la_sin_cos_f32(th, &sn, &c);
	const float vx = c * xm[0] - sn * xm[1], vy = sn * xm[0] + c * xm[1];

	s[0] += dt * vx;
	s[1] += dt * vy;
	s[2] = model_wrap_pi_f32(s[2] + dt * xm[2]);

	predict_cov(P, -dt * vy, dt * vx, dt * c, dt * sn, dt, phi);
	if (drv && e->layout)
		predict_cov_coupled(e);
	P[3][3] += e->q[0];
	P[4][4] += e->q[1];
	P[5][5] += e->q[2];
	/* odometry: a pose variance growing with the distance travelled */
	const float dist = fabsf(xm[0]) + fabsf(xm[1]);

	P[0][0] += e->qo[0] * dist;
	P[1][1] += e->qo[0] * dist;
	const float wheels_m_s = dist + e->d * fabsf(xm[2]);

	P[2][2] += e->qo[1] * wheels_m_s + e->qt * fminf(1.0f, wheels_m_s / EST_DRIFT_SPEED_M_S);
}

/* Scalar update of state component i with a reading of innovation nu and variance r. */
static void scalar_update(struct est *e, int i, float nu, float r)
{
	float (*P)[6] = e->P;
	float col[6];
	const float S = P[i][i] + r;

	if (!(S > 0.0f))
		return;
	const float inv = 1.0f / S;

	for (int j = 0; j < 6; j++)
		col[j] = j <= i ? P[j][i] : P[i][j]; /* column i from the upper triangle */
	for (int j = 0; j < 6; j++) {
		const float kj = col[j] * inv;

		e->s[j] += kj * nu;
		for (int l = j; l < 6; l++)
			P[j][l] -= kj * col[l];
	}
	/* the upper triangle only: the caller mirrors it once its updates are done */
}

/* The tick's wheel readings as a velocity (eqs 3-5) and the null-space residual. */
static void wheel_velocity(const struct est *e, const float v[4], float z[3], float *null_res)
{
	if (e->layout) { /* the layout's least squares and null vector (0: three wheels) */
		const float *n = e->nvec;

		wheel_body_f32(&e->wh, v, z);
		*null_res = n[0] * v[0] + n[1] * v[1] + n[2] * v[2] + n[3] * v[3];
		return;
	}
	fk_robot_velocity_f32(e->d, v, z);
	*null_res = v[0] - v[1] + v[2] - v[3];
}

/* A reading that does not fit a rigid body: the wheel that disagrees most with the prediction
 * is left out (its reading replaced by the one the other three imply, which zeroes the
 * residual nr), z the velocity from the other three. */
static int leave_out_worst(const struct est *e, const float wh[4], float nr, float z[3])
{
	float pred[4], v[4], worst = -1.0f, nr2;
	int jw = 0;

	wheel_rims_f32(&e->wh, &e->s[3], pred); /* eq 2 */
	for (int j = 0; j < 4; j++) {
		const float dj = fabsf(wh[j] - pred[j]);

		v[j] = wh[j];
		if (dj > worst) {
			worst = dj;
			jw = j;
		}
	}
	if (!e->layout)
		v[jw] -= (jw & 1) ? -nr : nr;
	else if (fabsf(e->nvec[jw]) > 0.05f) /* its share of the residual (n_j v_j) */
		v[jw] -= nr / e->nvec[jw];
	wheel_velocity(e, v, z, &nr2);
	return jw;
}

/* The wheel update (scale-corrected readings); live: the flags' counters too. The collision
 * innovation is the velocity of the wheels that fit (a slipping one left out) against the
 * model's prediction. */
static void wheel_update(struct est *e, const struct est_tick *t, bool live)
{
	float z[3], nr, wh[4];

	for (int j = 0; j < 4; j++)
		wh[j] = t->wheel[j] * (1.0f + e->cal[j]);
	wheel_velocity(e, wh, z, &nr);
	const bool slip_now = !(fabsf(nr) <= e->set.slip_threshold);
	const int jw = slip_now ? leave_out_worst(e, wh, nr, z) : -1;

	if (live) {
		e->slip.null_wheel = (int8_t)jw;
		est_slip_model(e, t, wh);
		const float nu[3] = {z[0] - e->s[3], z[1] - e->s[4], e->d * (z[2] - e->s[5])};
		float *m = e->innov_avg;

		for (int k = 0; k < 3; k++)
			m[k] += (nu[k] - m[k]) * (1.0f / EST_INNOV_AVG_TICKS);
		const float c = sqrtf(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);

		e->out.null_residual = nr;
		e->out.vel_innov = c;
		e->slip_run = slip_now ? e->slip_run + 1 : 0;
		e->collision_run = c > e->set.collision_threshold ? e->collision_run + 1 : 0;
	}
	if (e->layout) { /* one scalar update per wheel: the flagged and the worst left out */
		est_slip_rows(e, wh, (uint8_t)(t->untrusted | (jw >= 0 ? 1u << jw : 0u)));
		return;
	}
	if (t->untrusted) { /* wheels flagged at the tick before: the others only */
		est_slip_update(e, t, wh);
		return;
	}
	/* three wheels: twice the variance */
	const float scale = slip_now ? 2.0f : 1.0f;

	for (int k = 0; k < 3; k++)
		scalar_update(e, 3 + k, z[k] - e->s[3 + k], scale * e->rw[k]);
}

/* The camera pose z as three scalar updates (the upper triangle; the caller mirrors it). */
void est_pose_update(struct est *e, const float z[3])
{
	for (int k = 0; k < 3; k++) {
		float nu = z[k] - e->s[k];

		if (k == 2)
			nu = model_wrap_pi_f32(nu);
		scalar_update(e, k, nu, e->rc[k]);
	}
	e->s[2] = model_wrap_pi_f32(e->s[2]);
}

void est_run_tick(struct est *e, const struct est_tick *t, bool live)
{
	predict(e, t);
	if (t->have_wheels) {
		wheel_update(e, t, live);
	} else if (live) {
		e->slip_run = 0;
		e->collision_run = 0;
		e->slip.null_wheel = -1;
	}
	if (t->late == EST_LATE_POSE)
		est_pose_update(e, t->late_z);
	est_symmetrise(e); /* predict and the updates leave the lower triangle stale */
}

void est_publish(struct est *e, int64_t utime)
{
	e->out.utime = utime;
	for (int k = 0; k < 3; k++) {
		e->out.pose[k] = e->s[k];
		e->out.vel[k] = e->s[3 + k];
	}
	for (int k = 0; k < 6; k++)
		e->out.cov[k] = e->P[k][k];
	for (int j = 0; j < 4; j++)
		e->out.wheel_scale[j] = e->cal[j];
}

bool est_all_finite(const float *v, int n)
{
	for (int k = 0; k < n; k++)
		if (!isfinite(v[k]))
			return false;
	return true;
}

/* A reading is finite and no wheel faster than EST_WHEEL_MAX_M_S. */
static bool plausible_wheels(const float w[4], const float r[4])
{
	for (int j = 0; j < 4; j++)
		if (!(fabsf(w[j] * r[j]) <= EST_WHEEL_MAX_M_S))
			return false;
	return true;
}

/* A NaN or inf anywhere reaches the diagonal. Cannot happen with finite settings; never let a
 * NaN out: start again where the last output was. */
static void guard_finite(struct est *e)
{
	const float sum = e->s[0] + e->s[1] + e->s[2] + e->s[3] + e->s[4] + e->s[5] + e->P[0][0] +
	                  e->P[1][1] + e->P[2][2] + e->P[3][3] + e->P[4][4] + e->P[5][5];

	if (!isfinite(sum)) {
		static const float var[3] = {1.0f, 1.0f, 10.0f};
		const struct est_output keep = e->out;

		est_reset(e, keep.pose, var);
		e->out = keep;
	}
}

static uint32_t flags(const struct est *e, const struct est_tick *t, int64_t utime)
{
	uint32_t f = 0;

	if (!t->have_wheels)
		f |= EST_FLAG_NO_WHEELS;
	if (e->set.slip_ticks > 0 && e->slip_run >= e->set.slip_ticks)
		f |= EST_FLAG_SLIP |
		     (e->slip.null_wheel >= 0 ? EST_FLAG_SLIP_0 << e->slip.null_wheel : 0);
	if (t->have_wheels)
		f |= est_slip_flags(e, utime);
	if (e->set.collision_ticks > 0 && e->collision_run >= e->set.collision_ticks &&
	    !est_slip_common(e)) /* the wheels ran ahead: a slip's innovation */
		f |= EST_FLAG_COLLISION;
	if (!e->have_cam || utime - e->last_cam_us > EST_CAMERA_STALE_US)
		f |= EST_FLAG_CAMERA_STALE;
	return f;
}

static void step_one(struct est *e, const struct est_input *in)
{
	const uint32_t n = e->seq;
	struct est_tick *t = &e->hist[n % EST_HISTORY];

	t->utime = in->utime;
	t->driven = in->driven && est_all_finite(in->volts, 4);
	t->have_wheels = in->have_wheels && plausible_wheels(in->wheel_rad_s, e->r);
	t->late = EST_LATE_NONE;
	t->untrusted = (uint8_t)((e->out.flags & (EST_FLAG_SLIP_0 | EST_FLAG_SLIP_1 |
	                                          EST_FLAG_SLIP_2 | EST_FLAG_SLIP_3)) /
	                         EST_FLAG_SLIP_0);
	for (int j = 0; j < 4; j++) {
		t->volts[j] = t->driven ? in->volts[j] : 0.0f;
		t->wheel[j] = t->have_wheels ? in->wheel_rad_s[j] * e->r[j] : 0.0f;
	}
	est_replay_advance(e, e->replay_per_tick);
	est_replay_snap(e, n);
	est_run_tick(e, t, true);
	est_cal_step(e, t, n);
	e->seq = n + 1;
	guard_finite(e);
	e->out.flags = flags(e, t, in->utime);
	const uint8_t fresh = (uint8_t)(e->out.flags / EST_FLAG_SLIP_0 & 0x0fu & ~t->untrusted);

	if (fresh)
		est_slip_rewind(e, fresh);
	est_publish(e, in->utime);
}

/* The estimator's clock: the time of the periods predicted so far, one period a step. A tick's
 * time is its wake-up, late by a jitter of up to a period or more on a loaded host; counting the
 * periods missed from the last tick's time took a late tick followed by an on-time one for a
 * missed period and predicted it twice (a 0.5 rad turn's heading over-counted by 4 % under a
 * 0.4 ms mean jitter). Counted from this clock, a jitter predicts at most about one period too
 * many, which the next missed period takes back. The clock is set to the tick's time at the
 * first tick and wherever the two are more than EST_CATCH_UP periods apart (a stall beyond the
 * cap, a clock stepped). */
static int64_t period_ns(const struct est *e)
{
	return (int64_t)((double)e->dt * 1e9 + 0.5);
}

/* The periods a late tick missed (a loop late on a loaded host; never on the MCU, whose ticks
 * are the timer's): predicted one by one without a reading, under the voltages applied through
 * them, as the robot moved on through them; at most EST_CATCH_UP. */
static void catch_up(struct est *e, const struct est_input *in)
{
	if (e->seq == 0)
		return;
	const int64_t p = period_ns(e);
	int64_t missed = (in->utime * 1000 - e->clock_ns + p / 2) / p - 1;

	if (missed > EST_CATCH_UP)
		missed = EST_CATCH_UP;
	struct est_input gap = *in;

	gap.have_wheels = false;
	for (int64_t i = missed; i >= 1; i--) {
		gap.utime = in->utime - i * p / 1000;
		step_one(e, &gap);
		e->clock_ns += p;
	}
}

void est_step(struct est *e, const struct est_input *in)
{
	const int64_t p = period_ns(e), now_ns = in->utime * 1000;
	const bool first = e->seq == 0;

	catch_up(e, in);
	step_one(e, in);
	e->clock_ns += p;
	if (first || e->clock_ns - now_ns > EST_CATCH_UP * p ||
	    now_ns - e->clock_ns > EST_CATCH_UP * p)
		e->clock_ns = now_ns;
}
