// The simulated VESCs and ODrives of omni4-motorsim (host-tools/motorsim/) against frames
// written byte by byte from the vendors' documents (docs/can-drives.md): VESC "CAN-Bus
// Communication" (comm_can.md: 29-bit ID command << 8 | controller ID, big-endian, duty x 100000,
// current x 1000; STATUS_1 ERPM x 1, current x 10, duty x 1000; STATUS_5 voltage x 10) and ODrive
// "CAN Protocol" (11-bit ID node << 5 | command, little-endian, binary32 floats). Expected
// voltages from eq 21 by hand: u = R i + Kv w_m with the test motors R = 2 ohm, Kv = Kt = 0.05.
#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>

#include "drive_loop.hpp"

using namespace motorsim;

namespace
{

constexpr uint32_t EFF = OMNI4_CAN_EFF_FLAG, RTR = OMNI4_CAN_RTR_FLAG;

omni4_can_frame frame(uint32_t id, std::initializer_list<int> bytes)
{
	omni4_can_frame f{};
	f.id = id;
	for (int b : bytes)
		f.data[f.dlc++] = static_cast<uint8_t>(b);
	return f;
}

Motors test_motors()
{
	Motors m{};
	for (int j = 0; j < 4; ++j) {
		m.w.r[j] = 0.03;
		m.w.R[j] = 2.0;
		m.w.Kv[j] = m.w.Kt[j] = 0.05;
	}
	m.gear = 5;
	return m;
}

DriveView view(double motor_rad_s, double supply_v)
{
	DriveView v{};
	for (int j = 0; j < 4; ++j)
		v.motor_rad_s[j] = motor_rad_s;
	v.supply_v = supply_v;
	return v;
}

const omni4_can_frame *find(const Frames &out, uint32_t id)
{
	for (const auto &f : out)
		if (f.id == id)
			return &f;
	return nullptr;
}

void expect_bytes(const omni4_can_frame *f, std::initializer_list<int> bytes)
{
	ASSERT_NE(f, nullptr);
	ASSERT_EQ(f->dlc, bytes.size());
	int i = 0;
	for (int b : bytes) {
		EXPECT_EQ(f->data[i], b) << "byte " << i << " of ID " << std::hex << f->id;
		++i;
	}
}

VescSim vesc(int id0 = 23)
{
	VescSim s;
	VescOptions o;
	o.ids[0] = id0;
	vesc_sim_init(s, o, test_motors());
	return s;
}

} // namespace

TEST(Supply, SagsWithTheSumOfTheCurrentsMagnitudes)
{
	const double i[4] = {1, -2, 3, -4}; // sum |i| = 10 A
	EXPECT_DOUBLE_EQ(supply_sag(24, 0.5, i), 19.0);
	EXPECT_DOUBLE_EQ(supply_sag(24, 0.0, i), 24.0);
}

TEST(VescSim, SetCurrentDrivesTheCurrentLoopWithinTheBus)
{
	VescSim s = vesc();
	// SET_CURRENT (1) to ID 23: ID 0x0117; 1.5 A x 1000 = 1500 = 0x000005DC
	vesc_sim_receive(s, frame(EFF | 0x0117, {0x00, 0x00, 0x05, 0xDC}), 0.0);
	DriveOut u = vesc_sim_step(s, 0.001, view(100, 24));
	EXPECT_NEAR(u.u_v[0], 2 * 1.5 + 0.05 * 100, 1e-12); // 8 V
	EXPECT_TRUE(u.driven);
	EXPECT_NEAR(u.u_v[1], 0.05 * 100, 1e-12); // never commanded: released, back-EMF only
	// the document's own example: 51 A to ID 23 is 00 00 C7 38; 2 x 51 + 5 V > 24 V: the bus
	vesc_sim_receive(s, frame(EFF | 0x0117, {0x00, 0x00, 0xC7, 0x38}), 0.002);
	EXPECT_NEAR(vesc_sim_step(s, 0.003, view(100, 24)).u_v[0], 24.0, 1e-12);
}

