// omni4-sim: the firmware loop in lockstep with the simulated plant, driven through OMNI4_CMD by
// the paper's experiment sequence, every message written to an LCM event log.
#include "cli.hpp"
#include "omni4/core/vocab.h"
#include "traction_exp.hpp"
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "omni4/goal_status_t.hpp"
#include "omni4/motors_t.hpp"
#include "outfile.hpp"
#include "scenario.hpp"

extern "C" {
#include "omni4/model/consts.h"
}
#include "simexp.hpp"

namespace
{

std::string fault_names(int32_t f)
{
	std::string s;
	for (int k = 0; k < 32; ++k) {
		const char *name = fault_name(static_cast<int32_t>(1u << k)); // vocab.def's rows
		if ((f >> k & 1) && name)
			s += (s.empty() ? "" : "|") + std::string(name);
	}
	return s.empty() ? "none" : s;
}

} // namespace

namespace
{
volatile sig_atomic_t g_stop = 0;
void on_signal(int)
{
	g_stop = 1;
}

struct SimArgs {
	std::string params_path, out_path, speed = "max";
	std::string goals_path, drive_path; // scenario files (scenario.hpp)
	bool experiments = false, no_noise = false, quiet = false;
	bool no_truth = false, no_estimate = false;
	std::vector<std::string> only; // experiment kinds (traction_exp.hpp); implies experiments
	int seed = -1;
	double duration_s = 0;
	double rtf = 0; // real-time factor from speed; 0 = max
};

void add_options(CLI::App &app, SimArgs &a)
{
	app.add_option("--params", a.params_path,
	               "robot INI file: [model] of the simulated robot and firmware settings "
	               "(default: Table III)");
	app.add_flag(
	    "--experiments", a.experiments,
	    "run the paper's experiment sequence (steady rotation, coast-downs, motor runs, "
	    "ramped steps)");
	app.add_option("--only", a.only,
	               "run only these experiment kinds (steady_rotation coast motor step "
	               "traction); traction needs a floor ([sim] traction_mu)");
	app.add_option("--goals", a.goals_path,
	               "FILE.csv: rows x,y,theta[,speed_max] [m, m, rad, m/s], each goal sent when "
	               "the previous one ends (REACHED, ABORTED, REFUSED; at most 130 s), its "
	               "outcome and the truth's distance from it printed");
	app.add_option(
	    "--drive", a.drive_path,
	    "FILE.csv: rows t_s,v,vn,w [s, m/s, m/s, rad/s]: VELOCITY commands from time "
	    "t_s of the run on (kept alive), the run ending 1 s after the last row");
	app.add_option("--duration", a.duration_s, "without --experiments: idle run length [s]")
	    ->check(CLI::Range(0.0, 36000.0));
	app.add_option("--speed", a.speed,
	               "'max' (as fast as possible) or a real-time factor, e.g. 1");
	app.add_option("--out", a.out_path,
	               "event log to write (a file is replaced once the log is complete; a "
	               "symbolic link's target replaced; a FIFO or device written in place)")
	    ->required();
	app.add_option("--seed", a.seed, "noise seed (default: [sim] seed)")
	    ->check(CLI::Range(0, 2147483647));
	app.add_flag("--no-noise", a.no_noise,
	             "exact sensors (no current, encoder or camera noise)");
	app.add_flag("--no-truth", a.no_truth,
	             "leave the plant's true state (OMNI4_SIM_TRUTH) out of the log (as [sim] "
	             "truth = false)");
	app.add_flag("--no-estimate", a.no_estimate,
	             "leave the controller's state estimator (OMNI4_STATE) out (as [sim] "
	             "estimate = false)");
	app.add_flag("-q,--quiet", a.quiet, "no progress line");
}

// --speed into a.rtf and the run's length: 0, or 2 after a one-line error.
int check_args(SimArgs &a)
{
	if (a.speed != "max") {
		char *end = nullptr;
		a.rtf = std::strtod(a.speed.c_str(), &end);
		if (end == a.speed.c_str() || *end || !(a.rtf > 0) || !std::isfinite(a.rtf)) {
			std::fprintf(
			    stderr,
			    "omni4-sim: --speed must be 'max' or a positive number, not '%s'\n",
			    a.speed.c_str());
			return 2;
		}
	}
	const int modes = (a.experiments || !a.only.empty()) + !a.goals_path.empty() +
	                  !a.drive_path.empty() + (a.duration_s > 0);
	if (modes > 1) {
		std::fprintf(stderr, "omni4-sim: give one of --experiments (--only), --goals, "
		                     "--drive, --duration\n");
		return 2;
	}
	if (modes == 0) {
		std::fprintf(stderr, "omni4-sim: nothing to do: give --experiments, --goals FILE, "
		                     "--drive FILE or --duration S\n");
		return 2;
	}
	return 0;
}

// The robot INI (defaults without one) with --seed applied: 0, or 2 after a one-line error.
int load_config(const SimArgs &a, omni4_config &cfg)
{
	config_defaults(&cfg);
	if (!a.params_path.empty()) {
		config_error err;
		if (config_load(a.params_path.c_str(), &cfg, &err) != 0) {
			std::fprintf(stderr, "omni4-sim: %s\n", err.msg);
			return 2;
		}
	}
	if (a.seed >= 0)
		cfg.sim.seed = a.seed;
	if (a.no_truth)
		cfg.sim.truth = false;
	if (a.no_estimate)
		cfg.sim.estimate = false;
	return 0;
}

// What the run wrote and how fast; the exit status (1: log errors, 130: interrupted).
int report(const SimArgs &a, const omni4::SimRunResult &r)
{
	const simrun_stats &st = r.stats;
	// Every channel written, counted as each event was written: the parts add up to the total.
	std::string parts;
	for (const auto &[channel, n] : r.channels)
		parts += (parts.empty() ? "" : ", ") + channel + " " + std::to_string(n);
	std::printf("omni4-sim: wrote %s: %llu messages (%s)\n", a.out_path.c_str(),
	            (unsigned long long)st.messages, parts.empty() ? "none" : parts.c_str());
	std::printf(
	    "omni4-sim: %.1f s simulated in %.2f s wall (real-time factor %.0fx), %llu ticks; "
	    "faults seen: %s; commands rejected: %llu\n",
	    r.simulated_s, r.wall_s, r.simulated_s / r.wall_s, (unsigned long long)st.ticks,
	    fault_names(st.faults).c_str(), (unsigned long long)st.cmd_rejected);
	if (st.log_errors || st.log_dropped) {
		std::fprintf(stderr, "omni4-sim: %llu log write errors, %llu samples dropped\n",
		             (unsigned long long)st.log_errors, (unsigned long long)st.log_dropped);
		return 1;
	}
	if (r.interrupted) {
		std::fprintf(stderr,
		             "omni4-sim: interrupted after %.1f s simulated; %s is complete up to "
		             "there (the open segment closed)\n",
		             r.simulated_s, a.out_path.c_str());
		return 130;
	}
	return 0;
}
// --out as every output is written (outfile.hpp): the log replaces the file once complete, a
// symbolic link's target is replaced, a FIFO or device is written in place. A write error
// replaces nothing: 0, or 1 after one line naming --out.
int finish_out(OutFile &out, const SimArgs &a, const simrun_stats &st)
{
	try {
		if (st.log_errors)
			throw OutError(a.out_path + ": " +
			               std::strerror(st.log_errno ? st.log_errno : EIO) + " (" +
			               std::to_string(st.log_errors) + " log write errors)");
		out.commit();
	} catch (const OutError &e) {
		std::fprintf(stderr, "omni4-sim: %s\n", e.what());
		return 1;
	}
	return 0;
}
// The progress line: on a terminal it updates in place; in a log, one line per 10 %. The
// experiment phase only when there are phases (an idle run has none).
std::function<void(double, size_t, size_t)> progress_printer(bool quiet, bool tty, const char *part)
{
	return [quiet, tty, part, last_decile = -1](double frac, size_t phase,
	                                            size_t phases) mutable {
		const int pct = static_cast<int>(100 * frac);
		if (quiet || (!tty && pct / 10 == last_decile))
			return;
		const std::string ph = phases ? std::string("  ") + part + " " +
		                                    std::to_string(std::min(phase + 1, phases)) +
		                                    "/" + std::to_string(phases)
		                              : "";
		std::fprintf(stderr, "%somni4-sim: %3d%%%s%s", tty ? "\r" : "", pct, ph.c_str(),
		             tty ? "" : "\n");
		last_decile = pct / 10;
	};
}
// The goals' outcomes, one line each; 1 if any was not REACHED.
int report_goals(const omni4::ScenarioResult &res)
{
	int status = 0;
	for (size_t i = 0; i < res.goals.size(); ++i) {
		const omni4::GoalOutcome &g = res.goals[i];
		std::printf(
		    "omni4-sim: goal %zu of %zu: %s after %.2f s (sent at %.2f s), the truth "
		    "%.1f mm and %.2f deg from it\n",
		    i + 1, res.goals.size(), omni4::goal_outcome_text(g.status, g.reason).c_str(),
		    g.ended_s - g.sent_s, g.sent_s, g.truth_off_m * 1e3,
		    g.truth_off_rad * 180.0 / MODEL_PI);
		if (g.status != omni4::goal_status_t::STATUS_REACHED)
			status = 1;
	}
	return status;
}

// --goals or --drive: the file read (one line FILE:LINE:COLUMN and status 2 if malformed), the
// scenario played into the log; the exit status.
int scenario(const SimArgs &a, const omni4_config &cfg, OutFile &out,
             const std::function<void(double, size_t, size_t)> &progress)
{
	omni4::ScenarioResult res;
	try {
		if (!a.goals_path.empty()) {
			const auto goals = omni4::read_goals(a.goals_path);
			res = omni4::run_goals(cfg, cfg.ctl.model, !a.no_noise, out.write_path(),
			                       goals, 130.0, a.rtf, progress,
			                       [] { return g_stop != 0; });
		} else {
			const auto rows = omni4::read_drive(
			    a.drive_path, cfg.ctl.limits.vel_lin_max, cfg.ctl.limits.vel_rot_max);
			res = omni4::run_drive(cfg, cfg.ctl.model, !a.no_noise, out.write_path(),
			                       rows, 1.0, a.rtf, progress,
			                       [] { return g_stop != 0; });
		}
	} catch (const omni4::ScenarioError &e) {
		std::fprintf(stderr, "omni4-sim: %s\n", e.what());
		return 2;
	} catch (const std::exception &e) {
		std::fprintf(stderr, "omni4-sim: %s\n", e.what());
		return 1;
	}
	if (!a.quiet && isatty(STDERR_FILENO))
		std::fprintf(stderr, "\n");
	if (int status = finish_out(out, a, res.run.stats))
		return status;
	const int goals = report_goals(res);
	const int run = report(a, res.run);
	return run ? run : goals;
}
} // namespace

