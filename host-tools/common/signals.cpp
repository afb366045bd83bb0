// signals.cpp - Savitzky-Golay filters and velocity series.
#include "signals.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

extern "C" {
#include "omni4/kinematics.h"
}

namespace omni4 {

SgFilter savitzky_golay(int half, int order) {
  const int n = 2 * half + 1;
  if (half < 1 || order < 1 || order >= n) throw std::invalid_argument("bad SG window");
  Eigen::MatrixXd V(n, order + 1);
  for (int k = -half; k <= half; ++k)
    for (int p = 0; p <= order; ++p) V(k + half, p) = std::pow(k, p);
  // Rows of the least-squares solver (V^T V)^-1 V^T give the polynomial coefficients.
  const Eigen::MatrixXd P = (V.transpose() * V).ldlt().solve(V.transpose());
  SgFilter f;
  f.half = half;
  f.smooth.resize(n);
  f.deriv.resize(n);
  for (int k = 0; k < n; ++k) {
    f.smooth[k] = P(0, k);
    f.deriv[k] = P(1, k);
  }
  return f;
}

namespace {

double apply(const std::vector<double> &c, const std::vector<double> &y, size_t centre, int half) {
  double s = 0;
  for (int k = -half; k <= half; ++k) s += c[k + half] * y[centre + k];
  return s;
}

}  // namespace

void unwrap(std::vector<double> &a) {
  double offset = 0;
  for (size_t k = 1; k < a.size(); ++k) {
    const double raw = a[k] + offset;
    const double jump = raw - a[k - 1];
    if (jump > M_PI) offset -= 2 * M_PI * std::round(jump / (2 * M_PI));
    else if (jump < -M_PI) offset += 2 * M_PI * std::round(-jump / (2 * M_PI));
    a[k] += offset;
  }
}

int axis_index(const std::string &direction) {
  if (direction == "v") return 0;
  if (direction == "vn") return 1;
  if (direction == "w") return 2;
  throw std::invalid_argument("unknown direction '" + direction + "'");
}

VelocitySeries encoder_velocity(const Segment &s, double d, double r, int half) {
  VelocitySeries out;
  const auto &m = s.log->motors;
  const size_t n = s.m1 - s.m0;
  if (n < static_cast<size_t>(2 * half + 3)) return out;
  const double dt = (m[s.m1 - 1].utime - m[s.m0].utime) * 1e-6 / (n - 1);
  std::array<std::vector<double>, 3> raw;
  for (auto &v : raw) v.resize(n);
  for (size_t k = 0; k < n; ++k) {
    double vw[4], x[3];
    for (int j = 0; j < 4; ++j) vw[j] = m[s.m0 + k].w[j] * r;
    fk_robot_velocity(d, vw, x);
    for (int a = 0; a < 3; ++a) raw[a][k] = x[a];
  }
  const SgFilter f = savitzky_golay(half, 2);
  for (size_t k = half; k + half < n; ++k) {
    std::array<double, 3> x{}, dx{};
    for (int a = 0; a < 3; ++a) {
      x[a] = apply(f.smooth, raw[a], k, half);
      dx[a] = apply(f.deriv, raw[a], k, half) / dt;
    }
    out.t.push_back((m[s.m0 + k].utime - s.t0) * 1e-6);
    out.x.push_back(x);
    out.dx.push_back(dx);
    out.motors_index.push_back(s.m0 + k);
  }
  return out;
}

VelocitySeries camera_velocity(const Segment &s, int half) {
  VelocitySeries out;
  const auto &p = s.log->pose;
  const size_t n = s.p1 - s.p0;
  if (n < static_cast<size_t>(2 * half + 3)) return out;
  const double dt = (p[s.p1 - 1].utime - p[s.p0].utime) * 1e-6 / (n - 1);
  std::vector<double> xs(n), ys(n), th(n);
  for (size_t k = 0; k < n; ++k) {
    xs[k] = p[s.p0 + k].x;
    ys[k] = p[s.p0 + k].y;
    th[k] = p[s.p0 + k].theta;
  }
  unwrap(th);
  const SgFilter f = savitzky_golay(half, 2);
  for (size_t k = half; k + half < n; ++k) {
    const double vx = apply(f.deriv, xs, k, half) / dt;
    const double vy = apply(f.deriv, ys, k, half) / dt;
    const double w = apply(f.deriv, th, k, half) / dt;
    const double theta = apply(f.smooth, th, k, half);
    const double xw[3] = {vx, vy, w};
    double xr[3];
    frame_world_to_robot(theta, xw, xr);
    out.t.push_back((p[s.p0 + k].utime - s.t0) * 1e-6);
    out.x.push_back({xr[0], xr[1], xr[2]});
    out.dx.push_back({NAN, NAN, NAN});  // a second derivative of 25 Hz poses is not used
  }
  return out;
}

}  // namespace omni4
