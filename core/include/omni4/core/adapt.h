/*
 * adapt.h - online estimation of each motor's resistance R_j (a winding's R rises 0.39 %/K as
 * it heats) and its acceptance into the feedforward, with a revert when tracking worsens.
 * Portable like the rest of the core: single precision, fixed sizes, no allocation; an
 * instance with init / reset / step (CMSIS style). Every function here runs in the fast loop
 * (a few hundred float operations a tick at most) unless it says otherwise.
 *
 * Estimate, per motor j: recursive least squares with forgetting (factor lambda per sample
 * taken) on eq 21 with L neglected, u_j = R_j i_j + Kv_j w_mj, w_mj = l w_j the motor's speed:
 * the one unknown R_j, y = u_j - Kv_j l w_j = R_j i_j. Kv_j is the model's: the windings'
 * copper changes R by 0.39 %/K while a magnet's field changes Kv by about a quarter of that
 * (NdFeB, -0.1 %/K); a joint [R_j, Kv_j] fit is well conditioned only while speed and current
 * vary independently (docs/hard-drive.csv: correlation 0.37, condition number 1.5), and at any
 * steady cruise (i_j and w_j both constant) it is singular, where R_j alone still has its
 * samples. A sample is taken only when:
 * the bridges were driven over the step in a mode that drives them (the same mode as the tick
 * before: a mode change freezes it), no fault is latched, the estimator flags no slip and no
 * collision (a push or a block), |i_j| > current_min_a (excitation), |u_j| below
 * ADAPT_U_SHARE of the supply (not clipped by the bridge) and u_j within ADAPT_DU_MAX_V of the
 * tick before (steady: the current has settled after its step, L neglected). Each estimate is
 * held within [ADAPT_R_MIN, ADAPT_R_MAX] x the identified R_j; a non-finite value restarts it
 * from the identified one. Its variance: var = s2 P / (1 + lambda), s2 the residual's variance
 * (its running mean, then exponentially forgotten), P the RLS's (sum of lambda^k i_k^2)^-1,
 * the variance of an exponentially weighted least-squares fit of steady excitation.
 *
 * Accept: an estimate whose relative variance var / R^2 is below variance_gate and that differs
 * from the R_j in use by more than ADAPT_ACCEPT_SHARE goes into the feedforward (the caller
 * rebuilds that wheel's gains: ff_q16_wheels_set_resistance, nine products), all such motors at
 * once, once a whole window of tracking lies behind (the comparison's baseline).
 *
 * Revert: the mean square of the wheels' speed tracking error (VELOCITY, GOAL) over the
 * ADAPT_WINDOW_S of tracking after an acceptance is compared with the ADAPT_WINDOW_S before; more
 * than ADAPT_REVERT_RATIO times it puts the previous values back (flag REVERTED, a notice in the
 * log) and the estimates restart from them; no acceptance for ADAPT_HOLDOFF_S then.
 */
#ifndef OMNI4_ADAPT_H
#define OMNI4_ADAPT_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/core/ctl_settings.h"

#define ADAPT_R_MIN 0.5f /* bounds of an estimate, x the identified R_j */
#define ADAPT_R_MAX 2.0f
#define ADAPT_U_SHARE 0.95f       /* |u_j| beyond this share of the supply: clipped, not taken */
#define ADAPT_DU_MAX_V 1.0f       /* a step of u_j beyond this since the tick before: not taken */
#define ADAPT_ACCEPT_SHARE 0.005f /* an estimate this far from the R_j in use is taken */
#define ADAPT_WINDOW_S 2.0        /* tracking compared over this much, before and after [s] */
#define ADAPT_BINS 20             /* the window before, in this many bins */
#define ADAPT_REVERT_RATIO 1.5f   /* after / before mean square beyond it: revert */
#define ADAPT_HOLDOFF_S 10.0      /* no acceptance for this long after a revert [s] */
#define ADAPT_P0 0.1f             /* the identified R's prior: worth 10 samples at 1 A [1/A^2] */
#define ADAPT_S2_0 1.0f           /* the residual's variance before any sample [V^2] */

/* adapt_t.flags (lcmtypes/adapt_t.lcm, checked there by firmware/ lcmcodec.c) */
#define ADAPT_FLAG_ON 0x01       /* [adapt] enable and resistance */
#define ADAPT_FLAG_FED 0x02      /* a sample was taken since the last report */
#define ADAPT_FLAG_FROZEN 0x04   /* a fault, mode change, slip or collision froze it */
#define ADAPT_FLAG_ADAPTED 0x08  /* an R_j in use differs from the identified */
#define ADAPT_FLAG_WATCH 0x10    /* an acceptance under the revert check */
#define ADAPT_FLAG_ACCEPTED 0x20 /* estimates were accepted since the last report */
#define ADAPT_FLAG_REVERTED 0x40 /* an acceptance was reverted since the last report */
#define ADAPT_FLAG_RESTART 0x80  /* an estimate was not finite: restarted */

