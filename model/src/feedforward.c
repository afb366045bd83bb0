/* feedforward.c - double feedforward and the set-up of its Q16.16 coefficients. */
#include "omni4/model/feedforward.h"

#include "omni4/model/kinematics.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

double ff_sign(double x, double band)
{
	const double s = x / band;

	return s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s);
}

void ff_voltages(const struct model_params *p, const double vel[3], const double acc[3],
                 double u_max, double u[4])
{
	struct model_wheels w; /* four equal drives: the same expressions, the same bits */

	model_wheels_from_params(p, &w);
	ff_voltages_wheels(p, &w, vel, acc, u_max, u);
}

/* One drive's feedforward gains (R, r, Kt, Kv) in double, per axis: acc [V/(m/s^2)],
 * [V/(rad/s^2)]; vel (viscous friction and back-EMF) [V/(m/s)], [V/(rad/s)]; coul [V]. The Q16.16
 * gains (ff_q16_init, ff_q16_wheels_init) and their parts per ohm (ff_wheels_per_ohm_prepare)
 * all come from these expressions. */
static void ff_wheel_terms(const struct model_params *p, double R, double r, double Kt, double Kv,
                           double acc[3], double vel[3], double coul[3])
{
	const double kf = R * r / (p->l * Kt); /* [V/N] */
	const double k4d = kf / (4.0 * p->d);
	const double kemf = Kv * p->l / r; /* [V/(m/s)] at the wheel rim */

	acc[0] = kf * p->M / 2.0;
	acc[1] = kf * p->M / 2.0;
	acc[2] = k4d * p->J;
	vel[0] = kf * p->Bv / 2.0 + kemf;
	vel[1] = kf * p->Bvn / 2.0 + kemf;
	vel[2] = k4d * p->Bw + kemf * p->d;
	coul[0] = kf * p->Cv / 2.0;
	coul[1] = kf * p->Cvn / 2.0;
	coul[2] = k4d * p->Cw;
}

/* The Q16.16 gains of one drive's constants (R, r, Kt, Kv): the scalar model's (ff_q16_init)
 * and each wheel's (ff_q16_wheels_init) come from these expressions, so equal wheels give the
 * scalar bits. */
static void ff_q16_wheel_gains(const struct model_params *p, double R, double r, double Kt,
                               double Kv, q16_t k_acc[3], q16_t k_vel[3], q16_t k_coul[3])
{
	double acc[3], vel[3], coul[3];

	ff_wheel_terms(p, R, r, Kt, Kv, acc, vel, coul);
	for (int k = 0; k < 3; k++) {
		k_acc[k] = q16_from_double(acc[k]);
		k_vel[k] = q16_from_double(vel[k]);
		k_coul[k] = q16_from_double(coul[k]);
	}
}

int ff_q16_init(struct ff_q16 *ff, const struct model_params *p, double u_max)
{
	if (model_params_check(p, NULL) || !(u_max > 0.0) || !isfinite(u_max))
		return -EINVAL;
	const double band[3] = {FF_SIGN_BAND_LIN, FF_SIGN_BAND_LIN, FF_SIGN_BAND_ROT};

	ff->d = q16_from_double(p->d);
	ff_q16_wheel_gains(p, p->R, p->r, p->Kt, p->Kv, ff->k_acc, ff->k_vel, ff->k_coul);
	for (int k = 0; k < 3; k++)
		ff->sgn_gain[k] = (int32_t)lround(1.0 / band[k]);
	ff->u_max = q16_from_double(u_max);
	return 0;
}

void ff_voltages_wheels(const struct model_params *p, const struct model_wheels *w,
                        const double vel[3], const double acc[3], double u_max, double u[4])
{
	const double Fv =
	    p->M * acc[0] + p->Bv * vel[0] + p->Cv * ff_sign(vel[0], FF_SIGN_BAND_LIN);
	const double Fvn =
	    p->M * acc[1] + p->Bvn * vel[1] + p->Cvn * ff_sign(vel[1], FF_SIGN_BAND_LIN);
	const double T = p->J * acc[2] + p->Bw * vel[2] + p->Cw * ff_sign(vel[2], FF_SIGN_BAND_ROT);
	const double share[3] = {Fv / 2.0, Fvn / 2.0, T / (4.0 * p->d * p->d)};
	double f[4], vw[4];

	ik_wheel_speeds(p->d, share, f);
	ik_wheel_speeds(p->d, vel, vw);
	for (int j = 0; j < 4; j++) {
		const double uj = w->R[j] * w->r[j] / (p->l * w->Kt[j]) * f[j] +
		                  w->Kv[j] * p->l / w->r[j] * vw[j];

		u[j] = uj > u_max ? u_max : (uj < -u_max ? -u_max : uj);
	}
}

