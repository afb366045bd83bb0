// experiments.cpp - the paper's experiment sequence (see experiments.hpp).
#include "experiments.hpp"
#include "omni4/lcmtypes/channels.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "omni4/command_t.hpp"
#include "omni4/experiment_t.hpp"

namespace omni4
{

std::array<double, 4> drive_pattern(const std::string &direction)
{
	if (direction == "v")
		return {0, -1, 0, 1};
	if (direction == "vn")
		return {1, 0, -1, 0};
	if (direction == "w")
		return {1, 1, 1, 1};
	throw std::invalid_argument("unknown direction '" + direction + "' (v, vn or w)");
}

std::array<double, 4> drive_pattern(const std::string &direction, const Layout &layout)
{
	if (layout.paper)
		return drive_pattern(direction);
	const int axis = direction == "v" ? 0 : direction == "vn" ? 1 : direction == "w" ? 2 : -1;
	if (axis < 0)
		throw std::invalid_argument("unknown direction '" + direction + "' (v, vn or w)");
	std::array<double, 4> p{};
	double peak = 0;
	for (int j = 0; j < layout.n; ++j) {
		p[j] = layout.ph.split[j][axis];
		peak = std::max(peak, std::fabs(p[j]));
	}
	for (double &x : p)
		x /= peak;
	return p;
}

namespace
{

std::array<double, 4> scaled(const std::string &dir, double level, const Layout &layout)
{
	auto p = drive_pattern(dir, layout);
	for (double &x : p)
		x *= level;
	return p;
}

Phase voltage_phase(double dur, const std::array<double, 4> &u, double ramp)
{
	Phase p;
	p.duration_s = dur;
	p.mode = command_t::MODE_VOLTAGE;
	p.voltage = u;
	p.ramp_s = ramp;
	return p;
}

Phase coast_phase(double dur)
{
	Phase p;
	p.duration_s = dur;
	p.mode = command_t::MODE_COAST;
	return p;
}

// Close a measured segment and let the robot come to rest.
void settle(std::vector<Phase> &seq, double settle_s)
{
	Phase p = coast_phase(settle_s);
	p.end_mark = true;
	seq.push_back(p);
}

// One marked run: a voltage step with an initial ramp along dir, held, then coasting to rest.
void ramped_run(std::vector<Phase> &seq, const SequenceOptions &opt, const char *kind,
                const char *dir, double level)
{
	Phase p =
	    voltage_phase(opt.ramp_s + opt.hold_s, scaled(dir, level, opt.layout), opt.ramp_s);
	p.mark_kind = kind;
	p.mark_direction = dir;
	p.mark_level = level;
	seq.push_back(p);
	settle(seq, opt.settle_s);
}

// One motor-test run: motor j alone at u [V] (ramped, held, then coasting to rest), the others
// at 0 V with the bridges driven. It alone carries the robot's friction and the other motors'
// back-EMF braking: the whole current is its own, so eq 22 sees a large current at each load.
// Its direction is "" (one wheel drives no single robot axis; the voltages say which motor).
void motor_run(std::vector<Phase> &seq, const SequenceOptions &opt, int j, double u)
{
	std::array<double, 4> volts{};
	volts[j] = u;
	Phase p = voltage_phase(opt.ramp_s + opt.hold_s, volts, opt.ramp_s);
	p.mark_kind = "motor";
	p.mark_direction = "";
	p.mark_level = u;
	seq.push_back(p);
	settle(seq, opt.settle_s);
}

} // namespace

std::vector<Phase> paper_sequence(const SequenceOptions &opt)
{
	std::vector<Phase> seq;
	// Experiment 1: steady rotation at several voltages (ramped to avoid wheel slip).
	for (double level : opt.rotation_levels)
		ramped_run(seq, opt, "steady_rotation", "w", level);
	// Experiment 2: push off with the motors, then null traction (H-bridges off) and coast.
	for (const char *dir : {"v", "vn", "w"}) {
		for (double level : opt.coast_levels) {
			seq.push_back(voltage_phase(opt.ramp_s + 1.5,
			                            scaled(dir, level, opt.layout), opt.ramp_s));
			Phase c = coast_phase(opt.settle_s + 1.0);
			c.mark_kind = "coast";
			c.mark_direction = dir;
			c.mark_level = level;
			seq.push_back(c);
			settle(seq, 0.2);
		}
	}
	// Motor test (eqs 21-22): constant voltage on one motor at a time, the other three at 0 V.
	for (int j = 0; j < opt.layout.n; ++j)
		for (double level : opt.motor_levels)
			for (double sign : {1.0, -1.0})
				motor_run(seq, opt, j, sign * level);
	// Experiment 3: step voltage with an initial acceleration ramp along v, vn, w.
	for (const char *dir : {"v", "vn", "w"})
		for (double level : opt.step_levels)
			ramped_run(seq, opt, "step", dir, level);
	Phase idle;
	idle.duration_s = 0.1;
	idle.mode = command_t::MODE_IDLE;
	seq.push_back(idle);
	return seq;
}

double total_duration_s(const std::vector<Phase> &phases)
{
	double t = 0;
	for (const Phase &p : phases)
		t += p.duration_s;
	return t;
}

SequencePlayer::SequencePlayer(std::vector<Phase> phases, double keepalive_s)
    : phases_(std::move(phases)), keepalive_s_(keepalive_s)
{
}

namespace
{

template <typename T> std::vector<uint8_t> encode(const T &msg)
{
	std::vector<uint8_t> buf(msg.getEncodedSize());
	msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
	return buf;
}

} // namespace

std::vector<uint8_t> encode_mark(int64_t utime, const std::string &kind, const std::string &dir,
                                 double level)
{
	experiment_t m;
	m.utime = utime;
	m.kind = kind;
	m.direction = dir;
	m.level = level;
	return encode(m);
}

std::vector<uint8_t> encode_command(int64_t utime, int64_t seq, int8_t mode)
{
	command_t c{};
	c.utime = utime;
	c.seq = seq;
	c.mode = mode;
	return encode(c);
}

std::vector<uint8_t> SequencePlayer::stop_command(int64_t utime, int64_t seq)
{
	return encode_command(utime, seq, command_t::MODE_IDLE);
}

void SequencePlayer::skip_rest()
{
	if (!current() || phases_[index_].group.empty())
		return;
	const std::string g = phases_[index_].group;
	size_t j = index_ + 1;
	while (j < phases_.size() && phases_[j].group == g && phases_[j].mark_kind.empty())
		++j; // the present run's coast and the rest of it
	for (; j < phases_.size() && phases_[j].group == g; ++j)
		phases_[j].duration_s = 0;
}

SequencePlayer::Output SequencePlayer::due(double t_s, int64_t utime)
{
	Output out;
	bool entered = false;
	if (!started_) {
		started_ = true;
		phase_start_s_ = t_s;
		entered = true;
	}
	while (index_ < phases_.size() && t_s >= phase_start_s_ + phases_[index_].duration_s) {
		phase_start_s_ += phases_[index_].duration_s;
		++index_;
		entered = true;
	}
	if (index_ >= phases_.size())
		return out;
	const Phase &p = phases_[index_];
	if (entered) {
		if (p.end_mark)
			out.marks.push_back(encode_mark(utime, OMNI4_MARK_END));
		if (!p.mark_kind.empty())
			out.marks.push_back(
			    encode_mark(utime, p.mark_kind, p.mark_direction, p.mark_level));
	}
	if (entered || t_s - last_sent_s_ >= keepalive_s_) {
		command_t c{};
		c.utime = utime;
		c.seq = seq_++;
		c.mode = p.mode;
		for (int j = 0; j < 4; ++j)
			c.voltage[j] = p.voltage[j];
		for (int k = 0; k < 3; ++k)
			c.velocity[k] = p.velocity[k];
		c.ramp_s = p.ramp_s;
		out.command = encode(c);
		out.has_command = true;
		last_sent_s_ = t_s;
	}
	return out;
}

} // namespace omni4
