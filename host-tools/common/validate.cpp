// validate.cpp - model simulation against the logs.
#include "validate.hpp"

#include <cmath>
#include <map>

#include "regression.hpp"
#include "signals.hpp"
#include "windows.hpp"

extern "C" {
#include "omni4/model/plant.h"
}

namespace omni4
{

namespace
{

// Advance the plant tick by tick while the next tick is not after t [s]; the voltage logged at
// tick i acts until tick i + 1 (held across lost samples). i: the tick the plant state is at.
void advance(plant &pl, const std::vector<MotorsSample> &m, size_t &i, size_t end, double t)
{
	while (i + 1 < end && m[i + 1].utime * 1e-6 <= t + 1e-9) {
		const MotorsSample &ms = m[i];
		const double u[4] = {ms.u[0], ms.u[1], ms.u[2], ms.u[3]};
		plant_step(&pl, u, driven_mode(ms.mode), (m[i + 1].utime - ms.utime) * 1e-6);
		++i;
	}
}

// The points of the runs and their error sums per axis.
struct Errors {
	Validation &v;
	std::array<double, 3> sum{}, sum2{};

	void add(int axis, const ValidationPoint &pt)
	{
		const double e = pt.measured[axis] - pt.simulated[axis];
		AxisErrors &ax = v.axis[axis];
		ax.e_max = std::max(ax.e_max, std::abs(e));
		sum[axis] += e;
		sum2[axis] += e * e;
		++ax.n;
		v.points.push_back(pt);
	}
	// Mean and standard deviation of each axis's errors.
	void finish()
	{
		for (int a = 0; a < 3; ++a) {
			AxisErrors &ax = v.axis[a];
			if (!ax.n)
				continue;
			ax.e_mean = sum[a] / ax.n;
			ax.sigma = std::sqrt(std::max(0.0, sum2[a] / ax.n - ax.e_mean * ax.e_mean));
		}
	}
};

// One drive of segment si (window w, from sample k0), camera: the model's pose is sampled at
// the frame times and both pose series go through the same local-quadratic velocity estimator
// (+-0.4 s), so its smoothing acts on both alike and e is model error plus camera noise.
void compare_camera(plant &pl, const Segment &s, size_t si, int axis, const Window &w, size_t k0,
                    Errors &err)
{
	const auto &m = s.log->motors;
	const auto &pose = s.log->pose;
	const double ta = m[k0].utime * 1e-6, tb = m[w.m1 - 1].utime * 1e-6;
	std::vector<double> t, mx, my, mth, sx, sy, sth;
	size_t i = k0;
	for (const PoseSample &q : pose) {
		const double tq = q.utime * 1e-6;
		if (tq < ta || tq > tb)
			continue;
		if (t.empty()) { // the simulated pose starts at the first frame
			pl.pose[0] = q.x;
			pl.pose[1] = q.y;
			pl.pose[2] = q.theta;
		}
		advance(pl, m, i, w.m1, tq);
		t.push_back(tq);
		mx.push_back(q.x);
		my.push_back(q.y);
		mth.push_back(q.theta);
		sx.push_back(pl.pose[0]);
		sy.push_back(pl.pose[1]);
		sth.push_back(pl.pose[2]);
	}
	const double half = 0.4;
	const CameraTrack meas = pose_velocity(t, mx, my, mth, half);
	const CameraTrack sim = pose_velocity(t, sx, sy, sth, half);
	for (size_t q = 0; q < t.size(); ++q) // full windows only: no one-sided fits
		if (meas.ok[q] && sim.ok[q] && t[q] - half >= t.front() && t[q] + half <= t.back())
			err.add(axis, {si, s.direction, s.level, t[q] - s.t0 * 1e-6, meas.x[q],
			               sim.x[q]});
}

// One drive, encoders: compared only where the measured velocity's filter window lies inside
// the drive: one that reaches the samples after it (bridges off, the robot decelerating) or
// before it (at rest) mixes in what the model is not driven through here, and its last samples
// would set e_max.
void compare_encoder(plant &pl, const Segment &s, size_t si, int axis, const Window &w, size_t k0,
                     const EncoderTrack &enc, Errors &err)
{
	const auto &m = s.log->motors;
	const size_t h = static_cast<size_t>(enc.half);
	size_t i = k0;
	for (size_t k = k0; k < w.m1; ++k) {
		if (!enc.ok[k])
			continue;
		advance(pl, m, i, w.m1, m[k].utime * 1e-6);
		if (k < w.m0 + h || k + h >= w.m1)
			continue;
		err.add(axis, {si,
		               s.direction,
		               s.level,
		               (m[k].utime - s.t0) * 1e-6,
		               enc.x[k],
		               {pl.x[0], pl.x[1], pl.x[2]}});
	}
}

bool uniform_wheels(const model_params &p, const model_wheels &w)
{
	for (int j = 0; j < 4; ++j)
		if (w.r[j] != p.r || w.R[j] != p.R || w.Kv[j] != p.Kv || w.Kt[j] != p.Kt)
			return false;
	return true;
}

// The plant of p with w's drives as its motor and radius errors (the floor otherwise off).
void plant_of(plant &pl, const model_params &p, const model_wheels &w, bool uniform,
              const Layout &layout)
{
	if (plant_init(&pl, &p))
		throw IdentError("validate: parameters are not physical");
	if (!layout.paper && plant_set_geom(&pl, &layout.geom))
		throw IdentError("validate: the plant refuses the layout " + layout.describe());
	if (uniform)
		return;
	plant_floor f{};
	f.wheel_inertia = 1e-4;
	for (int j = 0; j < 4; ++j) {
		f.radius_error[j] = w.r[j] / p.r - 1;
		f.R_error[j] = w.R[j] / p.R - 1;
		f.Kv_error[j] = w.Kv[j] / p.Kv - 1;
	}
	if (plant_set_floor(&pl, &f))
		throw IdentError("validate: a wheel's drive is more than 50 % off the mean");
}

} // namespace

Validation validate(const std::vector<Segment> &segments, const model_params &p,
                    const IdentOptions &opt)
{
	model_wheels w;
	model_wheels_from_params(&p, &w);
	return validate(segments, p, w, opt);
}

Validation validate(const std::vector<Segment> &segments, const model_params &p,
                    const model_wheels &wh, const IdentOptions &opt)
{
	const bool uniform = uniform_wheels(p, wh);
	const std::array<double, 4> radii{wh.r[0], wh.r[1], wh.r[2], wh.r[3]};
	Validation v;
	Errors err{v};
	std::map<const LogData *, EncoderTrack> encs;
	const bool cam = opt.source == VelocitySource::Camera;
	for (size_t si = 0; si < segments.size(); ++si) {
		const Segment &s = segments[si];
		if (s.kind != "step")
			continue;
		if (!encs.count(s.log))
			encs.emplace(s.log, encoder_track(*s.log, opt.layout, p.d, radii));
		const EncoderTrack &enc = encs.at(s.log);
		const SegmentWindows wins = find_windows(s, enc, opt.windows);
		for (const Rejection &r : wins.rejected)
			v.rejected.push_back(
			    {si, s.kind, s.direction, r.what, r.t0_s, r.t1_s, false, r.reason});
		const int axis = find_axis(s.direction);
		if (axis < 0)
			continue; // find_windows rejected the segment, with the reason
		for (const Window &w : wins.step) {
			// Start at the first sample with a valid encoder velocity.
			size_t k0 = w.m0;
			while (k0 < w.m1 && !enc.ok[k0])
				++k0;
			if (k0 + 10 >= w.m1) {
				v.rejected.push_back({si, s.kind, s.direction, "step",
				                      seg_time(s, w.m0), seg_time(s, w.m1 - 1),
				                      false, "no valid encoder velocity"});
				continue;
			}
			++v.runs;
			plant pl;
			plant_of(pl, p, wh, uniform, opt.layout);
			for (int a = 0; a < 3; ++a)
				pl.x[a] = enc.x[k0][a];
			if (cam)
				compare_camera(pl, s, si, axis, w, k0, err);
			else
				compare_encoder(pl, s, si, axis, w, k0, enc, err);
		}
	}
	if (v.runs == 0)
		throw IdentError(
		    "validate: no step runs in the logs (no 'step' segment with a drive)");
	err.finish();
	return v;
}

} // namespace omni4