int ff_q16_wheels_init(struct ff_q16_wheels *ff, const struct model_params *p,
                       const struct model_wheels *w, double u_max)
{
	if (model_params_check(p, NULL) || model_wheels_check(w, NULL))
		return -EINVAL;
	return ff_q16_wheels_prepare(ff, p, w, u_max);
}

int ff_q16_wheels_prepare(struct ff_q16_wheels *ff, const struct model_params *p,
                          const struct model_wheels *w, double u_max)
{
	MODEL_ASSERT_CHECKED(p, w);
	if (!(u_max > 0.0) || !isfinite(u_max))
		return -EINVAL;
	const double band[3] = {FF_SIGN_BAND_LIN, FF_SIGN_BAND_LIN, FF_SIGN_BAND_ROT};

	/* eq 2's pattern: wheel 0 = vn + w, 1 = w - v, 2 = w - vn, 3 = v + w */
	static const int8_t paper_sign[4][3] = {{0, 1, 1}, {-1, 0, 1}, {0, -1, 1}, {1, 0, 1}};

	ff->d = q16_from_double(p->d);
	ff->n = 4;
	memcpy(ff->sign, paper_sign, sizeof(ff->sign));
	for (int j = 0; j < 4; j++)
		ff_q16_wheel_gains(p, w->R[j], w->r[j], w->Kt[j], w->Kv[j], ff->k_acc[j],
		                   ff->k_vel[j], ff->k_coul[j]);
	for (int k = 0; k < 3; k++)
		ff->sgn_gain[k] = (int32_t)lround(1.0 / band[k]);
	ff->u_max = q16_from_double(u_max);
	return 0;
}

/* Wheel j's per-ohm terms from its terms at 1 ohm (acc, vel, coul) and at 0 ohm (emf). */
static void per_ohm_put(struct ff_wheels_per_ohm *o, int j, const double acc[3],
                        const double vel[3], const double emf[3], const double coul[3])
{
	for (int k = 0; k < 3; k++) {
		o->acc[j][k] = (float)acc[k];
		o->vel[j][k] = (float)(vel[k] - emf[k]);
		o->emf[j][k] = (float)emf[k];
		o->coul[j][k] = (float)coul[k];
	}
}

void ff_wheels_per_ohm_prepare(struct ff_wheels_per_ohm *o, const struct model_params *p,
                               const struct model_wheels *w)
{
	for (int j = 0; j < 4; j++) {
		double acc[3], vel[3], coul[3], acc0[3], emf[3], coul0[3];

		ff_wheel_terms(p, 1.0, w->r[j], w->Kt[j], w->Kv[j], acc, vel, coul);
		ff_wheel_terms(p, 0.0, w->r[j], w->Kt[j], w->Kv[j], acc0, emf, coul0);
		per_ohm_put(o, j, acc, vel, emf, coul);
	}
}

void ff_q16_wheels_set_resistance(struct ff_q16_wheels *ff, const struct ff_wheels_per_ohm *o,
                                  int j, float R_ohm)
{
	for (int k = 0; k < 3; k++) {
		ff->k_acc[j][k] = q16_from_float(R_ohm * o->acc[j][k]);
		ff->k_vel[j][k] = q16_from_float(R_ohm * o->vel[j][k] + o->emf[j][k]);
		ff->k_coul[j][k] = q16_from_float(R_ohm * o->coul[j][k]);
	}
}

/* Wheel j's gains per axis in any layout (ff_q16_wheels_prepare_layout's expressions), for the
 * drive (R, r, Kt, Kv) and the layout's row g and split s of the wheel. */
