/*
 * est.h - where the robot is and whether it slips: a model-based state estimator (an extended
 * Kalman filter) in the controller core. Portable like the rest of the core: C11, single
 * precision, fixed sizes, no allocation; an instance with init / reset / step (CMSIS style).
 *
 * State s = [x, y, theta, v, vn, w]: the world pose (m, m, rad; theta wrapped to (-pi, pi]) and
 * the robot-frame velocity (m/s, m/s, rad/s; eq 1 maps one to the other), with its covariance.
 * - Predict, every tick: eq 23 with the derived signs (dynamics.h), Coulomb and viscous
 *   friction, driven by the voltages applied at that tick, or null traction (A_coast, no drive)
 *   when the bridges are off; the pose integrates eq 1.
 * - Update, every tick with a reading: the four wheel speeds (eq 2 as the measurement model),
 *   each corrected by the wheel's scale error, learnt from the null space (EST_CAL_*).
 * - Update with a camera pose at its capture time (pose_t.utime), by the replay of late
 *   measurements (est_replay.h): the filter keeps a ring of its past ticks and re-runs from
 *   the frame's tick to now; frames older than the history (EST_HISTORY ticks, less up to
 *   EST_SNAP_EVERY - 1) are counted and dropped.
 * - Outliers are gated: a camera pose beyond gate_sigmas (Mahalanobis), unless EST_CAM_RESYNC
 *   frames in a row disagree; in a wheel reading whose null-space residual is beyond
 *   slip_threshold, the wheel farthest from the prediction (the other three give the
 *   velocity); a wheel flagged SLIP (any witness, EST_FLAG_SLIP_j) is left out until it
 *   grips again (est_slip.c). A camera that stops leaves odometry and the model carrying on
 *   with a growing covariance.
 * - Flags, per tick (not faults): EST_FLAG_SLIP from the wheel null-space residual
 *   v0 - v1 + v2 - v3 (0 for a rigid body); EST_FLAG_COLLISION from the model-vs-wheels
 *   innovation averaged over EST_INNOV_AVG_TICKS (the robot slowed or was pushed although the
 *   voltages say otherwise); thresholds from the measured noise (est_settings,
 *   docs/estimator.md).
 * The model parameters in force follow the parameter service (est_set_model, between ticks).
 * Another wheel layout (three wheels, an asymmetric four: est_set_model_wheels' g): the same
 * with the layout's eq 23, rows and null vector; three wheels have no null space (the model's
 * and the camera's witnesses name a slipping wheel; no scale calibration).
 */
#ifndef OMNI4_EST_H
#define OMNI4_EST_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/model/dynamics.h"
#include "omni4/core/est_keys.h"
#include "omni4/model/params.h"
#include "omni4/model/wheels.h"
#include "omni4/core/vocab.h"

#ifndef EST_CATCH_UP
#define EST_CATCH_UP 32 /* periods a late tick may have missed that are predicted first */
#endif
#ifndef EST_HISTORY
#define EST_HISTORY 256 /* past ticks kept for the camera replay (256 ms at 1 kHz) */
#endif

/* The flags EST_FLAG_* (est_output.flags): vocab.h, from vocab.def. */

#define EST_CAMERA_STALE_US 500000
/* A wheel reading beyond this ground speed [m/s] (or not finite) is no reading: no omni-wheel
 * robot goes that fast, and the filter's and the calibration's sums stay finite. */
#define EST_WHEEL_MAX_M_S 50.0f
/* The velocity innovation behind EST_FLAG_COLLISION is averaged exponentially over this many
 * ticks: the wheels' noise averages out, a sustained push does not. */
#define EST_INNOV_AVG_TICKS 8

/* Odometry error: the pose variance grows by EST_ODOM_POS^2 [m^2/m] (x and y) and
 * EST_ODOM_THETA^2 [rad^2/m] per metre travelled (rotation counted at the wheels, d |w|), and
 * the heading's by EST_DRIFT_THETA^2 [rad^2/s] per second: the wheels' creep, a random walk of
 * the heading read from them (docs/estimator.md). */
