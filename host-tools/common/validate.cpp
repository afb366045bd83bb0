// validate.cpp - model simulation against the logs.
#include "validate.hpp"

#include <cmath>

#include "regression.hpp"
#include "signals.hpp"

extern "C" {
#include "omni4/plant.h"
}

namespace omni4 {

Validation validate(const std::vector<Segment> &segments, const model_params &p) {
  Validation v;
  std::array<double, 3> sum{}, sum2{};
  for (size_t si = 0; si < segments.size(); ++si) {
    const Segment &s = segments[si];
    if (s.kind != "step") continue;
    const int axis = axis_index(s.direction);
    const VelocitySeries vs = encoder_velocity(s, p.d, p.r);
    if (vs.t.size() < 10) continue;
    ++v.runs;
    plant pl;
    if (plant_init(&pl, &p)) throw IdentError("validate: parameters are not physical");
    const auto &m = s.log->motors;
    for (int k = 0; k < 3; ++k) pl.x[k] = vs.x[0][k];
    for (size_t k = 0; k < vs.t.size(); ++k) {
      if (k > 0) {
        // Advance the plant over the ticks between two series samples; the voltage logged at
        // tick i acts until tick i + 1.
        for (size_t i = vs.motors_index[k - 1]; i < vs.motors_index[k]; ++i) {
          const MotorsSample &ms = m[i];
          const double dt = (m[i + 1].utime - ms.utime) * 1e-6;
          const bool driven = ms.mode == 1 || ms.mode == 2;
          const double u[4] = {ms.u[0], ms.u[1], ms.u[2], ms.u[3]};
          plant_step(&pl, u, driven, dt);
        }
      }
      ValidationPoint pt{si, s.direction, s.level, vs.t[k], vs.x[k], {pl.x[0], pl.x[1], pl.x[2]}};
      const double e = pt.measured[axis] - pt.simulated[axis];
      AxisErrors &ax = v.axis[axis];
      ax.e_max = std::max(ax.e_max, std::abs(e));
      sum[axis] += e;
      sum2[axis] += e * e;
      ++ax.n;
      v.points.push_back(pt);
    }
  }
  if (v.runs == 0) throw IdentError("validate: no 'step' segments in the logs");
  for (int a = 0; a < 3; ++a) {
    AxisErrors &ax = v.axis[a];
    if (!ax.n) continue;
    ax.e_mean = sum[a] / ax.n;
    ax.sigma = std::sqrt(std::max(0.0, sum2[a] / ax.n - ax.e_mean * ax.e_mean));
  }
  return v;
}

}  // namespace omni4
