// drive_sim.hpp - simulated off-the-shelf drives (VESC, ODrive CANSimple) as pure protocol
// logic: a frame in changes a drive's state, a step turns the states into the voltages the
// plant gets, an emit writes the frames the drives send. No socket, no clock: the caller
// (drive_loop.cpp, the tests) passes the time in seconds.
//
// The frames are packed and unpacked here from the vendors' documents (docs/can-drives.md),
// independently of the controller's codecs (drivers/can/vesc_proto.c, odrive_proto.c), so a
// misreading of a document in one shows up against the other. Only the frame struct and its
// flag bits come from can_proto.h.
#pragma once

#include <cstdint>
#include <vector>

extern "C" {
#include "omni4/drivers/can_proto.h"
#include "omni4/model/params.h"
}

namespace motorsim
{

// The plant's motors as the drives see them: each motor's R, Kv, Kt and the gearbox.
struct Motors {
	model_wheels w;
	double gear; // l: motor turns per wheel turn
};

// What the drives see of the plant after its last step.
struct DriveView {
	double motor_rad_s[4]; // motor shaft speed (wheel speed x l) [rad/s]
	double current_a[4];   // motor currents [A]
	double supply_v;       // bus voltage after the sag [V]
};

// What the drives apply during the plant's next step.
struct DriveOut {
	double u_v[4]; // motor voltages [V]
	bool driven;   // at least one bridge on
};

// A fault injected at at_s on the drive of wheel `wheel` (none if at_s < 0).
struct Fault {
	double at_s = -1;
	int wheel = 0;
};

using Frames = std::vector<omni4_can_frame>;

// The bus voltage with internal resistance: v - r_int * sum |i_j| (the currents of the last
// step: one step late, which keeps the loop explicit).
double supply_sag(double v, double r_int_ohm, const double current_a[4]);

// A drive's current loop, ideal within its bus: the voltage that drives current_a through
// motor j at motor_rad_s (eq 21), limited to +-supply_v.
double current_loop_voltage(const Motors &m, int j, double current_a, double motor_rad_s,
                            double supply_v);

// A released motor (no current): the voltage that equals its back-EMF.
double coast_voltage(const Motors &m, int j, double motor_rad_s);

// ---- VESC (comm_can.md): 29-bit IDs, command << 8 | controller ID, big-endian -----------

enum VescCmd : uint8_t {
	VESC_SET_DUTY = 0,
	VESC_SET_CURRENT = 1,
	VESC_SET_CURRENT_BRAKE = 2,
	VESC_SET_RPM = 3,
	VESC_PROCESS_SHORT_BUFFER = 8, // a serial-protocol packet in one frame (commands.c)
	VESC_STATUS_1 = 9,
	VESC_STATUS_4 = 16,
	VESC_STATUS_5 = 27,
};

struct VescOptions {
	int ids[4] = {0, 1, 2, 3};
	int pole_pairs = 7;
	double timeout_s = 0.5; // the firmware's default CAN timeout
	int status_every = 1;   // periods between status messages (the app's CAN status rate)
	Fault fault;
	// What the faulted drive does: 0 goes silent (a dead controller); else it latches this
	// mc_fault_code (datatypes.h), releases its motor, takes no command and reports the code
	// to COMM_GET_VALUES_SELECTIVE.
	int fault_code = 0;
};

enum class VescMode { released, duty, current, brake };

struct VescDrive {
	VescMode mode = VescMode::released;
	double value = 0;         // duty (-1..1) or current [A] of the mode
	double last_cmd_s = -1e9; // time of the last command taken
	double tacho_steps = 0;   // 6 steps per electrical revolution
	double duty = 0;          // applied in the last step
	bool dead = false;        // injected fault: silent, ignores commands
	int fault_code = 0;       // latched mc_fault_code (0: none); ignores commands while set
	int reply_to = -1;        // a fault code request came from this id: reply at the next emit
};

struct VescSim {
	VescOptions o;
	Motors m;
	VescDrive d[4];
	double last_step_s = -1;
	long periods = 0; // vesc_sim_emit's calls: the status messages every o.status_every
};

void vesc_sim_init(VescSim &s, const VescOptions &o, const Motors &m);
// One received frame at t_s; frames for other IDs or commands are ignored.
void vesc_sim_receive(VescSim &s, const omni4_can_frame &f, double t_s);
// Timeouts and faults at t_s, then the voltages for the next step.
DriveOut vesc_sim_step(VescSim &s, double t_s, const DriveView &v);
// STATUS_1, STATUS_4 and STATUS_5 of every live drive, and the replies to the fault code
// requests received since the last emit, appended to out.
void vesc_sim_emit(VescSim &s, const DriveView &v, Frames &out);
// STATUS_1's ERPM for a motor speed: rad/s x pole pairs x 60 / 2 pi.
double vesc_erpm(double motor_rad_s, int pole_pairs);

} // namespace motorsim
