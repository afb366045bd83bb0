/*
 * odrive_proto.h - the ODrive "CANSimple" protocol, the messages a wheel drive needs: pure
 * encode/decode, no I/O, no allocation, no OS. Every frame is described in drivers/can/odrive.dbc
 * (written for node ID 0); docs/can-drives.md lists them.
 *
 * Sources: ODrive's "CAN Protocol" page for firmware 0.6
 * (https://docs.odriverobotics.com/v/latest/manual/can-protocol.html) and, for the ODrive v3
 * firmware 0.5, docs/can-protocol.rst with docs/figures/can-protocol.csv in
 * https://github.com/odriverobotics/ODrive. Where the two differ this file follows 0.6 and says so.
 *
 * Frames: 11-bit standard IDs, ID = node ID << 5 | command ID (node 0..63). Multi-byte values
 * little-endian, floats IEEE 754 binary32. Positions in turns, speeds in turns/s, torques in Nm.
 *   0x01 Heartbeat               drive -> host  u32 axis error (ODRIVE_ERRORS), u8 axis state,
 *                                               u8 procedure result, u8 trajectory done (bit 0)
 *                                               [0.5 firmware: bytes 5-7 are error flags instead]
 *   0x02 Estop                   host -> drive  no data
 *   0x07 Set_Axis_State          host -> drive  u32 requested state
 *   0x09 Get_Encoder_Estimates   drive -> host  f32 position [turn], f32 velocity [turn/s]
 *   0x0B Set_Controller_Mode     host -> drive  u32 control mode, u32 input mode
 *   0x0D Set_Input_Vel           host -> drive  f32 velocity [turn/s], f32 torque feed-forward [Nm]
 *   0x0E Set_Input_Torque        host -> drive  f32 torque [Nm]
 *   0x14 Get_Iq                  drive -> host  f32 Iq setpoint [A], f32 Iq measured [A]
 *   0x17 Get_Bus_Voltage_Current drive -> host  f32 bus voltage [V], f32 bus current [A]
 *   0x18 Clear_Errors            host -> drive  u8 identify (0; 0.6 only, 0.5 ignores the byte)
 * Get_ messages come cyclically (rates set on the drive) or answer a remote frame (RTR) of the
 * same ID: odrive_encode_request. Data frames that carry fewer than 8 bytes of signals are sent
 * with DLC 8 and zeros, as the vendor's DBC declares them (Estop: 0 bytes, Clear_Errors: 1).
 *
 * Calling context: every function is pure and bounded; safe in the fast loop, never blocks.
 * Encoders: -EINVAL for a node above 63, a non-finite float or a mode/state not in the tables
 * below. A finite float is always inside its float32 field: nothing saturates here, the drive
 * applies its own limits (vel_limit, current limit). Decoders: -EINVAL for a frame that is not
 * the message asked for (extended ID, RTR, other command, too short) and leave the outputs
 * untouched then; decoded floats may be NaN or infinite as the drive sent them (e.g. no encoder
 * estimate yet): the caller decides.
 */
#ifndef OMNI4_ODRIVE_PROTO_H
#define OMNI4_ODRIVE_PROTO_H

#include <stdbool.h>
#include <stdint.h>

#include "omni4/drivers/can_proto.h"

enum odrive_cmd {
	ODRIVE_CMD_HEARTBEAT = 0x01,
	ODRIVE_CMD_ESTOP = 0x02,
	ODRIVE_CMD_SET_AXIS_STATE = 0x07,
	ODRIVE_CMD_GET_ENCODER_ESTIMATES = 0x09,
	ODRIVE_CMD_SET_CONTROLLER_MODE = 0x0B,
	ODRIVE_CMD_SET_INPUT_VEL = 0x0D,
	ODRIVE_CMD_SET_INPUT_TORQUE = 0x0E,
	ODRIVE_CMD_GET_IQ = 0x14,
	ODRIVE_CMD_GET_BUS_VOLTAGE_CURRENT = 0x17,
	ODRIVE_CMD_CLEAR_ERRORS = 0x18,
};

