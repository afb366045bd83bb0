// signals.hpp - robot velocities from the logged sensors, once per log.
//
// Differentiator / filter: Savitzky-Golay (least-squares polynomial of order 2 over a centred
// window, evaluated at the centre). The value filter smooths noise; the derivative filter
// differentiates without the noise gain of a raw difference.
//   encoders: wheel speeds -> eqs 3-5 -> x = [v, vn, w] per motors_t sample; SG over +-20 ms
//             (41 samples at 1 kHz, 21 at 500 Hz, 81 at 2 kHz) of CONTIGUOUS samples only: a
//             seq gap or a jump in utime ends a block, and no value is computed where the
//             window would cross a block edge (no extrapolation, no filtering across lost data).
//   camera:   x, y, unwrapped theta fitted by a local quadratic in time over +-0.18 s (9 frames
//             at 25 Hz) using the real frame times, so missing frames only thin the fit; the
//             world velocity is rotated into the robot frame with eq 1.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "layout.hpp"
#include "logdata.hpp"

namespace omni4
{

struct SgFilter {
	int half = 0;
	std::vector<double> smooth; // coefficients of the value at the centre
	std::vector<double>
	    deriv; // coefficients of the first derivative at the centre (per sample)
};

SgFilter savitzky_golay(int half, int order);

// Robot velocity from the wheel encoders of a whole log (index = index into log.motors).
struct EncoderTrack {
	double dt = 0;                          // nominal sample period [s] (median spacing)
	int half = 0;                           // SG half window [samples]
	std::vector<std::array<double, 3>> raw; // eqs 3-5 per sample [m/s, m/s, rad/s]
	std::vector<std::array<double, 3>> x;   // SG-smoothed (valid where ok)
	std::vector<std::array<double, 3>> dx;  // SG derivative [m/s^2, m/s^2, rad/s^2]
	std::vector<uint8_t> ok;                // a full contiguous window lies around the sample
	std::vector<uint8_t> joined;            // sample k follows k-1 with no lost sample
};

EncoderTrack encoder_track(const LogData &log, double d, double r, double half_s = 0.020);
// The same with each wheel's own radius r[j] (rim speed r_j w_j): four equal radii r give the
// bits of the scalar version.
EncoderTrack encoder_track(const LogData &log, double d, const std::array<double, 4> &r,
                           double half_s = 0.020);
// The same for a layout: its least-squares inverse of eq 2 (the paper's layout: the above).
EncoderTrack encoder_track(const LogData &log, const Layout &layout, double d,
                           const std::array<double, 4> &r, double half_s = 0.020);

// Robot velocity from the camera poses of a whole log (index = index into log.pose).
struct CameraTrack {
	std::vector<double> t;                // [s] (utime)
	std::vector<double> theta;            // unwrapped heading [rad]
	std::vector<double> heading;          // smoothed heading [rad] (valid where ok)
	std::vector<std::array<double, 3>> x; // robot-frame velocity (valid where ok)
	std::vector<uint8_t> ok;
};

CameraTrack camera_track(const LogData &log, double half_s = 0.18);
// The same estimator on any pose series (times [s], world x, y [m], heading [rad]).
CameraTrack pose_velocity(const std::vector<double> &t, const std::vector<double> &px,
                          const std::vector<double> &py, const std::vector<double> &theta,
                          double half_s);

// Unwrap an angle sequence in place (removes 2 pi jumps).
void unwrap(std::vector<double> &a);

// 0, 1, 2 for "v", "vn", "w"; -1 for anything else.
int find_axis(const std::string &direction);

} // namespace omni4
