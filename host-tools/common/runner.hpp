// runner.hpp - drive a live robot (or omni4-fw on the sim backend) through the experiment
// sequence over LCM while recording every message on the bus into an event log.
#pragma once

#include <string>
#include <vector>

namespace omni4 {

struct RunOptions {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string out;
  std::vector<std::string> only;  // experiment kinds to keep (empty = all)
  double hold_s = 3.0;            // constant-voltage part of each run [s]
  double settle_s = 3.0;          // coasting to rest between runs [s]
};

// Returns the process exit status. SIGINT/SIGTERM: publish an IDLE command (safe stop), close
// the open segment, flush the log, exit 130.
int run_experiments(const RunOptions &opt);

}  // namespace omni4
