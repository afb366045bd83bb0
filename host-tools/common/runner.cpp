// runner.cpp - experiment runner over LCM.
#include "runner.hpp"

#include <lcm/eventlog.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <lcm/lcm.h>
#include <memory>
#include <stdexcept>

#include "experiments.hpp"

namespace omni4 {

namespace {

volatile std::sig_atomic_t g_interrupted = 0;

void on_signal(int) { g_interrupted = 1; }

int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Recorder {
  lcm_eventlog_t *log = nullptr;
  uint64_t written = 0, errors = 0;
};

// Every message on the bus goes to the event log, stamped with its receive time.
void record(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
  auto *rec = static_cast<Recorder *>(user);
  lcm_eventlog_event_t ev{};
  ev.timestamp = rbuf->recv_utime;
  ev.channellen = static_cast<int32_t>(std::strlen(channel));
  ev.datalen = static_cast<int32_t>(rbuf->data_size);
  ev.channel = const_cast<char *>(channel);
  ev.data = rbuf->data;
  if (lcm_eventlog_write_event(rec->log, &ev) == 0) ++rec->written;
  else ++rec->errors;
}

void publish(lcm_t *lcm, const char *channel, const std::vector<uint8_t> &msg) {
  lcm_publish(lcm, channel, msg.data(), static_cast<unsigned>(msg.size()));
}

std::vector<Phase> filtered(const RunOptions &opt) {
  SequenceOptions full;
  full.hold_s = opt.hold_s;
  full.settle_s = opt.settle_s;
  if (opt.only.empty()) return paper_sequence(full);
  SequenceOptions none = full;
  none.rotation_levels.clear();
  none.coast_levels.clear();
  none.motor_levels.clear();
  none.step_levels.clear();
  SequenceOptions pick = none;
  for (const std::string &k : opt.only) {
    if (k == "steady_rotation") pick.rotation_levels = full.rotation_levels;
    else if (k == "coast") pick.coast_levels = full.coast_levels;
    else if (k == "motor") pick.motor_levels = full.motor_levels;
    else if (k == "step") pick.step_levels = full.step_levels;
    else throw std::invalid_argument("unknown experiment kind '" + k + "'");
  }
  return paper_sequence(pick);
}

}  // namespace

int run_experiments(const RunOptions &opt) {
  std::vector<Phase> phases;
  try {
    phases = filtered(opt);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "omni4-ident run: %s\n", e.what());
    return 2;
  }
  std::unique_ptr<lcm_t, void (*)(lcm_t *)> lcm(lcm_create(opt.url.c_str()), lcm_destroy);
  if (!lcm) {
    std::fprintf(stderr, "omni4-ident run: cannot open LCM at '%s'\n", opt.url.c_str());
    return 1;
  }
  Recorder rec;
  rec.log = lcm_eventlog_create(opt.out.c_str(), "w");
  if (!rec.log) {
    std::fprintf(stderr, "omni4-ident run: %s: %s\n", opt.out.c_str(), std::strerror(errno));
    return 1;
  }
  lcm_subscription_t *sub = lcm_subscribe(lcm.get(), ".*", record, &rec);
  lcm_subscription_set_queue_capacity(sub, 100000);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  SequencePlayer player(phases);
  const double total = total_duration_s(phases);
  const auto t0 = std::chrono::steady_clock::now();
  int last_pct = -1;
  const bool tty = isatty(STDERR_FILENO);
  while (!player.done() && !g_interrupted) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto out = player.due(t, wall_us());
    for (const auto &m : out.marks) publish(lcm.get(), "OMNI4_EXPERIMENT", m);
    if (out.has_command) publish(lcm.get(), "OMNI4_CMD", out.command);
    lcm_handle_timeout(lcm.get(), 5);
    const int pct = static_cast<int>(100 * t / total);
    if (pct != last_pct && (tty || pct % 10 == 0)) {
      std::fprintf(stderr, "%somni4-ident run: %3d%%  %6.1f / %.1f s  phase %zu/%zu  logged %llu%s",
                   tty ? "\r" : "", pct, t, total, std::min(player.phase_index() + 1, player.phase_count()),
                   player.phase_count(), static_cast<unsigned long long>(rec.written),
                   tty ? "" : "\n");
      last_pct = pct;
    }
  }
  // Safe stop: IDLE (outputs off), close any open segment, collect the last messages.
  const auto stop = SequencePlayer::stop_command(wall_us(), 1 << 30);
  publish(lcm.get(), "OMNI4_CMD", stop);
  {
    std::vector<Phase> end_only(1);
    end_only[0].end_mark = true;
    end_only[0].duration_s = 1;
    SequencePlayer endp(end_only);
    const auto o = endp.due(0, wall_us());
    for (const auto &m : o.marks) publish(lcm.get(), "OMNI4_EXPERIMENT", m);
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
  while (std::chrono::steady_clock::now() < until) lcm_handle_timeout(lcm.get(), 20);
  lcm_unsubscribe(lcm.get(), sub);
  lcm_eventlog_destroy(rec.log);
  std::fprintf(stderr, "\nomni4-ident run: %s %s: %llu messages logged%s\n",
               g_interrupted ? "interrupted, robot stopped;" : "done;", opt.out.c_str(),
               static_cast<unsigned long long>(rec.written),
               rec.errors ? " (write errors!)" : "");
  return g_interrupted ? 130 : (rec.errors ? 1 : 0);
}

}  // namespace omni4
