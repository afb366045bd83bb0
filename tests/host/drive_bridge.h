/* drive_bridge.h - drive_lockstep's controller side in plain C types (the backends' headers use
 * C11 atomics, which C++ does not parse): the motor HAL the controller drives is omni4-fw's vesc
 * or odrive backend ([hal] motor) on a CAN socket (sc_os, wrapped at link time) that is a queue
 * each way with the kernel's receive filters; in front of the simulated robot's plant (the sim
 * backend, kept for its camera and truth), the caller's simulated drives take the frames, step
 * the plant through drive_bridge_step_plant and hand their frames back. One bridge per
 * process (the wrapped socket is). */
#ifndef OMNI4_DRIVE_BRIDGE_H
#define OMNI4_DRIVE_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>

#include "omni4/drivers/can_proto.h"

#ifdef __cplusplus
extern "C" {
#endif

struct omni4_config;
struct motor_hal;
struct plant;

/* The drives' period ending at t_s + dt_s: the frames the controller sent since the last one
 * (n of them) in, drive_bridge_step_plant once, drive_bridge_deliver for each frame out. */
typedef void (*drive_bridge_advance_fn)(void *ctx, double t_s, double dt_s,
                                        const struct omni4_can_frame *in, int n);

/* Before simrun_create_wrapped: the backend of cfg ([hal] motor vesc or odrive, its section's
 * settings, the model's drive constants) and the drives' side. 0, or -1 with the reason in
 * why. */
int drive_bridge_setup(const struct omni4_config *cfg, drive_bridge_advance_fn advance, void *ctx,
                       char *why, size_t n);
/* simrun_create_wrapped's wrap (ctx unused): opens the backend on the queues and returns the
 * HAL the controller drives: enable, write, clear_faults, halt the backend's; read the drives'
 * period (the plant's step) and then the backend's read; read_pose, read_truth the sim
 * backend's. If the backend does not open, the sim backend (the reason: drive_bridge_error). */
struct motor_hal drive_bridge_wrap(void *ctx, struct motor_hal sim);
/* The open error ("" if none). */
const char *drive_bridge_error(void);
/* The simulated robot's plant (after the wrap), which the drives look at. */
struct plant *drive_bridge_plant(void);
/* One loop period of the plant under the drives' voltages u_v (driven: a bridge on), through the
 * sim backend (its camera and truth follow): its readings after the step, each motor's current
 * [A] and wheel speed [rad/s] (its current noise and encoder counts, as the main job's). */
void drive_bridge_step_plant(const double u_v[4], bool driven, double current_a[4],
                             double wheel_rad_s[4]);
/* A frame from the drives, queued for the backend if the socket's filters pass it. */
void drive_bridge_deliver(const struct omni4_can_frame *f);
/* The backend's counters and vendor fault text, one line in buf; returns buf. */
const char *drive_bridge_summary(char *buf, size_t n);
/* The backend closed (after simrun_destroy). */
void drive_bridge_close(void);

#ifdef __cplusplus
}
#endif

#endif /* OMNI4_DRIVE_BRIDGE_H */
