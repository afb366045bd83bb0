// traction_exp.cpp - the traction experiment's timeline (traction_exp.hpp).
#include "traction_exp.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "omni4/command_t.hpp"

extern "C" {
#include "omni4/model/consts.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/plant.h"
#include "omni4/core/vocab.h"
}

namespace omni4
{

std::array<double, 4> traction_pattern(const std::string &direction, const Layout &layout)
{
	if (direction == "diag") {
		const auto v = drive_pattern("v", layout), vn = drive_pattern("vn", layout);
		std::array<double, 4> d{v[0] + vn[0], v[1] + vn[1], v[2] + vn[2], v[3] + vn[3]};
		double peak = 0; // another layout's sum: scaled to 1 V at its largest wheel
		for (double x : d)
			peak = std::max(peak, std::fabs(x));
		for (double &x : d)
			x = layout.paper || peak == 0 ? x : x / peak;
		return d;
	}
	return drive_pattern(direction, layout);
}

bool TractionWatch::step(SequencePlayer &player, int32_t est_flags)
{
	const Phase *p = player.current();
	if (!p || p->group.rfind("traction/", 0) != 0 || p->mode == command_t::MODE_CLEAR_FAULT)
		return false;
	if (p->mark_kind == "traction")
		level_ = p->mark_level;
	if ((est_flags & EST_FLAG_SLIP) && !first_slip_.count(p->group))
		first_slip_[p->group] = level_;
	const auto f = first_slip_.find(p->group);
	if (f == first_slip_.end())
		return false;
	if (level_ < factor(p->group.substr(9)) * f->second * (1 - 1e-9))
		return false;
	player.skip_rest();
	return true;
}

double TractionWatch::factor(const std::string &direction) const
{
	if (direction == "diag")
		return kDiagonalFactor;
	return !paper_ && direction == "w" ? kRotationFactor : 1.0;
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
		const auto pattern = traction_pattern(dir, opt.layout);
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
			p.group = "traction/" + dir;
			seq.push_back(p);
			Phase c;
			c.duration_s = opt.settle_s;
			c.mode = command_t::MODE_COAST;
			c.end_mark = true;
			c.group = p.group;
			seq.push_back(c);
			Phase clear;
			clear.duration_s = 0.05;
			clear.mode = command_t::MODE_CLEAR_FAULT;
			clear.group = p.group;
			seq.push_back(clear);
		}
	}
	return seq;
}

