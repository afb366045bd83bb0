// signals.hpp - robot velocities from the logged sensors.
//
// Differentiator / filter: Savitzky-Golay (least-squares polynomial of order `order` over a
// centred window of 2*half+1 samples, evaluated at the centre). The value filter smooths
// noise; the derivative filter differentiates without the noise gain of a raw difference. The
// first and last `half` samples of a series are dropped (no edge extrapolation).
//   encoders (1 kHz): wheel speeds -> eqs 3-5 -> x = [v, vn, w]; SG order 2, half 20 (41 ms)
//   camera (25 Hz): x, y, unwrapped theta; SG order 2, half 4 (9 frames = 0.36 s) derivative,
//                   world velocity rotated into the robot frame with eq 1.
#pragma once

#include <array>
#include <vector>

#include "logdata.hpp"

namespace omni4 {

struct SgFilter {
  int half = 0;
  std::vector<double> smooth;  // coefficients of the value at the centre
  std::vector<double> deriv;   // coefficients of the first derivative at the centre (per sample)
};

SgFilter savitzky_golay(int half, int order);

struct VelocitySeries {
  std::vector<double> t;                  // [s] from the segment start
  std::vector<std::array<double, 3>> x;   // smoothed [v, vn, w]
  std::vector<std::array<double, 3>> dx;  // derivative [m/s^2, m/s^2, rad/s^2]
  std::vector<size_t> motors_index;       // encoder series: index into log.motors
};

// From the wheel encoders of motors [m0, m1) of the segment's log; d, r from the robot.
VelocitySeries encoder_velocity(const Segment &s, double d, double r, int half = 20);
// From the camera poses [p0, p1).
VelocitySeries camera_velocity(const Segment &s, int half = 4);

// Unwrap an angle sequence in place (removes 2 pi jumps).
void unwrap(std::vector<double> &a);

int axis_index(const std::string &direction);  // "v" 0, "vn" 1, "w" 2; throws otherwise

}  // namespace omni4
