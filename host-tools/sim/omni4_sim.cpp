// omni4-sim: the firmware loop in lockstep with the simulated plant, driven through OMNI4_CMD by
// the paper's experiment sequence, every message written to an LCM event log.
#include <CLI/CLI.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>

#include "experiments.hpp"
#include "omni4/experiment_t.hpp"

extern "C" {
#include "omni4/config.h"
#include "omni4/simrun.h"
}

namespace {

std::string fault_names(int32_t f) {
  static const std::pair<int32_t, const char *> names[] = {
      {0x0001, "OVERCURRENT"}, {0x0002, "DRIVER_TIMEOUT"}, {0x0004, "DRIVER"},
      {0x0008, "BUS"},         {0x0010, "ENCODER"},        {0x0020, "CURRENT_SENSOR"},
      {0x0040, "SUPPLY"},      {0x0100, "ESTOP"},          {0x0200, "CMD_TIMEOUT"},
      {0x0400, "CMD_REJECTED"}, {0x0800, "LOG_OVERFLOW"},  {0x1000, "OVERRUN"}};
  std::string s;
  for (const auto &[bit, name] : names)
    if (f & bit) s += (s.empty() ? "" : "|") + std::string(name);
  return s.empty() ? "none" : s;
}

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{
      "Simulated omni4 robot: the firmware loop and the model plant in lockstep, logging to an\n"
      "LCM event log.\n"
      "Example: omni4-sim --params robot.ini --experiments --speed max --out sim.lcmlog"};
  std::string params_path, out_path, speed = "max";
  bool experiments = false, no_noise = false, quiet = false;
  int seed = -1;
  double duration_s = 0;
  app.add_option("--params", params_path,
                 "robot INI file: [model] of the simulated robot and firmware settings "
                 "(default: Table III)");
  app.add_flag("--experiments", experiments,
               "run the paper's experiment sequence (steady rotation, coast-downs, motor runs, "
               "ramped steps)");
  app.add_option("--duration", duration_s, "without --experiments: idle run length [s]")
      ->check(CLI::Range(0.0, 36000.0));
  app.add_option("--speed", speed, "'max' (as fast as possible) or a real-time factor, e.g. 1");
  app.add_option("--out", out_path, "event log to write")->required();
  app.add_option("--seed", seed, "noise seed (default: [sim] seed)")->check(CLI::Range(0, 2147483647));
  app.add_flag("--no-noise", no_noise, "exact sensors (no current, encoder or camera noise)");
  app.add_flag("-q,--quiet", quiet, "no progress line");
  CLI11_PARSE(app, argc, argv);

  double rtf = 0;  // 0 = max
  if (speed != "max") {
    char *end = nullptr;
    rtf = std::strtod(speed.c_str(), &end);
    if (end == speed.c_str() || *end || !(rtf > 0) || !std::isfinite(rtf)) {
      std::fprintf(stderr, "omni4-sim: --speed must be 'max' or a positive number, not '%s'\n",
                   speed.c_str());
      return 2;
    }
  }
  if (!experiments && !(duration_s > 0)) {
    std::fprintf(stderr, "omni4-sim: nothing to do: give --experiments or --duration S\n");
    return 2;
  }

  omni4_config cfg;
  config_defaults(&cfg);
  if (!params_path.empty()) {
    config_error err;
    if (config_load(params_path.c_str(), &cfg, &err) != 0) {
      std::fprintf(stderr, "omni4-sim: %s\n", err.msg);
      return 2;
    }
  }
  if (seed >= 0) cfg.sim.seed = seed;

  char err[256];
  simrun *sr = simrun_create(&cfg, &cfg.model, !no_noise, out_path.c_str(), err, sizeof(err));
  if (!sr) {
    std::fprintf(stderr, "omni4-sim: %s\n", err);
    return 1;
  }

  std::vector<omni4::Phase> phases;
  if (experiments) phases = omni4::paper_sequence();
  const double total_s = experiments ? omni4::total_duration_s(phases) : duration_s;
  omni4::SequencePlayer player(phases);
  const double dt = simrun_period_s(sr);
  const long ticks = std::lround(total_s / dt);
  const auto wall0 = std::chrono::steady_clock::now();
  int last_pct = -1;

  for (long k = 0; k < ticks; ++k) {
    const double t = k * dt;
    if (experiments) {
      auto out = player.due(t, simrun_now_us(sr));
      for (const auto &m : out.marks)
        simrun_publish(sr, "OMNI4_EXPERIMENT", m.data(), m.size());
      if (out.has_command) simrun_command(sr, out.command.data(), out.command.size());
    }
    simrun_tick(sr);
    if (rtf > 0) {
      std::this_thread::sleep_until(wall0 + std::chrono::duration<double>((k + 1) * dt / rtf));
    }
    const int pct = static_cast<int>(100.0 * (k + 1) / ticks);
    if (!quiet && pct / 10 != last_pct / 10) {
      std::fprintf(stderr, "\romni4-sim: %3d%%  %7.1f / %.1f s simulated  phase %zu/%zu", pct,
                   (k + 1) * dt, total_s, player.phase_index() + 1, phases.size());
      std::fflush(stderr);
      last_pct = pct;
    }
  }
  // Close the last segment in the log.
  if (experiments) {
    omni4::experiment_t end{};
    end.utime = simrun_now_us(sr);
    end.kind = "end";
    std::vector<uint8_t> buf(end.getEncodedSize());
    end.encode(buf.data(), 0, static_cast<int>(buf.size()));
    simrun_publish(sr, "OMNI4_EXPERIMENT", buf.data(), buf.size());
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  if (!quiet) std::fprintf(stderr, "\n");

  simrun_stats st;
  simrun_get_stats(sr, &st);
  simrun_destroy(sr);
  std::printf("omni4-sim: wrote %s: %llu messages (OMNI4_MOTORS %llu, OMNI4_POSE %llu, "
              "OMNI4_CMD %llu, OMNI4_EXPERIMENT %llu)\n",
              out_path.c_str(), (unsigned long long)st.messages, (unsigned long long)st.motors,
              (unsigned long long)st.pose, (unsigned long long)st.cmd,
              (unsigned long long)st.other);
  std::printf("omni4-sim: %.1f s simulated in %.2f s wall (real-time factor %.0fx), %llu ticks; "
              "faults seen: %s; commands rejected: %llu\n",
              ticks * dt, wall_s, ticks * dt / wall_s, (unsigned long long)st.ticks,
              fault_names(st.faults).c_str(), (unsigned long long)st.cmd_rejected);
  if (st.log_errors || st.log_dropped) {
    std::fprintf(stderr, "omni4-sim: %llu log write errors, %llu samples dropped\n",
                 (unsigned long long)st.log_errors, (unsigned long long)st.log_dropped);
    return 1;
  }
  return 0;
}
