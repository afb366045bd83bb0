// bootstrap.cpp - run-level bootstrap of identify().
#include "bootstrap.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <random>
#include <thread>

namespace omni4
{

namespace
{

// The motors a segment drives (0.5 V or more at some sample, as the motor test counts them):
// "0101" for motors 1 and 3.
std::string driven_motors(const Segment &s)
{
	std::string bits = "0000";
	for (size_t k = s.m0; k < s.m1 && s.log; ++k)
		for (int j = 0; j < 4; ++j)
			if (std::abs(s.log->motors[k].u[j]) >= 0.5f)
				bits[j] = '1';
	return bits;
}

// Groups of segment indices that are resampled together: one per (kind, direction), the
// motor test's also per set of motors driven (a one-motor test's runs, direction "", are
// resampled within each motor's own runs; an axis pattern's set follows from its direction).
std::vector<std::vector<size_t>> strata(const std::vector<Segment> &segments)
{
	std::map<std::string, std::vector<size_t>> by_key;
	for (size_t i = 0; i < segments.size(); ++i) {
		const Segment &s = segments[i];
		std::string key = s.kind + '/' + s.direction;
		if (s.kind == "motor")
			key += '/' + driven_motors(s);
		by_key[key].push_back(i);
	}
	std::vector<std::vector<size_t>> out;
	for (auto &[key, idx] : by_key)
		out.push_back(std::move(idx));
	return out;
}

// One replicate: its final values in kIdentParams order (NaN where the full data identify
// nothing either), or empty if it could not identify what the full data do.
std::vector<double> replicate(const Prepared &prep, const std::vector<std::vector<size_t>> &groups,
                              const std::map<std::string, bool> &wanted, uint64_t seed)
{
	std::mt19937_64 rng(seed);
	std::vector<size_t> drawn;
	drawn.reserve(prep.segments.size());
	for (const auto &g : groups) {
		std::uniform_int_distribution<size_t> pick(0, g.size() - 1);
		for (size_t k = 0; k < g.size(); ++k)
			drawn.push_back(g[pick(rng)]);
	}
	try {
		const IdentResult r = identify(prep, &drawn);
		std::vector<double> v;
		for (const char *p : kIdentParams) {
			if (!wanted.at(p)) {
				v.push_back(NAN);
				continue;
			}
			const auto it = r.table.at("final").find(p);
			if (it == r.table.at("final").end() || !std::isfinite(it->second.value))
				return {};
			v.push_back(it->second.value);
		}
		return v;
	} catch (const IdentError &) {
		return {};
	}
}

double percentile(std::vector<double> v, double q)
{
	std::sort(v.begin(), v.end());
	const double pos = q * static_cast<double>(v.size() - 1);
	const size_t i = static_cast<size_t>(pos);
	const double f = pos - static_cast<double>(i);
	return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

} // namespace

BootstrapResult bootstrap_runs(const std::vector<Segment> &segments, const model_params &base,
                               const IdentOptions &opt, int replicates, uint64_t seed,
                               const std::function<void(int, int)> &progress)
{
	BootstrapResult res;
	res.replicates = replicates;
	const auto groups = strata(segments);
	const Prepared prep = prepare(segments, base, opt);
	std::map<std::string, bool> wanted;
	for (const char *p : kIdentParams)
		wanted[p] = false;
	try {
		wanted = identify(prep).identified;
	} catch (const IdentError &) {
	}
	const int workers = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
	std::vector<std::vector<double>> values(static_cast<size_t>(std::max(replicates, 0)));
	int done = 0;
	for (int first = 0; first < replicates; first += workers) {
		std::vector<std::future<std::vector<double>>> batch;
		for (int k = first; k < std::min(replicates, first + workers); ++k)
			batch.push_back(std::async(std::launch::async, replicate, std::cref(prep),
			                           std::cref(groups), std::cref(wanted),
			                           seed + static_cast<uint64_t>(k)));
		for (size_t b = 0; b < batch.size(); ++b) {
			values[static_cast<size_t>(first) + b] = batch[b].get();
			if (progress)
				progress(++done, replicates);
		}
	}
	for (size_t p = 0; p < 9; ++p) {
		std::vector<double> x;
		for (const auto &v : values)
			if (!v.empty() && std::isfinite(v[p]))
				x.push_back(v[p]);
		if (x.size() < 2)
			continue;
		double mean = 0;
		for (double xi : x)
			mean += xi;
		mean /= static_cast<double>(x.size());
		double ss = 0;
		for (double xi : x)
			ss += (xi - mean) * (xi - mean);
		BootstrapStats s;
		s.se = std::sqrt(ss / static_cast<double>(x.size() - 1));
		s.lo95 = percentile(x, 0.025);
		s.hi95 = percentile(x, 0.975);
		res.final[kIdentParams[p]] = s;
		res.samples[kIdentParams[p]] = x;
	}
	for (const auto &v : values)
		res.failed += v.empty();
	return res;
}

} // namespace omni4
