// layout.hpp - the robot's wheel layout as the identification sees it (docs/design.md,
// "Layout"): taken from a log's first OMNI4_ROBOT (robot_t), else from the robot file's [model]
// wheels, wheel_angle_j, d_j, else the paper's four wheels at 0/90/180/270 deg at d.
//
// The paper's layout keeps the closed forms of eqs 3-5 and 9-11 (model/'s fk_robot_velocity,
// dyn_robot_forces with the model's d): a log written before OMNI4_ROBOT existed identifies to
// the same bits. Any other layout uses model/wheels.h's rows G (n x 3), the least-squares
// inverse (G^T G)^-1 G^T for the body velocity and G^T for the body force; its back-EMF
// couples the axes through G^T G (not diagonal).
#pragma once

#include <array>
#include <string>
#include <vector>

extern "C" {
#include "omni4/core/ctl_settings.h"
#include "omni4/model/wheels.h"
}

namespace omni4
{

struct LogData;

struct Layout {
	bool paper = true;            // the paper's closed forms with the model's d
	std::string source = "paper"; // "paper", "log", "robot file"
	int n = 4;                    // wheels (motors) in use
	std::array<double, 4> angle_deg{0, 90, 180, 270}; // from the v axis, counter-clockwise
	std::array<double, 4> dist_m{};                   // from the centre [m] (0: the model's d)
	wheel_geom geom{};                                // model/'s layout (not paper only)
	wheel_phys ph{};                                  // rows, fk, split (not paper only)
	double gtg[3][3]{};                               // G^T G (not paper only)

	// Body velocity (v, vn [m/s], w [rad/s]) from the rim speeds [m/s]: eqs 3-5 (paper, d) or
	// the layout's least-squares inverse.
	void body_velocity(double d, const double rim[4], double x[3]) const;
	// Body force (Fv, Fvn [N], T [N m]) of the wheel forces [N]: eqs 9-11 or G^T f.
	void body_force(double d, const double f[4], double F[3]) const;
	// One line: "3 wheels at 0/120/240 deg, d 0.09/0.09/0.09 m (from the log)".
	std::string describe() const;
};

// n wheels (3 or 4) at angle_deg, dist_m; the paper's layout (four at multiples of 90 deg in
// order, all at one distance) is marked paper. Throws IdentError for a layout that does not
// drive v, vn and w, or bad values.
Layout make_layout(int n, const double angle_deg[4], const double dist_m[4],
                   const std::string &source);

// The layout of a robot's settings ([model] wheels, wheel_angle_j, d_j; source names them in
// messages). Throws IdentError as make_layout.
Layout layout_of_settings(const ctl_settings &s, const std::string &source);

// The layout a robot_t describes (wheels, wheel_angle [rad], wheel_distance [m]); source names
// it in messages. Throws IdentError as make_layout.
Layout layout_of_description(int wheels, const double angle_rad[4], const double dist_m[4],
                             const std::string &source);

// The same wheels at the same angles and distances (to rounding: robot_t carries floats).
bool same_layout(const Layout &a, const Layout &b);

// The layout a log describes (its first robot_t); found false when it carries none.
Layout layout_of_log(const LogData &log, bool &found);

// The layout of several logs: each log's own (all must agree), else the fallback (the robot
// file's or the paper's). Throws IdentError when two logs describe different layouts.
Layout layout_of_logs(const std::vector<const LogData *> &logs, const Layout &fallback);

} // namespace omni4
