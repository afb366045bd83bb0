// logdata.cpp - event log reading (LCM C API) and segmentation.
#include "logdata.hpp"

#include <lcm/eventlog.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "omni4/experiment_t.hpp"
#include "omni4/motors_t.hpp"
#include "omni4/pose_t.hpp"

namespace omni4 {

namespace {

constexpr uint8_t kSync[4] = {0xED, 0xA1, 0xDA, 0x01};  // event log sync word (big-endian)

// Position of the next sync word at or after `from`, with the file positioned there; -1 if none.
long resync(FILE *f, long from) {
  if (std::fseek(f, from, SEEK_SET) != 0) return -1;
  int matched = 0, c;
  long pos = from;
  while ((c = std::fgetc(f)) != EOF) {
    ++pos;
    matched = (c == kSync[matched]) ? matched + 1 : (c == kSync[0] ? 1 : 0);
    if (matched == 4) {
      const long start = pos - 4;
      std::fseek(f, start, SEEK_SET);
      return start;
    }
  }
  return -1;
}

}  // namespace

LogData read_log(const std::string &path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0)
    throw std::runtime_error(path + ": " + std::strerror(errno));
  std::unique_ptr<lcm_eventlog_t, void (*)(lcm_eventlog_t *)> log(
      lcm_eventlog_create(path.c_str(), "r"), lcm_eventlog_destroy);
  if (!log) throw std::runtime_error(path + ": cannot open as an LCM event log");

  LogData d;
  d.path = path;
  d.bytes_total = static_cast<uint64_t>(st.st_size);
  // An OMNI4_MOTORS event takes ~110 bytes: reserve once instead of growing.
  d.motors.reserve(d.bytes_total / 100 + 16);
  int64_t last_seq = -1;
  FILE *f = log->f;
  long good_pos = 0;  // end of the last intact event
  for (;;) {
    lcm_eventlog_event_t *ev = lcm_eventlog_read_next_event(log.get());
    if (!ev) {
      // Truncated or corrupt: resynchronise on the next event sync word, if any.
      const long resume = resync(f, good_pos + 1);
      if (resume < 0) break;
      d.bytes_skipped += static_cast<uint64_t>(resume - good_pos);
      good_pos = resume;
      continue;
    }
    // Header: sync (4), event number (8), timestamp (8), channel length (4), data length (4).
    good_pos += 28 + ev->channellen + ev->datalen;
    std::unique_ptr<lcm_eventlog_event_t, void (*)(lcm_eventlog_event_t *)> guard(
        ev, lcm_eventlog_free_event);
    ++d.events;
    const std::string channel(ev->channel, ev->channellen);
    const int len = ev->datalen;
    if (channel == "OMNI4_MOTORS") {
      motors_t m{};
      if (m.decode(ev->data, 0, len) != len) {
        ++d.undecodable;
        continue;
      }
      MotorsSample s;
      s.utime = m.utime;
      s.seq = m.seq;
      s.mode = m.mode;
      s.faults = m.faults;
      for (int j = 0; j < 4; ++j) {
        s.u[j] = m.voltage[j];
        s.i[j] = m.current[j];
        s.w[j] = m.wheel_speed[j];
      }
      if (last_seq >= 0 && s.seq > last_seq + 1) d.seq_gaps += s.seq - last_seq - 1;
      last_seq = s.seq;
      d.motors.push_back(s);
    } else if (channel == "OMNI4_POSE") {
      pose_t p{};
      if (p.decode(ev->data, 0, len) != len) {
        ++d.undecodable;
        continue;
      }
      d.pose.push_back({p.utime, p.x, p.y, p.theta});
    } else if (channel == "OMNI4_EXPERIMENT") {
      experiment_t e{};
      if (e.decode(ev->data, 0, len) != len) {
        ++d.undecodable;
        continue;
      }
      d.marks.push_back({e.utime, e.kind, e.direction, e.level});
    } else {
      ++d.other_channels;
    }
  }
  // Whatever follows the last intact event was truncated.
  if (static_cast<uint64_t>(good_pos) < d.bytes_total)
    d.bytes_skipped += d.bytes_total - static_cast<uint64_t>(good_pos);
  if (d.events == 0) throw std::runtime_error(path + ": no intact LCM event in the file");
  // Logs are written in time order; sort only what is not (e.g. merged recordings).
  auto by_time = [](const auto &a, const auto &b) { return a.utime < b.utime; };
  auto sort = [&](auto &v) {
    if (!std::is_sorted(v.begin(), v.end(), by_time)) std::stable_sort(v.begin(), v.end(), by_time);
  };
  sort(d.motors);
  sort(d.pose);
  sort(d.marks);
  return d;
}

std::vector<Segment> split_segments(const LogData &log) {
  std::vector<Segment> out;
  auto motors_at = [&](int64_t t) {
    return static_cast<size_t>(
        std::lower_bound(log.motors.begin(), log.motors.end(), t,
                         [](const MotorsSample &s, int64_t v) { return s.utime < v; }) -
        log.motors.begin());
  };
  auto pose_at = [&](int64_t t) {
    return static_cast<size_t>(
        std::lower_bound(log.pose.begin(), log.pose.end(), t,
                         [](const PoseSample &s, int64_t v) { return s.utime < v; }) -
        log.pose.begin());
  };
  const int64_t t_end = log.motors.empty() ? 0 : log.motors.back().utime + 1;
  for (size_t k = 0; k < log.marks.size(); ++k) {
    const Mark &m = log.marks[k];
    if (m.kind == "end") continue;
    Segment s;
    s.kind = m.kind;
    s.direction = m.direction;
    s.level = m.level;
    s.log = &log;
    s.t0 = m.utime;
    s.t1 = k + 1 < log.marks.size() ? log.marks[k + 1].utime : t_end;
    s.m0 = motors_at(s.t0);
    s.m1 = motors_at(s.t1);
    s.p0 = pose_at(s.t0);
    s.p1 = pose_at(s.t1);
    if (s.m1 > s.m0) out.push_back(s);
  }
  return out;
}

}  // namespace omni4
