// simexp.hpp - run the paper's experiment sequence on the simulated robot into an event log.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "experiments.hpp"

extern "C" {
#include "omni4/config/config.h"
#include "omni4/sil/simrun.h"
}

namespace omni4
{

struct SimRunResult {
	simrun_stats stats{};
	// The events written per channel, in the order each channel was first written (they add
	// up to stats.messages).
	std::vector<std::pair<std::string, uint64_t>> channels;
	double simulated_s = 0;
	double wall_s = 0;
	bool interrupted = false; // stop() ended the run early
};

// cfg: firmware settings; plant: the simulated robot. rtf <= 0: as fast as possible, else a
// real-time factor. progress(fraction, phase, phases) is called every 1 % (may be empty).
// experiments = false: an idle run of idle_s. stop (may be empty) is asked every tick: true
// ends the run early, with the open segment closed and the log complete (interrupted set).
// Throws std::runtime_error on set-up errors.
SimRunResult run_simulation(const omni4_config &cfg, const model_params &plant, bool noise,
                            const std::string &log_path, bool experiments, double idle_s,
                            double rtf,
                            const std::function<void(double, size_t, size_t)> &progress = {},
                            const std::function<bool()> &stop = {});

// The same with the phases to play given (experiments.hpp; empty: an idle run of idle_s).
SimRunResult run_phases(const omni4_config &cfg, const model_params &plant, bool noise,
                        const std::string &log_path, const std::vector<Phase> &phases,
                        double idle_s, double rtf,
                        const std::function<void(double, size_t, size_t)> &progress = {},
                        const std::function<bool()> &stop = {});

// The same on a simulator already made (simrun_create_wrapped: e.g. drives in front of its
// plant); the caller keeps sr. cfg: the settings sr was made from.
SimRunResult play_phases(simrun *sr, const omni4_config &cfg, const std::vector<Phase> &phases,
                         double idle_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress = {},
                         const std::function<bool()> &stop = {});

// The wall clock of a lockstep run: its start, the period and the pace (rtf <= 0: as fast as
// possible), and whether stop() ended it.
struct LockstepClock {
	LockstepClock(double dt_s, double rtf_) : dt(dt_s), rtf(rtf_)
	{
	}
	std::chrono::steady_clock::time_point wall0 = std::chrono::steady_clock::now();
	double dt, rtf;
	bool interrupted = false;
};

// Up to `ticks` ticks of sr: before(k) ahead of tick k (false: the run ends there), after(k)
// behind it, paced by clock, progress(fraction) every 1 %, stop (may be empty) asked every
// tick (true: clock.interrupted, the run ends). The ticks run.
long lockstep(simrun *sr, long ticks, LockstepClock &clock, const std::function<bool(long)> &before,
              const std::function<void(long)> &after, const std::function<void(double)> &progress,
              const std::function<bool()> &stop);

// The run's result after ticks_run ticks: its log flushed, its statistics and channel counts.
SimRunResult finish_run(simrun *sr, const LockstepClock &clock, long ticks_run);

} // namespace omni4
