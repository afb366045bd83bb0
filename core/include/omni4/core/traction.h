/*
 * traction.h - the traction limit of VELOCITY's reference shaping: each wheel's drive force,
 * as the model splits the reference's force onto the wheels, kept within what the floor
 * holds less a margin; a slip in progress backs the limit off until the wheels grip.
 *
 * The force the reference needs (eq 23 written as forces): F_v = M a_v + Bv v + Cv sgn(v),
 * F_vn likewise, T = J a_w + Bw w + Cw sgn(w), split onto the wheels as the feedforward does
 * (eqs 9-11, least norm; wheels.h): f_0 = F_vn / 2 + T / 4d, f_1 = -F_v / 2 + T / 4d,
 * f_2 = -f_0 + T / 2d, f_3 = -f_1 + T / 2d. Wheel j holds mu N_j along its drive direction (its
 * rollers roll freely across), N_j = M g / 4 - M h (a . p_j) / (2 d^2) with the load transfer of
 * the reference acceleration a (h = com_height; p_0 = (d, 0), p_1 = (0, d), p_2 = -p_0,
 * p_3 = -p_1): wheels.h's loads.
 *
 * The rule (two parts): the shaper's step (its acceleration a) is scaled by the largest s in [0, 1]
 * with |f_j(s a)| <= b (1 - margin) mu N_j(s a) for every wheel (each bound linear in s: a closed
 * form, no iteration); s = 0 when friction alone needs more. b is the slip back-off: every
 * tick with a slip flagged it is multiplied by TRACTION_BACKOFF (down to TRACTION_BACKOFF_MIN),
 * every tick without, it grows back by dt / TRACTION_RECOVER_S (up to 1): a slip in progress
 * reduces the force until the wheels grip again, then the limit returns within
 * TRACTION_RECOVER_S. Then the wheels' voltages, feedback included, are clamped to the hold
 * (traction_clamp_volts). mu = 0 switches the limit off (the shaper's own acc_lin_max,
 * acc_rot_max only).
 *
 * Portable like the rest of the core: single precision, no allocation, no OS.
 */
#ifndef OMNI4_TRACTION_H
#define OMNI4_TRACTION_H

#include <stdbool.h>

#include "omni4/model/params.h"
#include "omni4/model/wheels.h"
#define TRACTION_BACKOFF 0.9f     /* per tick with a slip flagged */
#define TRACTION_BACKOFF_MIN 0.2f /* never below this share of the limit */
#define TRACTION_RECOVER_S 0.3f   /* from the floor back to the full limit */

struct traction {
	bool on;    /* mu > 0 */
	float mu;   /* floor's friction coefficient ([limits] traction_mu) */
	float keep; /* 1 - margin */
	float M, J; /* [kg], [kg m^2] */
	float B[3], C[3];
	struct wheel_phys_f32 ph; /* the wheels: split, loads, drive gains, back-EMF (wheels.h) */
	float recover;            /* back-off regained per tick */
	float backoff;            /* b, in [TRACTION_BACKOFF_MIN, 1] */
	float scale;              /* s of the last step (1: not limited) */
};

/* mu [-] (0 = off), margin in [0, 1), com_height [m] >= 0, dt [s] > 0; the model's M, J, d,
 * B, C, l, each drive's r_j, Kv_j, Kt_j, R_j and the layout g (NULL: the paper's at d; a
 * three-wheel layout's slot 3 carries no force, holds nothing and is clamped to 0 V). Keeps the
 * back-off (a retune between ticks does not forget a slip). */
void traction_set(struct traction *t, const struct model_params *p, const struct model_wheels *w,
                  const struct wheel_geom *g, double mu, double margin, double com_height,
                  float dt);
/* Back-off at 1, nothing limited. */
void traction_reset(struct traction *t);

/* Wheel j's drive force [N] for the reference velocity x and acceleration a (the split above). */
void traction_wheel_forces(const struct traction *t, const float x[3], const float a[3],
                           float f[4]);
/* Wheel j's share of the limit, b (1 - margin) mu N_j [N], at reference acceleration a. */
void traction_wheel_holds(const struct traction *t, const float x[3], const float a[3],
                          float hold[4]);

/*
 * Fast loop, once per VELOCITY tick after the shaper's step: prev the reference before the
 * step, ref and acc the shaper's reference and acceleration after it (scaled in place),
 * slipping the estimator's slip flag of the last tick.
 */
void traction_step(struct traction *t, const float prev[3], float ref[3], float acc[3],
                   bool slipping);

/*
 * Fast loop, after the PI: each wheel's voltage kept where its motor's force (eqs 12-13, 21 at
 * the wheel's measured rim speed rim_m_s[j], its own R_j, Kt_j, Kv_j, r_j) stays within its
 * hold at the reference (ref, acc): the feedback cannot push a wheel past the floor either,
 * and a wheel that slips (its rim fast, its back-EMF high) gets no more than the hold. Returns
 * per wheel the volts taken off (for the PI's anti-windup); all 0 when off.
 */
void traction_clamp_volts(const struct traction *t, const float ref[3], const float acc[3],
                          const float rim_m_s[4], float volts[4], float taken[4]);

#endif /* OMNI4_TRACTION_H */