TEST(VescSim, SetDutyIsAShareOfTheSaggedSupply)
{
	VescSim s = vesc();
	// SET_DUTY (0) to ID 1: ID 0x0001; -0.25 x 100000 = -25000 = 0xFFFF9E58
	vesc_sim_receive(s, frame(EFF | 0x0001, {0xFF, 0xFF, 0x9E, 0x58}), 0.0);
	const double i[4] = {1, -2, 3, -4};
	DriveView v = view(0, supply_sag(24, 0.5, i)); // 19 V
	EXPECT_NEAR(vesc_sim_step(s, 0.001, v).u_v[1], -0.25 * 19, 1e-12);
}

TEST(VescSim, SetCurrentBrakeOpposesTheMotion)
{
	VescSim s = vesc();
	// SET_CURRENT_BRAKE (2) to ID 2: ID 0x0202; 2 A = 2000 = 0x000007D0
	vesc_sim_receive(s, frame(EFF | 0x0202, {0x00, 0x00, 0x07, 0xD0}), 0.0);
	EXPECT_NEAR(vesc_sim_step(s, 0.001, view(100, 24)).u_v[2], -2 * 2 + 5, 1e-12);
	EXPECT_NEAR(vesc_sim_step(s, 0.002, view(-100, 24)).u_v[2], 2 * 2 - 5, 1e-12);
}

TEST(VescSim, NoCommandForHalfASecondReleasesTheMotor)
{
	VescSim s = vesc();
	// SET_DUTY 0.5 to ID 23: 50000 = 0x0000C350
	const omni4_can_frame duty = frame(EFF | 0x0017, {0x00, 0x00, 0xC3, 0x50});
	vesc_sim_receive(s, duty, 0.0);
	DriveOut u = vesc_sim_step(s, 0.499, view(100, 24));
	EXPECT_NEAR(u.u_v[0], 12.0, 1e-12);
	u = vesc_sim_step(s, 0.501, view(100, 24));
	EXPECT_FALSE(u.driven);
	EXPECT_NEAR(u.u_v[0], 0.05 * 100, 1e-12); // coasting: no current
	Frames out;
	vesc_sim_emit(s, view(100, 24), out);
	const omni4_can_frame *st1 = find(out, EFF | 0x0917);
	ASSERT_NE(st1, nullptr);
	EXPECT_EQ(st1->data[6] | st1->data[7], 0); // duty 0
	vesc_sim_receive(s, duty, 0.6);            // a command takes it back
	EXPECT_TRUE(vesc_sim_step(s, 0.601, view(100, 24)).driven);
}

TEST(VescSim, StatusFramesCarryErpmCurrentDutyAndInputVoltage)
{
	VescSim s = vesc();
	vesc_sim_receive(s, frame(EFF | 0x0017, {0x00, 0x00, 0xC3, 0x50}), 0.0); // duty 0.5
	DriveView v = view(100, 19.0);
	vesc_sim_step(s, 0.001, v);
	v.current_a[0] = 1.6;
	Frames out;
	vesc_sim_emit(s, v, out);
	EXPECT_EQ(out.size(), 12u); // STATUS_1, _4, _5 of four drives
	// STATUS_1 (9) of ID 23: 0x0917; ERPM 100 rad/s x 7 x 60 / 2 pi = 6684.5 -> 6685 = 0x1A1D;
	// 1.6 A x 10 = 16 = 0x0010; duty 0.5 x 1000 = 500 = 0x01F4
	expect_bytes(find(out, EFF | 0x0917), {0x00, 0x00, 0x1A, 0x1D, 0x00, 0x10, 0x01, 0xF4});
	// STATUS_5 (27 = 0x1B): tachometer 0 after no time; 19.0 V x 10 = 190 = 0x00BE; reserved
	expect_bytes(find(out, EFF | 0x1B17), {0, 0, 0, 0, 0x00, 0xBE, 0, 0});
	// STATUS_4 (16 = 0x10): 30 degC x 10 = 300 = 0x012C twice; input current 0.5 x 1.6 A = 0.8
	// A = 8
	expect_bytes(find(out, EFF | 0x1017), {0x01, 0x2C, 0x01, 0x2C, 0x00, 0x08, 0, 0});
}

