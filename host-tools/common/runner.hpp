// runner.hpp - drive a live robot (or omni4-fw on the sim backend) through the experiment
// sequence over LCM while recording every message on the bus into an event log; or record the
// paper's experiment 2 by hand (run_hand: bridges disabled throughout, the operator pushes).
#pragma once

#include <string>
#include <vector>

#include "layout.hpp"
#include "omni4/lcmtypes/channels.h"

extern "C" {
#include "omni4/model/params.h"
}

namespace omni4
{

struct RunOptions {
	std::string url = OMNI4_DEFAULT_LCM_URL;
	std::string out;
	std::vector<std::string> only;            // experiment kinds to keep (empty = all)
	double hold_s = 3.0;                      // constant-voltage part of each run [s]
	double settle_s = 3.0;                    // coasting to rest between runs [s]
	model_params model = model_params_table3; // for the ramps under the traction limit
	double traction_hold_n = 0; // > 0: no run's ramp asks a wheel for more (limit_ramps)
	Layout layout; // the wheels (--robot): the axis runs' patterns, the motor test's motors
};

// Returns the process exit status. SIGINT/SIGTERM: publish an IDLE command (safe stop), close
// the open segment, flush the log, exit 130.
int run_experiments(const RunOptions &opt);

struct HandRunOptions {
	int pushes = 3; // counted runs per direction
	std::vector<std::string> directions{"v", "vn", "w"};
	double push_timeout_s = 30;         // wait for each push (and its stop) [s]
	double d_m = model_params_table3.d; // eqs 3-5 (BASE.ini; Table III otherwise)
	double r_m = model_params_table3.r;
	Layout layout; // eqs 3-5's wheels (--robot) until the controller's OMNI4_ROBOT says
};

// Experiment 2 by hand: only MODE_COAST keep-alives (never VOLTAGE or VELOCITY), a "coast" mark
// before each push, "end" once the robot has stopped; MODE_IDLE at the end. Uses opt.url and
// opt.out. Returns the exit status (1: no OMNI4_MOTORS on the bus; 130: interrupted).
int run_hand(const RunOptions &opt, const HandRunOptions &hand);

} // namespace omni4
