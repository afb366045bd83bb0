// identify.hpp - the paper's identification procedure on segmented logs.
//   motor test  (eq 22): Kv, R per motor and combined (Kt = Kv)
//   experiment 1 (eq 16): Bw, Cw from steady rotation
//   experiment 2 (eqs 17-20): Bv, Cv, Bvn, Cvn from null-traction coast-downs; J from eq 20
//   experiment 3 (eqs 31-35): LS and IV on the ramped steps for the state-space model
// Final values: inverse-variance weighted mean of motor test / experiments 1-2 and experiment 3
// (IV); least squares is reported beside IV but not used in the final values.
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "logdata.hpp"
#include "regression.hpp"

extern "C" {
#include "omni4/params.h"
}

namespace omni4 {

enum class VelocitySource { Encoder, Camera };

struct IdentOptions {
  VelocitySource source = VelocitySource::Encoder;
  double steady_fraction = 0.4;  // last part of a constant-voltage segment taken as steady
};

// Points kept for plots and CSV export.
struct MotorPoint { int motor; double u, i, wm; };               // [V, A, rad/s]
struct RotationPoint { double level, omega_cam, omega_enc, torque; };
struct CurvePoint { size_t segment; double t, measured, fitted; };

struct IdentResult {
  // Per method: parameter name -> estimate. Method names: "motor", "exp1", "exp2",
  // "exp3_ls", "exp3_iv", "final".
  std::map<std::string, std::map<std::string, Estimate>> table;
  std::array<Estimate, 4> R_motor{}, Kv_motor{};
  model_params final{};
  std::vector<MotorPoint> motor_points;
  std::vector<RotationPoint> rotation_points;
  std::map<std::string, std::vector<CurvePoint>> coast_curves;  // by direction
  std::map<std::string, size_t> segments_used;                  // by kind
  std::vector<std::string> notes;
};

// base: the measured d, r, l, M (other fields ignored). Throws IdentError naming what is
// missing (an experiment kind, too few segments, a singular regression).
IdentResult identify(const std::vector<Segment> &segments, const model_params &base,
                     const IdentOptions &opt = {});

extern const char *const kIdentParams[9];   // Kv R J Bv Bvn Bw Cv Cvn Cw
extern const char *const kIdentMethods[6];  // motor exp1 exp2 exp3_ls exp3_iv final

}  // namespace omni4