// The app's CAN status rate: STATUS_1, 4 and 5 of every drive each status_every periods,
// starting at the first; a fault code's reply is not held back by it.
TEST(VescSim, StatusFramesComeAtTheStatusRate)
{
	VescSim s = vesc();
	s.o.status_every = 5;
	int with_status = 0;
	for (int k = 0; k < 1000; ++k) {
		Frames out;
		vesc_sim_emit(s, view(100, 24), out);
		if (find(out, EFF | 0x0917) != nullptr) {
			EXPECT_EQ(k % 5, 0) << "period " << k;
			EXPECT_EQ(out.size(), 12u);
			++with_status;
		} else {
			EXPECT_TRUE(out.empty());
		}
	}
	EXPECT_EQ(with_status, 200);
}

TEST(VescSim, TachometerCountsSixStepsPerElectricalRevolution)
{
	VescSim s = vesc();
	const DriveView v = view(2 * M_PI, 24); // one motor turn per second = 7 electrical
	for (int k = 0; k <= 1000; ++k)
		vesc_sim_step(s, k * 1e-3, v);
	Frames out;
	vesc_sim_emit(s, v, out);
	// 7 x 6 = 42 = 0x2A steps; 24 V = 240 = 0x00F0
	expect_bytes(find(out, EFF | 0x1B17), {0, 0, 0, 0x2A, 0x00, 0xF0, 0, 0});
	EXPECT_NEAR(vesc_erpm(2 * M_PI, 7), 420.0, 1e-9);
}

TEST(VescSim, AFaultedDriveGoesSilentAndIgnoresCommands)
{
	VescSim s;
	VescOptions o;
	o.fault = Fault{1.0, 2};
	vesc_sim_init(s, o, test_motors());
	vesc_sim_step(s, 0.5, view(0, 24));
	Frames out;
	vesc_sim_emit(s, view(0, 24), out);
	EXPECT_EQ(out.size(), 12u);
	vesc_sim_step(s, 1.0, view(0, 24));
	vesc_sim_receive(s, frame(EFF | 0x0002, {0x00, 0x00, 0xC3, 0x50}), 1.0);
	EXPECT_FALSE(vesc_sim_step(s, 1.001, view(0, 24)).driven);
	out.clear();
	vesc_sim_emit(s, view(0, 24), out);
	EXPECT_EQ(out.size(), 9u);
	for (const auto &f : out)
		EXPECT_NE(f.id & 0xFF, 2u);
}

TEST(VescSim, ALatchedFaultCodeIsTheReplyToCommGetValuesSelective)
{
	// commands.c COMM_GET_VALUES_SELECTIVE (50) with mask bit 15 (the fault code) alone, in a
	// PROCESS_SHORT_BUFFER (8) from id 254 to VESC 1: [254, 0 = process and reply, 50,
	// 00 00 80 00]; the reply to 254: [1, 1 = a reply, 50, 00 00 80 00, code].
	VescSim s;
	VescOptions o;
	o.fault = Fault{1.0, 1};
	o.fault_code = 5; // FAULT_CODE_OVER_TEMP_FET
	vesc_sim_init(s, o, test_motors());
	const omni4_can_frame ask = frame(EFF | 0x0801, {254, 0, 50, 0x00, 0x00, 0x80, 0x00});
	vesc_sim_receive(s, ask, 0.5);
	vesc_sim_step(s, 0.5, view(0, 24));
	Frames out;
	vesc_sim_emit(s, view(0, 24), out);
	expect_bytes(find(out, EFF | 0x08FE), {1, 1, 50, 0x00, 0x00, 0x80, 0x00, 0});
	out.clear();
	vesc_sim_emit(s, view(0, 24), out); // answered once
	EXPECT_EQ(find(out, EFF | 0x08FE), nullptr);
	vesc_sim_step(s, 1.0, view(0, 24));
	// SET_DUTY 0.5 to VESC 1 after the fault: not taken, the motor stays released
	vesc_sim_receive(s, frame(EFF | 0x0001, {0x00, 0x00, 0xC3, 0x50}), 1.0);
	vesc_sim_receive(s, ask, 1.0);
	EXPECT_FALSE(vesc_sim_step(s, 1.001, view(0, 24)).driven);
	out.clear();
	vesc_sim_emit(s, view(0, 24), out);
	expect_bytes(find(out, EFF | 0x08FE), {1, 1, 50, 0x00, 0x00, 0x80, 0x00, 5});
	EXPECT_NE(find(out, EFF | 0x0901), nullptr); // still reporting
	// another mask (more values than one frame holds) is not simulated: no reply
	vesc_sim_receive(s, frame(EFF | 0x0801, {254, 0, 50, 0x00, 0x00, 0x80, 0x01}), 1.0);
	out.clear();
	vesc_sim_emit(s, view(0, 24), out);
	EXPECT_EQ(find(out, EFF | 0x08FE), nullptr);
}

