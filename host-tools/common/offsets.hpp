// offsets.hpp - current-sense offsets estimated from a log's own bridge-off samples.
//
// With the H-bridges off (motors_t.mode IDLE, COAST, FAULT, ESTOP) no current flows, so what a
// channel reads there is its offset plus noise. A constant offset per channel biases the motor
// test (u = Kv w + R i has no term for it) and experiment 1 (the torque d l Kt / r sum i adds
// four of them), so identification estimates the offsets first and subtracts them.
//
// A controller that calibrates its own offsets says so on OMNI4_PARAM_CHANGED (source
// "calibration", the first tick it applies them in `seq`); each notice opens a new stretch
// (an epoch) of the log, whose residual offsets are estimated separately. Logs of firmware
// that does not calibrate are one epoch.
#pragma once

#include <string>
#include <vector>

#include "logdata.hpp"

namespace omni4
{

struct OffsetOptions {
	double guard_s = 0.020;   // bridge-off samples this soon after a driven one are not used
	                          // (the winding current decays through the bridge's diodes)
	size_t min_samples = 100; // fewer in an epoch: the log's pooled estimate is used instead
	size_t batch = 32;        // batch length of the batch-means standard error [samples]
};

// Bridge-off samples used: at least guard_s after the last driven sample (none before it in
// the log counts as long ago), without a latching fault that concerns the reading
// (OVERCURRENT, DRIVER_TIMEOUT, DRIVER, BUS, CURRENT_SENSOR).
// Fills log.current_offsets (one epoch per calibration notice, plus the stretch before the
// first) and subtracts the estimated offsets from log.motors' currents. Returns warnings (one
// line each: no bridge-off samples, an epoch that borrowed the pooled estimate, a calibration
// notice that reports a channel over its limit).
std::vector<std::string> calibrate_currents(LogData &log, const OffsetOptions &opt = {});

} // namespace omni4