#define EST_ODOM_POS 0.005f
#define EST_ODOM_THETA 0.005f
#define EST_DRIFT_THETA 0.01f
/* The heading's creep needs turning wheels: it grows to EST_DRIFT_THETA^2 per second as the
 * wheels' ground speeds (|v| + |vn| + d |w|) rise to this [m/s], and stops at rest, where the
 * camera's frames then average the heading down (a goal's arrival waits for that). */
#define EST_DRIFT_SPEED_M_S 0.05f
/* Wheel scale calibration: a rigid body's wheel ground speeds satisfy g0 - g1 + g2 - g3 = 0
 * (eq 2), so every reading r w_j (1 + k_j) gives one linear equation in the wheels' scale errors
 * k_j (effective radius / nominal - 1). The equations of the last EST_CAL_TAU_S (exponential
 * forgetting) are solved by least squares every EST_CAL_EVERY ticks, with a prior of 0 worth
 * EST_CAL_PRIOR [(m/s)^2] of squared regressor (a 1 % error against the readings' 1 cm/s noise;
 * the same as 1 ms of readings at 1 m/s, so it only holds the first few ticks), within
 * +-EST_CAL_MAX. The common scale of all four wheels has no equation (every wheel read as 0
 * satisfies them all): it is not estimated and stays the model's r. Readings flagged as slip or
 * collision are left out. */
#define EST_CAL_TAU_S 60.0f
#define EST_CAL_EVERY 50
#define EST_CAL_PRIOR 1.0f
#define EST_CAL_MAX 0.05f
/* Frames refused by the gate in a row before the next one is taken anyway (with the pose
 * variance widened by its innovation): a camera that keeps disagreeing is right. */
#define EST_CAM_RESYNC 5

/* Noise and thresholds of the filter (SI units, standard deviations): one member per row of
 * est_keys.def (its unit, range and description), float where the key is a double. */
#define EST_SETTING_TYPE_DBL float
#define EST_SETTING_TYPE_INT int
#define EST_SETTING_TYPE_BOOL bool
struct est_settings {
#define OMNI4_KEY(kind, section, key, field, ...) EST_SETTING_TYPE_##kind field;
#include "omni4/core/est_keys.def"
#undef OMNI4_KEY
};

/* One tick's inputs. */
struct est_input {
	int64_t utime;        /* controller time of the tick [us] */
	float volts[4];       /* applied [V] */
	bool driven;          /* H-bridges on */
	bool have_wheels;     /* a reading this tick */
	float wheel_rad_s[4]; /* wheel angular speeds [rad/s] */
};

struct est_output {
	int64_t utime;
	float pose[3];          /* x, y [m], theta [rad] */
	float vel[3];           /* v, vn [m/s], w [rad/s] (robot frame) */
	float cov[6];           /* diagonal of the covariance, state order */
	uint32_t flags;         /* EST_FLAG_* */
	float null_residual;    /* v0 - v1 + v2 - v3 of the last reading (another layout: its
	                         * null vector's n . v; three wheels: 0) [m/s] */
	float vel_innov;        /* |wheel velocity - model prediction|, w as d w, averaged over
	                         * the last readings (EST_INNOV_AVG_TICKS) [m/s] (what
	                         * EST_FLAG_COLLISION looks at) */
	float cam_innov[3];     /* last camera pose minus the estimate at its capture time */
	int64_t cam_latency_us; /* arrival minus capture of the last camera pose taken */
	uint32_t cam_taken, cam_gated, cam_too_old;
	float wheel_scale[4]; /* learnt scale error k_j per wheel (ground = r w_j (1 + k_j)) */
	float slip_model[4];  /* each wheel's reading minus the model's prediction, averaged,
	                       * signed along its force (> 0: running ahead) [m/s] */
	float slip_camera[3]; /* the wheels' velocity minus the camera's over the last baseline,
	                       * v, vn, d w, in the camera's sigmas over that baseline */
};

/* The kinds of late measurement (est_replay.h) a past tick can hold. */
#define EST_LATE_NONE 0
#define EST_LATE_POSE 1 /* a camera pose x, y [m], theta [rad] */

/* One past tick as the replay of late measurements needs it (private). */
struct est_tick {
	int64_t utime;
	float volts[4];
	float wheel[4];  /* wheel linear speeds [m/s] */
	float late_z[3]; /* the late measurement taken at this tick (late: its EST_LATE_ kind) */
	uint8_t driven, have_wheels, late;
	uint8_t untrusted; /* wheels flagged SLIP at the tick before (bit j: wheel j): left out */
};