int main(int argc, char **argv)
{
	CLI::App app{
	    "Simulated omni4 robot: the firmware loop and the model plant in lockstep, logging to "
	    "an\n"
	    "LCM event log.\n"
	    "Example: omni4-sim --params robot.ini --experiments --speed max --out sim.lcmlog",
	    "omni4-sim"};
	omni4_cli_setup(app);
	SimArgs a;
	add_options(app, a);
	OMNI4_CLI_PARSE(app, argc, argv);
	if (int status = check_args(a))
		return status;
	omni4_config cfg;
	if (int status = load_config(a, cfg))
		return status;

	const bool tty = isatty(STDERR_FILENO);
	auto progress = progress_printer(a.quiet, tty,
	                                 !a.goals_path.empty()   ? "goal"
	                                 : !a.drive_path.empty() ? "row"
	                                                         : "phase");
	// Ctrl-C or SIGTERM: the run ends at the next tick, the open segment is closed and the log
	// is written out whole (exit status 130).
	std::signal(SIGINT, on_signal);
	std::signal(SIGTERM, on_signal);
	std::unique_ptr<OutFile> out;
	try {
		out = std::make_unique<OutFile>(a.out_path);
	} catch (const OutError &e) {
		std::fprintf(stderr, "omni4-sim: cannot create log: %s\n", e.what());
		return 1;
	}
	if (!a.goals_path.empty() || !a.drive_path.empty())
		return scenario(a, cfg, *out, progress);
	omni4::SimRunResult r;
	try {
		const omni4::Layout layout = omni4::layout_of_settings(cfg.ctl, "--params");
		std::vector<omni4::Phase> phases =
		    a.experiments || !a.only.empty()
		        ? omni4::selected_sequence(a.only, 3.0, 3.0, layout)
		        : std::vector<omni4::Phase>{};
		// The robot's own traction limit ([limits] traction_mu) ramps the runs under it.
		omni4::limit_ramps(phases, cfg.ctl.model,
		                   omni4::traction_hold_n(cfg.ctl.model, cfg.ctl.limits.traction_mu,
		                                          cfg.ctl.limits.traction_margin),
		                   layout);
		r = omni4::run_phases(cfg, cfg.ctl.model, !a.no_noise, out->write_path(), phases,
		                      a.duration_s, a.rtf, progress, [] { return g_stop != 0; });
	} catch (const std::exception &e) {
		std::fprintf(stderr, "omni4-sim: %s\n", e.what());
		return 1;
	}
	if (!a.quiet && tty)
		std::fprintf(stderr, "\n");
	if (int status = finish_out(*out, a, r.stats))
		return status;
	return report(a, r);
}