namespace
{

// Each wheel's load at rest over a quarter of the weight (the paper's layout: 1 each; another:
// model/wheels.h's least-norm loads, as the plant's floor), so that a hold given for a
// quarter-weight wheel is each wheel's hold times this.
std::array<double, 4> load_shares(const Layout &L)
{
	std::array<double, 4> share{1, 1, 1, 1};
	if (!L.paper)
		for (int j = 0; j < 4; ++j)
			share[j] = j < L.n ? 4 * L.geom.lmap[j][0] : 0.0;
	return share;
}

// Peak |wheel force| [N] of a voltage ramp from rest to u over ramp_s, held until run_s, on the
// layout's plant: each wheel's over its load's share of a quarter of the weight (load_shares).
double peak_force(const model_params &p, const Layout &L, const std::array<double, 4> &u,
                  double ramp_s, double run_s)
{
	struct plant pl;
	if (plant_init(&pl, &p) || (!L.paper && plant_set_geom(&pl, &L.geom)))
		return 0;
	const std::array<double, 4> share = load_shares(L);
	const double dt = 1e-3;
	double peak = 0;
	for (double t = dt; t <= run_s + 1e-9; t += dt) {
		const double k = std::min(1.0, t / ramp_s);
		const double v[4] = {k * u[0], k * u[1], k * u[2], k * u[3]};
		plant_step(&pl, v, true, dt);
		double f[4];
		dyn_wheel_forces(&p, pl.current_a, f); // eqs 12-13
		for (int j = 0; j < 4; ++j)
			if (share[j] > 0)
				peak = std::max(peak, L.paper ? std::fabs(f[j])
				                              : std::fabs(f[j]) / share[j]);
	}
	return peak;
}

// The largest factor (at most 1) on the voltages u whose run, ramped over ramp_s and held until
// run_s, asks no wheel for more than hold_n [N] (bisection, to 0.1 %).
double holding_scale(const model_params &p, const Layout &L, const std::array<double, 4> &u,
                     double ramp_s, double run_s, double hold_n)
{
	const auto times = [&](double s) {
		std::array<double, 4> v = u;
		for (double &x : v)
			x *= s;
		return v;
	};
	if (peak_force(p, L, u, ramp_s, run_s) <= hold_n)
		return 1.0;
	double lo = 0, hi = 1;
	for (int k = 0; k < 10; ++k) {
		const double mid = 0.5 * (lo + hi);
		(peak_force(p, L, times(mid), ramp_s, run_s) <= hold_n ? lo : hi) = mid;
	}
	return lo;
}

// A motor-test run drives one wheel against the other three's back-EMF braking, and its
// steady force alone may be more than the floor holds, however long the ramp. Then every
// motor run is scaled down by the one factor that keeps the hardest under hold_n with the
// longest ramp: the runs' loads stay apart (eq 22 needs different loads).
void scale_motor_runs(std::vector<Phase> &phases, const model_params &p, const Layout &L,
                      double hold_n, double longest_ramp_s)
{
	double s = 1.0;
	for (const Phase &ph : phases) {
		if (ph.mark_kind != "motor" || ph.mode != command_t::MODE_VOLTAGE)
			continue;
		const double run_s = longest_ramp_s + std::min(ph.duration_s - ph.ramp_s, 1.0);
		std::array<double, 4> u = ph.voltage;
		for (double &x : u)
			x *= s;
		s *= holding_scale(p, L, u, longest_ramp_s, run_s, hold_n);
	}
	if (s >= 1.0)
		return;
	for (Phase &ph : phases) {
		if (ph.mark_kind != "motor" || ph.mode != command_t::MODE_VOLTAGE)
			continue;
		for (double &x : ph.voltage)
			x *= s;
		ph.mark_level *= s;
	}
}

} // namespace

void limit_ramps(std::vector<Phase> &phases, const model_params &p, double hold_n,
                 const Layout &layout)
{
	static const double ramps[] = {0.5, 0.75, 1, 1.5, 2, 3, 4, 6};
	if (!(hold_n > 0))
		return;
	scale_motor_runs(phases, p, layout, hold_n, ramps[std::size(ramps) - 1]);
	bool at_rest = true; // the sequence starts at rest; coasting to rest follows each run
	for (Phase &ph : phases) {
		const bool from_rest = at_rest;
		at_rest = ph.mode != command_t::MODE_VOLTAGE && (at_rest || ph.duration_s >= 0.2);
		if (ph.mode != command_t::MODE_VOLTAGE || !from_rest ||
		    ph.mark_kind == "traction" || ph.ramp_s <= 0)
			continue;
		const double hold = ph.duration_s - ph.ramp_s;
		for (double r : ramps) {
			if (r < ph.ramp_s)
				continue;
			const double grown = r - ph.ramp_s;
			ph.ramp_s = r;
			ph.duration_s += grown;
			if (peak_force(p, layout, ph.voltage, r, r + std::min(hold, 1.0)) <= hold_n)
				break;
		}
	}
}

double traction_hold_n(const model_params &p, double mu, double margin)
{
	return mu > 0 ? (1 - margin) * mu * p.M * MODEL_G_M_S2 / 4 : 0.0;
}

std::vector<Phase> selected_sequence(const std::vector<std::string> &only, double hold_s,
                                     double settle_s, const Layout &layout)
{
	SequenceOptions full;
	full.hold_s = hold_s;
	full.settle_s = settle_s;
	full.layout = layout;
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
		TractionSeqOptions topt;
		topt.layout = layout;
		const std::vector<Phase> t = traction_sequence(topt);
		seq.insert(seq.end() - 1, t.begin(), t.end());
	}
	return seq;
}

} // namespace omni4
