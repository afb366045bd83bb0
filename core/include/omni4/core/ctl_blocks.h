/*
 * ctl_blocks.h - the controller's small signal blocks, each an instance struct with
 * init / reset / step in the CMSIS-DSP manner: a PI with anti-windup, a voltage ramp, a
 * reference shaper (rate limiter), the current-sense offset calibration. Single precision (the
 * Cortex-M4F's FPU); no state outside the instance, no allocation.
 */
#ifndef OMNI4_CTL_BLOCKS_H
#define OMNI4_CTL_BLOCKS_H

#include <stdbool.h>
#include <stdint.h>

/* PI on one channel: u = ff + kp e + integral, clamped to +-limit. The integral stops while
 * the output is saturated in the direction the error pushes (conditional integration), and
 * is itself held within +-limit. */
struct ctl_pi {
	float kp;    /* [V per unit of e] */
	float ki_dt; /* ki x the step period [V per unit of e, per step] */
	float limit; /* output and integral bound [V] */
	float integ; /* state [V] */
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

/*
 * Current-sense offset calibration of four channels. With the H-bridges off no current flows,
 * so a reading is the channel's offset plus noise: once the bridges have been off for
 * settle_us, the block averages `samples` readings per channel (one measurement), and then
 * the next, for as long as they stay off. A reading taken with the bridges on drops the
 * measurement in progress (and the settle time starts again when they are off again). A
 * completed measurement comes into force (the set the caller subtracts from every reading) if
 * it is the first, or if some channel moved from the set in force by more than
 * max(change_min_a, change_sigmas x the standard error of that difference, sqrt((s_new^2 +
 * s_old^2) / samples) from the readings' own spread); otherwise it is dropped, so repeated
 * measurements do not make the offsets jump by noise. A channel whose offset in force is
 * beyond +-limit_a is flagged (fault_mask). Fixed size, no allocation; single precision.
 */
struct ctl_cal_cfg {
	int samples;         /* readings per channel in one measurement, >= 2 */
	int64_t settle_us;   /* bridges off this long before the first reading counts [us] */
	float limit_a;       /* |offset| beyond this: the channel's sensor is faulty [A] */
	float change_min_a;  /* a new set needs a channel that moved by more than this [A] */
	float change_sigmas; /* ... and by more than this many standard errors */
};

struct ctl_cal {
	struct ctl_cal_cfg cfg;
	/* The set in force (all 0 until the first measurement completes). */
	float offset[4];     /* [A], subtracted from every reading */
	float var[4];        /* variance of the readings it came from [A^2] */
	uint32_t fault_mask; /* bit j: |offset[j]| > limit_a */
	uint32_t gen;        /* sets that came into force; 0 = not calibrated yet */
	/* The set before it (0 before the first), for the announcement. */
	float prev[4];
	uint32_t prev_fault_mask;
	/* The measurement in progress. */
	bool off;             /* the bridges were off at the last step */
	int64_t off_since_us; /* first step that saw them off */
	int n;                /* readings taken */
	float ref[4];         /* the first reading: sums are of (reading - ref) */
	float sum[4], sum2[4];
};

/* Offsets 0, not calibrated, nothing measured; the bridges are taken as on until a step says
 * otherwise. */
void ctl_cal_init(struct ctl_cal *c, const struct ctl_cal_cfg *cfg);
/* One tick at now_us: bridges_off = the bridges were off while the reading was taken; current
 * NULL = no new reading this tick. True if a new set came into force with this reading. */
bool ctl_cal_step(struct ctl_cal *c, int64_t now_us, bool bridges_off, const float *current);
/* Drop the readings of the measurement in progress (a reading that cannot be trusted); the
 * settle time already passed still counts. */
void ctl_cal_restart(struct ctl_cal *c);

#endif /* OMNI4_CTL_BLOCKS_H */
