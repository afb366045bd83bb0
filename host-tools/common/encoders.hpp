// encoders.hpp - what a log's wheel speeds need before use: tick intervals and eccentric discs.
//
// Late ticks. A controller whose loop wakes some tens of us late reads its encoder counts at
// the true (logged) tick time but may divide the count difference by the nominal period. Its
// speeds then carry the interval's jitter (3 % per tick for 30 us at 1 kHz, several times the
// quantisation noise): dividing by the true interval instead is exact. Whether the log's
// speeds need it is decided from the data: rescaled, their second differences must be smaller.
//
// Eccentric discs.
// An encoder disc mounted slightly off centre reads the angle th + eps sin(th - phi): the speed
// it reports ripples by a factor (1 + eps cos(th - phi)) once per revolution of the shaft it
// sits on. With eps ~ 1 % the ripple's derivative (eps w x omega_shaft) is as large as the
// accelerations experiment 3 regresses on, and validation's e_max sees the ripple itself.
//
// Per wheel j, with th_w the wheel angle (the logged wheel speed integrated over the nominal
// loop period: a logged speed is a count difference over that period) and w the wheel speed:
//   w_logged = w (1 + a cos(l th_w) + b sin(l th_w))
// (once per motor revolution, l the gear ratio: the encoder on the motor shaft). The slowly
// varying w is removed by a centred moving average (box of 0.1 s) applied to the data and to
// the regressors alike, so (a, b) come from a linear least-squares fit that a drive profile
// does not bias, on samples fast enough that the box leaves the ripple in (min_cycles periods
// in it). The ripple is removed only where its amplitude is over 4 standard errors, cluster-
// robust (the residual carries the speed's bends the box does not follow: runs of cluster_s
// count as one observation each); the log is fitted in stretches of `chunk_s` so that a phase
// that drifts (lost samples) is followed. An encoder on the wheel shaft ripples once per wheel
// turn, as slowly as the robot's own speed changes (a spin's turn takes about as long as its
// ramp): that ripple cannot be told from the speed and is left alone.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "logdata.hpp"

namespace omni4
{

struct TickRescale {
	bool applied = false; // the speeds were rescaled to the true intervals
	double period_s = 0;  // the nominal period (median interval)
	double jitter_s = 0;  // RMS deviation of the intervals from it
	double roughness_logged = 0, roughness_rescaled = 0; // mean squared second difference
};

// Rescales log.motors' wheel speeds by (nominal period / true interval) where that makes them
// smoother by more than 5 % (samples after a lost one are left as logged: their interval is
// not known). Call before remove_encoder_ripple.
TickRescale rescale_to_tick_intervals(LogData &log);

struct EccentricityOptions {
	double box_s = 0.1;        // moving average that takes the slow speed out [s]
	double chunk_s = 20.0;     // stretch fitted with its own coefficients [s]
	double min_speed = 2.0;    // wheel speed below which a sample carries no ripple [rad/s]
	double min_cycles = 0.75;  // ... or fewer ripple periods than this in box_s
	double significance = 4.0; // a harmonic is removed when its amplitude is over this many SE
	                           // (Hotelling's F over the clusters, as a normal pair's z)
	double cluster_s = 0.5;    // longest run of samples taken as one cluster in the SE [s]
};

struct RippleFit {
	size_t m0 = 0, m1 = 0; // motors index range of the stretch
	// Per wheel: relative amplitude of the once-per-motor-revolution ripple, its standard
	// error, and whether it was removed.
	// motor_z: the amplitude in standard errors (both components, as significance); clusters:
	// the fit's clusters (under 4: no test, nothing removed).
	std::array<double, 4> motor_eps{}, motor_se{}, motor_z{};
	std::array<int, 4> motor_clusters{};
	std::array<bool, 4> motor_removed{};
	size_t samples = 0; // samples used (wheel turning, filter window complete)
};

// Estimates the ripple of log.motors' wheel speeds in stretches of chunk_s and divides it out
// in place. gear: the gear ratio l (motor revolutions per wheel revolution). Returns one fit
// per stretch.
std::vector<RippleFit> remove_encoder_ripple(LogData &log, double gear,
                                             const EccentricityOptions &opt = {});

} // namespace omni4
