/*
 * robot.h - the one place a robot is built from its settings: the motor and line backends
 * chosen by their enums (backends.h), the controller (fw) on them, the backend's parameter
 * hooks (the CAN plausibility limits follow the model and the limits), and the simulated
 * camera as the pose source of a sim robot. omni4-fw, the lockstep simulator (sil/), the
 * latency benchmark and the microcontroller image all build their robot here.
 *
 * Generic over backends.def: its rows give the robot's storage, the settings in robot_spec and
 * the openers (struct robot_backend). Portable: on a microcontroller (no OMNI4_ROBOT_LINUX) only
 * the rows with os ANY exist; a value naming another backend is refused with the reason.
 */
#ifndef OMNI4_ROBOT_H
#define OMNI4_ROBOT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/drivers/backend_states.h"
#include "omni4/core/ctl_settings.h"
#include "omni4/core/fw.h"

/* What a robot is built from. The settings are read while robot_open runs, not kept. */
struct robot_spec {
	const struct ctl_settings *ctl;
	enum omni4_motor_backend motor;
	enum omni4_lines_backend lines;
	/* Each backend's settings by its member (backends.def: .sim, .can, .gpio); the chosen
	 * backends' must be set. */
#define ROBOT_SPEC_SETTINGS(member, settings) const struct settings *member;
	OMNI4_BACKEND_SETTINGS(ROBOT_SPEC_SETTINGS)
#undef ROBOT_SPEC_SETTINGS
	/* motor = SIM: sim_exact: ideal sensors instead of the settings' noise and faults; plant:
	 * the simulated robot (NULL: the controller's own model); utime0: controller time [us] of
	 * the first tick (camera timestamps). */
	bool sim_exact;
	const struct model_params *plant;
	int64_t utime0;
	/* Optional: the motor backend as the controller sees it, e.g. a guard around it; NULL =
	 * the backend itself. Called once, with the opened backend. */
	struct motor_hal (*wrap)(void *ctx, struct motor_hal backend);
	void *wrap_ctx;
};

struct robot;

/* A backend's code as the robot uses it: robot_backend_<member> for each row of backends.def
 * (in its own file, firmware/src/robot_<...>.c). */
struct robot_backend {
	/* Open the backend in r's storage and set r->motor or r->lines. 0, or -1 with the reason
	 * in why (nothing left open). */
	int (*open)(struct robot *r, const struct robot_spec *spec, char *why, size_t n);
	/* Optional: once the controller runs on it (parameter hooks, the clock). */
	void (*started)(struct robot *r, const struct robot_spec *spec);
	/* Optional: robot_sim_follow_clock's work (loop thread, before fw_tick). */
	void (*follow_clock)(struct robot *r, int64_t now_us);
	/* Optional: its counters for a person, after the loop has stopped (Linux: stderr). */
	void (*summary)(const struct robot *r);
};

#define ROBOT_BACKEND_DECLARE(hal, name, word, keys, member, settings, state, header, os, ...)     \
	BACKEND_OS_##os(extern const struct robot_backend robot_backend_##member;)
#define OMNI4_BACKEND ROBOT_BACKEND_DECLARE
#include OMNI4_BACKENDS_DEF

/* The state of each HAL's backend, one member per row (backends.def), e.g. sim, can, sim_lines. */
#define ROBOT_STATE(hal, name, word, keys, member, settings, state, header, os, ...)               \
	BACKEND_OS_##os(struct state member;)

struct robot {
	struct fw fw;
	struct motor_hal motor; /* the backend as opened (fw.motor may wrap it) */
	struct line_hal lines;
	enum omni4_motor_backend motor_kind;
	const struct robot_backend *motor_backend, *lines_backend; /* as opened */
	union {
#define OMNI4_BACKEND(hal, ...) BACKEND_MOTOR_##hal(ROBOT_STATE(hal, __VA_ARGS__))
#include OMNI4_BACKENDS_DEF
	};
	union {
#define OMNI4_BACKEND(hal, ...) BACKEND_LINES_##hal(ROBOT_STATE(hal, __VA_ARGS__))
#include OMNI4_BACKENDS_DEF
	};
};

/* Open the backends of spec and start the controller on them (outputs off). 0, or -1 with the
 * reason in why (nothing left open). r may be large (the log ring): static or heap. */
int robot_open(struct robot *r, const struct robot_spec *spec, char *why, size_t n);
/* Outputs off, backends closed. */
void robot_close(struct robot *r);

/* The motor and lines backends' summaries (their counters), if they have one. */
void robot_summary(const struct robot *r);

/* Loop thread, before fw_tick, in a loop paced by a clock (omni4-fw): the sim backend's plant
 * keeps up with the loop's clock now_us (the tick's time) as a real robot's physics does: a
 * late or skipped tick advances it the periods it missed under the last voltages (up to
 * ROBOT_SIM_CATCH_UP_MAX; a longer stall, e.g. a stopped process, is skipped over), and its
 * camera and truth stamps follow the clock, so the log's times and the plant agree on a loaded
 * machine too. Nothing for other backends. The lockstep simulator's clock is the sim's own:
 * not needed. */
#define ROBOT_SIM_CATCH_UP_MAX 500 /* periods (0.5 s at 1 kHz) */
void robot_sim_follow_clock(struct robot *r, int64_t now_us);

#endif /* OMNI4_ROBOT_H */