static void ff_layout_terms(const struct model_params *p, double R, double r, double Kt, double Kv,
                            const double g[3], const double s[3], double acc[3], double vel[3],
                            double coul[3])
{
	const double kf = R * r / (p->l * Kt); /* [V/N] */
	const double kemf = Kv * p->l / r;     /* [V/(m/s)] at the rim */
	const double I[3] = {p->M, p->M, p->J}, B[3] = {p->Bv, p->Bvn, p->Bw},
	             C[3] = {p->Cv, p->Cvn, p->Cw};

	for (int k = 0; k < 3; k++) {
		acc[k] = kf * s[k] * I[k];
		vel[k] = kf * s[k] * B[k] + kemf * g[k];
		coul[k] = kf * s[k] * C[k];
	}
}

int ff_q16_wheels_prepare_layout(struct ff_q16_wheels *ff, const struct model_params *p,
                                 const struct model_wheels *w, const struct wheel_geom *g,
                                 double u_max)
{
	struct wheel_phys ph;

	if (!g)
		return ff_q16_wheels_prepare(ff, p, w, u_max);
	if (wheel_phys_layout(&ph, g) || ff_q16_wheels_prepare(ff, p, w, u_max))
		return -EINVAL;
	ff->n = ph.n;
	memset(ff->k_acc, 0, sizeof(ff->k_acc));
	memset(ff->k_vel, 0, sizeof(ff->k_vel));
	memset(ff->k_coul, 0, sizeof(ff->k_coul));
	memset(ff->sign, 0, sizeof(ff->sign));
	for (int j = 0; j < ph.n; j++) {
		double acc[3], vel[3], coul[3];

		ff_layout_terms(p, w->R[j], w->r[j], w->Kt[j], w->Kv[j], ph.row[j], ph.split[j],
		                acc, vel, coul);
		for (int k = 0; k < 3; k++) {
			ff->k_acc[j][k] = q16_from_double(acc[k]);
			ff->k_vel[j][k] = q16_from_double(vel[k]);
			ff->k_coul[j][k] = q16_from_double(coul[k]);
			ff->sign[j][k] = 1;
		}
	}
	return 0;
}

int ff_wheels_per_ohm_prepare_layout(struct ff_wheels_per_ohm *o, const struct model_params *p,
                                     const struct model_wheels *w, const struct wheel_geom *g)
{
	struct wheel_phys ph;

	if (!g) {
		ff_wheels_per_ohm_prepare(o, p, w);
		return 0;
	}
	if (wheel_phys_layout(&ph, g))
		return -EINVAL;
	memset(o, 0, sizeof(*o));
	for (int j = 0; j < ph.n; j++) {
		double acc[3], vel[3], coul[3], acc0[3], emf[3], coul0[3];

		ff_layout_terms(p, 1.0, w->r[j], w->Kt[j], w->Kv[j], ph.row[j], ph.split[j], acc,
		                vel, coul);
		ff_layout_terms(p, 0.0, w->r[j], w->Kt[j], w->Kv[j], ph.row[j], ph.split[j], acc0,
		                emf, coul0);
		per_ohm_put(o, j, acc, vel, emf, coul);
	}
	return 0;
}

void ff_voltages_layout(const struct model_params *p, const struct wheel_phys *ph,
                        const double vel[3], const double acc[3], double u_max, double u[4])
{
	const double F[3] = {
	    p->M * acc[0] + p->Bv * vel[0] + p->Cv * ff_sign(vel[0], FF_SIGN_BAND_LIN),
	    p->M * acc[1] + p->Bvn * vel[1] + p->Cvn * ff_sign(vel[1], FF_SIGN_BAND_LIN),
	    p->J * acc[2] + p->Bw * vel[2] + p->Cw * ff_sign(vel[2], FF_SIGN_BAND_ROT)};
	double f[4], rim[4];

	wheel_split(ph, F, f);
	wheel_rims(ph, vel, rim);
	for (int j = 0; j < 4; j++) {
		const double uj = j < ph->n ? ph->vpn[j] * f[j] + ph->kemf[j] * rim[j] : 0.0;

		u[j] = uj > u_max ? u_max : (uj < -u_max ? -u_max : uj);
	}
}
