// compare.hpp - one robot's figures for the paper's comparison of wheel layouts (omni4-compare,
// docs/compare.md): top steady speeds, the acceleration envelope from rest, energy per metre,
// the planner's time for a fixed set of moves and each wheel's traction margin. Everything from
// the robot's INI (its identified model, layout and limits) through model/wheels.h and the
// planner (core/ planner/traj.h); no I/O here.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

extern "C" {
#include "omni4/core/ctl_settings.h"
#include "omni4/model/wheels.h"
}

namespace omni4::compare
{

// One line for the user: a robot file that cannot be read or compared.
struct CompareError : std::runtime_error {
	using std::runtime_error::runtime_error;
};

struct Robot {
	std::string name; // the INI's file name without folder and ".ini"
	std::string path;
	ctl_settings s{};
	wheel_geom geom{};
	model_wheels w{}; // the drives in force (ctl_settings_wheels)
	wheel_phys ph{};  // drives and loads with the INI's com_height
	double mu = 0.0;  // the floor's friction coefficient: [limits] traction_mu, else floor_mu
	double supply_v = 0.0;
};

// Reads and checks path (the config library's one-line message on error).
Robot load_robot(const std::string &path);

// A largest value and what bounds it: wheel (0-based, -1: none) and "voltage" or "traction".
struct Bound {
	double value = 0.0;
	int wheel = -1;
	std::string kind = "none";
};

// The unit direction of heading_deg [deg] in the v-vn plane, (v, vn, w) with w = 0 (exact at
// multiples of 90 deg).
void heading_dir(double heading_deg, double e[3]);

// Top steady speed along the unit body direction e ((v, vn, w)): the largest s [m/s or rad/s]
// at which the least-norm split of the body friction B s e + C sgn(e) needs no wheel voltage
// beyond supply_v (motor equation, back-EMF included).
Bound top_speed(const Robot &r, const double e[3]);

// The largest acceleration [m/s^2 or rad/s^2] along e from rest: body force a (M, M, J) e +
// C sgn(e) split least norm, every |u_j| <= supply_v and |f_j| <= mu N_j (loads with the load
// transfer of the centre of mass's acceleration a e).
Bound envelope(const Robot &r, const double e[3]);

// Each wheel's force [N], load [N] and voltage [V] at acceleration acc along e from rest.
struct WheelState {
	double force_n[4], load_n[4], voltage_v[4];
};
WheelState at_rest(const Robot &r, const double e[3], double acc);

// Electrical power sum u_j i_j [W] at steady speed speed (> 0) along e, over that speed [J/m].
double energy_per_m(const Robot &r, const double e[3], double speed);

// A move from rest at the origin to rest at (x [m], y [m], theta [rad]), world = body frame at
// the start.
struct Move {
	const char *name;
	double x_m, y_m, theta_rad;
};
const std::vector<Move> &moves();

// The planner's duration [s] of each of moves() (traj_plan with the goal mode's limits of the
// INI, goal_limits, and the robot's layout); all NaN when the planner refuses the limits (no
// acceleration at rest: Coulomb friction beyond traction or voltage).
std::vector<double> move_times(const Robot &r);

} // namespace omni4::compare
