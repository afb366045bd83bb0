/*
 * vesc_proto.h - the VESC motor controller's single-frame CAN messages: pure encode/decode, no
 * I/O, no allocation, no OS (builds for a microcontroller too). Every frame is described in
 * drivers/can/vesc.dbc (written for controller ID 0); docs/can-drives.md lists them.
 *
 * Source: the VESC firmware's CAN document, "VESC CAN-Bus Communication"
 * (https://github.com/vedderb/bldc/blob/master/documentation/comm_can.md), and for the command
 * IDs and the fault codes the firmware's datatypes.h (enums CAN_PACKET_ID, mc_fault_code).
 *
 * Frames: 29-bit extended IDs, ID = command << 8 | controller ID (bits 28-16 unused, 0);
 * controller ID 255 addresses every controller. Payloads are big-endian signed integers with a
 * scale (value = raw / scale):
 *   cmd  0 SET_DUTY           4 bytes  int32 duty x 100000        [-1, 1]
 *   cmd  1 SET_CURRENT        4 bytes  int32 motor current x 1000 [A]
 *   cmd  2 SET_CURRENT_BRAKE  4 bytes  int32 brake current x 1000 [A]
 *   cmd  3 SET_RPM            4 bytes  int32 electrical RPM x 1 (the document says "RPM"; the
 *                                      firmware's speed loop and STATUS_1 both use ERPM)
 *   cmd  9 STATUS_1           8 bytes  int32 ERPM, int16 current x 10 [A], int16 duty x 1000
 *   cmd 16 STATUS_4           8 bytes  int16 FET temp x 10 [degC], int16 motor temp x 10 [degC],
 *                                      int16 input current x 10 [A], int16 PID pos x 50 [deg]
 *   cmd 27 STATUS_5           8 bytes  int32 tachometer [steps, 6 per electrical revolution],
 *                                      int16 input voltage x 10 [V], 2 bytes reserved (0)
 *   cmd  8 PROCESS_SHORT_BUFFER a command packet of the firmware's serial protocol
 *                              (commands.c) in one frame: byte 0 the sender's id (where a reply
 *                              goes), byte 1 what to do with it (0: process and reply), then the
 *                              packet (at most 6 bytes). The reply comes back the same way,
 *                              addressed to that sender id, byte 1 = 1 (a reply: pass it on).
 * The controller stops the motor when no command came for its timeout (0.5 s by default):
 * commands are meant to be repeated at a fixed rate. No status frame carries the fault code
 * (mc_fault_code): it is asked for with COMM_GET_VALUES_SELECTIVE (packet id 50, a big-endian
 * uint32 mask of the values wanted; bit 15 the fault code, one byte) in a PROCESS_SHORT_BUFFER,
 * whose reply is packet id, the mask, then the selected values in bit order: with bit 15 alone
 * [50, 00 00 80 00, code], 6 bytes, one frame.
 *
 * Calling context: every function is pure and bounded (a few dozen instructions); safe in the
 * fast loop and in an interrupt handler, never blocks. Encoders reject a non-finite value with
 * -EINVAL and saturate a finite one to the field's range: duty to [-1, 1] (the document's range),
 * the others to the int32 field. Values are rounded to the nearest LSB (the document's example
 * code truncates toward zero: the two differ by less than one LSB). Decoders return -EINVAL for
 * a frame that is not the message asked for (standard ID, RTR, other command, bits 28-16 set,
 * other length) and leave the outputs untouched then.
 */
#ifndef OMNI4_VESC_PROTO_H
#define OMNI4_VESC_PROTO_H

#include <stdint.h>

#include "omni4/drivers/can_proto.h"

enum vesc_cmd {
	VESC_CMD_SET_DUTY = 0,
	VESC_CMD_SET_CURRENT = 1,
	VESC_CMD_SET_CURRENT_BRAKE = 2,
	VESC_CMD_SET_RPM = 3,
	VESC_CMD_PROCESS_SHORT_BUFFER = 8,
	VESC_CMD_STATUS_1 = 9,
	VESC_CMD_STATUS_4 = 16,
	VESC_CMD_STATUS_5 = 27,
};

#define VESC_ID_BROADCAST 255u
/* The frame ID (with OMNI4_CAN_EFF_FLAG) of a command for a controller. */
#define VESC_CAN_ID(cmd, controller)                                                               \
	(OMNI4_CAN_EFF_FLAG | ((uint32_t)(cmd) << 8) | ((uint32_t)(controller) & 0xFFu))

/* PROCESS_SHORT_BUFFER's byte 1: process the packet and send the reply to the sender id; the
 * mark of a reply. */
#define VESC_BUFFER_PROCESS 0u
#define VESC_BUFFER_REPLY 1u
/* The serial protocol's packet COMM_GET_VALUES_SELECTIVE and its mask bit of the fault code. */
#define VESC_COMM_GET_VALUES_SELECTIVE 50u
#define VESC_VALUES_FAULT_CODE (1u << 15)

/* Scales: physical value = raw / scale. */
#define VESC_SCALE_DUTY 100000.0f
#define VESC_SCALE_CURRENT 1000.0f
#define VESC_SCALE_STATUS_CURRENT 10.0f
#define VESC_SCALE_STATUS_DUTY 1000.0f
#define VESC_SCALE_TEMP 10.0f
#define VESC_SCALE_PID_POS 50.0f
#define VESC_SCALE_VOLTAGE 10.0f
#define VESC_TACHO_STEPS_PER_EREV 6

