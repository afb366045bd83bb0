// offsets.cpp - current-sense offsets from bridge-off samples (see offsets.hpp).
#include "offsets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "omni4/core/vocab.h"
#include "windows.hpp"

namespace omni4
{

namespace
{

// motors_t latching faults under which a current reading says nothing about the offset.
constexpr int32_t kReadingFaults = CTL_FAULT_OVERCURRENT | CTL_FAULT_DRIVER_TIMEOUT |
                                   CTL_FAULT_DRIVER | CTL_FAULT_BUS | CTL_FAULT_CURRENT_SENSOR;

struct Accumulator {
	size_t n = 0;
	std::array<double, 4> sum{}, sum2{};
	// Batch means: consecutive usable samples in groups of `batch`.
	std::vector<std::array<double, 4>> batches;
	std::array<double, 4> bsum{};
	size_t bn = 0;

	void add(const std::array<float, 4> &i, size_t batch);
	// The batch in progress is given up (a drive or lost samples interrupt it): a batch is made
	// of consecutive usable samples only.
	void drop_partial_batch()
	{
		bsum.fill(0);
		bn = 0;
	}
	void merge(const Accumulator &o);
	// Mean and its standard error: from the spread of the batch means when there are enough of
	// them (honest for noise correlated over less than a batch), else white-noise.
	void result(std::array<double, 4> &mean, std::array<double, 4> &se) const;
};

void Accumulator::add(const std::array<float, 4> &i, size_t batch)
{
	++n;
	for (int j = 0; j < 4; ++j) {
		sum[j] += i[j];
		sum2[j] += i[j] * i[j];
		bsum[j] += i[j];
	}
	if (++bn < batch)
		return;
	std::array<double, 4> m{};
	for (int j = 0; j < 4; ++j)
		m[j] = bsum[j] / static_cast<double>(bn);
	batches.push_back(m);
	drop_partial_batch();
}

void Accumulator::merge(const Accumulator &o)
{
	n += o.n;
	for (int j = 0; j < 4; ++j) {
		sum[j] += o.sum[j];
		sum2[j] += o.sum2[j];
	}
	batches.insert(batches.end(), o.batches.begin(), o.batches.end());
}

void Accumulator::result(std::array<double, 4> &mean, std::array<double, 4> &se) const
{
	const double nn = static_cast<double>(n);
	for (int j = 0; j < 4; ++j) {
		mean[j] = sum[j] / nn;
		const double var =
		    n > 1 ? std::max(0.0, (sum2[j] - nn * mean[j] * mean[j]) / (nn - 1)) : 0;
		double s = std::sqrt(var / nn);
		if (batches.size() >= 8) {
			double bm = 0, bv = 0;
			for (const auto &b : batches)
				bm += b[j];
			bm /= static_cast<double>(batches.size());
			for (const auto &b : batches)
				bv += (b[j] - bm) * (b[j] - bm);
			bv /= static_cast<double>(batches.size() - 1);
			s = std::max(s, std::sqrt(bv / static_cast<double>(batches.size())));
		}
		se[j] = s;
	}
}

std::string fmt_offsets(const std::array<double, 4> &a)
{
	char buf[96];
	std::snprintf(buf, sizeof(buf), "%+.4f %+.4f %+.4f %+.4f", a[0], a[1], a[2], a[3]);
	return buf;
}

// The log's offset epochs: [0, first notice's seq), then one per calibration notice (empty
// leading stretches dropped). A notice that found a sensor fault adds a warning.
std::vector<OffsetEpoch> offset_epochs(const LogData &log, std::vector<std::string> &warn)
{
	const auto &m = log.motors;
	std::vector<OffsetEpoch> ep(1);
	size_t k = 0;
	for (size_t c = 0; c < log.calibrations.size(); ++c) {
		const int64_t seq = log.calibrations[c].seq;
		while (k < m.size() && m[k].seq < seq)
			++k;
		ep.back().m1 = k;
		OffsetEpoch e;
		e.m0 = k;
		e.notice = static_cast<int>(c);
		ep.push_back(e);
		if (!log.calibrations[c].fault_channels.empty())
			warn.push_back(log.path + ": the controller's calibration at seq " +
			               std::to_string(seq) + " found channel(s) " +
			               log.calibrations[c].fault_channels +
			               " over its offset limit (current sensor fault)");
	}
	ep.back().m1 = m.size();
	// Drop empty leading stretches (a notice at the log's first sample).
	ep.erase(
	    std::remove_if(ep.begin(), ep.end(), [](const OffsetEpoch &e) { return e.m1 <= e.m0; }),
	    ep.end());
	return ep;
}

// The usable bridge-off readings of each epoch into acc[e], and of all of them into all:
// not driven, no reading fault, at least guard_s after the last drive.
void accumulate_bridge_off(const std::vector<MotorsSample> &m, const std::vector<OffsetEpoch> &ep,
                           const OffsetOptions &opt, std::vector<Accumulator> &acc,
                           Accumulator &all)
{
	int64_t last_driven = INT64_MIN;
	for (size_t e = 0; e < ep.size(); ++e) {
		for (size_t q = ep[e].m0; q < ep[e].m1; ++q) {
			const MotorsSample &s = m[q];
			const bool joined = q > 0 && s.seq == m[q - 1].seq + 1;
			if (!joined)
				acc[e].drop_partial_batch(); // a batch never spans lost samples
			if (driven_mode(s.mode)) {
				last_driven = s.utime;
				acc[e].drop_partial_batch();
				continue;
			}
			if (s.faults & kReadingFaults)
				continue;
			if (last_driven != INT64_MIN &&
			    (s.utime - last_driven) * 1e-6 < opt.guard_s)
				continue;
			acc[e].add(s.i, opt.batch);
		}
		acc[e].drop_partial_batch();
		all.merge(acc[e]);
	}
}

// Each epoch's offsets (its own estimate, or the whole log's pooled one pm +- ps when it has
// too few samples) subtracted from its currents.
void subtract_offsets(LogData &log, std::vector<OffsetEpoch> &ep,
                      const std::vector<Accumulator> &acc, const std::array<double, 4> &pm,
                      const std::array<double, 4> &ps, const OffsetOptions &opt,
                      std::vector<std::string> &warn)
{
	auto &m = log.motors;
	for (size_t e = 0; e < ep.size(); ++e) {
		ep[e].samples = acc[e].n;
		if (acc[e].n >= opt.min_samples) {
			acc[e].result(ep[e].offset_a, ep[e].se_a);
			ep[e].estimated = true;
		} else {
			ep[e].offset_a = pm;
			ep[e].se_a = ps;
			ep[e].pooled = true;
			// A notice means the controller changed what it subtracts: the pooled
			// residual is then only as good as the controller's calibration noise. Say
			// so.
			if (ep.size() > 1)
				warn.push_back(
				    log.path + ": " + std::to_string(acc[e].n) +
				    " bridge-off samples after " +
				    (ep[e].notice >= 0
				         ? "the calibration at seq " +
				               std::to_string(log.calibrations[ep[e].notice].seq)
					 : std::string("the log's start")) +
				    ": its residual offsets taken from the whole log (" +
				    fmt_offsets(pm) + " A)");
		}
		for (size_t q = ep[e].m0; q < ep[e].m1; ++q)
			for (int j = 0; j < 4; ++j)
				m[q].i[j] = static_cast<float>(m[q].i[j] - ep[e].offset_a[j]);
		ep[e].subtracted = true;
	}
}

} // namespace

std::vector<std::string> calibrate_currents(LogData &log, const OffsetOptions &opt)
{
	std::vector<std::string> warn;
	log.current_offsets.clear();
	std::vector<OffsetEpoch> ep = offset_epochs(log, warn);
	std::vector<Accumulator> acc(ep.size());
	Accumulator all;
	accumulate_bridge_off(log.motors, ep, opt, acc, all);
	if (all.n < opt.min_samples) {
		warn.push_back(
		    log.path + ": " + std::to_string(all.n) +
		    " samples with the bridges off (need " + std::to_string(opt.min_samples) +
		    "): current-sense offsets not estimated, currents used as logged (record "
		    "some rest in IDLE before or after the runs)");
		for (OffsetEpoch &e : ep) {
			e.offset_a.fill(0);
			e.se_a.fill(NAN);
		}
		log.current_offsets = ep;
		return warn;
	}
	std::array<double, 4> pm{}, ps{};
	all.result(pm, ps);
	subtract_offsets(log, ep, acc, pm, ps, opt, warn);
	log.current_offsets = ep;
	return warn;
}

} // namespace omni4
