/*
 * feedforward.h - model-based feedforward: desired velocity and acceleration -> four channel
 * voltages (docs/design.md):
 *   Fv = M a_v + Bv v + Cv sgn(v), Fvn = M a_vn + Bvn vn + Cvn sgn(vn), T = J a_w + Bw w + Cw
 * sgn(w) f  = IK(d) [Fv/2, Fvn/2, T/(4 d^2)] u_j = (R r / (l Kt)) f_j + (Kv l / r) v_j, clamped to
 * +-u_max.
 *
 * sgn is a dead-banded sign: a saturated linear ramp, sgn(x) = clamp(x / band, -1, 1), with
 * band FF_SIGN_BAND_LIN (v, vn) and FF_SIGN_BAND_ROT (w). It is exactly 0 at rest (no
 * chattering voltage around zero) and exactly +-1 outside the band.
 */
#ifndef OMNI4_FEEDFORWARD_H
#define OMNI4_FEEDFORWARD_H

#include "omni4/model/params.h"
#include "omni4/model/q16.h"
#include "omni4/model/wheels.h"

#define FF_SIGN_BAND_LIN 0.01 /* [m/s] */
#define FF_SIGN_BAND_ROT 0.1  /* [rad/s] */

/* The dead-banded sign used above. */
double ff_sign(double x, double band);

/* Double feedforward. vel = [v, vn, w], acc = [a_v, a_vn, a_w]; u_max [V] > 0. */
void ff_voltages(const struct model_params *p, const double vel[3], const double acc[3],
                 double u_max, double u[4]);

/*
 * Fixed-point coefficients, all Q16.16, prepared once by ff_q16_init from the double
 * parameters. Composite gains keep every product well scaled (volts per unit of input).
 */
struct ff_q16 {
	q16_t d;             /* [m] */
	q16_t k_acc[3];      /* R r/(l Kt) * [M/2, M/2, J/(4d)]   [V/(m/s^2)], [V/(rad/s^2)] */
	q16_t k_vel[3];      /* R r/(l Kt) * [Bv/2, Bvn/2, Bw/(4d)] + Kv l/r * [1, 1, d]: viscous
	                      * friction and back-EMF, both linear in the velocity, in one gain */
	q16_t k_coul[3];     /* R r/(l Kt) * [Cv/2, Cvn/2, Cw/(4d)] [V] */
	int32_t sgn_gain[3]; /* 1/band per axis (integer) */
	q16_t u_max;         /* [V] */
};

/* Returns -EINVAL for parameters that fail model_params_check or u_max <= 0. */
int ff_q16_init(struct ff_q16 *ff, const struct model_params *p, double u_max);

/*
 * ff_voltages_q16 - the feedforward in Q16.16 (integer only; runs in the fast loop).
 * Scaling and overflow: vel, acc in Q16.16 (|v| <= 32767 m/s by format); each term is one
 * q16_mul_wide (Q32.32 product rounded to Q16.16, kept in int64_t); the sums cannot overflow
 * int64_t for any input, and the one saturation is the final clamp to +-u_max.
 */
void ff_voltages_q16(const struct ff_q16 *ff, const q16_t vel[3], const q16_t acc[3], q16_t u[4]);

/*
 * Per-wheel drives (struct model_wheels; docs/model.md). The body's forces are shared out as
 * above (the least-squares f, which does not depend on the motors), and each wheel gets the
 * voltage that makes its own motor give f_j at its rim speed v_j:
 *   u_j = (R_j r_j / (l Kt_j)) f_j + (Kv_j l / r_j) v_j, clamped to +-u_max.
 * With four equal wheels, the bits of ff_voltages / ff_voltages_q16.
 */
void ff_voltages_wheels(const struct model_params *p, const struct model_wheels *w,
                        const double vel[3], const double acc[3], double u_max, double u[4]);

/* ff_q16 with one set of axis gains per wheel: k_*[j] are ff_q16's k_* with wheel j's
 * R_j r_j / (l Kt_j) and Kv_j l / r_j (only the two axes that move wheel j are used). */
struct ff_q16_wheels {
	q16_t d;             /* [m] */
	int n;               /* wheels driven: 3 or 4 (u[3] = 0 for 3) */
	int8_t sign[4][3];   /* wheel j's term of axis k enters with this sign (0: not at all) */
	q16_t k_acc[4][3];   /* [V/(m/s^2)], [V/(rad/s^2)] */
	q16_t k_vel[4][3];   /* [V/(m/s)], [V/(rad/s)] */
	q16_t k_coul[4][3];  /* [V] */
	int32_t sgn_gain[3]; /* 1/band per axis (integer) */
	q16_t u_max;         /* [V] */
};