struct vesc_status1 {
	int32_t erpm;    /* electrical RPM (mechanical RPM x pole pairs) */
	float current_a; /* motor current [A], 0.1 A steps */
	float duty;      /* duty cycle [-1, 1], 0.001 steps */
};

struct vesc_status4 {
	float temp_fet_c;   /* [degC], 0.1 steps */
	float temp_motor_c; /* [degC], 0.1 steps */
	float current_in_a; /* input (battery) current [A], 0.1 steps */
	float pid_pos_deg;  /* position loop's angle [deg], 0.02 steps */
};

struct vesc_status5 {
	int32_t tacho_steps; /* VESC_TACHO_STEPS_PER_EREV per electrical revolution */
	float input_v;       /* input voltage [V], 0.1 steps */
};

/* Commands (controller -> drive). */
int vesc_encode_set_duty(uint8_t controller, float duty, struct omni4_can_frame *f);
int vesc_encode_set_current(uint8_t controller, float current_a, struct omni4_can_frame *f);
int vesc_encode_set_current_brake(uint8_t controller, float current_a, struct omni4_can_frame *f);
int vesc_encode_set_rpm(uint8_t controller, float erpm, struct omni4_can_frame *f);

/* A command's value and the controller it addresses (the drive's side, e.g. a simulated drive):
 * duty, current [A] or ERPM by cmd. -EINVAL for any other frame. */
int vesc_decode_command(const struct omni4_can_frame *f, enum vesc_cmd cmd, uint8_t *controller,
                        float *value);

/* Status (drive -> controller). Encoders saturate each field to its integer range. */
int vesc_encode_status1(uint8_t controller, const struct vesc_status1 *s,
                        struct omni4_can_frame *f);
int vesc_encode_status4(uint8_t controller, const struct vesc_status4 *s,
                        struct omni4_can_frame *f);
int vesc_encode_status5(uint8_t controller, const struct vesc_status5 *s,
                        struct omni4_can_frame *f);
int vesc_decode_status1(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status1 *s);
int vesc_decode_status4(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status4 *s);
int vesc_decode_status5(const struct omni4_can_frame *f, uint8_t *controller,
                        struct vesc_status5 *s);

/* The fault code request (host -> controller): PROCESS_SHORT_BUFFER to `controller`, 7 bytes
 * [host, VESC_BUFFER_PROCESS, 50, 00 00 80 00]; the reply goes to `host`. -EINVAL if the two
 * are equal or either is the broadcast id. */
int vesc_encode_fault_request(uint8_t controller, uint8_t host, struct omni4_can_frame *f);
/* Its reply (controller -> host): PROCESS_SHORT_BUFFER to `host`, 8 bytes [controller,
 * VESC_BUFFER_REPLY, 50, 00 00 80 00, code]. The controller that answered and its
 * mc_fault_code; -EINVAL for any other frame (another address, length, packet or mask). */
int vesc_decode_fault_reply(const struct omni4_can_frame *f, uint8_t host, uint8_t *controller,
                            uint8_t *code);

/* mc_fault_code (datatypes.h): value, our short name. */
#define VESC_FAULTS(X)                                                                             \
	X(0, "none")                                                                               \
	X(1, "over_voltage")                                                                       \
	X(2, "under_voltage")                                                                      \
	X(3, "drv")                                                                                \
	X(4, "abs_over_current")                                                                   \
	X(5, "over_temp_fet")                                                                      \
	X(6, "over_temp_motor")                                                                    \
	X(7, "gate_driver_over_voltage")                                                           \
	X(8, "gate_driver_under_voltage")                                                          \
	X(9, "mcu_under_voltage")                                                                  \
	X(10, "booting_from_watchdog_reset")                                                       \
	X(11, "encoder_spi")                                                                       \
	X(12, "encoder_sincos_below_min_amplitude")                                                \
	X(13, "encoder_sincos_above_max_amplitude")                                                \
	X(14, "flash_corruption")                                                                  \
	X(15, "high_offset_current_sensor_1")                                                      \
	X(16, "high_offset_current_sensor_2")                                                      \
	X(17, "high_offset_current_sensor_3")                                                      \
	X(18, "unbalanced_currents")                                                               \
	X(19, "brk")                                                                               \
	X(20, "resolver_lot")                                                                      \
	X(21, "resolver_dos")                                                                      \
	X(22, "resolver_los")                                                                      \
	X(23, "flash_corruption_app_cfg")                                                          \
	X(24, "flash_corruption_mc_cfg")                                                           \
	X(25, "encoder_no_magnet")                                                                 \
	X(26, "encoder_magnet_too_strong")                                                         \
	X(27, "phase_filter")                                                                      \
	X(28, "encoder_fault")                                                                     \
	X(29, "lv_output_fault")                                                                   \
	X(30, "encoder_slip")                                                                      \
	X(31, "overspeed")                                                                         \
	X(32, "underspeed")                                                                        \
	X(33, "abs_overspeed")

/* The name of an mc_fault_code value; "unknown" for a value not in the table. */
const char *vesc_fault_name(uint32_t code);

#endif /* OMNI4_VESC_PROTO_H */
