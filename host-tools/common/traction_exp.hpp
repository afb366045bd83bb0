// traction_exp.hpp - the traction experiment as a timeline of phases (experiments.hpp): along v,
// vn, w and the diagonal v + vn, voltage steps from rest with a short ramp, each a little
// larger than the last (a geometric series of levels) up to a cap, each held briefly and
// followed by coasting to rest (bridges off: the safe stop). The runner watches the
// estimator's SLIP flag (traction_watch) and stops a direction at its first slipped level; the
// cap (12 V, the supply) ends a direction whose wheels never slip. The first level at which a
// wheel slips brackets the floor's traction (ident_traction.hpp). Each coast ends with a
// clear-fault command: a slip trips the controller's encoder plausibility check (FAULT_ENCODER,
// bridges off), which the experiment provokes on purpose; once the robot is at rest it is cleared.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "experiments.hpp"

extern "C" {
#include "omni4/model/params.h"
}

namespace omni4
{

struct TractionSeqOptions {
	std::vector<std::string> directions{"v", "vn", "w", "diag"};
	double level0_v = 1.2; // first level [V]: above what Coulomb friction takes along v
	double growth = 1.05;  // each level this much above the last
	double cap_v = 12.0;   // the last level [V]: the supply
	double ramp_s = 0.03;  // rise of each step (the paper's ramped steps)
	double hold_s = 0.10;  // held after the ramp, then the bridges go off
	double settle_s = 1.2; // coasting to rest
	Layout layout;         // the wheels' layout: each direction's pattern (drive_pattern)
};

// Channel voltage pattern per volt along "v", "vn", "w" (drive_pattern) or "diag" (v + vn), of
// the paper's layout or of layout.
std::array<double, 4> traction_pattern(const std::string &direction, const Layout &layout = {});

// The runner's live watch on the estimator's flags (state_t.flags) while the sequence plays:
// the first SLIP in a traction run (its step or the coast after it) notes that run's level,
// and once the run at kDiagonalFactor times that level has played along the diagonal (the
// load transfer needs all four wheels slipping: ident_traction.hpp), at once along v, vn and
// w, the direction's remaining levels are skipped (SequencePlayer::skip_rest): the run that
// slipped plays to its end (the bridges go off after its hold), the next direction follows.
// Another layout's wheels shift load along v and vn as well (ident_traction.hpp): the floor's
// mu comes from the rotation's runs alone, so along w the runs go on to kRotationFactor times
// the first slipped level (about five more, each past its break-away).
class TractionWatch
{
      public:
	static constexpr double kDiagonalFactor = 2.0;
	static constexpr double kRotationFactor = 1.25;
	explicit TractionWatch(const Layout &layout = {}) : paper_(layout.paper)
	{
	}
	// Call once per tick (or per state message); true when it skipped.
	bool step(SequencePlayer &player, int32_t est_flags);
	// The multiple of the first slipped level a direction's runs go to.
	double factor(const std::string &direction) const;

      private:
	bool paper_ = true;
	std::map<std::string, double> first_slip_; // group -> level [V]
	double level_ = 0;                         // of the run playing
};

// The levels of one direction, ascending [V].
std::vector<double> traction_levels(const TractionSeqOptions &opt = {});

// The phases: per direction and level a "traction" segment (the step) closed by "end" at the
// start of the coast.
std::vector<Phase> traction_sequence(const TractionSeqOptions &opt = {});

// Every voltage phase that starts from rest (the paper's runs and push-offs) gets a ramp long
// enough that no wheel needs more than hold_n [N] (the traction less the margin: the paper's
// "this way wheel sleeping was avoided"): the shortest of 0.5, 0.75, 1, 1.5, 2, 3, 4, 6 s whose
// peak wheel force, simulated on the model p (a gripping robot, eqs 12-13, 21, 23), stays
// within it; the phase grows by what its ramp grew. Phases of the traction experiment are
// left as they are. The motor test's runs (one wheel driven against the other three's back-EMF
// braking) whose force even the 6 s ramp does not keep within hold_n are first scaled down,
// all by one factor (voltages and marks' levels), until the hardest holds. hold_n <= 0:
// nothing changes. hold_n is a wheel's carrying a quarter of the weight: on another layout
// (the plant of layout) each wheel's hold is hold_n times its load at rest over M g / 4
// (model/wheels.h's least-norm loads; a three-wheel robot's at 0/120/240 deg: 4/3).
void limit_ramps(std::vector<Phase> &phases, const model_params &p, double hold_n,
                 const Layout &layout = {});
// (1 - margin) mu M g / 4 [N] ([limits] traction_mu, traction_margin); 0 when mu is 0.
double traction_hold_n(const model_params &p, double mu, double margin);

// The phases of the kinds in `only` (steady_rotation, coast, motor, step, traction) in that
// order, or the paper's whole sequence when `only` is empty; throws std::invalid_argument on an
// unknown kind. hold_s, settle_s: the paper's runs'.
std::vector<Phase> selected_sequence(const std::vector<std::string> &only, double hold_s,
                                     double settle_s, const Layout &layout = Layout{});

} // namespace omni4
