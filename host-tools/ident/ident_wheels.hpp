// ident_wheels.hpp - omni4-ident's per-wheel output: the table, the [model] wheel keys, the CSV,
// and a robot file's wheels (its [model] wheel keys, and for a simulated robot its [sim] errors).
#pragma once

#include <string>

#include "identify.hpp"

namespace omni4
{

// The per-wheel table (each motor's R_j, Kv_j, each wheel's radius relative to the mean, with
// SEs; the tests of whether they differ; the camera's mean radius), with the truth's error
// where given.
void print_wheels(const IdentResult &r, const model_wheels *truth);

// The [model] wheel keys of r (appended after the scalars): R_j, Kv_j, Kt_j where the motors
// differ, r_j where the radii do; "" for a uniform robot (its file keeps the scalars only).
std::string wheel_keys_ini(const IdentResult &r);

// wheels.csv: wheel, quantity (R, Kv, rho, r), value, se, true (empty without a truth).
std::string wheels_csv(const IdentResult &r, const model_wheels *truth);

// A robot file's wheels: its [model] (wheel keys over the scalars) and, for the simulated
// robot's file, its [sim] motor_R_error_j, motor_Kv_error_j, wheel_radius_error_j on top.
// Dies with the config's message when the file is not valid.
model_wheels load_wheels(const std::string &path, bool with_sim_errors);

} // namespace omni4
