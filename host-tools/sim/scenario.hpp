// scenario.hpp - a scenario replayed in lockstep (omni4-sim --goals, --drive): goals sent one
// after the other, each when the previous one ends, or VELOCITY commands from given times on.
// The same file gives the same run on every machine (the simulator's clock, not the wall's).
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "simexp.hpp"

namespace omni4
{

// A malformed scenario file: what() is one line, "FILE:LINE:COLUMN: what is wrong".
struct ScenarioError : std::runtime_error {
	using std::runtime_error::runtime_error;
};

// One goal of a --goals file: a world pose [m, m, rad], and a speed cap [m/s] (0: the model's).
struct ScenarioGoal {
	double x = 0, y = 0, theta = 0, speed_max = 0;
	int line = 0; // in the file
};

// One row of a --drive file: from t_s [s] of the run on, VELOCITY (v, vn [m/s], w [rad/s]).
struct DriveRow {
	double t_s = 0, v = 0, vn = 0, w = 0;
	int line = 0;
};

// Rows "x,y,theta[,speed_max]" (comma-separated; a first row with no number in it is a header;
// blank lines and lines starting with '#' skipped). At least one goal; every value finite, the
// pose within goal_t's range (|x|, |y| <= 100 m), speed_max >= 0. Throws ScenarioError.
std::vector<ScenarioGoal> read_goals(const std::string &path);

// Rows "t_s,v,vn,w", t_s >= 0 and not decreasing, every value finite, the velocities within the
// controller's limits given (|v|, |vn| <= lin_max, |w| <= rot_max). Throws ScenarioError.
std::vector<DriveRow> read_drive(const std::string &path, double lin_max, double rot_max);

// How a goal of the scenario ended.
struct GoalOutcome {
	int64_t goal_id = 0;
	int status = 0, reason = 0;     // goal_status_t STATUS_* / REASON_* (0 / 0: never ended)
	double sent_s = 0, ended_s = 0; // on the simulator's clock [s]
	double truth_off_m = 0, truth_off_rad = 0; // the plant's true pose from the goal then
};

// "REACHED", "ABORTED (NO_PROGRESS)", ...: goal_status_t's words for a status and reason.
std::string goal_outcome_text(int status, int reason);

struct ScenarioResult {
	SimRunResult run;
	std::vector<GoalOutcome> goals; // --goals: one per goal, in order
};

// Each goal sent (goal_t, kept alive every 50 ms as a client does) once the previous one has
// ended (REACHED, ABORTED or REFUSED; a REACHED goal is then cancelled, as clients do), at most
// goal_limit_s each; then 1 s at rest. Throws std::runtime_error on set-up errors.
ScenarioResult run_goals(const omni4_config &cfg, const model_params &plant, bool noise,
                         const std::string &log_path, const std::vector<ScenarioGoal> &goals,
                         double goal_limit_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress,
                         const std::function<bool()> &stop);

// Each row's VELOCITY command from its time on (repeated every 50 ms), until the last row's
// time plus hold_s. Throws std::runtime_error on set-up errors.
ScenarioResult run_drive(const omni4_config &cfg, const model_params &plant, bool noise,
                         const std::string &log_path, const std::vector<DriveRow> &rows,
                         double hold_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress,
                         const std::function<bool()> &stop);

} // namespace omni4
