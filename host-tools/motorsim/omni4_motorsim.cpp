// omni4-motorsim: the two motor-driver boards of the CAN protocol with the model plant behind
// them. Receives CMD_VOLTAGE / CMD_CONTROL, steps the plant at 1 kHz, answers with STATUS
// (every ms) and HEALTH (100 Hz), so the unmodified omni4-fw (socketcan backend) drives a
// simulated robot. Works with candump / cansend by hand.
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "cli.hpp"

extern "C" {
#include "omni4/can_proto.h"
#include "omni4/config.h"
#include "omni4/plant.h"
#include "omni4/rng.h"
#include "omni4/sc_os.h"
}

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

constexpr int64_t kCmdTimeoutUs = 50000;  // a board disables itself without commands

struct Stats {
  unsigned long long rx = 0, tx = 0, tx_dropped = 0, crc_errors = 0, replayed = 0, cmd_timeouts = 0;
};

float clip(double x, float lim) {
  return static_cast<float>(std::fmax(-lim, std::fmin(lim, x)));
}

// The receiver's counter policy of the protocol (as the controller's, socketcan_motor.h): a
// frame is taken if its counter is 1..CAN_COUNTER_WINDOW ahead of the last taken one; any
// other value is rejected unless the next frame continues from it (resynchronisation).
struct CounterWindow {
  bool have = false;
  uint8_t last = 0;
  int candidate = -1;
  bool accept(uint8_t now) {
    if (have) {
      const int gap = can_counter_gap(last, now);
      if (gap == -EALREADY || gap > CAN_COUNTER_WINDOW - 1) {
        if (gap != -EALREADY && candidate >= 0 &&
            can_counter_gap(static_cast<uint8_t>(candidate), now) == 0) {
          candidate = -1;
          last = now;
          return true;
        }
        candidate = gap == -EALREADY ? -1 : now;
        return false;
      }
    }
    have = true;
    candidate = -1;
    last = now;
    return true;
  }
};

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"Simulated omni4 motor-driver boards on a CAN interface (model plant behind).\n"
               "Example: omni4-motorsim --iface vcan0 --params robot.ini"};
  std::string iface = "vcan0", params_path;
  double duration_s = 0, replay_at = -1, corrupt_at = -1;
  bool no_noise = false, quiet = false;
  app.add_option("--iface", iface, "CAN interface")->capture_default_str();
  app.add_option("--params", params_path, "robot INI ([model]; default Table III)");
  app.add_option("--duration", duration_s, "stop after S seconds (default: until SIGINT)");
  app.add_flag("--no-noise", no_noise, "exact current readings");
  app.add_option("--replay-at", replay_at, "test: at S seconds, send the last STATUS_0 again");
  app.add_option("--corrupt-at", corrupt_at, "test: at S seconds, send a STATUS_0 with a bad CRC");
  app.add_flag("-q,--quiet", quiet, "no summary");
  OMNI4_CLI_PARSE(app, argc, argv);

  omni4_config cfg;
  config_defaults(&cfg);
  if (!params_path.empty()) {
    config_error err;
    if (config_load(params_path.c_str(), &cfg, &err)) {
      std::fprintf(stderr, "omni4-motorsim: %s\n", err.msg);
      return 2;
    }
  }
  plant pl;
  if (plant_init(&pl, &cfg.model)) {
    std::fprintf(stderr, "omni4-motorsim: invalid model parameters\n");
    return 2;
  }
  const uint32_t ids[] = {CAN_ID_CMD_VOLTAGE, CAN_ID_CMD_CONTROL};
  int fd = -1;
  if (int rc = sc_os_open(iface.c_str(), ids, 2, &fd)) {
    std::fprintf(stderr, "omni4-motorsim: CAN interface '%s': %s\n", iface.c_str(),
                 std::strerror(-rc));
    return 1;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  rng g;
  rng_seed(&g, 7);
  Stats st;
  double u[4] = {0, 0, 0, 0};
  bool cmd_enable = false, ctl_enable = true;
  CounterWindow cmd_window;
  bool have_ctl_counter = false;
  uint8_t ctl_counter = 0;
  uint8_t status_counter[2] = {0, 0}, health_counter[2] = {0, 0};
  uint8_t drv_faults = 0;
  int64_t last_cmd = 0;
  omni4_can_frame last_status0{};
  timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  const int64_t t0 = sc_os_now_us();
  for (long tick = 0; !g_stop; ++tick) {
    const int64_t now = sc_os_now_us();
    const double t = (now - t0) * 1e-6;
    if (duration_s > 0 && t >= duration_s) break;
    omni4_can_frame f;
    uint32_t err;
    int rc;
    while ((rc = sc_os_recv(fd, &f, &err)) > 0) {
      if (rc != 1) continue;
      ++st.rx;
      float v[4];
      bool en;
      uint8_t c;
      enum can_control cmd;
      if (f.id == CAN_ID_CMD_VOLTAGE) {
        if (can_decode_cmd_voltage(&f, v, &en, &c)) {
          ++st.crc_errors;
          continue;
        }
        if (!cmd_window.accept(c)) {
          ++st.replayed;
          continue;
        }
        for (int j = 0; j < 4; ++j) u[j] = v[j];
        cmd_enable = en;
        last_cmd = now;
        drv_faults &= static_cast<uint8_t>(~CAN_DRV_CMD_TIMEOUT);
      } else if (can_decode_control(&f, &cmd, &c) == 0) {
        // Control frames are sparse events (a restarted controller's first ENABLE must not wait
        // for a second frame): only the same counter again is refused; 36 reserved bits keep
        // a random frame's acceptance far below the protocol's bound.
        if (have_ctl_counter && can_counter_gap(ctl_counter, c) == -EALREADY) {
          ++st.replayed;
          continue;
        }
        have_ctl_counter = true;
        ctl_counter = c;
        if (cmd == CAN_CTL_ENABLE) ctl_enable = true;
        if (cmd == CAN_CTL_DISABLE) ctl_enable = false;
        if (cmd == CAN_CTL_CLEAR_FAULTS) drv_faults = 0;
      } else {
        ++st.crc_errors;
      }
    }
    if (last_cmd && now - last_cmd > kCmdTimeoutUs && !(drv_faults & CAN_DRV_CMD_TIMEOUT)) {
      drv_faults |= CAN_DRV_CMD_TIMEOUT;
      ++st.cmd_timeouts;
    }
    const bool driven = cmd_enable && ctl_enable && !(drv_faults & CAN_DRV_CMD_TIMEOUT);
    plant_step(&pl, u, driven, 1e-3);
    double w[4];
    plant_wheel_speeds(&pl, w);
    for (int n = 0; n < CAN_NODES; ++n) {
      can_status s;
      for (int k = 0; k < 2; ++k) {
        const int j = 2 * n + k;
        const double noise = (no_noise || !driven) ? 0.0 : rng_normal(&g, cfg.sim.current_noise_a);
        s.current_a[k] = clip(pl.current_a[j] + noise, CAN_CURR_MAX);
        s.speed_rad_s[k] = clip(w[j], CAN_SPEED_MAX);
      }
      can_encode_status(n, &s, status_counter[n]++ & 0xF, &f);
      if (n == 0) last_status0 = f;
      if (sc_os_send(fd, &f)) ++st.tx_dropped;
      else ++st.tx;
      if (tick % 10 == n) {
        // The command timeout is the board protecting itself, not a hardware fault: it keeps
        // the state "disabled" so that the controller's own timeout logic rules.
        const bool self_off = drv_faults == CAN_DRV_CMD_TIMEOUT;
        can_health hh{};
        hh.faults = self_off ? 0 : drv_faults;
        hh.supply_v = static_cast<float>(cfg.limits.supply_v);
        hh.temp_c = 30;
        hh.state = static_cast<uint8_t>(self_off     ? CAN_STATE_DISABLED
                                        : drv_faults ? CAN_STATE_FAULT
                                        : driven     ? CAN_STATE_ENABLED
                                                     : CAN_STATE_DISABLED);
        can_encode_health(n, &hh, health_counter[n]++ & 0xF, &f);
        if (sc_os_send(fd, &f)) ++st.tx_dropped;
        else ++st.tx;
      }
    }
    if (replay_at >= 0 && t >= replay_at) {
      sc_os_send(fd, &last_status0);  // same counter again
      replay_at = -1;
    }
    if (corrupt_at >= 0 && t >= corrupt_at) {
      omni4_can_frame bad = last_status0;
      bad.data[2] ^= 0x10;
      sc_os_send(fd, &bad);
      corrupt_at = -1;
    }
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      ++next.tv_sec;
    }
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR && !g_stop) {
    }
  }
  sc_os_close(fd);
  if (!quiet)
    std::fprintf(stderr,
                 "omni4-motorsim: rx %llu tx %llu tx_dropped %llu crc_errors %llu replayed %llu "
                 "cmd_timeouts %llu; final v %.3f vn %.3f w %.3f\n",
                 st.rx, st.tx, st.tx_dropped, st.crc_errors, st.replayed, st.cmd_timeouts,
                 pl.x[0], pl.x[1], pl.x[2]);
  return 0;
}
