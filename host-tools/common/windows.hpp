// windows.hpp - the parts of an experiment segment that identification may use, found in the
// data (docs/log-contract.md): nothing is assumed about where inside a segment the drive starts,
// holds, ramps or stops.
//
//   steady  driven (motors_t mode VOLTAGE or VELOCITY), every applied voltage inside a band no
//           wider than volt_tol_v + volt_tol_rel * |u|, and the robot velocity settled: the 50 ms
//           block means of every axis stay within steady_tol * |x| + a floor + 3 standard
//           deviations of a block mean's noise (estimated from the hold) of the final value for at
//           least steady_min_s. A ramp, a transient or a ramp-down is never inside one.
//   coast   bridges off (IDLE, COAST, FAULT, ESTOP: null traction) and decelerating freely along
//           the segment's axis: from just after the speed peak that follows the last drive or
//           push (once the speed has fallen 3 % below the peak and 50 ms have passed) down to
//           the stop threshold. Works for a motor-driven push and for a push by hand with the
//           bridges off for the whole segment.
//   step    a run of driven samples, from the start of the drive to its end (ramps, holds and
//           ramp-downs included: the model covers any logged voltage).
// Every candidate that is not used is returned as a Rejection with its reason.
#pragma once

#include <string>
#include <vector>

#include "logdata.hpp"
#include "signals.hpp"

namespace omni4
{

struct WindowOptions {
	double volt_tol_v = 0.02; // constant voltage: max - min of u <= this + volt_tol_rel |u|
	double volt_tol_rel = 0.005;
	double steady_tol = 0.003; // settled: block means within this fraction of the final speed
	double steady_floor_v = 0.002; // ... plus this [m/s] on v and vn
	double steady_floor_w = 0.01;  // ... plus this [rad/s] on w
	double steady_min_s = 0.4;     // shortest steady window [s]
	double block_s = 0.05;         // block length for the steadiness test [s]
	double coast_min_s = 0.2;      // shortest coast-down window [s]
	double step_min_s = 0.3;       // shortest driven run for a step window [s]
};

// Below these speeds the Coulomb sign is unreliable and the robot is about to stick.
constexpr double kStopSpeed[3] = {0.05, 0.05, 0.5}; // [m/s, m/s, rad/s]

bool driven_mode(int8_t mode); // bridges driven in this motors_t mode (core's mode_drives)

struct Window {
	size_t m0 = 0, m1 = 0; // motors samples [m0, m1) of the segment's log
	double sign = 1;       // coast: direction of the motion along the segment's axis
};

struct Rejection {
	std::string what; // "steady window", "coast-down", "step", "segment", "motor 2 point", ...
	double t0_s = 0, t1_s = 0; // from the segment's mark [s]
	std::string reason;
};

struct SegmentWindows {
	std::vector<Window> steady, coast, step;
	std::vector<Rejection> rejected;
};

// Windows of segment s (its kind decides which: steady_rotation and motor -> steady, coast ->
// coast, step -> step). enc is the encoder track of s.log.
SegmentWindows find_windows(const Segment &s, const EncoderTrack &enc, const WindowOptions &opt);

// Seconds from the segment's mark to motors sample k.
double seg_time(const Segment &s, size_t k);

} // namespace omni4
