/*
 * ctl_blocks.h - the controller's small signal blocks, each an instance struct with
 * init / reset / step in the CMSIS-DSP manner: a PI with anti-windup, a voltage ramp, a
 * reference shaper (rate limiter). Single precision (the Cortex-M4F's FPU); no state outside
 * the instance, no allocation.
 */
#ifndef OMNI4_CTL_BLOCKS_H
#define OMNI4_CTL_BLOCKS_H

#include <stdbool.h>
#include <stdint.h>

/* PI on one channel: u = ff + kp e + integral, clamped to +-limit. The integral stops while
 * the output is saturated in the direction the error pushes (conditional integration), and
 * is itself held within +-limit. */
struct ctl_pi {
	float kp;     /* [V per unit of e] */
	float ki_dt;  /* ki x the step period [V per unit of e, per step] */
	float limit;  /* output and integral bound [V] */
	float integ;  /* state [V] */
};

void ctl_pi_init(struct ctl_pi *s, float kp, float ki, float dt, float limit);
/* New gains, the integral kept (a parameter change between two ticks). */
void ctl_pi_set_gains(struct ctl_pi *s, float kp, float ki, float dt, float limit);
void ctl_pi_reset(struct ctl_pi *s);
/* One step with feedforward ff and error e; returns the clamped output. */
float ctl_pi_step(struct ctl_pi *s, float ff, float e);

/* Four outputs moving linearly from `from` to `to` over len_us, from t0_us on. */
struct ctl_ramp {
	float from[4], to[4];
	int64_t t0_us, len_us;
};

/* The ramp's init: from `from` to `to` over len_s (0: at `to` at once) from now_us on. */
void ctl_ramp_start(struct ctl_ramp *r, const float from[4], const float to[4], float len_s,
		    int64_t now_us);
/* No ramp in progress: the outputs stay at `hold` (done at once). */
void ctl_ramp_reset(struct ctl_ramp *r, const float hold[4]);
/* The outputs at now_us; true once the ramp has reached `to`. */
bool ctl_ramp_step(const struct ctl_ramp *r, int64_t now_us, float out[4]);

/* Three axes, each following its target with a bounded rate: the shaped reference and its
 * derivative (the acceleration the feedforward needs). */
struct ctl_shaper {
	float max_step[3]; /* acc_max x the step period */
	float inv_dt;      /* 1 / the step period [1/s] */
	float ref[3];      /* state: shaped reference */
	float acc[3];      /* derivative of the last step */
};

void ctl_shaper_init(struct ctl_shaper *s, const float acc_max[3], float dt);
/* The reference starts at ref (bumpless), with zero acceleration. */
void ctl_shaper_reset(struct ctl_shaper *s, const float ref[3]);
void ctl_shaper_step(struct ctl_shaper *s, const float target[3]);

#endif /* OMNI4_CTL_BLOCKS_H */
