// odrive_sim.hpp - four simulated ODrives, one axis each (CANSimple, "CAN Protocol" of
// docs.odriverobotics.com, firmware 0.6): 11-bit IDs node << 5 | command, little-endian,
// floats IEEE 754 binary32. Pure protocol logic as drive_sim.hpp's VESCs.
#pragma once

#include "drive_sim.hpp"

namespace motorsim
{

enum OdriveCmd : uint8_t {
	ODRIVE_HEARTBEAT = 0x01,
	ODRIVE_ESTOP = 0x02,
	ODRIVE_SET_AXIS_STATE = 0x07,
	ODRIVE_GET_ENCODER_ESTIMATES = 0x09,
	ODRIVE_SET_CONTROLLER_MODE = 0x0B,
	ODRIVE_SET_INPUT_VEL = 0x0D,
	ODRIVE_SET_INPUT_TORQUE = 0x0E,
	ODRIVE_GET_IQ = 0x14,
	ODRIVE_GET_BUS_VOLTAGE_CURRENT = 0x17,
	ODRIVE_CLEAR_ERRORS = 0x18,
};

// Axis states and control modes used here (AxisState, ControlMode of the 0.6 reference).
constexpr uint8_t ODRIVE_STATE_IDLE = 1;
constexpr uint8_t ODRIVE_STATE_CLOSED_LOOP = 8;
constexpr uint32_t ODRIVE_CONTROL_TORQUE = 1;
constexpr uint32_t ODRIVE_CONTROL_VELOCITY = 2; // the drive's default
// ODriveError bits (0.6).
constexpr uint32_t ODRIVE_ERR_DRV_FAULT = 0x20;
constexpr uint32_t ODRIVE_ERR_WATCHDOG_TIMER_EXPIRED = 0x1000000;
constexpr uint32_t ODRIVE_ERR_ESTOP_REQUESTED = 0x2000000;

struct OdriveOptions {
	int nodes[4] = {0, 1, 2, 3};
	double watchdog_s = 0.2;  // 0: off
	double heartbeat_s = 0.1; // the drive's default rates
	double encoder_s = 0.01;
	double iq_s = 0; // Get_Iq sent cyclically (iq_msg_rate_ms); 0: on request only, the default
	double vel_gain = 1.0 / 6; // velocity control's P gain [Nm/(turn/s)], the drive's default
	Fault fault;
};

struct OdriveAxis {
	uint32_t error = 0;
	uint8_t state = ODRIVE_STATE_IDLE;
	uint32_t control_mode = ODRIVE_CONTROL_VELOCITY, input_mode = 1;
	double torque_nm = 0, vel_turn_s = 0, torque_ff_nm = 0; // inputs
	double last_cmd_s = 0;                                  // watchdog
	double pos_turns = 0;                                   // motor shaft
	double iq_set_a = 0; // current set-point of the last step
	double u_v = 0;      // motor voltage of the last step
	uint32_t rtr = 0;    // bit c: a remote request for command c to answer
	double next_heartbeat_s = 0, next_encoder_s = 0, next_iq_s = 0;
};

struct OdriveSim {
	OdriveOptions o;
	Motors m;
	OdriveAxis a[4];
	double last_step_s = -1;
	bool fault_done = false;
};

void odrive_sim_init(OdriveSim &s, const OdriveOptions &o, const Motors &m);
// One received frame at t_s (data or remote); other nodes' and unknown commands are ignored.
void odrive_sim_receive(OdriveSim &s, const omni4_can_frame &f, double t_s);
// Watchdog and faults at t_s, then the voltages for the next step.
DriveOut odrive_sim_step(OdriveSim &s, double t_s, const DriveView &v);
// The answers to remote requests and the cyclic heartbeat and encoder estimates due at t_s.
void odrive_sim_emit(OdriveSim &s, double t_s, const DriveView &v, Frames &out);

} // namespace motorsim
