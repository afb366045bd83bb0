// simexp.cpp - lockstep simulation driven by the experiment sequence (see simexp.hpp).
#include "simexp.hpp"
#include "omni4/lcmtypes/channels.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <thread>

#include "experiments.hpp"
#include "traction_exp.hpp"

extern "C" {
#include "omni4/core/est.h"
}

namespace omni4
{

namespace
{

// The phases' marks and command due at tick k, handed to the simulated bus.
void play_tick(simrun *sr, SequencePlayer &player, long k, double dt)
{
	const auto out = player.due(k * dt, simrun_now_us(sr));
	for (const auto &m : out.marks)
		simrun_publish(sr, OMNI4_CHANNEL_EXPERIMENT, m.data(), m.size());
	if (out.has_command)
		simrun_command(sr, out.command.data(), out.command.size());
}

// The run's statistics and message counts per channel, after its log is flushed.
void collect_stats(simrun *sr, SimRunResult &r)
{
	simrun_flush_log(sr); // a failure is in the stats (log_errors, log_errno)
	simrun_get_stats(sr, &r.stats);
	const char *names[SIMRUN_CHANNELS_MAX];
	uint64_t counts[SIMRUN_CHANNELS_MAX];
	const size_t n = simrun_channel_counts(sr, names, counts, SIMRUN_CHANNELS_MAX);
	for (size_t c = 0; c < n && c < SIMRUN_CHANNELS_MAX; ++c)
		r.channels.emplace_back(names[c], counts[c]);
}

} // namespace

SimRunResult run_simulation(const omni4_config &cfg, const model_params &plant, bool noise,
                            const std::string &log_path, bool experiments, double idle_s,
                            double rtf, const std::function<void(double, size_t, size_t)> &progress,
                            const std::function<bool()> &stop)
{
	SequenceOptions opt; // the axis runs' patterns and the motor test of the robot's layout
	opt.layout = layout_of_settings(cfg.ctl, "the robot's settings");
	return run_phases(cfg, plant, noise, log_path,
	                  experiments ? paper_sequence(opt) : std::vector<Phase>{}, idle_s, rtf,
	                  progress, stop);
}

SimRunResult run_phases(const omni4_config &cfg, const model_params &plant, bool noise,
                        const std::string &log_path, const std::vector<Phase> &phases,
                        double idle_s, double rtf,
                        const std::function<void(double, size_t, size_t)> &progress,
                        const std::function<bool()> &stop)
{
	char err[256];
	std::unique_ptr<simrun, void (*)(simrun *)> sr(
	    simrun_create(&cfg, &plant, noise, log_path.empty() ? nullptr : log_path.c_str(), err,
	                  sizeof(err)),
	    simrun_destroy);
	if (!sr)
		throw std::runtime_error(err);
	return play_phases(sr.get(), cfg, phases, idle_s, rtf, progress, stop);
}

SimRunResult play_phases(simrun *sr, const omni4_config &cfg, const std::vector<Phase> &phases,
                         double idle_s, double rtf,
                         const std::function<void(double, size_t, size_t)> &progress,
                         const std::function<bool()> &stop)
{
	const bool experiments = !phases.empty();
	const double total_s = experiments ? total_duration_s(phases) : idle_s;
	SequencePlayer player(phases);
	TractionWatch watch(layout_of_settings(cfg.ctl, "the robot's settings"));
	const double dt = simrun_period_s(sr);
	const long ticks = std::lround(total_s / dt);
	LockstepClock clock(dt, rtf);
	const long k = lockstep(
	    sr, ticks, clock,
	    [&](long tick) {
		    if (experiments && player.done())
			    return false; // the watch skipped runs: the sequence ended early
		    if (experiments)
			    play_tick(sr, player, tick, dt);
		    return true;
	    },
	    [&](long) { // a traction direction stops at its first slip
		    if (experiments)
			    watch.step(player, static_cast<int32_t>(simrun_estimate(sr)->flags));
	    },
	    [&](double frac) {
		    if (progress)
			    progress(frac, player.phase_index(), phases.size());
	    },
	    stop);
	const bool interrupted = clock.interrupted;
	if (experiments) { // close the last segment
		const std::vector<uint8_t> end = encode_mark(simrun_now_us(sr), OMNI4_MARK_END);
		simrun_publish(sr, OMNI4_CHANNEL_EXPERIMENT, end.data(), end.size());
	}
	if (progress && !interrupted)
		progress(1.0, phases.size(), phases.size());
	return finish_run(sr, clock, k);
}

long lockstep(simrun *sr, long ticks, LockstepClock &clock, const std::function<bool(long)> &before,
              const std::function<void(long)> &after, const std::function<void(double)> &progress,
              const std::function<bool()> &stop)
{
	long next_report = 0;
	long k = 0;

	for (; k < ticks; ++k) {
		if (stop && stop()) {
			clock.interrupted = true;
			break;
		}
		if (before && !before(k))
			break;
		simrun_tick(sr);
		if (after)
			after(k);
		if (clock.rtf > 0)
			std::this_thread::sleep_until(
			    clock.wall0 +
			    std::chrono::duration<double>((k + 1) * clock.dt / clock.rtf));
		if (progress && k >= next_report) {
			progress(static_cast<double>(k + 1) / static_cast<double>(ticks));
			next_report += std::max(1L, ticks / 100);
		}
	}
	return k;
}

SimRunResult finish_run(simrun *sr, const LockstepClock &clock, long ticks_run)
{
	SimRunResult r;
	r.wall_s =
	    std::chrono::duration<double>(std::chrono::steady_clock::now() - clock.wall0).count();
	r.simulated_s = static_cast<double>(ticks_run) * clock.dt;
	r.interrupted = clock.interrupted;
	collect_stats(sr, r);
	return r;
}

} // namespace omni4
