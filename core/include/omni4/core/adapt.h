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
 *
 * Friction, per body axis k (v, vn, w): eq 23 at steady motion, F_k = B_k x_k + C_k sgn(x_k),
 * F the body force of the measured wheel currents through the model's force map (eqs 12-13,
 * 9-11: dyn_wheel_forces_wheels, dyn_robot_forces) and x the body velocity of the wheel speeds
 * (eqs 3-5: fk_robot_velocity_rates), both as 3x4 matrices built at init. The ticks are summed
 * in blocks of ADAPT_FRIC_BLOCK_S; a block's means are one sample of an axis when every tick of
 * it could be taken (as R's: driven, same mode, no fault, slip or collision), the axis moved
 * one way beyond ADAPT_FRIC_V_MIN_LIN / _ROT through it and the ADAPT_FRIC_SPAN blocks before,
 * and the whole body was steady over that span: on every axis the mean velocity changed by less
 * than ADAPT_FRIC_STEADY C / M per second (the inertia force M a under that share of the Coulomb
 * friction; it is then taken out of F) and every block's mean force stayed within
 * ADAPT_FRIC_F_STEADY C of this one's. One block is too short to see it: the encoders' counts
 * step a block's mean. Steady on every axis, not just k's: a reversal on a slippery floor holds
 * its force at the traction bound while the velocity changes, and the other axes' wheels, at the
 * bound, bias k's force; a push's start and end step the force at a steady velocity.
 * The fit of [B_k, C_k] is least squares
 * with forgetting (friction_forget per sample) kept in information form, I = lambda I + phi
 * phi^T + (1 - lambda) I0, b likewise with I0 theta_id: a direction the samples do not excite
 * (the drive's cruises all at one speed make v and sgn(v) collinear) returns to the prior
 * instead of winding up. The prior I0 = ADAPT_FRIC_PRIOR C_k^2 (theta theta^T + ADAPT_FRIC_EPS
 * diag(theta^2))^-1, theta = the identified [B_k, C_k]: a change mostly along theta (a floor
 * scales B and C together), each part free by sqrt(ADAPT_FRIC_EPS) besides. Each estimate is
 * held within [ADAPT_F_MIN, ADAPT_F_MAX] x the identified; a non-finite one restarts the axis
 * from the values in use. Variance: s2 I^-1 / (1 + lambda), as R's. An axis whose C's relative
 * variance is below friction_variance_gate and whose C is more than ADAPT_FRIC_ACCEPT_SHARE
 * from the C in use is accepted (B and C of it), with R's candidates, under the same revert
 * check: a revert puts R and friction back alike.
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
#define ADAPT_F_MIN 0.25f         /* bounds of a friction estimate, x the identified B_k, C_k */
#define ADAPT_F_MAX 4.0f
#define ADAPT_FRIC_BLOCK_S 0.01       /* ticks summed into one sample [s] */
#define ADAPT_FRIC_V_MIN_LIN 0.1f     /* |v|, |vn| beyond this: moving [m/s] */
#define ADAPT_FRIC_V_MIN_ROT 0.5f     /* |w| beyond this: moving [rad/s] */
#define ADAPT_FRIC_STEADY 0.05f       /* M |a| below this share of C: steady */
#define ADAPT_FRIC_SPAN 8             /* the acceleration over this many blocks before */
#define ADAPT_FRIC_F_STEADY 0.2f      /* every block's force this share of C from the last's */
#define ADAPT_FRIC_PRIOR 1.0f         /* the prior's weight: I0 in units of C_k^2 */
#define ADAPT_FRIC_EPS 0.01f          /* B and C apart: (10 %)^2 of the prior's variance */
#define ADAPT_FRIC_ACCEPT_SHARE 0.02f /* a C_k this far from the C_k in use is taken */

/* adapt_step's mask: bits 0-3 the wheels' R, this bit the friction in use */
#define ADAPT_CHANGED_FRICTION 0x10u

/* adapt_t.flags (lcmtypes/adapt_t.lcm, checked there by firmware/ lcmcodec.c) */
#define ADAPT_FLAG_ON 0x01       /* [adapt] enable and resistance */
#define ADAPT_FLAG_FED 0x02      /* a sample was taken since the last report */
#define ADAPT_FLAG_FROZEN 0x04   /* a fault, mode change, slip or collision froze it */
#define ADAPT_FLAG_ADAPTED 0x08  /* an R_j or friction in use differs from the identified */
#define ADAPT_FLAG_WATCH 0x10    /* an acceptance under the revert check */
#define ADAPT_FLAG_ACCEPTED 0x20 /* estimates were accepted since the last report */
#define ADAPT_FLAG_REVERTED 0x40 /* an acceptance was reverted since the last report */
#define ADAPT_FLAG_RESTART 0x80  /* an estimate was not finite: restarted */

/* The settings as the step uses them ([adapt] keys). */
struct adapt_settings {
	bool on;       /* enable && resistance */
	bool friction; /* enable && friction */
	float forget;
	float friction_forget;
	float friction_variance_gate;
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

/* One body axis's friction fit [B_k, C_k] in information form (private). */
struct adapt_fric {
	float th[2]; /* the estimate [B_k, C_k] */
	float I[3];  /* information I00, I01, I11 */
	float b[2];  /* information vector */
	float I0[3]; /* the prior's information */
	float b0[2]; /* I0 theta_id */
	float s2;    /* residual variance [N^2] or [(N m)^2] */
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
	float B[3];      /* viscous friction in use: Bv, Bvn [N/(m/s)], Bw [N m/(rad/s)] */
	float C[3];      /* Coulomb friction in use: Cv, Cvn [N], Cw [N m] */
	float C_est[3];  /* the estimates of C */
	float C_var[3];  /* their variances */
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
	/* friction */
	float B_id[3], C_id[3];     /* identified */
	float B_use[3], C_use[3];   /* in the feedforward */
	float B_prev[3], C_prev[3]; /* in use before the acceptance under watch */
	float Gi[3][4];             /* body force per wheel current [N/A], [N m/A] */
	float Gw[3][4];             /* body velocity per wheel speed [m/s / (rad/s)], [-] */
	float v_min[3], dv_max[3];  /* moving; steady: the change of a block's mean velocity */
	float m_dt[3];              /* M_k over the span's time: inertia force per dv [N/(m/s)] */
	float df_max[3];            /* steady: a block's mean force this close to the span's */
	float blk_hist[3][ADAPT_FRIC_SPAN + 1];  /* the last blocks' mean velocities */
	float blk_fhist[3][ADAPT_FRIC_SPAN + 1]; /* and mean forces */
	float blk_sgn_run[3];                    /* the direction of the run */
	uint16_t blk_run[3];                     /* the blocks of the axis's run one way so far */
	int blk_i;                               /* this block's place in blk_hist */
	struct adapt_fric f[3];
	float blk_F[3], blk_x[3]; /* the block's sums */
	float blk_sgn[3];         /* the block's direction per axis (0: not moving) */
	uint32_t blk_n, blk_len;
	bool blk_ok;
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
/* Between two ticks, after the controller took cfg (its feedforward the identified R_j's again);
 * fresh: adapt_init of cfg, prepared beside the loop (fw_param_prepare: the friction's maps are
 * double arithmetic). A new identified model starts everything again (a = fresh); otherwise new
 * [adapt] settings only (off: the R in use back to the identified) and the estimates stay.
 * Returns the wheels (bit j) whose R in use is not the identified: their gains are to follow
 * adapt_r_in_use; and ADAPT_CHANGED_FRICTION if the friction in use is not the identified
 * (adapt_b/c_in_use). */
uint32_t adapt_retune(struct adapt *a, const struct adapt *fresh);

/* Fast loop, once per tick after the controller's step. Returns a mask: bit j set, wheel j's R
 * in use changed (accepted or reverted): its feedforward gains are to follow adapt_r_in_use;
 * ADAPT_CHANGED_FRICTION: the friction in use changed (ctl_set_friction). */
uint32_t adapt_step(struct adapt *a, const struct adapt_input *in);

/* Fast loop: take R (each within the bounds; a non-finite one leaves that motor alone) into use
 * now, as an accepted estimate is, under the revert check. Returns adapt_step's mask. */
uint32_t adapt_accept(struct adapt *a, const float R[4]);

/* Fast loop: take B, C (each within the bounds; a non-finite one leaves that value alone) into
 * use now, under the revert check. Returns adapt_step's mask. */
uint32_t adapt_accept_friction(struct adapt *a, const float B[3], const float C[3]);

static inline const float *adapt_r_in_use(const struct adapt *a)
{
	return a->R_use;
}

/* Friction in use, per axis v, vn, w (adapt_report's B, C). */
static inline const float *adapt_b_in_use(const struct adapt *a)
{
	return a->B_use;
}
static inline const float *adapt_c_in_use(const struct adapt *a)
{
	return a->C_use;
}

/* The state for a report (adapt_t); the sticky flags (FED, FROZEN, ACCEPTED, REVERTED,
 * RESTART) start again. */
void adapt_report(struct adapt *a, struct adapt_report *out);

#endif /* OMNI4_ADAPT_H */