/* -EINVAL if p fails model_params_check, w fails model_wheels_check or u_max <= 0. */
int ff_q16_wheels_init(struct ff_q16_wheels *ff, const struct model_params *p,
                       const struct model_wheels *w, double u_max);
/* The same for a model already checked (MODEL_ASSERT_CHECKED): -EINVAL only if u_max <= 0. */
int ff_q16_wheels_prepare(struct ff_q16_wheels *ff, const struct model_params *p,
                          const struct model_wheels *w, double u_max);

/*
 * Any layout (model/wheels.h; docs/model.md "Layouts"): wheel j's gains per axis k from its row
 * g_j (eq 2) and its share of a body force (the least-norm split s_j):
 *   k_acc[j][k] = R_j r_j / (l Kt_j) s_jk I_k, k_coul[j][k] = R_j r_j / (l Kt_j) s_jk C_k,
 *   k_vel[j][k] = R_j r_j / (l Kt_j) s_jk B_k + Kv_j l / r_j g_jk  (I = M, M, J), sign +1,
 * so u_j = sum_k (k_acc a_k + k_vel v_k + k_coul sgn(v_k)) is eqs 9-13 and 21 with the force
 * split least norm. g NULL: the paper's layout, ff_q16_wheels_prepare's bits. -EINVAL for a
 * layout that does not drive the body or u_max <= 0. The model is checked (as _prepare).
 */
int ff_q16_wheels_prepare_layout(struct ff_q16_wheels *ff, const struct model_params *p,
                                 const struct model_wheels *w, const struct wheel_geom *g,
                                 double u_max);
/* The double twin: the body force F = I a + B v + C sgn(v) split least norm onto the wheels,
 * u_j = R_j r_j / (l Kt_j) f_j + Kv_j l / r_j (g_j . v), clamped to +-u_max; u[j] = 0 for
 * j >= ph->n. ph from wheel_phys_init with p and w. */
void ff_voltages_layout(const struct model_params *p, const struct wheel_phys *ph,
                        const double vel[3], const double acc[3], double u_max, double u[4]);

/*
 * ff_voltages_q16_wheels - the per-wheel feedforward in Q16.16 (integer only; fast loop).
 * Scaling and overflow: as ff_voltages_q16, with wheel j's gains: each wheel sums two axis
 * terms of three rounded Q16.16 products each (all below 2^48 in int64_t, no overflow for any
 * input); the one saturation is the final clamp to +-u_max.
 */
void ff_voltages_q16_wheels(const struct ff_q16_wheels *ff, const q16_t vel[3], const q16_t acc[3],
                            q16_t u[4]);

/*
 * Each wheel's gains as affine functions of its resistance R_j (its online estimate: core/
 * adapt.h): k_acc[j] = R_j acc[j], k_vel[j] = R_j vel[j] + emf[j], k_coul[j] = R_j coul[j], in
 * single precision (the loop's arithmetic), from the expressions of ff_q16_wheels_init.
 */
struct ff_wheels_per_ohm {
	float acc[4][3];  /* [V/(m/s^2)/ohm], [V/(rad/s^2)/ohm] */
	float vel[4][3];  /* viscous friction [V/(m/s)/ohm], [V/(rad/s)/ohm] */
	float emf[4][3];  /* back-EMF [V/(m/s)], [V/(rad/s)]: no R in it */
	float coul[4][3]; /* [V/ohm] */
};

/* From a checked model (as ff_q16_wheels_prepare); w's R is not used. Off the fast loop. */
void ff_wheels_per_ohm_prepare(struct ff_wheels_per_ohm *o, const struct model_params *p,
                               const struct model_wheels *w);
/* The same for any layout (g NULL: the paper's, ff_wheels_per_ohm_prepare's values); -EINVAL
 * for a layout that does not drive the body. */
int ff_wheels_per_ohm_prepare_layout(struct ff_wheels_per_ohm *o, const struct model_params *p,
                                     const struct model_wheels *w, const struct wheel_geom *g);
/*
 * Fast loop: wheel j's nine Q16.16 gains of ff for its resistance R_ohm (> 0, finite, within
 * the model's range: the caller's bounds), the other wheels untouched. Scaling and overflow:
 * nine float products and sums, each rounded once to Q16.16 (q16_from_float saturates at the
 * format's +-32768, far above any gain of a model within its ranges). The same gains as
 * ff_q16_wheels_prepare with R_j = R_ohm to within float's rounding (a Q16.16 LSB).
 */
void ff_q16_wheels_set_resistance(struct ff_q16_wheels *ff, const struct ff_wheels_per_ohm *o,
                                  int j, float R_ohm);

#endif /* OMNI4_FEEDFORWARD_H */
