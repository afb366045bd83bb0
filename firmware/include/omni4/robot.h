/*
 * robot.h - the one place a robot is built from its settings: the motor and line backends
 * chosen by their enums (backends.h), the controller (fw) on them, the backend's parameter
 * hooks (the CAN plausibility limits follow the model and the limits), and the simulated
 * camera as the pose source of a sim robot. omni4-fw, the lockstep simulator (sil/), the
 * latency benchmark and the microcontroller image all build their robot here.
 *
 * Portable: on a microcontroller (no OMNI4_ROBOT_LINUX) only the sim backends exist; a value
 * naming another backend is refused with the reason.
 */
#ifndef OMNI4_ROBOT_H
#define OMNI4_ROBOT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/backends.h"
#include "omni4/ctl_settings.h"
#include "omni4/fw.h"
#include "omni4/sim_motor.h"
#ifdef OMNI4_ROBOT_LINUX
#include "omni4/gpiod_lines.h"
#include "omni4/socketcan_motor.h"
#include "omni4/socketcan_settings.h"
#endif

/* What a robot is built from. The settings are read while robot_open runs, not kept. */
struct robot_spec {
	const struct ctl_settings *ctl;
	enum omni4_motor_backend motor;
	enum omni4_lines_backend lines;
	/* motor = SIM: the sensors; sim_exact: ideal sensors instead of the settings' noise and
	 * faults; plant: the simulated robot (NULL: the controller's own model); utime0:
	 * controller time [us] of the first tick (camera timestamps). */
	const struct sim_settings *sim;
	bool sim_exact;
	const struct model_params *plant;
	int64_t utime0;
#ifdef OMNI4_ROBOT_LINUX
	const struct socketcan_settings *can; /* motor = SOCKETCAN */
	const struct gpiod_settings *gpio;    /* lines = GPIOD */
#endif
	/* Optional: the motor backend as the controller sees it, e.g. a guard around it; NULL =
	 * the backend itself. Called once, with the opened backend. */
	struct motor_hal (*wrap)(void *ctx, struct motor_hal backend);
	void *wrap_ctx;
};

struct robot {
	struct fw fw;
	struct motor_hal motor; /* the backend as opened (fw.motor may wrap it) */
	struct line_hal lines;
	enum omni4_motor_backend motor_kind;
	struct sim_motor sim;
	struct sim_lines sim_lines;
#ifdef OMNI4_ROBOT_LINUX
	struct socketcan_motor can;
	struct gpiod_lines gpio;
#endif
};

/* Open the backends of spec and start the controller on them (outputs off). 0, or -1 with the
 * reason in why (nothing left open). r may be large (the log ring): static or heap. */
int robot_open(struct robot *r, const struct robot_spec *spec, char *why, size_t n);
/* Outputs off, backends closed. */
void robot_close(struct robot *r);

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