#define ODRIVE_NODE_MAX 63u
#define ODRIVE_CAN_ID(node, cmd) (((uint32_t)(node) << 5) | (uint32_t)(cmd))

/* Axis states (Axis_Requested_State, heartbeat's Axis_State): value, name. */
#define ODRIVE_AXIS_STATES(X)                                                                      \
	X(0, "undefined")                                                                          \
	X(1, "idle")                                                                               \
	X(2, "startup_sequence")                                                                   \
	X(3, "full_calibration_sequence")                                                          \
	X(4, "motor_calibration")                                                                  \
	X(5, "sensorless_control")                                                                 \
	X(6, "encoder_index_search")                                                               \
	X(7, "encoder_offset_calibration")                                                         \
	X(8, "closed_loop_control")                                                                \
	X(9, "lockin_spin")                                                                        \
	X(10, "encoder_dir_find")                                                                  \
	X(11, "homing")                                                                            \
	X(12, "encoder_hall_polarity_calibration")                                                 \
	X(13, "encoder_hall_phase_calibration")                                                    \
	X(14, "anticogging_calibration")
#define ODRIVE_AXIS_STATE_IDLE 1u
#define ODRIVE_AXIS_STATE_CLOSED_LOOP 8u
#define ODRIVE_AXIS_STATE_MAX 14u

/* Control modes and input modes (Set_Controller_Mode). */
enum odrive_control_mode {
	ODRIVE_CONTROL_VOLTAGE = 0,
	ODRIVE_CONTROL_TORQUE = 1,
	ODRIVE_CONTROL_VELOCITY = 2,
	ODRIVE_CONTROL_POSITION = 3,
};
enum odrive_input_mode {
	ODRIVE_INPUT_INACTIVE = 0,
	ODRIVE_INPUT_PASSTHROUGH = 1,
	ODRIVE_INPUT_VEL_RAMP = 2,
	ODRIVE_INPUT_POS_FILTER = 3,
	ODRIVE_INPUT_MIX_CHANNELS = 4,
	ODRIVE_INPUT_TRAP_TRAJ = 5,
	ODRIVE_INPUT_TORQUE_RAMP = 6,
	ODRIVE_INPUT_MIRROR = 7,
	ODRIVE_INPUT_TUNING = 8,
};

/* Axis error bits of firmware 0.6 (ODriveError; heartbeat bytes 0-3): bit value, name. The 0.5
 * firmware's AxisError bits mean other things (docs/can-drives.md). */
#define ODRIVE_ERRORS(X)                                                                           \
	X(0x00000001u, "initializing")                                                             \
	X(0x00000002u, "system_level")                                                             \
	X(0x00000004u, "timing_error")                                                             \
	X(0x00000008u, "missing_estimate")                                                         \
	X(0x00000010u, "bad_config")                                                               \
	X(0x00000020u, "drv_fault")                                                                \
	X(0x00000040u, "missing_input")                                                            \
	X(0x00000100u, "dc_bus_over_voltage")                                                      \
	X(0x00000200u, "dc_bus_under_voltage")                                                     \
	X(0x00000400u, "dc_bus_over_current")                                                      \
	X(0x00000800u, "dc_bus_over_regen_current")                                                \
	X(0x00001000u, "current_limit_violation")                                                  \
	X(0x00002000u, "motor_over_temp")                                                          \
	X(0x00004000u, "inverter_over_temp")                                                       \
	X(0x00008000u, "velocity_limit_violation")                                                 \
	X(0x00010000u, "position_limit_violation")                                                 \
	X(0x01000000u, "watchdog_timer_expired")                                                   \
	X(0x02000000u, "estop_requested")                                                          \
	X(0x04000000u, "spinout_detected")                                                         \
	X(0x08000000u, "brake_resistor_disarmed")                                                  \
	X(0x10000000u, "thermistor_disconnected")                                                  \
	X(0x40000000u, "calibration_error")

