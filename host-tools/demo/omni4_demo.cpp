// omni4-demo: the Table III robot's response to the paper's ramped voltage steps along v, vn
// and w (model only: no firmware, no LCM), printed as a table.
#include "cli.hpp"

#include <cmath>
#include <cstdio>
#include <string>

extern "C" {
#include "omni4/config.h"
#include "omni4/dynamics.h"
#include "omni4/plant.h"
}

namespace {

struct Direction {
  const char *name;
  double pattern[4];  // channel voltages per volt of level (eq 26 columns)
  int axis;
};

const Direction kDirections[] = {
    {"v", {0, -1, 0, 1}, 0},
    {"vn", {1, 0, -1, 0}, 1},
    {"w", {1, 1, 1, 1}, 2},
};

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"Simulate the paper's ramped voltage steps on the model and print the response.\n"
               "Example: omni4-demo --level 6 --ramp 0.5 --duration 2"};
  std::string params_path;
  double level = 6.0, ramp_s = 0.5, duration_s = 2.0, print_every_s = 0.1;
  app.add_option("--params", params_path, "robot INI file (default: Table III)");
  app.add_option("--level", level, "step voltage [V]")->check(CLI::Range(-12.0, 12.0));
  app.add_option("--ramp", ramp_s, "ramp length [s]")->check(CLI::Range(0.0, 10.0));
  app.add_option("--duration", duration_s, "run length per direction [s]")
      ->check(CLI::Range(0.01, 60.0));
  app.add_option("--print-every", print_every_s, "table row spacing [s]")
      ->check(CLI::Range(0.001, 10.0));
  OMNI4_CLI_PARSE(app, argc, argv);

  omni4_config cfg;
  config_defaults(&cfg);
  if (!params_path.empty()) {
    config_error err;
    if (config_load(params_path.c_str(), &cfg, &err) != 0) {
      std::fprintf(stderr, "omni4-demo: %s\n", err.msg);
      return 1;
    }
  }
  plant pl;
  if (plant_init(&pl, &cfg.model) != 0) {
    std::fprintf(stderr, "omni4-demo: invalid model parameters\n");
    return 1;
  }

  const double dt = 1e-3;
  for (const Direction &dir : kDirections) {
    double u_final[4], x_ss[3];
    for (int j = 0; j < 4; ++j) u_final[j] = level * dir.pattern[j];
    dyn_steady_velocity(&pl.ss, u_final, x_ss);
    std::printf("\nramped step along %s: %.2f V reached in %.2f s; steady state (closed form) "
                "%s = %.4f %s\n",
                dir.name, level, ramp_s, dir.name, x_ss[dir.axis], dir.axis == 2 ? "rad/s" : "m/s");
    std::printf("%8s %8s %9s %9s %9s %9s %9s %9s %9s\n", "t[s]", "u[V]", "v[m/s]", "vn[m/s]",
                "w[rad/s]", "i0[A]", "i1[A]", "i2[A]", "i3[A]");
    plant_reset(&pl);
    const long steps = std::lround(duration_s / dt);
    const long every = std::max(1L, std::lround(print_every_s / dt));
    for (long k = 0; k <= steps; ++k) {
      const double t = k * dt;
      if (k % every == 0) {
        std::printf("%8.3f %8.3f %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f\n", t,
                    pl.voltage_v[dir.axis == 2 ? 0 : 3 - 3 * dir.axis], pl.x[0], pl.x[1], pl.x[2],
                    pl.current_a[0], pl.current_a[1], pl.current_a[2], pl.current_a[3]);
      }
      const double frac = ramp_s > 0 ? std::min(1.0, (t + dt / 2) / ramp_s) : 1.0;
      double u[4];
      for (int j = 0; j < 4; ++j) u[j] = frac * u_final[j];
      plant_step(&pl, u, true, dt);
    }
  }
  return 0;
}
