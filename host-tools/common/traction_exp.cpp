// traction_exp.cpp - the traction experiment's timeline (traction_exp.hpp).
#include "traction_exp.hpp"

#include <cmath>
#include <stdexcept>

#include "omni4/command_t.hpp"

namespace omni4
{

std::array<double, 4> traction_pattern(const std::string &direction)
{
	if (direction == "diag") {
		const auto v = drive_pattern("v"), vn = drive_pattern("vn");
		return {v[0] + vn[0], v[1] + vn[1], v[2] + vn[2], v[3] + vn[3]};
	}
	return drive_pattern(direction);
}

std::vector<double> traction_levels(const TractionSeqOptions &opt)
{
	std::vector<double> levels;
	if (!(opt.level0_v > 0) || !(opt.growth > 1) || !(opt.cap_v >= opt.level0_v))
		throw std::invalid_argument(
		    "traction levels: need 0 < first level <= cap, growth > 1");
	for (double u = opt.level0_v; u <= opt.cap_v * (1 + 1e-9); u *= opt.growth)
		levels.push_back(u);
	return levels;
}

std::vector<Phase> traction_sequence(const TractionSeqOptions &opt)
{
	std::vector<Phase> seq;
	const std::vector<double> levels = traction_levels(opt);
	for (const std::string &dir : opt.directions) {
		const auto pattern = traction_pattern(dir);
		for (double level : levels) {
			Phase p;
			p.duration_s = opt.ramp_s + opt.hold_s;
			p.mode = command_t::MODE_VOLTAGE;
			for (int j = 0; j < 4; ++j)
				p.voltage[j] = pattern[j] * level;
			p.ramp_s = opt.ramp_s;
			p.mark_kind = "traction";
			p.mark_direction = dir;
			p.mark_level = level;
			seq.push_back(p);
			Phase c;
			c.duration_s = opt.settle_s;
			c.mode = command_t::MODE_COAST;
			c.end_mark = true;
			seq.push_back(c);
			Phase clear;
			clear.duration_s = 0.05;
			clear.mode = command_t::MODE_CLEAR_FAULT;
			seq.push_back(clear);
		}
	}
	return seq;
}

std::vector<Phase> selected_sequence(const std::vector<std::string> &only, double hold_s,
                                     double settle_s)
{
	SequenceOptions full;
	full.hold_s = hold_s;
	full.settle_s = settle_s;
	if (only.empty())
		return paper_sequence(full);
	SequenceOptions pick = full;
	pick.rotation_levels.clear();
	pick.coast_levels.clear();
	pick.motor_levels.clear();
	pick.step_levels.clear();
	bool traction = false;
	for (const std::string &k : only) {
		if (k == "steady_rotation")
			pick.rotation_levels = full.rotation_levels;
		else if (k == "coast")
			pick.coast_levels = full.coast_levels;
		else if (k == "motor")
			pick.motor_levels = full.motor_levels;
		else if (k == "step")
			pick.step_levels = full.step_levels;
		else if (k == "traction")
			traction = true;
		else
			throw std::invalid_argument("unknown experiment kind '" + k + "'");
	}
	std::vector<Phase> seq = paper_sequence(pick); // ends with a short IDLE
	if (traction) {
		const std::vector<Phase> t = traction_sequence();
		seq.insert(seq.end() - 1, t.begin(), t.end());
	}
	return seq;
}

} // namespace omni4
