/*
 * simrun.h - the firmware loop in lockstep with the simulated plant, as fast as the machine
 * allows (or paced by the caller), writing every message to an LCM event log.
 *
 * Per tick: commands handed in since the last tick go through the same decoding and mailbox as
 * the robot's LCM receive thread, then fw_tick runs (sim HAL read = one plant step), then the
 * log ring is drained into the event log; every SIMRUN_PLANT_PERIOD_US of simulated time the
 * plant's changing parameters follow (OMNI4_SIM_PLANT, sim_plant_t). Plain C types only:
 * usable from C++.
 */
#ifndef OMNI4_SIMRUN_H
#define OMNI4_SIMRUN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/config/config.h"
#include "omni4/core/hal.h"

#ifdef __cplusplus
extern "C" {
#endif

struct simrun;

#define SIMRUN_PLANT_PERIOD_US 100000 /* OMNI4_SIM_PLANT at 10 Hz of simulated time */

/* Events written to the log (or handed to the tap when there is none), counted per channel:
 * messages is their total, the named ones are parts of it and other the rest. */
struct simrun_stats {
	uint64_t ticks;
	uint64_t messages; /* all channels */
	uint64_t motors, pose, cmd;
	uint64_t goal, goal_status; /* OMNI4_GOAL (handed in), OMNI4_GOAL_STATUS */
	uint64_t state;             /* the controller's estimate (OMNI4_STATE) */
	uint64_t truth;             /* the plant's true state (OMNI4_SIM_TRUTH) */
	uint64_t plant;             /* the plant's changing parameters (OMNI4_SIM_PLANT) */
	uint64_t experiment;        /* marks (OMNI4_EXPERIMENT) */
	uint64_t calibrations;      /* current-offset notices (OMNI4_PARAM_CHANGED) */
	uint64_t other;             /* any other channel (simrun_publish) */
	uint64_t log_errors;        /* failed writes (never silently: the caller reports them) */
	int log_errno;              /* the first failed write's errno (ENOSPC...), 0 if none */
	uint64_t log_dropped;       /* ring overflow */
	uint64_t cmd_rejected;
	int32_t faults; /* OR of every motors_t.faults written */
	int8_t mode;    /* controller mode after the last tick */
};

/*
 * Start-up. plant_params: the simulated robot (truth); cfg: the firmware's settings and model.
 * noise = false gives exact sensors. log_path NULL = no log. cfg->sim.truth and
 * cfg->sim.estimate ([sim] truth, estimate): false leaves OMNI4_SIM_TRUTH out of the log and
 * the state estimator (OMNI4_STATE) out of the loop. On error returns NULL and puts a
 * one-line reason in err (size errlen).
 */
struct simrun *simrun_create(const struct omni4_config *cfg,
                             const struct model_params *plant_params, bool noise,
                             const char *log_path, char *err, size_t errlen);
/* The same with the controller's motor HAL handed to wrap first (robot_spec.wrap): wrap gets
 * the sim backend (the plant, its camera and truth) once, at start-up, and returns the HAL the
 * controller drives, e.g. a drive's protocol in front of that plant (tests/host/drive_lockstep).
 * wrap NULL: simrun_create. */
struct simrun *simrun_create_wrapped(const struct omni4_config *cfg,
                                     const struct model_params *plant_params, bool noise,
                                     const char *log_path,
                                     struct motor_hal (*wrap)(void *ctx, struct motor_hal sim),
                                     void *wrap_ctx, char *err, size_t errlen);
void simrun_destroy(struct simrun *sr);
/* Writes out what the log holds in memory (before reading the stats, at the end of a run): 0, or
 * a negative errno, counted as a log error. */
int simrun_flush_log(struct simrun *sr);

/* Controller clock of the next tick [us]. */
int64_t simrun_now_us(const struct simrun *sr);
double simrun_period_s(const struct simrun *sr);

/* Hand in an encoded command_t (logged on OMNI4_CMD). -EINVAL if it does not decode. */
int simrun_command(struct simrun *sr, const void *data, size_t len);
/* Hand in an encoded goal_t (logged on OMNI4_GOAL), as omni4-fw's receive thread does.
 * -EINVAL if it does not decode. */
int simrun_goal(struct simrun *sr, const void *data, size_t len);
/* Log any other message (e.g. OMNI4_EXPERIMENT marks) at the next tick's time. */
int simrun_publish(struct simrun *sr, const char *channel, const void *data, size_t len);

/* One loop tick (firmware + plant) and the log drain. */
void simrun_tick(struct simrun *sr);

void simrun_get_stats(const struct simrun *sr, struct simrun_stats *out);

/* The events written per channel, in the order each channel was first written: up to max
 * names and counts; returns how many channels there are (the names live as long as sr). The
 * counts add up to simrun_stats.messages. */
#define SIMRUN_CHANNELS_MAX 32
#define SIMRUN_CHANNEL_NAME_MAX 64
size_t simrun_channel_counts(const struct simrun *sr, const char **names, uint64_t *counts,
                             size_t max);

/* Test access: the true plant state [v, vn, w] and pose [x, y, theta]. */
void simrun_truth(const struct simrun *sr, double x[3], double pose[3]);
/* Test access: the controller's shaped velocity reference and its counters. */
void simrun_reference(const struct simrun *sr, double ref[3]);
uint64_t simrun_watchdog_trips(const struct simrun *sr);

/* Test access: press / release the simulated e-stop; inject faults via the returned struct. */
void simrun_set_estop(struct simrun *sr, bool pressed);

/* Every message the controller emits (motors_t, pose_t, state_t, ...), as encoded, also when no
 * log is written: for benchmarks and tests that score what the robot says. NULL: none. */
typedef void (*simrun_tap_fn)(void *ctx, const char *channel, int64_t utime, const void *data,
                              size_t len);
void simrun_set_tap(struct simrun *sr, simrun_tap_fn fn, void *ctx);

/* The controller's state estimate after the last tick (est.h's est_output, as a pointer to its
 * first fields: utime, pose[3], vel[3], cov[6], flags). */
struct est_output;
const struct est_output *simrun_estimate(const struct simrun *sr);
struct sim_motor_faults *simrun_faults(struct simrun *sr);
/* Test access: the firmware instance in the loop (between ticks), and the simulated plant's
 * resistances now [ohm] (sim_plant_t.R). */
struct fw;
struct fw *simrun_fw(struct simrun *sr);
void simrun_plant_resistance(const struct simrun *sr, double R_ohm[4]);
/* The simulated plant's friction scale now (its B and C over the model's; sim_plant_t). */
double simrun_plant_friction_scale(const struct simrun *sr);

#ifdef __cplusplus
}
#endif

#endif /* OMNI4_SIMRUN_H */
