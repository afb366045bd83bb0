/* vesc_sag_robot.h - test_vesc_sag's controller side in plain C types (core's headers use C11
 * atomics, which C++ does not parse): omni4-fw's robot with [hal] motor = vesc, mode = duty, the
 * defaults otherwise, and the CAN socket (sc_os, wrapped at link time) as two queues with the
 * kernel's receive filters and a clock the caller sets. */
#ifndef OMNI4_VESC_SAG_ROBOT_H
#define OMNI4_VESC_SAG_ROBOT_H

#include <stddef.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"
#include "omni4/model/params.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The controller's FAULT_DRIVER bit (motors_t.faults). */
extern const int32_t sag_fault_driver;

/* The bus's queues emptied (can_queue.h: the frames each way), the clock at now_us. */
void sag_bus_reset(int64_t now_us);
void sag_bus_set_clock(int64_t now_us);

/* The controller's model (the defaults) for the plant. */
void sag_robot_model(struct model_params *out);
/* Open the robot: 0, or -1 with the reason in why. */
int sag_robot_open(char *why, size_t n);
/* One tick at now_us with a VELOCITY command v [m/s, m/s, rad/s] taken at it; the tick's
 * fault bits (motors_t.faults, OR over its samples) and whether the robot is in VELOCITY. */
void sag_robot_tick(int64_t now_us, int64_t seq, const double v[3], int32_t *faults,
                    int *in_velocity);
/* The backend's fault codes named (vesc_motor_fault_text); returns buf. */
const char *sag_robot_fault_text(char *buf, size_t n);
void sag_robot_close(void);

#ifdef __cplusplus
}
#endif

#endif /* OMNI4_VESC_SAG_ROBOT_H */
