// validate.hpp - simulate the model on each logged input and compare (eqs 28-30, Table IV).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "identify.hpp"
#include "logdata.hpp"

extern "C" {
#include "omni4/model/params.h"
}

namespace omni4
{

struct AxisErrors {
	double e_max = 0;  // largest |measured - simulated| (eq 28)
	double e_mean = 0; // mean of (measured - simulated) (eq 29)
	double sigma = 0;  // standard deviation (eq 30)
	size_t n = 0;
};

struct ValidationPoint {
	size_t segment;
	std::string direction;
	double level, t; // t: from the segment's mark [s]
	std::array<double, 3> measured, simulated;
};

struct Validation {
	std::array<AxisErrors, 3> axis{}; // v, vn, w: from the step runs along that axis
	std::vector<ValidationPoint> points;
	std::vector<WindowRecord> rejected; // step segments or drives not used, with the reason
	size_t runs = 0;
};

// Every step window (a driven run inside a 'step' segment, see windows.hpp): the plant of `p`
// driven by the logged voltages (and H-bridge state), started from the encoder velocity at the
// start of the drive, against the measured velocity: the wheel encoders (eqs 3-5,
// SG-smoothed) or the camera (opt.source). Throws IdentError if no step window exists.
Validation validate(const std::vector<Segment> &segments, const model_params &p,
                    const IdentOptions &opt = {});
// The same with each wheel's own drive w (dynamics.h, per-wheel drives): the plant gets w's
// R_j, Kv_j (= Kt_j) and r_j as its motor and radius errors against p's scalars, the encoder
// velocities use r_j. With four wheels equal to p's scalars: the bits of the scalar version.
Validation validate(const std::vector<Segment> &segments, const model_params &p,
                    const model_wheels &w, const IdentOptions &opt = {});

} // namespace omni4
