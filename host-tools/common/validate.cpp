// validate.cpp - model simulation against the logs.
#include "validate.hpp"

#include <cmath>
#include <map>

#include "regression.hpp"
#include "signals.hpp"
#include "windows.hpp"

extern "C" {
#include "omni4/plant.h"
}

namespace omni4 {

Validation validate(const std::vector<Segment> &segments, const model_params &p,
                    const IdentOptions &opt) {
  Validation v;
  std::array<double, 3> sum{}, sum2{};
  std::map<const LogData *, EncoderTrack> encs;
  std::map<const LogData *, CameraTrack> cams;
  const bool cam = opt.source == VelocitySource::Camera;
  for (size_t si = 0; si < segments.size(); ++si) {
    const Segment &s = segments[si];
    if (s.kind != "step") continue;
    if (!encs.count(s.log)) encs.emplace(s.log, encoder_track(*s.log, p.d, p.r));
    if (cam && !cams.count(s.log)) cams.emplace(s.log, camera_track(*s.log));
    const EncoderTrack &enc = encs.at(s.log);
    const SegmentWindows wins = find_windows(s, enc, opt.windows);
    for (const Rejection &r : wins.rejected)
      v.rejected.push_back({si, s.kind, s.direction, r.what, r.t0_s, r.t1_s, false, r.reason});
    const int axis = axis_index(s.direction);
    const auto &m = s.log->motors;
    for (const Window &w : wins.step) {
      // Start at the first sample with a valid encoder velocity.
      size_t k0 = w.m0;
      while (k0 < w.m1 && !enc.ok[k0]) ++k0;
      if (k0 + 10 >= w.m1) {
        v.rejected.push_back({si, s.kind, s.direction, "step", seg_time(s, w.m0),
                              seg_time(s, w.m1 - 1), false, "no valid encoder velocity"});
        continue;
      }
      ++v.runs;
      plant pl;
      if (plant_init(&pl, &p)) throw IdentError("validate: parameters are not physical");
      for (int a = 0; a < 3; ++a) pl.x[a] = enc.x[k0][a];
      // Measured samples: encoder samples of the window, or camera frames inside it.
      std::vector<std::pair<double, std::array<double, 3>>> meas;  // utime [s], velocity
      if (cam) {
        const CameraTrack &ct = cams.at(s.log);
        const double ta = m[k0].utime * 1e-6, tb = m[w.m1 - 1].utime * 1e-6;
        for (size_t q = 0; q < ct.t.size(); ++q)
          if (ct.ok[q] && ct.t[q] >= ta && ct.t[q] <= tb) meas.push_back({ct.t[q], ct.x[q]});
      } else {
        for (size_t k = k0; k < w.m1; ++k)
          if (enc.ok[k]) meas.push_back({m[k].utime * 1e-6, enc.x[k]});
      }
      size_t i = k0;  // the plant state is at m[i].utime
      for (const auto &[t, x] : meas) {
        // Advance the plant tick by tick up to the measurement; the voltage logged at tick i
        // acts until tick i + 1 (held across lost samples).
        while (i + 1 < w.m1 && m[i + 1].utime * 1e-6 <= t + 1e-9) {
          const MotorsSample &ms = m[i];
          const double u[4] = {ms.u[0], ms.u[1], ms.u[2], ms.u[3]};
          plant_step(&pl, u, driven_mode(ms.mode), (m[i + 1].utime - ms.utime) * 1e-6);
          ++i;
        }
        ValidationPoint pt{si, s.direction, s.level, t - s.t0 * 1e-6, x,
                           {pl.x[0], pl.x[1], pl.x[2]}};
        const double e = pt.measured[axis] - pt.simulated[axis];
        AxisErrors &ax = v.axis[axis];
        ax.e_max = std::max(ax.e_max, std::abs(e));
        sum[axis] += e;
        sum2[axis] += e * e;
        ++ax.n;
        v.points.push_back(pt);
      }
    }
  }
  if (v.runs == 0) throw IdentError("validate: no step runs in the logs (no 'step' segment with a drive)");
  for (int a = 0; a < 3; ++a) {
    AxisErrors &ax = v.axis[a];
    if (!ax.n) continue;
    ax.e_mean = sum[a] / ax.n;
    ax.sigma = std::sqrt(std::max(0.0, sum2[a] / ax.n - ax.e_mean * ax.e_mean));
  }
  return v;
}

}  // namespace omni4
