// identify.cpp - the identification: the logs' tracks and windows (prepare), the experiments
// (identify_motor.cpp, identify_exp1.cpp, identify_exp2.cpp, identify_exp3.cpp) and the final
// value of each parameter from the methods that give it (identify_stats.cpp).
#include "identify.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <numeric>
#include <thread>

#include "identify_context.hpp"
#include "identify_wheels.hpp"

namespace omni4
{

const char *const kIdentParams[9] = {"Kv", "R", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw"};
const char *const kIdentMethods[6] = {"motor", "exp1", "exp2", "exp3_ls", "exp3_iv", "final"};

bool IdentResult::complete() const
{
	for (const char *p : kIdentParams) {
		const auto it = identified.find(p);
		if (it == identified.end() || !it->second)
			return false;
	}
	return true;
}

Estimate find_estimate(const IdentResult &r, const char *method, const char *param)
{
	const auto m = r.table.find(method);
	if (m == r.table.end())
		return {};
	const auto p = m->second.find(param);
	return p == m->second.end() ? Estimate{} : p->second;
}

size_t log_workers(size_t n_logs)
{
	// Up to two per core: with fewer logs than twice the cores (3 logs on 2 cores) every log
	// runs at once and the cores share them evenly, instead of the last one running alone.
	const size_t cores = std::max(1u, std::thread::hardware_concurrency());
	return std::max(cores, std::min(n_logs, 2 * cores));
}

Prepared prepare(const std::vector<Segment> &segments, const model_params &base,
                 const IdentOptions &opt)
{
	Prepared P;
	P.base = base;
	P.opt = opt;
	P.segments = segments;
	// The logs' tracks and the segments' windows are independent: on all cores, one log (with
	// its segments) per task.
	std::vector<const LogData *> logs;
	for (const Segment &s : segments)
		if (std::find(logs.begin(), logs.end(), s.log) == logs.end())
			logs.push_back(s.log);
	struct Tracks {
		EncoderTrack enc;
		CameraTrack cam;
		std::vector<std::pair<size_t, SegmentWindows>> windows; // by segment index
	};
	P.radii.shape.layout = opt.layout;
	if (opt.layout.paper)
		ident::estimate_radii(P); // the left null space of the paper's eq 2
	std::array<double, 4> radii;
	for (int j = 0; j < 4; ++j)
		radii[j] = base.r * P.radii.shape.r[j];
	auto work = [&](const LogData *log) {
		Tracks t{encoder_track(*log, opt.layout, base.d, radii), camera_track(*log), {}};
		for (size_t i = 0; i < segments.size(); ++i)
			if (segments[i].log == log)
				t.windows.emplace_back(
				    i, find_windows(segments[i], t.enc, opt.windows));
		return t;
	};
	const size_t workers = log_workers(logs.size());
	std::vector<std::future<Tracks>> pending;
	P.windows.resize(segments.size());
	size_t next = 0;
	for (size_t k = 0; k < logs.size(); ++k) {
		while (next < logs.size() && pending.size() < k + workers)
			pending.push_back(std::async(std::launch::async, work, logs[next++]));
		Tracks t = pending[k].get();
		for (auto &[i, w] : t.windows)
			P.windows[i] = std::move(w);
		P.enc.emplace(logs[k], std::move(t.enc));
		P.cam.emplace(logs[k], std::move(t.cam));
		for (size_t e = 0; e < logs[k]->current_offsets.size(); ++e) {
			const OffsetEpoch &ep = logs[k]->current_offsets[e];
			if (ep.subtracted && std::isfinite(ep.se_a[0]))
				P.offset_epochs.emplace_back(logs[k], e);
		}
	}
	if (opt.layout.paper)
		ident::camera_radius_scale(P);
	else
		P.radii.r_scale_note = "not estimated for a layout other than the paper's";
	return P;
}

namespace
{

// The report: every window found and every rejection.
void record_windows(const Prepared &P, IdentResult &res)
{
	for (size_t i = 0; i < P.segments.size(); ++i) {
		const Segment &s = P.segments[i];
		const SegmentWindows &w = P.windows[i];
		auto used = [&](const std::vector<Window> &ws, const char *what) {
			for (const Window &x : ws)
				res.windows.push_back({i, s.kind, s.direction, what,
				                       seg_time(s, x.m0), seg_time(s, x.m1 - 1),
				                       true, ""});
		};
		used(w.steady, "steady window");
		used(w.coast, "coast-down");
		used(w.step, "step");
		for (const Rejection &r : w.rejected)
			res.windows.push_back(
			    {i, s.kind, s.direction, r.what, r.t0_s, r.t1_s, false, r.reason});
	}
}

// Each wheel's drive: final's scalars with the shape the experiments used; r_j's SE is rho_j's
// (the mean radius is the measured one).
void finish_wheels(IdentResult &res)
{
	res.final_wheels = res.wheels.shape.wheels(res.final);
	if (!res.wheels.radii_differ)
		return;
	for (int j = 0; j < 4; ++j)
		res.wheels.r_wheel[j] = {res.final.r * res.wheels.rho[j].value,
		                         res.final.r * res.wheels.rho[j].se};
}

// A current drive's M: experiment 3's IV estimate (force form), the base model's M kept where
// there is none.
void combine_mass(const Prepared &P, IdentResult &res)
{
	Agreement ag;
	const Estimate e = combine_methods({find_estimate(res, "exp3_iv", "M")}, P.opt, &ag);
	res.identified["M"] = e.ok();
	if (!e.ok())
		return;
	res.table["final"]["M"] = e;
	res.agreement["M"] = ag;
	res.final.M = e.value;
}

// Each parameter's final value from the methods that give it (combine_methods), into
// res.table["final"] and res.final. Returns how many were found.
size_t combine_final(const Prepared &P, IdentResult &res)
{
	auto &fin = res.table["final"];
	static const std::map<std::string, std::vector<const char *>> sources = {
	    {"Kv", {"motor"}},           {"R", {"motor", "exp3_iv"}},  {"J", {"exp2", "exp3_iv"}},
	    {"Bv", {"exp2", "exp3_iv"}}, {"Bvn", {"exp2", "exp3_iv"}}, {"Bw", {"exp1", "exp3_iv"}},
	    {"Cv", {"exp2", "exp3_iv"}}, {"Cvn", {"exp2", "exp3_iv"}}, {"Cw", {"exp1", "exp3_iv"}}};
	res.final = P.base;
	size_t found = 0;
	const bool current = P.opt.drive == DriveKind::Current;
	for (const char *p : kIdentParams) {
		if (current && (std::string(p) == "Kv" || std::string(p) == "R")) {
			// The drive's: the base model's value, not a fit (nothing to combine).
			fin[p] = res.table["drive"][p];
			res.agreement[p] = Agreement{};
			res.identified[p] = true;
			continue;
		}
		std::vector<Estimate> est;
		for (const char *m : sources.at(p))
			est.push_back(find_estimate(res, m, p));
		Agreement ag;
		const Estimate e = combine_methods(est, P.opt, &ag);
		if (ag.kept >= 0) {
			ag.kept_method = sources.at(p)[static_cast<size_t>(ag.kept)];
			ag.rule =
			    "methods disagree: kept " + ag.kept_method + " (better-determined)";
		}
		res.agreement[p] = ag;
		res.identified[p] = e.ok();
		if (!e.ok())
			continue;
		fin[p] = e;
		++found;
		for (int i = 0; i < MODEL_PARAMS_COUNT; ++i)
			if (std::string(p) == model_params_names[i])
				*model_params_field(&res.final, i) = e.value;
	}
	if (current) {
		combine_mass(P, res);
		return found;
	}
	if (res.identified["Kv"])
		res.final.Kt = res.final.Kv;
	return found;
}

} // namespace

IdentResult identify(const Prepared &P, const std::vector<size_t> *use_in)
{
	std::vector<size_t> all(P.segments.size());
	std::iota(all.begin(), all.end(), 0);
	const std::vector<size_t> &use = use_in ? *use_in : all;
	IdentResult res;
	for (size_t i : use)
		++res.segments_used[P.segments[i].kind];
	if (!use_in)
		record_windows(P, res);
	res.wheels = P.radii;
	ident::Context c{P, use, res};
	for (const ident::Experiment run : ident::kExperiments)
		run(c);
	if (combine_final(P, res) == 0) {
		std::string why = "nothing can be identified from these logs:";
		for (const std::string &m : res.missing)
			why += "\n  " + m;
		throw IdentError(why);
	}
	finish_wheels(res);
	if (res.complete()) {
		int bad = -1;
		if (model_params_check(&res.final, &bad))
			throw IdentError(std::string("identified parameters are not physical: ") +
			                 model_params_names[bad] + " = " +
			                 std::to_string(model_params_get(&res.final, bad)));
	}
	return res;
}

IdentResult identify(const std::vector<Segment> &segments, const model_params &base,
                     const IdentOptions &opt)
{
	return identify(prepare(segments, base, opt));
}

} // namespace omni4
