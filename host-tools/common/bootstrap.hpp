// bootstrap.hpp - uncertainty of the identified parameters by resampling whole experiment runs.
//
// The analytic standard errors of identify() come from regression residuals and assume the
// residuals of one run are (after the filter-length correction) independent. Resampling runs
// makes no such assumption: each replicate draws, within every (experiment kind, direction)
// group, as many runs as the group has, with replacement, and identifies again. The spread of
// the final values over the replicates is the bootstrap standard error; the 2.5 and 97.5
// percentiles bound a 95 % interval. Replicates run on all cores and do not depend on the
// scheduling (replicate k always uses the same seed).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "identify.hpp"

namespace omni4
{

struct BootstrapStats {
	double se = 0, lo95 = 0, hi95 = 0;
};

struct BootstrapResult {
	int replicates = 0; // asked for
	int failed = 0;     // replicates whose resampled runs could not be identified (skipped)
	std::map<std::string, BootstrapStats> final;        // by parameter name (kIdentParams)
	std::map<std::string, std::vector<double>> samples; // final values of every replicate
};

// progress(done, total) is called from the calling thread as replicates finish.
BootstrapResult bootstrap_runs(const std::vector<Segment> &segments, const model_params &base,
                               const IdentOptions &opt, int replicates, uint64_t seed,
                               const std::function<void(int, int)> &progress = {});

} // namespace omni4