TEST(VescSim, IgnoresStandardRemoteAndOtherControllersFrames)
{
	VescSim s = vesc();
	vesc_sim_receive(s, frame(0x0017, {0x00, 0x00, 0xC3, 0x50}), 0.0);             // 11-bit
	vesc_sim_receive(s, frame(EFF | RTR | 0x0017, {0x00, 0x00, 0xC3, 0x50}), 0.0); // remote
	vesc_sim_receive(s, frame(EFF | 0x0018, {0x00, 0x00, 0xC3, 0x50}), 0.0);       // ID 24
	vesc_sim_receive(s, frame(EFF | 0x10017, {0x00, 0x00, 0xC3, 0x50}), 0.0);      // bit 16
	EXPECT_FALSE(vesc_sim_step(s, 0.001, view(0, 24)).driven);
}

namespace
{

OdriveSim odrive(double watchdog_s = 0.2)
{
	OdriveSim s;
	OdriveOptions o;
	o.watchdog_s = watchdog_s;
	odrive_sim_init(s, o, test_motors());
	return s;
}

// Node 1, commands: Set_Controller_Mode (0x0B) torque 1, passthrough 1 at ID 1 << 5 | 0x0B =
// 0x2B; Set_Axis_State (0x07) at 0x27; Set_Input_Torque (0x0E) at 0x2E.
const omni4_can_frame kTorqueMode = frame(0x2B, {1, 0, 0, 0, 1, 0, 0, 0});
const omni4_can_frame kClosedLoop = frame(0x27, {8, 0, 0, 0, 0, 0, 0, 0});
// 0.25f = 0x3E800000, little-endian
const omni4_can_frame kTorque = frame(0x2E, {0x00, 0x00, 0x80, 0x3E, 0, 0, 0, 0});

const omni4_can_frame *heartbeat(OdriveSim &s, double t_s, Frames &out)
{
	out.clear();
	odrive_sim_receive(s, frame(RTR | 0x21, {}), t_s); // remote Heartbeat (0x01) of node 1
	odrive_sim_emit(s, t_s, view(0, 24), out);
	return find(out, 0x21);
}

} // namespace

