// Prints the frames omni4-motorsim's simulated VESCs and ODrives send on the Table III plant,
// with the physical values each should carry (taken from the drives' and the plant's state,
// not from the frame), in drive_vectors' format: check_drive_dbc.py decodes them with
// drivers/can/vesc.dbc and odrive.dbc. Commands are written by hand below.
#include <cinttypes>
#include <cmath>
#include <cstdio>

#include "drive_loop.hpp"

using namespace motorsim;

namespace
{

constexpr uint32_t EFF = OMNI4_CAN_EFF_FLAG, RTR = OMNI4_CAN_RTR_FLAG;
constexpr double kTwoPi = 6.283185307179586;

omni4_can_frame frame(uint32_t id, int dlc, uint64_t bytes_be)
{
	omni4_can_frame f{};
	f.id = id;
	f.dlc = static_cast<uint8_t>(dlc);
	for (int i = 0; i < dlc; ++i)
		f.data[i] = static_cast<uint8_t>(bytes_be >> (8 * (dlc - 1 - i)));
	return f;
}

void print(const char *proto, const omni4_can_frame &f, int node, const char *signals)
{
	std::printf("%s %08" PRIX32 " %d ", proto, f.id, f.dlc);
	for (int i = 0; i < f.dlc; ++i)
		std::printf("%02X", f.data[i]);
	std::printf("%s node=%d %s\n", f.dlc ? "" : "-", node, signals);
}

void print_vesc(const DriveLoop &d, const omni4_can_frame &f)
{
	const int j = static_cast<int>(f.id & 0xFF); // IDs 0..3 here
	const VescDrive &v = d.vesc.d[j];
	const double w_m = d.view.motor_rad_s[j];
	const double i = v.mode == VescMode::released ? 0.0 : d.pl->current_a[j];
	char s[200];
	switch ((f.id >> 8) & 0xFF) {
	case VESC_STATUS_1: // ERPM = motor rad/s x pole pairs x 60 / 2 pi
		std::snprintf(s, sizeof s, "erpm=%.17g current=%.17g duty=%.17g",
		              w_m * 7 * 60 / kTwoPi, i, v.duty);
		break;
	case VESC_STATUS_4:
		std::snprintf(s, sizeof s, "temp_fet=30 temp_motor=30 current_in=%.17g pid_pos=0",
		              v.duty * i);
		break;
	default: // STATUS_5
		std::snprintf(s, sizeof s, "tacho=%.17g input_voltage=%.17g reserved=0",
		              v.tacho_steps, d.view.supply_v);
	}
	print("vesc", f, j, s);
}

// A float signal's value as the drive sends it (binary32), printed to round-trip.
double f32(double x)
{
	return static_cast<float>(x);
}

void print_odrive(const DriveLoop &d, const omni4_can_frame &f)
{
	const int j = static_cast<int>(f.id >> 5); // nodes 0..3 here
	const OdriveAxis &a = d.odrive.a[j];
	const bool closed = a.state == ODRIVE_STATE_CLOSED_LOOP;
	const double i = closed ? d.pl->current_a[j] : 0.0;
	const double u = closed ? d.pl->voltage_v[j] : 0.0;
	char s[200];
	switch (f.id & 0x1F) {
	case ODRIVE_HEARTBEAT:
		std::snprintf(s, sizeof s,
		              "axis_error=%" PRIu32 " axis_state=%d procedure_result=0 "
		              "trajectory_done=1",
		              a.error, a.state);
		break;
	case ODRIVE_GET_ENCODER_ESTIMATES: // motor turns and turns/s
		std::snprintf(s, sizeof s, "pos_estimate=%.9g vel_estimate=%.9g", f32(a.pos_turns),
		              f32(d.view.motor_rad_s[j] / kTwoPi));
		break;
	case ODRIVE_GET_IQ:
		std::snprintf(s, sizeof s, "iq_setpoint=%.9g iq_measured=%.9g", f32(a.iq_set_a),
		              f32(i));
		break;
	default: // Get_Bus_Voltage_Current: the bridge's power balance
		std::snprintf(s, sizeof s, "bus_voltage=%.9g bus_current=%.9g",
		              f32(d.view.supply_v), f32(u * i / d.view.supply_v));
	}
	print("odrive", f, j, s);
}

void run(Protocol proto, const Frames &cmds, const Frames &requests)
{
	plant pl;
	plant_init(&pl, &model_params_table3);
	DriveLoop d;
	drive_loop_init(d, proto, VescOptions{}, OdriveOptions{}, Supply{24.0, 0.2}, &pl);
	for (int k = 0; k < 400; ++k) {
		const double t = k * 1e-3;
		drive_loop_advance(d, t, 1e-3,
		                   k % 50 == 0   ? cmds
		                   : k % 50 == 1 ? requests
		                                 : Frames{});
		if (k % 10 != 9 && k % 50 != 1)
			continue;
		for (const omni4_can_frame &f : d.out) {
			if (proto == Protocol::vesc)
				print_vesc(d, f);
			else
				print_odrive(d, f);
		}
	}
}

} // namespace

int main()
{
	// VESC IDs 0-3: SET_DUTY 0.3 (30000 = 0x7530) to 0, SET_CURRENT 2 A (2000 = 0x7D0) to 1,
	// SET_CURRENT_BRAKE 1.5 A (1500 = 0x5DC) to 2, SET_CURRENT -3 A (0xFFFFF448) to 3.
	run(Protocol::vesc,
	    {frame(EFF | 0x0000, 4, 0x7530), frame(EFF | 0x0101, 4, 0x7D0),
	     frame(EFF | 0x0202, 4, 0x5DC), frame(EFF | 0x0103, 4, 0xFFFFF448)},
	    {});
	// ODrive nodes 0-2: torque control (Set_Controller_Mode 0x0B: 1, 1), CLOSED_LOOP (0x07: 8),
	// torque 0.1 Nm (0x0E: 0.1f = 0x3DCCCCCD, little-endian); node 2 then Estop (0x02); node 3
	// stays IDLE. Remote requests for Get_Iq (0x14) and Get_Bus_Voltage_Current (0x17).
	Frames cmds, reqs;
	for (uint32_t n = 0; n < 3; ++n) {
		cmds.push_back(frame(n << 5 | 0x0B, 8, 0x0100000001000000));
		cmds.push_back(frame(n << 5 | 0x07, 8, 0x0800000000000000));
		cmds.push_back(frame(n << 5 | 0x0E, 8, 0xCDCCCC3D00000000));
	}
	cmds.push_back(frame(2 << 5 | 0x02, 0, 0));
	for (uint32_t n = 0; n < 4; ++n) {
		reqs.push_back(frame(RTR | n << 5 | 0x14, 8, 0));
		reqs.push_back(frame(RTR | n << 5 | 0x17, 8, 0));
	}
	run(Protocol::odrive, cmds, reqs);
	return 0;
}
