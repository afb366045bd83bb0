// vesc_sim.cpp - four simulated VESCs (VESC CAN-Bus Communication, documentation/comm_can.md of
// github.com/vedderb/bldc): SET_DUTY, SET_CURRENT, SET_CURRENT_BRAKE in; STATUS_1, STATUS_4,
// STATUS_5 out; the 0.5 s command timeout that releases the motor; a fault code (mc_fault_code)
// asked for with COMM_GET_VALUES_SELECTIVE in a PROCESS_SHORT_BUFFER (comm_can.c, commands.c).
#include <algorithm>
#include <cmath>

#include "drive_sim.hpp"

namespace motorsim
{
namespace
{

constexpr double kTwoPi = 6.283185307179586;
constexpr uint32_t kBroadcastId = 255;        // every controller (the firmware's reading)
constexpr uint8_t kGetValuesSelective = 50;   // COMM_GET_VALUES_SELECTIVE (datatypes.h)
constexpr uint32_t kMaskFaultCode = 1u << 15; // its mask bit of the fault code (one byte)

// comm_can.md: "signed 32-bit, big-endian" payloads; value = raw / scale.
int32_t be_i32(const uint8_t *p)
{
	const uint32_t u = (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
	return static_cast<int32_t>(u);
}

void put_be(uint8_t *p, int64_t raw, int bytes)
{
	const auto u = static_cast<uint64_t>(raw);
	for (int i = 0; i < bytes; ++i)
		p[i] = static_cast<uint8_t>(u >> (8 * (bytes - 1 - i)));
}

int64_t scaled(double x, double scale, int64_t lim)
{
	const double r = std::nearbyint(x * scale);
	return r > lim ? lim : r < -lim - 1 ? -lim - 1 : static_cast<int64_t>(r);
}

omni4_can_frame status_frame(uint8_t cmd, int id)
{
	omni4_can_frame f{};
	f.id = OMNI4_CAN_EFF_FLAG | (uint32_t)cmd << 8 | static_cast<uint32_t>(id);
	f.dlc = 8;
	return f;
}

// PROCESS_SHORT_BUFFER: [sender id, 0 = process and reply, packet...]. The one packet simulated:
// COMM_GET_VALUES_SELECTIVE with the fault code alone in its mask (big-endian uint32).
void take_packet(VescDrive &d, const omni4_can_frame &f)
{
	if (f.dlc == 7 && f.data[1] == 0 && f.data[2] == kGetValuesSelective &&
	    static_cast<uint32_t>(be_i32(f.data + 3)) == kMaskFaultCode)
		d.reply_to = f.data[0];
}

void take(VescDrive &d, uint8_t cmd, int32_t raw, double t_s)
{
	switch (cmd) {
	case VESC_SET_DUTY:
		d.mode = VescMode::duty;
		d.value = std::fmax(-1.0, std::fmin(1.0, raw / 100000.0));
		break;
	case VESC_SET_CURRENT:
		d.mode = VescMode::current;
		d.value = raw / 1000.0;
		break;
	case VESC_SET_CURRENT_BRAKE:
		d.mode = VescMode::brake;
		d.value = std::fabs(raw / 1000.0);
		break;
	default:
		return; // SET_RPM and the rest: not simulated, and no refresh of the timeout
	}
	d.last_cmd_s = t_s;
}

// The motor voltage of drive j in its mode (released: no current).
double drive_voltage(const VescSim &s, int j, const DriveView &v)
{
	const VescDrive &d = s.d[j];
	const double w = v.motor_rad_s[j];
	switch (d.mode) {
	case VescMode::duty:
		return d.value * v.supply_v;
	case VescMode::current:
		return current_loop_voltage(s.m, j, d.value, w, v.supply_v);
	case VescMode::brake: // against the motion; none at rest
		return current_loop_voltage(s.m, j, -std::copysign(d.value, w) * (w != 0), w,
		                            v.supply_v);
	case VescMode::released:
		break;
	}
	return coast_voltage(s.m, j, w);
}

} // namespace

double vesc_erpm(double motor_rad_s, int pole_pairs)
{
	return motor_rad_s * pole_pairs * 60.0 / kTwoPi;
}

void vesc_sim_init(VescSim &s, const VescOptions &o, const Motors &m)
{
	s = VescSim{};
	s.o = o;
	s.m = m;
}

void vesc_sim_receive(VescSim &s, const omni4_can_frame &f, double t_s)
{
	if (!(f.id & OMNI4_CAN_EFF_FLAG) || (f.id & OMNI4_CAN_RTR_FLAG) || f.dlc < 4)
		return;
	const uint32_t id = f.id & OMNI4_CAN_EFF_MASK;
	if (id >> 16) // bits 28-16 unused
		return;
	const auto cmd = static_cast<uint8_t>(id >> 8);
	const uint32_t to = id & 0xFF;
	for (int j = 0; j < 4; ++j) {
		if (s.d[j].dead || (to != static_cast<uint32_t>(s.o.ids[j]) && to != kBroadcastId))
			continue;
		if (cmd == VESC_PROCESS_SHORT_BUFFER)
			take_packet(s.d[j], f);
		else
			take(s.d[j], cmd, be_i32(f.data), t_s);
	}
}

DriveOut vesc_sim_step(VescSim &s, double t_s, const DriveView &v)
{
	const double dt = s.last_step_s < 0 ? 0 : t_s - s.last_step_s;
	s.last_step_s = t_s;
	if (s.o.fault.at_s >= 0 && t_s >= s.o.fault.at_s) {
		VescDrive &f = s.d[s.o.fault.wheel];
		f.dead = s.o.fault_code == 0;
		f.fault_code = s.o.fault_code;
	}
	DriveOut out{};
	for (int j = 0; j < 4; ++j) {
		VescDrive &d = s.d[j];
		if (d.dead || d.fault_code ||
		    (d.mode != VescMode::released && t_s - d.last_cmd_s > s.o.timeout_s))
			d.mode = VescMode::released; // duty 0: the motor coasts
		out.u_v[j] = drive_voltage(s, j, v);
		out.driven |= d.mode != VescMode::released;
		d.duty = d.mode == VescMode::released || v.supply_v <= 0
		             ? 0.0
		             : std::fmax(-1.0, std::fmin(1.0, out.u_v[j] / v.supply_v));
		// 6 tachometer steps per electrical revolution
		d.tacho_steps += v.motor_rad_s[j] * s.o.pole_pairs / kTwoPi * 6.0 * dt;
	}
	return out;
}

namespace
{

// The reply to a fault code request: PROCESS_SHORT_BUFFER to the asker, [own id, 1 = a reply,
// packet id, mask, the code].
omni4_can_frame fault_reply(int own_id, int to, int code)
{
	omni4_can_frame f{};
	f.id = OMNI4_CAN_EFF_FLAG | (uint32_t)VESC_PROCESS_SHORT_BUFFER << 8 |
	       static_cast<uint32_t>(to);
	f.dlc = 8;
	f.data[0] = static_cast<uint8_t>(own_id);
	f.data[1] = 1;
	f.data[2] = kGetValuesSelective;
	put_be(f.data + 3, kMaskFaultCode, 4);
	f.data[7] = static_cast<uint8_t>(code);
	return f;
}

} // namespace

void vesc_sim_emit(VescSim &s, const DriveView &v, Frames &out)
{
	const bool status = s.periods++ % std::max(1, s.o.status_every) == 0;
	for (int j = 0; j < 4; ++j) {
		VescDrive &d = s.d[j];
		if (d.dead)
			continue;
		if (d.reply_to >= 0)
			out.push_back(fault_reply(s.o.ids[j], d.reply_to, d.fault_code));
		d.reply_to = -1;
		if (!status)
			continue;
		const double i_motor = d.mode == VescMode::released ? 0.0 : v.current_a[j];
		omni4_can_frame f = status_frame(VESC_STATUS_1, s.o.ids[j]);
		put_be(f.data, scaled(vesc_erpm(v.motor_rad_s[j], s.o.pole_pairs), 1, INT32_MAX),
		       4);
		put_be(f.data + 4, scaled(i_motor, 10, INT16_MAX), 2);
		put_be(f.data + 6, scaled(d.duty, 1000, INT16_MAX), 2);
		out.push_back(f);
		f = status_frame(VESC_STATUS_4, s.o.ids[j]);
		put_be(f.data, scaled(30.0, 10, INT16_MAX), 2);     // FET temperature [degC]
		put_be(f.data + 2, scaled(30.0, 10, INT16_MAX), 2); // motor temperature
		put_be(f.data + 4, scaled(d.duty * i_motor, 10, INT16_MAX), 2); // input current
		out.push_back(f);                                               // PID position 0
		f = status_frame(VESC_STATUS_5, s.o.ids[j]);
		put_be(f.data, scaled(d.tacho_steps, 1, INT32_MAX), 4);
		put_be(f.data + 4, scaled(v.supply_v, 10, INT16_MAX), 2);
		out.push_back(f); // bytes 6-7 reserved, 0
	}
}

} // namespace motorsim
