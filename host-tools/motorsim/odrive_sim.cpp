// odrive_sim.cpp - four simulated ODrives (CANSimple): the axis state machine (IDLE, CLOSED_LOOP
// via Set_Axis_State; Estop; Clear_Errors; the watchdog), torque and velocity control, the
// heartbeat and encoder estimates sent cyclically and the Get_ messages answered to remote
// requests.
#include <cmath>
#include <cstring>

#include "odrive_sim.hpp"

namespace motorsim
{
namespace
{

constexpr double kTwoPi = 6.283185307179586;

// The document: little-endian; floats IEEE 754 binary32.
uint32_t le_u32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

float le_f32(const uint8_t *p)
{
	const uint32_t u = le_u32(p);
	float x;
	std::memcpy(&x, &u, sizeof x);
	return x;
}

void put_le_u32(uint8_t *p, uint32_t u)
{
	for (int i = 0; i < 4; ++i)
		p[i] = static_cast<uint8_t>(u >> (8 * i));
}

void put_le_f32(uint8_t *p, double x)
{
	const auto f = static_cast<float>(x);
	uint32_t u;
	std::memcpy(&u, &f, sizeof u);
	put_le_u32(p, u);
}

omni4_can_frame frame(int node, uint8_t cmd)
{
	omni4_can_frame f{};
	f.id = static_cast<uint32_t>(node) << 5 | cmd;
	f.dlc = 8;
	return f;
}

int axis_of(const OdriveSim &s, uint32_t node)
{
	for (int j = 0; j < 4; ++j)
		if (static_cast<uint32_t>(s.o.nodes[j]) == node)
			return j;
	return -1;
}

void request_state(OdriveAxis &a, uint32_t state, double t_s)
{
	if (state == ODRIVE_STATE_IDLE)
		a.state = ODRIVE_STATE_IDLE;
	if (state != ODRIVE_STATE_CLOSED_LOOP || a.error) // refused while an error stands
		return;
	a.state = ODRIVE_STATE_CLOSED_LOOP;
	a.torque_nm = a.vel_turn_s = a.torque_ff_nm = 0;
	a.last_cmd_s = t_s;
}

// A data frame for the axis (the watchdog has been fed).
void take(OdriveAxis &a, uint8_t cmd, const omni4_can_frame &f, double t_s)
{
	const bool closed = a.state == ODRIVE_STATE_CLOSED_LOOP;
	if (cmd == ODRIVE_ESTOP) {
		a.error |= ODRIVE_ERR_ESTOP_REQUESTED;
		a.state = ODRIVE_STATE_IDLE;
	} else if (cmd == ODRIVE_SET_AXIS_STATE && f.dlc >= 4) {
		request_state(a, le_u32(f.data), t_s);
	} else if (cmd == ODRIVE_SET_CONTROLLER_MODE && f.dlc >= 8) {
		a.control_mode = le_u32(f.data);
		a.input_mode = le_u32(f.data + 4);
	} else if (cmd == ODRIVE_SET_INPUT_TORQUE && f.dlc >= 4 && closed) {
		a.torque_nm = le_f32(f.data);
	} else if (cmd == ODRIVE_SET_INPUT_VEL && f.dlc >= 8 && closed) {
		a.vel_turn_s = le_f32(f.data);
		a.torque_ff_nm = le_f32(f.data + 4);
	} else if (cmd == ODRIVE_CLEAR_ERRORS) {
		a.error = 0;
	}
}

// The motor torque the axis asks for [Nm] (0 unless in closed loop).
double axis_torque(const OdriveSim &s, const OdriveAxis &a, double motor_rad_s)
{
	if (a.state != ODRIVE_STATE_CLOSED_LOOP || !std::isfinite(a.torque_nm) ||
	    !std::isfinite(a.vel_turn_s) || !std::isfinite(a.torque_ff_nm))
		return 0;
	if (a.control_mode == ODRIVE_CONTROL_TORQUE)
		return a.torque_nm;
	if (a.control_mode == ODRIVE_CONTROL_VELOCITY)
		return s.o.vel_gain * (a.vel_turn_s - motor_rad_s / kTwoPi) + a.torque_ff_nm;
	return 0; // position control: not simulated
}

omni4_can_frame answer(const OdriveSim &s, int j, uint8_t cmd, const DriveView &v)
{
	const OdriveAxis &a = s.a[j];
	omni4_can_frame f = frame(s.o.nodes[j], cmd);
	const bool closed = a.state == ODRIVE_STATE_CLOSED_LOOP;
	const double i = closed ? v.current_a[j] : 0.0;
	if (cmd == ODRIVE_HEARTBEAT) {
		put_le_u32(f.data, a.error);
		f.data[4] = a.state;
		f.data[5] = 0; // procedure result: success
		f.data[6] = 1; // trajectory done (bit 0)
	} else if (cmd == ODRIVE_GET_ENCODER_ESTIMATES) {
		put_le_f32(f.data, a.pos_turns);
		put_le_f32(f.data + 4, v.motor_rad_s[j] / kTwoPi);
	} else if (cmd == ODRIVE_GET_IQ) {
		put_le_f32(f.data, a.iq_set_a);
		put_le_f32(f.data + 4, i);
	} else if (cmd == ODRIVE_GET_BUS_VOLTAGE_CURRENT) {
		// the bridge's power balance: bus current = motor power / bus voltage
		const double u = closed ? a.u_v : 0.0;
		put_le_f32(f.data, v.supply_v);
		put_le_f32(f.data + 4, v.supply_v > 0 ? u * i / v.supply_v : 0.0);
	}
	return f;
}

// The next time a cyclic message is due: one period on (the rate holds on average), or one
// period from now after a stall.
double next_due(double due_s, double period_s, double t_s)
{
	due_s += period_s;
	return due_s <= t_s ? t_s + period_s : due_s;
}

} // namespace

void odrive_sim_init(OdriveSim &s, const OdriveOptions &o, const Motors &m)
{
	s = OdriveSim{};
	s.o = o;
	s.m = m;
}

void odrive_sim_receive(OdriveSim &s, const omni4_can_frame &f, double t_s)
{
	if (f.id & OMNI4_CAN_EFF_FLAG)
		return;
	const uint32_t id = f.id & OMNI4_CAN_SFF_MASK;
	const int j = axis_of(s, id >> 5);
	const auto cmd = static_cast<uint8_t>(id & 0x1F);
	if (j < 0)
		return;
	OdriveAxis &a = s.a[j];
	if (f.id & OMNI4_CAN_RTR_FLAG) {
		if (cmd == ODRIVE_HEARTBEAT || cmd == ODRIVE_GET_ENCODER_ESTIMATES ||
		    cmd == ODRIVE_GET_IQ || cmd == ODRIVE_GET_BUS_VOLTAGE_CURRENT)
			a.rtr |= 1u << cmd;
		return;
	}
	a.last_cmd_s = t_s;
	take(a, cmd, f, t_s);
}

DriveOut odrive_sim_step(OdriveSim &s, double t_s, const DriveView &v)
{
	const double dt = s.last_step_s < 0 ? 0 : t_s - s.last_step_s;
	s.last_step_s = t_s;
	if (s.o.fault.at_s >= 0 && t_s >= s.o.fault.at_s && !s.fault_done) {
		s.a[s.o.fault.wheel].error |= ODRIVE_ERR_DRV_FAULT;
		s.a[s.o.fault.wheel].state = ODRIVE_STATE_IDLE;
		s.fault_done = true;
	}
	DriveOut out{};
	for (int j = 0; j < 4; ++j) {
		OdriveAxis &a = s.a[j];
		const double w = v.motor_rad_s[j];
		if (a.state == ODRIVE_STATE_CLOSED_LOOP && s.o.watchdog_s > 0 &&
		    t_s - a.last_cmd_s > s.o.watchdog_s) {
			a.error |= ODRIVE_ERR_WATCHDOG_TIMER_EXPIRED;
			a.state = ODRIVE_STATE_IDLE;
		}
		a.iq_set_a = axis_torque(s, a, w) / s.m.w.Kt[j]; // torque at the motor shaft
		const bool closed = a.state == ODRIVE_STATE_CLOSED_LOOP;
		out.u_v[j] = closed ? current_loop_voltage(s.m, j, a.iq_set_a, w, v.supply_v)
		                    : coast_voltage(s.m, j, w);
		out.driven |= closed;
		a.u_v = out.u_v[j];
		a.pos_turns += w / kTwoPi * dt;
	}
	return out;
}

void odrive_sim_emit(OdriveSim &s, double t_s, const DriveView &v, Frames &out)
{
	for (int j = 0; j < 4; ++j) {
		OdriveAxis &a = s.a[j];
		for (uint8_t c = 0; c < 32; ++c)
			if (a.rtr & (1u << c))
				out.push_back(answer(s, j, c, v));
		a.rtr = 0;
		if (t_s >= a.next_heartbeat_s) {
			out.push_back(answer(s, j, ODRIVE_HEARTBEAT, v));
			a.next_heartbeat_s = next_due(a.next_heartbeat_s, s.o.heartbeat_s, t_s);
		}
		if (s.o.encoder_s > 0 && t_s >= a.next_encoder_s) {
			out.push_back(answer(s, j, ODRIVE_GET_ENCODER_ESTIMATES, v));
			a.next_encoder_s = next_due(a.next_encoder_s, s.o.encoder_s, t_s);
		}
		if (s.o.iq_s > 0 && t_s >= a.next_iq_s) {
			out.push_back(answer(s, j, ODRIVE_GET_IQ, v));
			a.next_iq_s = next_due(a.next_iq_s, s.o.iq_s, t_s);
		}
	}
}

} // namespace motorsim