TEST(OdriveSim, TorqueIsIgnoredWhileIdleAndDrivesTheCurrentInClosedLoop)
{
	OdriveSim s = odrive();
	odrive_sim_receive(s, kTorqueMode, 0.0);
	odrive_sim_receive(s, kTorque, 0.0); // IDLE: ignored
	DriveOut u = odrive_sim_step(s, 0.001, view(100, 24));
	EXPECT_FALSE(u.driven);
	EXPECT_NEAR(u.u_v[1], 0.05 * 100, 1e-12);
	odrive_sim_receive(s, kClosedLoop, 0.002);
	u = odrive_sim_step(s, 0.003, view(100, 24));
	EXPECT_NEAR(u.u_v[1], 0.05 * 100,
	            1e-12); // closed loop, no torque yet: the earlier one lost
	odrive_sim_receive(s, kTorque, 0.004);
	u = odrive_sim_step(s, 0.005, view(100, 24));
	EXPECT_TRUE(u.driven);
	// i = torque / Kt = 0.25 / 0.05 = 5 A; u = 2 x 5 + 0.05 x 100 = 15 V
	EXPECT_NEAR(u.u_v[1], 15.0, 1e-12);
	EXPECT_NEAR(u.u_v[0], 0.05 * 100, 1e-12); // node 0 untouched
	// IDLE (Set_Axis_State 1) and CLOSED_LOOP again: the torque starts from 0
	odrive_sim_receive(s, frame(0x27, {1, 0, 0, 0, 0, 0, 0, 0}), 0.006);
	EXPECT_FALSE(odrive_sim_step(s, 0.007, view(100, 24)).driven);
	odrive_sim_receive(s, kClosedLoop, 0.008);
	EXPECT_NEAR(odrive_sim_step(s, 0.009, view(100, 24)).u_v[1], 0.05 * 100, 1e-12);
}

TEST(OdriveSim, VelocityControlIsProportionalWithTheTorqueFeedForward)
{
	OdriveSim s = odrive(); // velocity control: the drive's default
	odrive_sim_receive(s, kClosedLoop, 0.0);
	// Set_Input_Vel (0x0D) to node 1 (ID 0x2D): 3.0f = 0x40400000, 0.05f = 0x3D4CCCCD
	odrive_sim_receive(s, frame(0x2D, {0, 0, 0x40, 0x40, 0xCD, 0xCC, 0x4C, 0x3D}), 0.0);
	// motor at 2 pi rad/s = 1 turn/s: torque 1/6 x (3 - 1) + 0.05 = 0.3833 Nm, i = 7.667 A,
	// u = 2 i + 0.05 x 2 pi
	const double i = (2.0 / 6 + 0.05f) / 0.05;
	EXPECT_NEAR(odrive_sim_step(s, 0.001, view(2 * M_PI, 24)).u_v[1], 2 * i + 0.05 * 2 * M_PI,
	            1e-6);
}

TEST(OdriveSim, EstopSetsTheErrorAndIdlesUntilClearErrors)
{
	OdriveSim s = odrive();
	Frames out;
	odrive_sim_receive(s, kTorqueMode, 0.0);
	odrive_sim_receive(s, kClosedLoop, 0.0);
	// Heartbeat: error 0, state 8, procedure result 0, trajectory done 1
	expect_bytes(heartbeat(s, 0.001, out), {0, 0, 0, 0, 8, 0, 1, 0});
	odrive_sim_receive(s, frame(0x22, {}), 0.002); // Estop (0x02), no data
	// ESTOP_REQUESTED 0x02000000 little-endian; state 1 (IDLE)
	expect_bytes(heartbeat(s, 0.003, out), {0, 0, 0, 0x02, 1, 0, 1, 0});
	odrive_sim_receive(s, kClosedLoop, 0.004); // refused while the error stands
	odrive_sim_receive(s, kTorque, 0.004);
	EXPECT_FALSE(odrive_sim_step(s, 0.005, view(0, 24)).driven);
	odrive_sim_receive(s, frame(0x38, {0}), 0.006); // Clear_Errors (0x18), identify 0
	expect_bytes(heartbeat(s, 0.007, out), {0, 0, 0, 0, 1, 0, 1, 0});
	odrive_sim_receive(s, kClosedLoop, 0.008);
	odrive_sim_receive(s, kTorque, 0.008);
	EXPECT_TRUE(odrive_sim_step(s, 0.009, view(0, 24)).driven);
}