struct odrive_heartbeat {
	uint32_t axis_error;      /* ODRIVE_ERRORS bits */
	uint8_t axis_state;       /* ODRIVE_AXIS_STATES */
	uint8_t procedure_result; /* 0 success, 1 busy, ... (0.6) */
	bool trajectory_done;
};

struct odrive_encoder_estimates {
	float pos_turn;   /* [turn] */
	float vel_turn_s; /* [turn/s] */
};

struct odrive_iq {
	float setpoint_a; /* [A] */
	float measured_a; /* [A] */
};

struct odrive_bus {
	float voltage_v; /* [V] */
	float current_a; /* [A], positive drawn from the supply */
};

/* Host -> drive. */
int odrive_encode_estop(uint8_t node, struct omni4_can_frame *f);
int odrive_encode_set_axis_state(uint8_t node, uint32_t state, struct omni4_can_frame *f);
int odrive_encode_set_controller_mode(uint8_t node, enum odrive_control_mode control,
                                      enum odrive_input_mode input, struct omni4_can_frame *f);
int odrive_encode_set_input_vel(uint8_t node, float vel_turn_s, float torque_ff_nm,
                                struct omni4_can_frame *f);
int odrive_encode_set_input_torque(uint8_t node, float torque_nm, struct omni4_can_frame *f);
int odrive_encode_clear_errors(uint8_t node, struct omni4_can_frame *f);
/* A remote frame asking for a Get_ message (encoder estimates, Iq, bus voltage/current). */
int odrive_encode_request(uint8_t node, enum odrive_cmd cmd, struct omni4_can_frame *f);

/* The node and command of any standard frame (data or remote); -EINVAL for an extended one. */
int odrive_split_id(const struct omni4_can_frame *f, uint8_t *node, uint8_t *cmd);

/* The drive's side (a simulated drive): the commands' values. */
int odrive_decode_set_axis_state(const struct omni4_can_frame *f, uint8_t *node, uint32_t *state);
int odrive_decode_set_controller_mode(const struct omni4_can_frame *f, uint8_t *node,
                                      uint32_t *control, uint32_t *input);
int odrive_decode_set_input_vel(const struct omni4_can_frame *f, uint8_t *node, float *vel_turn_s,
                                float *torque_ff_nm);
int odrive_decode_set_input_torque(const struct omni4_can_frame *f, uint8_t *node,
                                   float *torque_nm);

/* Drive -> host. */
int odrive_encode_heartbeat(uint8_t node, const struct odrive_heartbeat *h,
                            struct omni4_can_frame *f);
int odrive_encode_encoder_estimates(uint8_t node, const struct odrive_encoder_estimates *e,
                                    struct omni4_can_frame *f);
int odrive_encode_iq(uint8_t node, const struct odrive_iq *q, struct omni4_can_frame *f);
int odrive_encode_bus(uint8_t node, const struct odrive_bus *b, struct omni4_can_frame *f);
int odrive_decode_heartbeat(const struct omni4_can_frame *f, uint8_t *node,
                            struct odrive_heartbeat *h);
int odrive_decode_encoder_estimates(const struct omni4_can_frame *f, uint8_t *node,
                                    struct odrive_encoder_estimates *e);
int odrive_decode_iq(const struct omni4_can_frame *f, uint8_t *node, struct odrive_iq *q);
int odrive_decode_bus(const struct omni4_can_frame *f, uint8_t *node, struct odrive_bus *b);

/* Name of one error bit (a value with a single bit set); "unknown" for any other value. */
const char *odrive_error_name(uint32_t bit);
/* Name of an axis state; "unknown" outside the table. */
const char *odrive_axis_state_name(uint32_t state);

#endif /* OMNI4_ODRIVE_PROTO_H */