/* A cross-covariance below this is zero [the state's units squared]: against the smallest
 * variances the filter keeps (the velocities' per-tick process noise, about 1e-6) a correlation
 * of 1e-9, below float's resolution; and the products of two kept terms stay far above float's
 * subnormals (1.2e-38), whose arithmetic costs about a hundred cycles an operation on many FPUs. */
#define EST_COV_TINY 1e-15f
#define EST_SNAP_EVERY 8 /* a state + covariance snapshot before every 8th tick */
/* A late measurement's re-run of the ticks since it is spread over the following ticks, this
 * many a tick (est_replay.h): about a seventh of the lag is made up each tick, and no tick pays
 * the whole replay (40 ticks behind a 40 ms camera). */
#define EST_REPLAY_PER_TICK 8

/* Slip on every wheel (est_slip.c): the camera frames kept to compare the wheels' distance
 * with the body's, the oldest still in the ring of ticks taken as the baseline. */
#define EST_SLIP_FRAMES 6

struct est_slip {
	/* private: see est_slip.c */
	float nu_avg[4]; /* each wheel's reading minus the model's prediction, averaged [m/s] */
	int model_run[4];
	uint32_t frame_tick[EST_SLIP_FRAMES];
	float frame_z[EST_SLIP_FRAMES][3];
	int frames;         /* frames kept (at most EST_SLIP_FRAMES), the newest last */
	uint8_t cam_run[3]; /* camera comparisons in a row beyond the threshold, per axis */
	uint8_t cam_bits;   /* the wheels the last comparison named (bit j: wheel j) */
	int64_t cam_us;     /* capture time of the last comparison */
	int8_t null_wheel;  /* the wheel the null space left out this tick, or -1 */
};

struct est {
	/* private: see est.c, est_replay.c, est_cal.c */
	struct est_settings set;
	float phi[3], gam[3];     /* per-tick velocity transition and input gain, bridges on */
	float phic[3], gamc[3];   /* the same with the bridges off (A_coast) */
	float B[3][4], C[3];      /* eq 26 B; Coulomb levels -K (>= 0) */
	struct wheel_phys_f32 wh; /* the wheels (wheels.h): eq 2's rows, back-EMF per rim speed */
	float q[3];               /* process variance per tick on v, vn, w */
	float rw[3];              /* wheel reading variance mapped onto v, vn, w */
	float rc[3];              /* camera variance x, y, theta */
	float qt;                 /* heading variance per tick from EST_DRIFT_THETA */
	float qo[2];              /* odometry variance per tick per m/s: position, heading */
	float
	    Ax[4]; /* eq 23's off-diagonal A, unequal wheels: A[0][2], A[1][2], A[2][0], A[2][1] */
	bool coupled; /* any Ax != 0 */
	/* A layout other than the paper's (est_set_model_wheels' g; docs/estimator.md, "Other
	 * wheel layouts"): the coupled prediction, one scalar update per wheel, its null vector. */
	bool layout;
	float Ao[3][3];   /* eq 23's A less its diagonal (dyn_state_space_layout) [1/s] */
	float Dv[3][3];   /* per tick: gam_k Ao[k][l], the velocity block of F less diag(phi) */
	float nvec[4];    /* the null vector of G^T (four wheels; |n| = 2, the paper's
	                   * (1, -1, 1, -1)); three wheels: 0 */
	uint8_t carry[3]; /* the wheels that carry v, vn (bit j: |row_j| >= 0.5 on it), w (all) */
	float d, dt;
	float r[4]; /* each wheel's radius */
	float s[6], P[6][6];
	float cal[4];             /* the wheels' scale errors in force (EST_CAL_*, est_cal.c) */
	float cal_A[6], cal_b[3]; /* the calibration's normal equations (upper triangle) */
	float cal_forget;         /* per tick */
	struct est_output out;
	struct est_tick hist[EST_HISTORY]; /* est_replay.c */
	struct {
		float s[6], P[21]; /* upper triangle, row by row */
	} snap[EST_HISTORY / EST_SNAP_EVERY];
	struct {
		bool on;    /* a re-run is under way: s, P are the corrected state at tick n */
		uint32_t n; /* the next tick it re-runs */
		float s[6], P[6][6];
	} job; /* est_replay.c */
	uint32_t
	    replay_per_tick; /* ticks re-run a live tick (EST_REPLAY_PER_TICK; 0: all at once) */
	uint32_t seq;        /* ticks since init/reset: the next tick's number */
	int64_t clock_ns;    /* the periods predicted so far, as a time [ns]: a period a step */
	float innov_avg[3];  /* the velocity innovation averaged (EST_INNOV_AVG_TICKS) */
	int slip_run, collision_run, cam_gate_run;
	struct est_slip slip; /* est_slip.c */
	int64_t last_cam_us;  /* capture time of the last camera pose taken */
	bool have_cam;
	/* Another layout's four wheels (est_slip_rows): the readings whitened, three scalar updates
	 * for four. G^T G = U^T U (Cholesky, U upper triangular [1, 1, m]), y = W wheels with
	 * W = U^-T G^T: y = U (v, vn, w) + noise of variance wheel_noise^2 on each. white: U (wu)
	 * and W (ww) hold them. Last in the struct: the fields the tick reads most keep their
	 * short offsets. */
	bool white;
	float wu[3][3], ww[3][4];
};

