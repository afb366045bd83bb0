// identify.cpp - motor test, experiments 1-3 and their combination.
#include "identify.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "signals.hpp"

namespace omni4 {

const char *const kIdentParams[9] = {"Kv", "R", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw"};
const char *const kIdentMethods[6] = {"motor", "exp1", "exp2", "exp3_ls", "exp3_iv", "final"};

namespace {

constexpr int kEncHalf = 20;  // encoder SG half window (41 samples at 1 kHz)
constexpr int kMotorsModeVoltage = 2;

std::vector<const Segment *> of_kind(const std::vector<Segment> &all, const std::string &kind) {
  std::vector<const Segment *> out;
  for (const Segment &s : all)
    if (s.kind == kind) out.push_back(&s);
  return out;
}

// Index range of the steady part of a constant-voltage segment (driven samples only).
std::pair<size_t, size_t> steady_window(const Segment &s, double fraction) {
  size_t last = s.m1;
  while (last > s.m0 && s.log->motors[last - 1].mode != kMotorsModeVoltage) --last;
  const size_t n = last - s.m0;
  const size_t first = last - static_cast<size_t>(fraction * n);
  return {first, last};
}

// ---- motor test (eq 22) ----------------------------------------------------------------

void motor_test(const std::vector<const Segment *> &segs, const model_params &base,
                const IdentOptions &opt, IdentResult &res) {
  if (segs.empty())
    throw IdentError("no 'motor' segments: the motor test (eq 22) is needed for Kv and R");
  for (const Segment *s : segs) {
    const auto [a, b] = steady_window(*s, opt.steady_fraction);
    if (b - a < 50) continue;
    for (int j = 0; j < 4; ++j) {
      double u = 0, i = 0, w = 0;
      for (size_t k = a; k < b; ++k) {
        const MotorsSample &m = s->log->motors[k];
        u += m.u[j];
        i += m.i[j];
        w += m.w[j] * base.l;  // motor speed before the gearbox
      }
      const double n = static_cast<double>(b - a);
      if (std::abs(u / n) > 1.0 && std::abs(i / n) > 0.05)
        res.motor_points.push_back({j, u / n, i / n, w / n});
    }
  }
  // eq 22: u/i = Kv (w_m / i) + R, per motor and pooled.
  auto fit = [&](int motor) {
    std::vector<const MotorPoint *> pts;
    for (const MotorPoint &p : res.motor_points)
      if (motor < 0 || p.motor == motor) pts.push_back(&p);
    Eigen::MatrixXd X(pts.size(), 2);
    Eigen::VectorXd y(pts.size());
    for (size_t k = 0; k < pts.size(); ++k) {
      X(k, 0) = pts[k]->wm / pts[k]->i;
      X(k, 1) = 1.0;
      y[k] = pts[k]->u / pts[k]->i;
    }
    const std::string what = motor < 0 ? "motor test (all motors)"
                                       : "motor test (motor " + std::to_string(motor) + ")";
    return least_squares(X, y, 1.0, what);
  };
  double rsum = 0, rvar = 0;
  for (int j = 0; j < 4; ++j) {
    const Fit f = fit(j);
    res.Kv_motor[j] = {f.theta[0], std::sqrt(f.cov(0, 0))};
    res.R_motor[j] = {f.theta[1], std::sqrt(f.cov(1, 1))};
    rsum += f.theta[1];
    rvar += f.cov(1, 1);
  }
  const Fit all = fit(-1);
  res.table["motor"]["Kv"] = {all.theta[0], std::sqrt(all.cov(0, 0))};
  // The paper averages R over the four motors.
  res.table["motor"]["R"] = {rsum / 4, std::sqrt(rvar) / 4};
}

// ---- experiment 1 (eq 16) ----------------------------------------------------------------

double slope(const std::vector<double> &t, const std::vector<double> &y) {
  const double n = static_cast<double>(t.size());
  const double tm = std::accumulate(t.begin(), t.end(), 0.0) / n;
  const double ym = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double num = 0, den = 0;
  for (size_t k = 0; k < t.size(); ++k) {
    num += (t[k] - tm) * (y[k] - ym);
    den += (t[k] - tm) * (t[k] - tm);
  }
  return den > 0 ? num / den : NAN;
}

void experiment1(const std::vector<const Segment *> &segs, const model_params &base, double Kt,
                 const IdentOptions &opt, IdentResult &res) {
  if (segs.size() < 3)
    throw IdentError("experiment 1 needs at least 3 'steady_rotation' segments, found " +
                     std::to_string(segs.size()));
  for (const Segment *s : segs) {
    const auto [a, b] = steady_window(*s, opt.steady_fraction);
    if (b - a < 50) continue;
    const auto &m = s->log->motors;
    double isum = 0, wenc = 0;
    for (size_t k = a; k < b; ++k) {
      isum += m[k].i[0] + m[k].i[1] + m[k].i[2] + m[k].i[3];
      wenc += (m[k].w[0] + m[k].w[1] + m[k].w[2] + m[k].w[3]) * base.r / (4 * base.d);
    }
    const double n = static_cast<double>(b - a);
    const double torque = base.d * base.l * Kt / base.r * isum / n;  // eqs 11-13
    // Camera: slope of the unwrapped heading over the same window.
    std::vector<double> t, th;
    for (size_t k = s->p0; k < s->p1; ++k) {
      const PoseSample &p = s->log->pose[k];
      if (p.utime < m[a].utime || p.utime > m[b - 1].utime) continue;
      t.push_back(p.utime * 1e-6);
      th.push_back(p.theta);
    }
    unwrap(th);
    const double wcam = t.size() >= 5 ? slope(t, th) : NAN;
    res.rotation_points.push_back({s->level, wcam, wenc / n, torque});
  }
  const bool cam = opt.source == VelocitySource::Camera;
  Eigen::MatrixXd X(res.rotation_points.size(), 2);
  Eigen::VectorXd y(res.rotation_points.size());
  for (size_t k = 0; k < res.rotation_points.size(); ++k) {
    const RotationPoint &p = res.rotation_points[k];
    X(k, 0) = cam ? p.omega_cam : p.omega_enc;
    X(k, 1) = 1.0;
    y[k] = p.torque;
  }
  if (!X.allFinite()) throw IdentError("experiment 1: no camera poses in the steady windows");
  const Fit f = least_squares(X, y, 1.0, "experiment 1 (T = Bw w + Cw)");
  res.table["exp1"]["Bw"] = {f.theta[0], std::sqrt(f.cov(0, 0))};
  res.table["exp1"]["Cw"] = {f.theta[1], std::sqrt(f.cov(1, 1))};
}

// ---- experiment 2 (eqs 17-20) ----------------------------------------------------------

VelocitySeries velocity(const Segment &s, const model_params &base, const IdentOptions &opt) {
  return opt.source == VelocitySource::Camera ? camera_velocity(s)
                                              : encoder_velocity(s, base.d, base.r, kEncHalf);
}

// Integral form of x' = -b x - c (x > 0): x(t) = x0_s - b int x dt - c (t - t0), one x0 per
// segment. No numerical differentiation. Returns theta = [x0..., b, c].
Fit coast_fit(const std::vector<const Segment *> &segs, int axis, const model_params &base,
              const IdentOptions &opt, const std::string &dir, IdentResult &res) {
  const double stop = axis == 2 ? 0.5 : 0.05;  // below this the robot is about to stick
  struct Row { size_t seg; double t, x, integral; };
  std::vector<Row> rows;
  std::vector<VelocitySeries> series;
  for (size_t si = 0; si < segs.size(); ++si) {
    VelocitySeries vs = velocity(*segs[si], base, opt);
    if (vs.t.size() < 5) continue;
    const double sign = vs.x.front()[axis] >= 0 ? 1.0 : -1.0;
    double integral = 0;
    size_t first = rows.size();
    for (size_t k = 0; k < vs.t.size(); ++k) {
      const double x = sign * vs.x[k][axis];
      if (vs.t[k] < 0.05) continue;  // skip the switch-off instant
      if (x < stop) break;
      if (rows.size() > first)
        integral += 0.5 * (x + rows.back().x) * (vs.t[k] - rows.back().t);
      rows.push_back({si, vs.t[k], x, integral});
    }
  }
  const size_t nseg = segs.size();
  if (rows.size() < 10)
    throw IdentError("experiment 2: the '" + dir + "' coast-downs hold too few moving samples");
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(rows.size(), nseg + 2);
  Eigen::VectorXd y(rows.size());
  std::vector<double> t0(nseg, NAN);
  for (const Row &r : rows)
    if (std::isnan(t0[r.seg])) t0[r.seg] = r.t;
  for (size_t k = 0; k < rows.size(); ++k) {
    X(k, rows[k].seg) = 1.0;
    X(k, nseg) = -rows[k].integral;
    X(k, nseg + 1) = -(rows[k].t - t0[rows[k].seg]);
    y[k] = rows[k].x;
  }
  // Segments without samples leave an all-zero column: drop them.
  std::vector<Eigen::Index> keep;
  for (size_t c = 0; c < nseg + 2; ++c)
    if (X.col(c).cwiseAbs().sum() > 0) keep.push_back(c);
  Eigen::MatrixXd Xk(X.rows(), keep.size());
  for (size_t c = 0; c < keep.size(); ++c) Xk.col(c) = X.col(keep[c]);
  const double corr = opt.source == VelocitySource::Camera ? 9 : 2 * kEncHalf + 1;
  Fit f = least_squares(Xk, y, corr, "experiment 2 (coast-down along " + dir + ")");
  const Eigen::VectorXd fitted = Xk * f.theta;
  for (size_t k = 0; k < rows.size(); ++k)
    res.coast_curves[dir].push_back({rows[k].seg, rows[k].t, rows[k].x, fitted[k]});
  return f;
}

void experiment2(const std::vector<const Segment *> &segs, const model_params &base,
                 const IdentOptions &opt, IdentResult &res) {
  const Estimate Bw = res.table["exp1"]["Bw"], Cw = res.table["exp1"]["Cw"];
  for (const char *dir : {"v", "vn", "w"}) {
    std::vector<const Segment *> mine;
    for (const Segment *s : segs)
      if (s->direction == dir) mine.push_back(s);
    if (mine.empty())
      throw IdentError(std::string("experiment 2 needs 'coast' segments along ") + dir);
    const int axis = axis_index(dir);
    const Fit f = coast_fit(mine, axis, base, opt, dir, res);
    const Eigen::Index nb = f.theta.size() - 2, nc = f.theta.size() - 1;
    const Estimate b{f.theta[nb], std::sqrt(f.cov(nb, nb))};
    const Estimate c{f.theta[nc], std::sqrt(f.cov(nc, nc))};
    if (axis < 2) {
      const std::string B = axis == 0 ? "Bv" : "Bvn", C = axis == 0 ? "Cv" : "Cvn";
      res.table["exp2"][B] = {base.M * b.value, base.M * b.se};  // eqs 17-18
      res.table["exp2"][C] = {base.M * c.value, base.M * c.se};
      continue;
    }
    // eq 20 over the coast-down: J (b w + c) = Bw w + Cw in the least-squares sense.
    double num = 0, den = 0;
    for (const CurvePoint &p : res.coast_curves["w"]) {
      const double a = b.value * p.measured + c.value;
      num += a * (Bw.value * p.measured + Cw.value);
      den += a * a;
    }
    const double J = num / den;
    // Relative errors of b, c and of Bw, Cw add (first order).
    const double rel = std::hypot(std::hypot(b.se / b.value, c.se / c.value),
                                  std::hypot(Bw.se / Bw.value, Cw.se / Cw.value));
    res.table["exp2"]["J"] = {J, J * rel};
  }
}

// ---- experiment 3 (eqs 31-35) ----------------------------------------------------------

double input_of(const MotorsSample &m, int axis) {
  switch (axis) {
    case 0: return m.u[3] - m.u[1];
    case 1: return m.u[0] - m.u[2];
    default: return m.u[0] + m.u[1] + m.u[2] + m.u[3];
  }
}

double sgn(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

struct AxisData {
  Eigen::MatrixXd X;  // [x, input, sign(x)]
  Eigen::VectorXd y;  // dx/dt
  std::vector<size_t> start;  // first row of each run
  std::vector<double> dt;     // sample period of each run
};

AxisData axis_data(const std::vector<const Segment *> &segs, int axis, const model_params &base) {
  const double thr = axis == 2 ? 0.5 : 0.05;
  std::vector<std::array<double, 4>> rows;  // x, input, sign, y
  AxisData d;
  const SgFilter f = savitzky_golay(kEncHalf, 2);
  for (const Segment *s : segs) {
    const VelocitySeries vs = encoder_velocity(*s, base.d, base.r, kEncHalf);
    const auto &m = s->log->motors;
    bool started = false;
    double dt = 1e-3;
    if (vs.t.size() > 1) dt = (vs.t.back() - vs.t.front()) / (vs.t.size() - 1);
    for (size_t k = 0; k < vs.t.size(); ++k) {
      const size_t mi = vs.motors_index[k];
      if (m[mi].mode != kMotorsModeVoltage) break;  // the run ends where the drive stops
      const double x = vs.x[k][axis];
      if (std::abs(x) < thr) {
        if (started) break;
        continue;
      }
      // Input filtered like the output; the voltage logged at tick k-1 acts until tick k.
      double in = 0;
      for (int q = -kEncHalf; q <= kEncHalf; ++q) {
        const long idx = std::clamp<long>(static_cast<long>(mi) + q - 1, 0,
                                          static_cast<long>(m.size()) - 1);
        in += f.smooth[q + kEncHalf] * input_of(m[idx], axis);
      }
      if (!started) {
        d.start.push_back(rows.size());
        d.dt.push_back(dt);
        started = true;
      }
      rows.push_back({x, in, sgn(x), vs.dx[k][axis]});
    }
  }
  d.X.resize(rows.size(), 3);
  d.y.resize(rows.size());
  for (size_t k = 0; k < rows.size(); ++k) {
    d.X.row(k) << rows[k][0], rows[k][1], rows[k][2];
    d.y[k] = rows[k][3];
  }
  return d;
}

// Instruments: the noise-free response of the current model to the logged input (Euler at the
// sample period, from the first measured value of each run).
Eigen::MatrixXd instruments(const AxisData &d, const Eigen::VectorXd &theta) {
  Eigen::MatrixXd Z = d.X;
  for (size_t r = 0; r < d.start.size(); ++r) {
    const size_t a = d.start[r], b = r + 1 < d.start.size() ? d.start[r + 1] : d.X.rows();
    double xb = d.X(a, 0);
    for (size_t k = a; k < b; ++k) {
      Z(k, 0) = xb;
      Z(k, 2) = sgn(xb);
      xb += d.dt[r] * (theta[0] * xb + theta[1] * d.X(k, 1) + theta[2] * sgn(xb));
    }
  }
  return Z;
}

void experiment3(const std::vector<const Segment *> &segs, const model_params &base,
                 IdentResult &res) {
  const double Kv = res.table["motor"]["Kv"].value, Kt = Kv;
  const double l = base.l, r = base.r, d = base.d, M = base.M;
  const double emf = Kt * Kv * l * l / (r * r);  // x 1/R
  std::array<Fit, 3> ls, iv;
  for (int axis = 0; axis < 3; ++axis) {
    static const char *const dirs[3] = {"v", "vn", "w"};
    std::vector<const Segment *> mine;
    for (const Segment *s : segs)
      if (s->direction == dirs[axis]) mine.push_back(s);
    if (mine.empty())
      throw IdentError(std::string("experiment 3 needs 'step' segments along ") + dirs[axis]);
    const AxisData data = axis_data(mine, axis, base);
    const std::string what = std::string("experiment 3 along ") + dirs[axis];
    ls[axis] = least_squares(data.X, data.y, 2 * kEncHalf + 1, what + " (LS)");
    Eigen::VectorXd theta = ls[axis].theta;
    for (int it = 0; it < 3; ++it) {
      iv[axis] = instrumental_variables(instruments(data, theta), data.X, data.y,
                                        2 * kEncHalf + 1, what + " (IV)");
      theta = iv[axis].theta;
    }
  }
  for (const auto &[name, fits] : {std::pair<std::string, std::array<Fit, 3> *>{"exp3_ls", &ls},
                                   {"exp3_iv", &iv}}) {
    auto &t = res.table[name];
    const Fit &fv = (*fits)[0], &fn = (*fits)[1], &fw = (*fits)[2];
    // theta_2 = l Kt / (r R M) along v and vn (eq 26): R from each, combined.
    const Estimate Rv = propagate([&](const Eigen::VectorXd &q) { return l * Kt / (r * M * q[1]); },
                                  fv.theta, fv.cov);
    const Estimate Rn = propagate([&](const Eigen::VectorXd &q) { return l * Kt / (r * M * q[1]); },
                                  fn.theta, fn.cov);
    const Estimate R = combine({Rv, Rn});
    t["R"] = R;
    // A11 = -(2 emf / (R M) + Bv / M), K11 = -Cv / M.
    t["Bv"] = propagate([&](const Eigen::VectorXd &q) { return -M * q[0] - 2 * emf / R.value; },
                        fv.theta, fv.cov);
    t["Bvn"] = propagate([&](const Eigen::VectorXd &q) { return -M * q[0] - 2 * emf / R.value; },
                         fn.theta, fn.cov);
    t["Cv"] = propagate([&](const Eigen::VectorXd &q) { return -M * q[2]; }, fv.theta, fv.cov);
    t["Cvn"] = propagate([&](const Eigen::VectorXd &q) { return -M * q[2]; }, fn.theta, fn.cov);
    // Along w: theta_2 = l Kt d / (r R J), A33 = -(4 d^2 emf / (R J) + Bw / J), K33 = -Cw / J.
    auto J_of = [&](const Eigen::VectorXd &q) { return l * Kt * d / (r * R.value * q[1]); };
    t["J"] = propagate(J_of, fw.theta, fw.cov);
    t["Bw"] = propagate(
        [&](const Eigen::VectorXd &q) { return -J_of(q) * q[0] - 4 * d * d * emf / R.value; },
        fw.theta, fw.cov);
    t["Cw"] = propagate([&](const Eigen::VectorXd &q) { return -J_of(q) * q[2]; }, fw.theta,
                        fw.cov);
  }
}

}  // namespace

IdentResult identify(const std::vector<Segment> &segments, const model_params &base,
                     const IdentOptions &opt) {
  IdentResult res;
  for (const Segment &s : segments) ++res.segments_used[s.kind];
  motor_test(of_kind(segments, "motor"), base, opt, res);
  const double Kt = res.table["motor"]["Kv"].value;  // Kt = Kv (SI units)
  experiment1(of_kind(segments, "steady_rotation"), base, Kt, opt, res);
  experiment2(of_kind(segments, "coast"), base, opt, res);
  experiment3(of_kind(segments, "step"), base, res);

  auto &fin = res.table["final"];
  auto &t = res.table;
  fin["Kv"] = t["motor"]["Kv"];
  fin["R"] = combine({t["motor"]["R"], t["exp3_iv"]["R"]});
  for (const char *p : {"Bv", "Bvn", "Cv", "Cvn", "J"})
    fin[p] = combine({t["exp2"][p], t["exp3_iv"][p]});
  for (const char *p : {"Bw", "Cw"}) fin[p] = combine({t["exp1"][p], t["exp3_iv"][p]});

  res.final = base;
  res.final.Kv = res.final.Kt = fin["Kv"].value;
  res.final.R = fin["R"].value;
  res.final.J = fin["J"].value;
  res.final.Bv = fin["Bv"].value;
  res.final.Bvn = fin["Bvn"].value;
  res.final.Bw = fin["Bw"].value;
  res.final.Cv = fin["Cv"].value;
  res.final.Cvn = fin["Cvn"].value;
  res.final.Cw = fin["Cw"].value;
  int bad = -1;
  if (model_params_check(&res.final, &bad))
    throw IdentError(std::string("identified parameters are not physical: ") +
                     model_params_names[bad] + " = " +
                     std::to_string(model_params_get(&res.final, bad)));
  return res;
}

}  // namespace omni4