TEST(OdriveSim, WatchdogExpiresWithoutCommands)
{
	OdriveSim s = odrive(0.2);
	Frames out;
	odrive_sim_receive(s, kTorqueMode, 0.0);
	odrive_sim_receive(s, kClosedLoop, 0.0);
	odrive_sim_receive(s, kTorque, 0.1);
	EXPECT_TRUE(odrive_sim_step(s, 0.299, view(0, 24)).driven);
	EXPECT_FALSE(odrive_sim_step(s, 0.301, view(0, 24)).driven);
	// WATCHDOG_TIMER_EXPIRED 0x01000000; IDLE
	expect_bytes(heartbeat(s, 0.302, out), {0, 0, 0, 0x01, 1, 0, 1, 0});
	OdriveSim off = odrive(0.0);
	odrive_sim_receive(off, kTorqueMode, 0.0);
	odrive_sim_receive(off, kClosedLoop, 0.0);
	EXPECT_TRUE(odrive_sim_step(off, 10.0, view(0, 24)).driven);
}

TEST(OdriveSim, EncoderEstimatesAreMotorTurnsAnsweringARemoteRequest)
{
	OdriveSim s = odrive();
	const DriveView v = view(4 * M_PI, 24); // 2 motor turns/s
	for (int k = 0; k <= 500; ++k)
		odrive_sim_step(s, k * 1e-3, v); // 0.5 s: 1 turn
	Frames out;
	s.a[0].next_encoder_s = 1e9; // the cyclic one off: the answer alone
	odrive_sim_receive(s, frame(RTR | 0x09, {}), 0.5);
	odrive_sim_emit(s, 0.5, v, out);
	// Get_Encoder_Estimates (0x09) of node 0: 1.0f = 0x3F800000, 2.0f = 0x40000000
	expect_bytes(find(out, 0x09), {0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0x40});
}

TEST(OdriveSim, IqAndBusVoltageAnswerRemoteRequests)
{
	OdriveSim s = odrive();
	odrive_sim_receive(s, kTorqueMode, 0.0);
	odrive_sim_receive(s, kClosedLoop, 0.0);
	odrive_sim_receive(s, kTorque, 0.0);
	DriveView v = view(0, 20.0);
	odrive_sim_step(s, 0.001, v);
	v.current_a[1] = 4.0;
	odrive_sim_receive(s, frame(RTR | 0x34, {}), 0.001); // Get_Iq (0x14) of node 1
	odrive_sim_receive(s, frame(RTR | 0x37, {}), 0.001); // Get_Bus_Voltage_Current (0x17)
	Frames out;
	odrive_sim_emit(s, 0.001, v, out);
	// Iq set-point 5.0f = 0x40A00000, measured 4.0f = 0x40800000
	expect_bytes(find(out, 0x34), {0, 0, 0xA0, 0x40, 0, 0, 0x80, 0x40});
	// 20.0f = 0x41A00000; bus current u i / V = (2 x 5) x 4 / 20 = 2.0f = 0x40000000
	expect_bytes(find(out, 0x37), {0, 0, 0xA0, 0x41, 0, 0, 0, 0x40});
}

TEST(OdriveSim, HeartbeatAndEncoderEstimatesAreCyclic)
{
	OdriveSim s = odrive();
	int heartbeats = 0, estimates = 0;
	Frames out;
	for (int k = 1; k <= 995; ++k) { // the first at once, then every 100 ms and 10 ms
		out.clear();
		odrive_sim_emit(s, k * 1e-3, view(0, 24), out);
		heartbeats += find(out, 0x01) != nullptr;
		estimates += find(out, 0x09) != nullptr;
	}
	EXPECT_EQ(heartbeats, 10);
	EXPECT_EQ(estimates, 100);
}

// iq_msg_rate_ms: off by default (Get_Iq answers requests only), else Get_Iq every period.
TEST(OdriveSim, IqIsCyclicOnlyWhenARateIsSet)
{
	for (const double iq_s : {0.0, 0.001}) {
		OdriveSim s;
		OdriveOptions o;
		o.iq_s = iq_s;
		odrive_sim_init(s, o, test_motors());
		int iqs = 0;
		Frames out;
		for (int k = 1; k <= 100; ++k) {
			out.clear();
			odrive_sim_emit(s, k * 1e-3, view(0, 24), out);
			iqs += find(out, 0x34) != nullptr; // Get_Iq (0x14) of node 1
		}
		if (iq_s > 0)
			EXPECT_NEAR(iqs, 100, 1); // one a period (a tick on the boundary may slip)
		else
			EXPECT_EQ(iqs, 0);
	}
}