/* The default noise and thresholds (the paper's camera, 1 kHz wheels). */
void est_settings_defaults(struct est_settings *s);
/* 0, or -EINVAL if a noise, gate or threshold is not > 0 (or not below 1e6) or ticks < 1. */
int est_settings_check(const struct est_settings *s);
/* The INI's settings ([estimator], est_keys.def) as the filter's floats. */
void est_settings_from_keys(const struct est_keys *k, struct est_settings *s);
/* Between two ticks: new noise figures and thresholds (the covariance and state stay). 0, or
 * -EINVAL (est_settings_check; the settings in force stay). */
int est_set_settings(struct est *e, const struct est_settings *s);
/* Start at the origin, at rest, with a wide pose covariance. s NULL: the defaults. -EINVAL for a
 * bad model or rate, or settings with a noise, gate or threshold not > 0 or ticks < 1. */
int est_init(struct est *e, const struct est_settings *s, const struct model_params *p,
             double rate_hz);
/* Between two ticks: the model in force changed (four equal wheels: p's r, Kv, Kt, R). */
void est_set_model(struct est *e, const struct model_params *p);
/* The same with each wheel's own r, Kv, Kt, R (w; dynamics.h): the prediction with each wheel's
 * gain and the back-EMF coupling of unequal wheels, each reading with its wheel's radius. p and w
 * are checked (MODEL_ASSERT_CHECKED: the caller's door, ctl_settings_check). g: the wheels'
 * layout (wheels.h; ctl_settings_geom); NULL or the paper's rows (wheel_geom_paper at p's d):
 * the paper's closed forms, to the last bit. Another layout (three or four wheels): eq 23's
 * full coupled A and B, one scalar update per wheel reading, the layout's null vector
 * (docs/estimator.md, "Other wheel layouts"); a layout wheel_phys_init refuses is ignored (the
 * model in force stays). A three-wheel robot's slot 3 reads 0. */
void est_set_model_wheels(struct est *e, const struct model_params *p, const struct model_wheels *w,
                          const struct wheel_geom *g);
/* Start again at pose (x, y, theta) with the pose's covariance diag (m^2, m^2, rad^2). */
void est_reset(struct est *e, const float pose[3], const float pose_var[3]);
/* Fast loop, once per tick. A tick that comes two or more periods after the periods predicted
 * so far (in->utime; a wake-up's jitter is not a missed period) first predicts the periods
 * missed, without a reading (up to EST_CATCH_UP). */
void est_step(struct est *e, const struct est_input *in);
/* Fast loop, between ticks: a camera pose captured at capture_us, now_us = the current tick's
 * time. 0 taken; -ERANGE older than the history (counted); -EINVAL gated or not finite
 * (counted). */
int est_camera(struct est *e, int64_t capture_us, const double pose[3], int64_t now_us);
static inline const struct est_output *est_get(const struct est *e)
{
	return &e->out;
}

#endif /* OMNI4_EST_H */
