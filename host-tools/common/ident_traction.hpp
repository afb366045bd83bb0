// ident_traction.hpp - the floor's traction from the traction experiment (traction_exp.hpp):
// per direction, the friction coefficient and the largest acceleration the robot holds.
//
// Each "traction" segment is one voltage step from rest. It slipped when the robot velocity
// the encoders read (eqs 3-5) runs away from the velocity the measured currents can give a
// gripping robot (eqs 9-13, 23 integrated from the segment's start with the model; a 10-sample
// running mean beyond 0.02 m/s + 3 % of the speed): a slipping wheel spins up on its own
// inertia, faster than the body. Its peak wheel force is l Kt i / r of the driven wheels'
// currents (5-sample mean, the largest), as a share of a quarter of the weight (mu_run).
// A wheel that slips on, its rim near the speed where its motor's force meets the kinetic
// friction (it gets there within a few J_w R / (l^2 Kt Kv), tens of ms), pushes with
// l Kt i / r = mu N_j + (J_w / r^2) s', the last term fading but still 1-2 % of mu at the end
// of a 0.1 s step on the simulated floors. Each run still slipping at its end gives two
// windows, its last 20 driven samples and the 20 before: the driven wheels' mean force over
// M g / 4 and their rims' acceleration. Of the top half of those runs by level (lower levels
// may grip again before the end), those past their break-away (the rim's acceleration fading
// from the first window to the last) give mu as the intercept of force against rim
// acceleration over both windows of every run, the slope (J_w / r^2) fitted from each run's
// own fading; the SE is cluster-robust with the run as the observation. Too few such runs:
// the end windows' mean, SE their spread. Without a run slipping at its end, mu is a lower
// bound: the largest peak of the runs that held. The first slipped level and the
// last held one are reported; the largest held acceleration is the steepest 25-sample
// least-squares slope of the velocity along the direction (with that fit's SE) of the
// highest run that held and whose peak stayed below mu M g / 4.
//
// Along v, vn and w the driving wheels carry no load transfer (they sit across the
// acceleration, or it is a rotation): one fit over their runs gives the floor's traction_mu
// (one floor, one wheel inertia; too few runs: the directions' inverse-variance mean). Along
// the diagonal all four push and the two ahead of the acceleration unload: with all four
// slipping (the runs at twice the first slipped level or more), the pair on the v
// axis (wheels 0 ahead, 2 behind) differ by M h a_v / d in load, a_v = (|f_1| + |f_3| - Cv) / M,
// so h = (|f_2| - |f_0|) d / (mu M a_v); the vn pair likewise; com_height is their mean.
//
// Another layout (docs/identification.md, "The traction experiment on another layout"): the
// directions whose driven wheels keep their load (always w) give mu by a per-wheel fit of the
// wheels still slipping at their run's end, each against its own load at rest (model/wheels.h);
// com_height comes from the other directions' slipping wheels, written only when the load
// transfer they saw is 5 % of their force or more.
#pragma once

#include <array>
#include <cstdio>
#include <string>
#include <vector>

#include "layout.hpp"
#include "logdata.hpp"

extern "C" {
#include "omni4/model/params.h"
}

namespace omni4
{

struct TractionRun {
	std::string direction;
	std::array<double, 4> pattern{}; // the channels' voltages per volt of level (the layout's)
	double level = 0;                // [V]
	bool slipped = false;
	double slip = 0;  // largest |encoder velocity - current-driven prediction| [m/s]
	double force = 0; // peak wheel force, mean over the driven wheels [N]
	double mu = 0;    // the driven wheels' peak force over their load at rest (M g / 4 each)
	double acc = 0;   // steepest acceleration along the direction [m/s^2 or rad/s^2]
	double acc_se = 0;
	bool slip_at_end = false;                // still slipping when the bridges went off
	std::array<bool, 4> wheel_slip_at_end{}; // each rim then off the body's (eq 2) speed
	std::array<double, 3> body_end{};        // the body's velocity the currents gave, then
	std::array<double, 4> end_f{};   // each wheel's force over the last 20 driven samples [N]
	double end_mu = 0;               // mean |end_f| / load at rest of the driven wheels
	std::array<double, 4> end_acc{}; // each rim's acceleration over those samples [m/s^2]
	double end_rim_acc = 0;          // the driven rims', along their force, mean [m/s^2]
	// The same over the 20 driven samples before those (the rim nearer its break-away).
	double early_mu = 0, early_rim_acc = 0;
	std::array<double, 4> early_f{}, early_acc{};
};

struct TractionDirection {
	std::string direction;
	int runs = 0, held = 0;
	bool reached = false; // some level slipped (otherwise mu is a lower bound)
	double mu = 0, mu_se = 0;
	double acc = 0, acc_se = 0;            // largest held acceleration [m/s^2; rad/s^2 along w]
	double level_held = 0, level_slip = 0; // [V]
	double wheel_share = 0; // J_w / r^2 in units of M g / 4 per m/s^2 (kinetic_fit)
};

struct TractionResult {
	std::vector<TractionRun> runs;
	std::vector<TractionDirection> directions;
	bool ok = false;          // traction_mu measured
	double mu = 0, mu_se = 0; // the floor's (from the directions in pooled)
	std::string pooled;       // the directions whose driven wheels keep their load: "v, vn, w"
	int runs_fitted = 0;      // the settled kinetic runs it was fitted on (0: directions' mean)
	bool have_com = false;
	double com_height = 0; // [m], from the diagonal (another layout: the runs in com_from)
	std::string com_from;  // where com_height came from, in words
	double com_share =
	    0; // another layout: the load transfer seen, a share of the wheels' force
};

// The traction segments of segs with the robot's model p (M, J, d, r, l, Kt, B*, C*) and its
// wheel layout L (default: the paper's four at 0/90/180/270 deg at d).
TractionResult identify_traction(const std::vector<Segment> &segs, const model_params &p,
                                 const Layout &L = Layout{});

// Table on stdout; CSV files traction_runs.csv and traction.csv in dir; the [limits] lines of
// PARAMS.ini (traction_mu, com_height, the per-direction figures as comments). false: a write
// failed.
void print_traction(const TractionResult &r);
void export_traction_csv(const std::string &dir, const TractionResult &r);
bool write_traction_limits(FILE *f, const TractionResult &r);

} // namespace omni4