TEST(OdriveSim, AnInjectedFaultIsAnAxisErrorAndIdle)
{
	OdriveSim s;
	OdriveOptions o;
	o.fault = Fault{0.5, 1};
	odrive_sim_init(s, o, test_motors());
	odrive_sim_receive(s, kTorqueMode, 0.4);
	odrive_sim_receive(s, kClosedLoop, 0.4);
	odrive_sim_receive(s, kTorque, 0.45);
	EXPECT_TRUE(odrive_sim_step(s, 0.49, view(0, 24)).driven);
	EXPECT_FALSE(odrive_sim_step(s, 0.5, view(0, 24)).driven);
	Frames out;
	expect_bytes(heartbeat(s, 0.501, out), {0x20, 0, 0, 0, 1, 0, 1, 0}); // DRV_FAULT 0x20
}

// The plant behind the drives: an ODrive's torque command is the motor's current Kt i.
TEST(DriveLoop, OdriveTorqueBecomesThePlantsMotorCurrent)
{
	plant pl;
	ASSERT_EQ(plant_init(&pl, &model_params_table3), 0);
	DriveLoop d;
	drive_loop_init(d, Protocol::odrive, VescOptions{}, OdriveOptions{}, Supply{24, 0.1}, &pl);
	// Set_Input_Torque 0.1 Nm to node 1: 0.1f = 0x3DCCCCCD, little-endian
	const Frames in = {kTorqueMode, kClosedLoop,
	                   frame(0x2E, {0xCD, 0xCC, 0xCC, 0x3D, 0, 0, 0, 0})};
	drive_loop_advance(d, 0.0, 1e-3, in);
	// 0.1 Nm / Kt 0.0259 = 3.86 A (R i = 16.6 V, within the bus); the back-EMF of the motor
	// speed the step builds is followed by the current loop at the next step
	drive_loop_advance(d, 1e-3, 1e-3, {});
	const double i = 0.1f / 0.0259;
	EXPECT_NEAR(pl.current_a[1], i, 0.01 * i);
	double sum = 0;
	for (double c : pl.current_a)
		sum += std::fabs(c);
	EXPECT_NEAR(d.view.supply_v, 24 - 0.1 * sum, 1e-9);
}

// The hooks: step moves the plant in plant_step's place with the drives' voltages, sense
// changes what the drives report (STATUS_1's current) and not what they apply.
TEST(DriveLoop, StepAndSenseHooksTakeThePlantAndTheReports)
{
	plant pl;
	ASSERT_EQ(plant_init(&pl, &model_params_table3), 0);
	DriveLoop d;
	drive_loop_init(d, Protocol::vesc, VescOptions{}, OdriveOptions{}, Supply{12, 0}, &pl);
	int steps = 0;
	double applied = 0;
	d.step = [&](const DriveOut &u, double dt_s) {
		++steps;
		applied = u.u_v[0];
		plant_step(&pl, u.u_v, u.driven, dt_s);
	};
	d.sense = [](DriveView &v) { v.current_a[0] = 1.5; };
	// SET_DUTY (0) 0.5 x 100000 = 50000 = 0x0000C350 to controller 0
	const omni4_can_frame duty = frame(EFF | 0x0000, {0, 0, 0xC3, 0x50});
	drive_loop_advance(d, 0.0, 1e-3, {duty});
	EXPECT_EQ(steps, 1);
	EXPECT_DOUBLE_EQ(applied, 6.0); // 0.5 x 12 V
	EXPECT_NE(pl.current_a[0], 1.5);
	const omni4_can_frame *s1 = find(d.out, EFF | 0x0900); // STATUS_1 (9) of controller 0
	ASSERT_NE(s1, nullptr);
	EXPECT_EQ(s1->data[4] << 8 | s1->data[5], 15); // 1.5 A x 10
}
