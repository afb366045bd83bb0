// windows.cpp - steady, coast-down and step windows found in the data (see windows.hpp).
#include "windows.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "omni4/core/vocab.h"

namespace omni4
{

bool driven_mode(int8_t mode)
{
	return mode_drives(mode);
}

double seg_time(const Segment &s, size_t k)
{
	return (s.log->motors[k].utime - s.t0) * 1e-6;
}

namespace
{

std::string fmt(const char *f, double a, double b = 0, double c = 0)
{
	char buf[200];
	std::snprintf(buf, sizeof(buf), f, a, b, c);
	return buf;
}

double span_s(const std::vector<MotorsSample> &m, size_t a, size_t b)
{
	return b > a ? (m[b - 1].utime - m[a].utime) * 1e-6 : 0.0;
}

// Maximal runs [a, b) of samples whose driven state equals `driven`.
std::vector<std::pair<size_t, size_t>> mode_runs(const Segment &s, bool driven)
{
	std::vector<std::pair<size_t, size_t>> out;
	const auto &m = s.log->motors;
	size_t k = s.m0;
	while (k < s.m1) {
		if (driven_mode(m[k].mode) != driven) {
			++k;
			continue;
		}
		const size_t a = k;
		while (k < s.m1 && driven_mode(m[k].mode) == driven)
			++k;
		out.push_back({a, k});
	}
	return out;
}

// The mean raw encoder velocity over the block of samples starting at a.
struct Block {
	size_t a;
	std::array<double, 3> x;
};

// Final value ref: the last two blocks (the first two of blocks, which run backwards). The
// tolerance tol grows by 3 standard deviations of a block mean's measurement noise, estimated
// from the hold itself: the lower quartile of the differences of neighbouring blocks
// (|N(0, s)| has its quartile at 0.3186 s) is blind to a transient over up to 3/4 of the hold;
// a difference of two block means has s = sqrt(2) sigma.
void final_value(const std::vector<Block> &blocks, const WindowOptions &opt,
                 std::array<double, 3> &ref, std::array<double, 3> &tol)
{
	std::vector<double> diff(blocks.size() - 1);
	for (int ax = 0; ax < 3; ++ax) {
		ref[ax] = 0.5 * (blocks[0].x[ax] + blocks[1].x[ax]);
		for (size_t q = 0; q + 1 < blocks.size(); ++q)
			diff[q] = std::abs(blocks[q].x[ax] - blocks[q + 1].x[ax]);
		std::nth_element(diff.begin(), diff.begin() + diff.size() / 4, diff.end());
		const double noise = diff[diff.size() / 4] / 0.3186 / std::sqrt(2.0);
		tol[ax] = opt.steady_tol * std::abs(ref[ax]) +
		          (ax == 2 ? opt.steady_floor_w : opt.steady_floor_v) + 3 * noise;
	}
}

// The settled tail of a constant-voltage hold [a, b), or a rejection.
void settle(const Segment &s, const EncoderTrack &enc, size_t a, size_t b, const WindowOptions &opt,
            SegmentWindows &out)
{
	const auto &m = s.log->motors;
	const size_t nb =
	    std::max<size_t>(5, static_cast<size_t>(std::lround(opt.block_s / enc.dt)));
	// Block means of the raw encoder velocity, from the end backwards (so the last block is
	// full).
	std::vector<Block> blocks;
	for (size_t e = b; e >= a + nb; e -= nb) {
		std::array<double, 3> x{};
		for (size_t k = e - nb; k < e; ++k)
			for (int ax = 0; ax < 3; ++ax)
				x[ax] += enc.raw[k][ax] / static_cast<double>(nb);
		blocks.push_back({e - nb, x});
	}
	const double hold = span_s(m, a, b);
	if (blocks.size() < 2) {
		out.rejected.push_back({"steady window", seg_time(s, a), seg_time(s, b - 1),
		                        fmt("hold of %.2f s too short to test", hold)});
		return;
	}
	std::array<double, 3> ref{}, tol{};
	final_value(blocks, opt, ref, tol);
	size_t keep = 0;
	for (const Block &bl : blocks) {
		bool within = true;
		for (int ax = 0; ax < 3; ++ax)
			within = within && std::abs(bl.x[ax] - ref[ax]) <= tol[ax];
		if (!within)
			break;
		++keep;
	}
	const size_t start = keep ? blocks[keep - 1].a : b;
	const double settled = span_s(m, start, b);
	if (settled + enc.dt < opt.steady_min_s) {
		out.rejected.push_back({"steady window", seg_time(s, a), seg_time(s, b - 1),
		                        fmt("speed not settled: within %.1f %% of its final value "
		                            "only for the last %.2f s of "
		                            "a %.2f s hold",
		                            100 * opt.steady_tol, settled, hold) +
		                            fmt(" (need %.2f s)", opt.steady_min_s)});
		return;
	}
	out.steady.push_back({start, b, 1});
}

void steady_windows(const Segment &s, const EncoderTrack &enc, const WindowOptions &opt,
                    SegmentWindows &out)
{
	const auto &m = s.log->motors;
	size_t holds = 0;
	double longest = 0;
	for (const auto &[a, b] : mode_runs(s, true)) {
		// Split the driven run into pieces of constant applied voltage: every channel stays
		// in a band no wider than the tolerance (a ramp of any slope leaves it).
		size_t p = a;
		std::array<float, 4> lo = m[a].u, hi = m[a].u;
		for (size_t k = a + 1; k <= b; ++k) {
			bool same = k < b;
			for (int j = 0; same && j < 4; ++j) {
				const double l = std::min(lo[j], m[k].u[j]),
				             h = std::max(hi[j], m[k].u[j]);
				same = h - l <=
				       opt.volt_tol_v +
				           opt.volt_tol_rel * std::max(std::abs(l), std::abs(h));
			}
			if (same) {
				for (int j = 0; j < 4; ++j) {
					lo[j] = std::min(lo[j], m[k].u[j]);
					hi[j] = std::max(hi[j], m[k].u[j]);
				}
				continue;
			}
			if (k < b)
				lo = hi = m[k].u;
			const double dur = span_s(m, p, k);
			longest = std::max(longest, dur);
			if (dur + enc.dt >= opt.steady_min_s) {
				++holds;
				settle(s, enc, p, k, opt, out);
			}
			p = k;
		}
	}
	if (holds == 0)
		out.rejected.push_back(
		    {"segment", 0, seg_time(s, s.m1 - 1),
		     fmt("no constant-voltage hold of %.2f s or more (longest %.2f s)",
		         opt.steady_min_s, longest)});
}

// From the first sample k of a motion along axis (sign: its direction) in [k, b): follow the
// speed up to its peak; the free coast starts once it has fallen 3 % below the peak and 50 ms
// have passed (a push by hand lets go gradually). start == b: no free coast (stopped: the
// robot stopped again before one could be seen).
struct CoastStart {
	size_t peak, start;
	bool stopped;
};

CoastStart free_coast_start(const std::vector<MotorsSample> &m, const EncoderTrack &enc, int axis,
                            double sign, double stop, size_t k, size_t b)
{
	CoastStart c{k, b, false};
	for (size_t q = k; q < b; ++q) {
		if (!enc.ok[q])
			continue;
		const double x = sign * enc.x[q][axis];
		if (x > sign * enc.x[c.peak][axis])
			c.peak = q;
		if (x <= 0.97 * sign * enc.x[c.peak][axis] &&
		    (m[q].utime - m[c.peak].utime) >= 50000) {
			c.start = q;
			break;
		}
		if (x < stop) { // stopped again before a free coast could be seen
			c.stopped = true;
			break;
		}
	}
	return c;
}

// The coast-down [start, end) of a motion with peak speed peak_x: kept, or rejected as too
// slow or too short.
void judge_coast(const Segment &s, size_t start, size_t end, double sign, double peak_x,
                 double stop, const WindowOptions &opt, SegmentWindows &out)
{
	const double dur = span_s(s.log->motors, start, end);
	if (peak_x < 3 * stop) {
		out.rejected.push_back({"coast-down", seg_time(s, start), seg_time(s, end - 1),
		                        fmt("too slow: peak %.3g, need %.3g", peak_x, 3 * stop)});
	} else if (dur < opt.coast_min_s) {
		out.rejected.push_back({"coast-down", seg_time(s, start), seg_time(s, end - 1),
		                        fmt("too short: %.2f s of free deceleration, need %.2f s",
		                            dur, opt.coast_min_s)});
	} else {
		out.coast.push_back({start, end, sign});
	}
}

void coast_windows(const Segment &s, const EncoderTrack &enc, int axis, const WindowOptions &opt,
                   SegmentWindows &out)
{
	const auto &m = s.log->motors;
	const double stop = kStopSpeed[axis];
	bool moved = false;
	for (const auto &[a, b] : mode_runs(s, false)) {
		size_t k = a;
		while (k < b) {
			// Motion: the first valid sample above twice the stop threshold (a robot
			// that has just stopped may hover at the threshold: that is not a new
			// motion).
			while (k < b && !(enc.ok[k] && std::abs(enc.x[k][axis]) > 2 * stop))
				++k;
			if (k >= b)
				break;
			moved = true;
			const double sign = enc.x[k][axis] > 0 ? 1.0 : -1.0;
			const CoastStart c = free_coast_start(m, enc, axis, sign, stop, k, b);
			const double peak_x = sign * enc.x[c.peak][axis];
			if (c.start >= b) {
				out.rejected.push_back(
				    {"coast-down", seg_time(s, k), seg_time(s, b - 1),
				     c.stopped
				         ? fmt("stopped within 50 ms of its peak of %.3g", peak_x)
					 : fmt("no free deceleration after the peak of %.3g "
					       "(bridges driven again or the segment ends)",
					       peak_x)});
				k = std::max(c.peak + 1, k + 1);
				while (k < b && enc.ok[k] && std::abs(enc.x[k][axis]) > stop)
					++k;
				continue;
			}
			size_t end = c.start;
			while (end < b && (!enc.ok[end] || sign * enc.x[end][axis] >= stop))
				++end;
			judge_coast(s, c.start, end, sign, peak_x, stop, opt, out);
			k = end;
		}
	}
	if (!moved)
		out.rejected.push_back({"segment", 0, seg_time(s, s.m1 - 1),
		                        "no motion along the segment's axis with the bridges off"});
}

void step_windows(const Segment &s, const EncoderTrack &enc, int axis, const WindowOptions &opt,
                  SegmentWindows &out)
{
	const auto &m = s.log->motors;
	const auto runs = mode_runs(s, true);
	if (runs.empty()) {
		out.rejected.push_back({"segment", 0, seg_time(s, s.m1 - 1), "no driven samples"});
		return;
	}
	for (const auto &[a, b] : runs) {
		const double dur = span_s(m, a, b);
		double top = 0;
		size_t n_ok = 0;
		for (size_t k = a; k < b; ++k)
			if (enc.ok[k]) {
				top = std::max(top, std::abs(enc.x[k][axis]));
				++n_ok;
			}
		if (dur < opt.step_min_s)
			out.rejected.push_back(
			    {"step", seg_time(s, a), seg_time(s, b - 1),
			     fmt("drive of %.2f s too short, need %.2f s", dur, opt.step_min_s)});
		else if (top < 2 * kStopSpeed[axis] && 2 * n_ok < b - a)
			// (the smoothing runs only over evenly timed ticks: a loop late again and
			// again, or lost samples, leave too few to see the motion)
			out.rejected.push_back(
			    {"step", seg_time(s, a), seg_time(s, b - 1),
			     fmt("only %.0f of %.0f samples evenly timed (late ticks or lost "
			         "samples): the motion is not seen",
			         static_cast<double>(n_ok), static_cast<double>(b - a))});
		else if (top < 2 * kStopSpeed[axis])
			out.rejected.push_back(
			    {"step", seg_time(s, a), seg_time(s, b - 1),
			     fmt("the robot hardly moved along the axis (peak %.3g)", top)});
		else
			out.step.push_back({a, b, 1});
	}
}

} // namespace

SegmentWindows find_windows(const Segment &s, const EncoderTrack &enc, const WindowOptions &opt)
{
	SegmentWindows out;
	if (s.kind == "steady_rotation" || s.kind == "motor") {
		steady_windows(s, enc, opt, out);
		return out;
	}
	const int axis = find_axis(s.direction);
	if (axis < 0) {
		out.rejected.push_back({"segment", 0, seg_time(s, s.m1 - 1),
		                        "unknown direction '" + s.direction + "' (v, vn or w)"});
		return out;
	}
	if (s.kind == "coast")
		coast_windows(s, enc, axis, opt, out);
	else if (s.kind == "step")
		step_windows(s, enc, axis, opt, out);
	else
		out.rejected.push_back(
		    {"segment", 0, seg_time(s, s.m1 - 1), "unknown kind '" + s.kind + "'"});
	return out;
}

} // namespace omni4