/* The settings as the step uses them ([adapt] keys). */
struct adapt_settings {
	bool on; /* enable && resistance */
	float forget;
	float current_min_a;
	float variance_gate;
};

/* One motor's RLS (private). */
struct adapt_rls {
	float R;  /* estimate [ohm] */
	float P;  /* [1/A^2] */
	float s2; /* residual variance [V^2] */
	uint32_t n;
};

/* One tick's inputs. */
struct adapt_input {
	bool reading;         /* a new reading this tick */
	bool driven;          /* the bridges were on over the step that led to it */
	int8_t mode;          /* the controller's mode after this tick (vocab.def) */
	bool faulted;         /* a latching fault is latched */
	uint32_t est_flags;   /* the estimator's flags (EST_FLAG_*) of the last tick */
	float volts[4];       /* applied over that step [V] */
	float current_a[4];   /* this reading, offsets subtracted [A] */
	float wheel_rad_s[4]; /* this reading [rad/s] */
	float supply_v;       /* the drives' supply [V]; not a positive number: unknown */
	bool tracking;        /* the controller tracked a velocity reference this tick */
	float track_e2;       /* sum over the wheels of the squared speed error [(m/s)^2] */
};

struct adapt_report {
	float R[4];      /* in use [ohm] */
	float R_est[4];  /* the estimates [ohm] */
	float var[4];    /* their variances [ohm^2] */
	float supply_v;  /* the drives' supply as last read [V] (0: none) */
	float track_rms; /* the wheels' speed tracking error since the last report, RMS [m/s]
	                  * (0: none tracked) */
	uint32_t flags;  /* ADAPT_FLAG_* */
};

struct adapt {
	/* private: see adapt.c */
	struct adapt_settings set;
	float R_id[4];   /* identified [ohm] */
	float R_use[4];  /* in the feedforward */
	float R_prev[4]; /* in use before the acceptance under watch */
	float kvl[4];    /* Kv_j l [V/(rad/s)] at the wheel */
	struct adapt_rls m[4];
	float u_prev[4];
	int8_t mode_prev;
	bool have_prev;
	/* tracking before (bins) and after an acceptance */
	float bin_e2[ADAPT_BINS];
	uint32_t bin_n[ADAPT_BINS];
	int bin;          /* the bin being filled */
	uint32_t bin_len; /* ticks per bin */
	float after_e2;
	uint32_t after_n;
	float before_ms; /* the baseline of the acceptance under watch [(m/s)^2] */
	bool watch;
	uint32_t holdoff; /* ticks without acceptance left */
	uint32_t holdoff_ticks;
	uint32_t flags; /* sticky until adapt_report */
	float supply_v;
	float rep_e2; /* tracking since the last report */
	uint32_t rep_n;
	uint32_t accepted, reverted; /* counters */
};

/* [adapt] keys as the step's settings. */
void adapt_settings_from_keys(const struct ctl_settings *cfg, struct adapt_settings *s);

/* Off the fast loop (start-up, a parameter change): the identified model (R_j, Kv_j, l from
 * cfg's wheels) and the settings; every estimate and R in use back to the identified. */
void adapt_init(struct adapt *a, const struct ctl_settings *cfg);
/* Between two ticks, after the controller took cfg (its feedforward the identified R_j's again):
 * a new identified model starts everything again (adapt_init); otherwise new [adapt] settings
 * only (off: the R in use back to the identified) and the estimates stay. Returns the wheels
 * (bit j) whose R in use is not the identified: their gains are to follow adapt_r_in_use. */
uint32_t adapt_retune(struct adapt *a, const struct ctl_settings *cfg);

/* Fast loop, once per tick after the controller's step. Returns a mask: bit j set, wheel j's R
 * in use changed (accepted or reverted): its feedforward gains are to follow adapt_r_in_use. */
uint32_t adapt_step(struct adapt *a, const struct adapt_input *in);

/* Fast loop: take R (each within the bounds; a non-finite one leaves that motor alone) into use
 * now, as an accepted estimate is, under the revert check. Returns adapt_step's mask. */
uint32_t adapt_accept(struct adapt *a, const float R[4]);

static inline const float *adapt_r_in_use(const struct adapt *a)
{
	return a->R_use;
}

/* The state for a report (adapt_t); the sticky flags (FED, FROZEN, ACCEPTED, REVERTED,
 * RESTART) start again. */
void adapt_report(struct adapt *a, struct adapt_report *out);

#endif /* OMNI4_ADAPT_H */
