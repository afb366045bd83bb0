// identify_wheels.hpp - the per-wheel part of the identification (identify_wheels.cpp,
// identify_radii.cpp). Internal to identify*.cpp.
#pragma once

#include <vector>

#include "identify.hpp"

namespace omni4::ident
{

// The F-test of eq 22 with one (Kv, R) for every motor against one per motor (the motors with
// at least 3 points): F = ((RSS_pooled - RSS_separate) / (2 m - 2)) / (RSS_separate / (n - 2 m)),
// m motors, n points. The motors differ when P(F) < opt.agree_p.
void motors_differ_test(const std::vector<MotorPoint> &points, WheelResult &w,
                        const IdentOptions &opt);

// Each wheel's radius relative to the mean from the logs' wheel speeds (P.segments' logs), into
// P.radii (rho, the chi-square test, radii_differ).
void estimate_radii(Prepared &P);

// The mean radius from the camera, where the logs have poses (P.enc must hold tracks with
// P.base.r * rho_j): into P.radii.r_scale, or the reason it is unobservable into r_scale_note.
void camera_radius_scale(Prepared &P);

} // namespace omni4::ident
