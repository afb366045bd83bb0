// validate.hpp - simulate the model on each logged input and compare (eqs 28-30, Table IV).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "logdata.hpp"

extern "C" {
#include "omni4/params.h"
}

namespace omni4 {

struct AxisErrors {
  double e_max = 0;   // largest |measured - simulated| (eq 28)
  double e_mean = 0;  // mean of (measured - simulated) (eq 29)
  double sigma = 0;   // standard deviation (eq 30)
  size_t n = 0;
};

struct ValidationPoint {
  size_t segment;
  std::string direction;
  double level, t;
  std::array<double, 3> measured, simulated;
};

struct Validation {
  std::array<AxisErrors, 3> axis{};  // v, vn, w: from the step runs along that axis
  std::vector<ValidationPoint> points;
  size_t runs = 0;
};

// Every 'step' segment: the plant of `p` driven by the logged voltages (and H-bridge state),
// started from the measured velocity, against the encoder velocity (eqs 3-5, SG-smoothed).
// Throws IdentError if no step segment exists.
Validation validate(const std::vector<Segment> &segments, const model_params &p);

}  // namespace omni4
