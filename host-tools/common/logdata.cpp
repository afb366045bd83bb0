// logdata.cpp - event log reading (LCM C API) and segmentation.
#include "logdata.hpp"
#include "omni4/lcmtypes/channels.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string_view>

#include "omni4/experiment_t.hpp"
#include "omni4/motors_t.hpp"
#include "omni4/param_changed_t.hpp"
#include "omni4/pose_t.hpp"
#include "omni4/robot_t.hpp"

namespace omni4
{

namespace
{

// The LCM event log format (what lcm-logger writes, see lcm/eventlog.h): per event a
// big-endian header -- sync word 0xEDA1DA01, event number (int64), timestamp (int64), channel
// length (int32), data length (int32) -- then the channel name and the data. The file is
// mapped and parsed in place: lcm_eventlog_read_next_event costs several fread calls and three
// mallocs per event, which was 62 % of the whole identification time.
constexpr uint32_t kSync = 0xEDA1DA01u;
constexpr size_t kHeader = 28;
constexpr int32_t kMaxChannel = 256; // LCM channel names are at most 63 characters

// lcm-gen's C++ decoders throw (std::length_error) on a string length <= 0 instead of
// returning an error: any exception is an undecodable message here.
template <typename T> bool decode(T &msg, const uint8_t *data, int32_t len)
{
	try {
		return msg.decode(data, 0, len) == len;
	} catch (const std::exception &) {
		return false;
	}
}

uint32_t be32(const uint8_t *p)
{
	return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | p[3];
}

uint64_t be64(const uint8_t *p)
{
	return uint64_t{be32(p)} << 32 | be32(p + 4);
}

// motors_t is fixed size: lcm-gen's decoder (fingerprint, then each field big-endian, floats
// by their bit patterns) read in place, without the decoder's call per field. The same
// values bit for bit, and false exactly where motors_t::decode would not consume len bytes.
bool decode_motors(motors_t &m, const uint8_t *data, int32_t len)
{
	static const int32_t kLen = motors_t{}.getEncodedSize();
	if (len != kLen || be64(data) != static_cast<uint64_t>(motors_t::getHash()))
		return false;
	m.utime = static_cast<int64_t>(be64(data + 8));
	m.seq = static_cast<int64_t>(be64(data + 16));
	m.mode = static_cast<int8_t>(data[24]);
	m.faults = static_cast<int32_t>(be32(data + 25));
	auto floats = [](const uint8_t *p, float (&out)[4]) {
		for (int j = 0; j < 4; ++j) {
			const uint32_t bits = be32(p + 4 * j);
			std::memcpy(&out[j], &bits, sizeof bits);
		}
	};
	floats(data + 29, m.voltage);
	floats(data + 45, m.current);
	floats(data + 61, m.wheel_speed);
	return true;
}

// lcm-gen's decoders compute `length - 1` on a string's raw int32 length (signed overflow for
// INT32_MIN) and throw for lengths <= 0; an array count is allocated before it is checked. So
// messages with strings are walked first. Skips the LCM string at pos (an int32 length with
// the NUL, then the bytes); false if it does not fit in len.
bool skip_string(const uint8_t *data, int32_t len, int64_t &pos)
{
	if (pos + 4 > len)
		return false;
	const int32_t slen = static_cast<int32_t>(be32(data + pos));
	pos += 4;
	if (slen < 1 || slen > len - pos)
		return false;
	pos += slen;
	return true;
}

// experiment_t: fingerprint (8) and utime (8), then two strings.
bool experiment_strings_ok(const uint8_t *data, int32_t len)
{
	int64_t pos = 16;
	return skip_string(data, len, pos) && skip_string(data, len, pos);
}

// param_changed_t: fingerprint, utime, seq, request_id (8 bytes each), two strings (source,
// path), int32 n, then 3 n strings.
bool param_changed_ok(const uint8_t *data, int32_t len)
{
	int64_t pos = 32;
	if (!skip_string(data, len, pos) || !skip_string(data, len, pos) || pos + 4 > len)
		return false;
	const int32_t n = static_cast<int32_t>(be32(data + pos));
	pos += 4;
	if (n < 0 || n > (len - pos) / 15)
		return false; // 3 strings of at least 5 bytes each
	for (int64_t k = 0; k < 3 * int64_t{n}; ++k)
		if (!skip_string(data, len, pos))
			return false;
	return pos == len;
}

// Times and sequence numbers beyond 2^53 (285 years in microseconds; exact in a double) or
// below zero come from no clock or counter a log is written with. Dropping them keeps every
// difference of two times or counts far from int64 overflow.
constexpr int64_t kMaxCount = int64_t{1} << 53;
bool plausible_count(int64_t v)
{
	return v >= 0 && v <= kMaxCount;
}
template <size_t N> bool finite(const float (&a)[N])
{
	for (float x : a)
		if (!std::isfinite(x))
			return false;
	return true;
}

// The file mapped read-only for the life of the object; throws std::runtime_error("PATH: ...").
struct Mapping {
	const uint8_t *data = nullptr;
	size_t size = 0;

	explicit Mapping(const std::string &path)
	{
		const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
		if (fd < 0)
			throw std::runtime_error(path + ": " + std::strerror(errno));
		struct stat st{};
		if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
			const int e = errno;
			close(fd);
			throw std::runtime_error(path + ": " +
			                         (e ? std::strerror(e) : "not a regular file"));
		}
		size = static_cast<size_t>(st.st_size);
		if (size) {
			void *m = mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
			if (m == MAP_FAILED) {
				const int e = errno;
				close(fd);
				throw std::runtime_error(path + ": " + std::strerror(e));
			}
			data = static_cast<const uint8_t *>(m);
			madvise(m, size, MADV_SEQUENTIAL);
		}
		close(fd);
	}
	Mapping(const Mapping &) = delete;
	Mapping &operator=(const Mapping &) = delete;
	~Mapping()
	{
		if (data)
			munmap(const_cast<uint8_t *>(data), size);
	}
};

struct Event {
	std::string_view channel;
	const uint8_t *data = nullptr;
	int32_t len = 0;
};

// The intact event at pos of the n bytes at p: its size in the file, or 0 if there is none
// (a corrupt or truncated header or body).
size_t event_at(const uint8_t *p, size_t n, size_t pos, Event &ev)
{
	const int32_t clen = static_cast<int32_t>(be32(p + pos + 20));
	const int32_t dlen = static_cast<int32_t>(be32(p + pos + 24));
	const bool ok = be32(p + pos) == kSync && clen > 0 && clen <= kMaxChannel && dlen >= 0 &&
	                pos + kHeader + static_cast<size_t>(clen) + static_cast<size_t>(dlen) <= n;
	if (!ok)
		return 0;
	ev.channel = std::string_view(reinterpret_cast<const char *>(p + pos + kHeader),
	                              static_cast<size_t>(clen));
	ev.data = p + pos + kHeader + clen;
	ev.len = dlen;
	return kHeader + static_cast<size_t>(clen) + static_cast<size_t>(dlen);
}

void take_motors(const Event &ev, LogData &d)
{
	motors_t m;
	if (!decode_motors(m, ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	if (!plausible_count(m.utime) || !plausible_count(m.seq) || !finite(m.voltage) ||
	    !finite(m.current) || !finite(m.wheel_speed)) {
		++d.implausible;
		return;
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
	// Samples are appended in file order: the previous one is the last in the vector.
	const int64_t last_seq = d.motors.empty() ? -1 : d.motors.back().seq;
	if (last_seq >= 0 &&
	    (s.seq < last_seq || (s.seq == last_seq && s.utime != d.motors.back().utime)))
		++d.seq_backwards;
	d.motors.push_back(s);
}

void take_pose(const Event &ev, LogData &d)
{
	pose_t q{};
	if (!decode(q, ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	if (!plausible_count(q.utime) || !std::isfinite(q.x) || !std::isfinite(q.y) ||
	    !std::isfinite(q.theta)) {
		++d.implausible;
		return;
	}
	d.pose.push_back({q.utime, q.x, q.y, q.theta});
}

void take_mark(const Event &ev, LogData &d)
{
	experiment_t e{};
	if (!experiment_strings_ok(ev.data, ev.len) || !decode(e, ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	if (!plausible_count(e.utime) || !std::isfinite(e.level)) {
		++d.implausible;
		return;
	}
	d.marks.push_back({e.utime, e.kind, e.direction, e.level});
}

// Only the controller's calibration notices matter here; other parameter notices are counted
// with the other channels.
void take_param_changed(const Event &ev, LogData &d)
{
	if (!param_changed_ok(ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	param_changed_t p{};
	if (!decode(p, ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	if (p.source != "calibration") {
		++d.other_channels;
		return;
	}
	if (!plausible_count(p.utime) || !plausible_count(p.seq)) {
		++d.implausible;
		return;
	}
	CalibrationNotice c;
	c.utime = p.utime;
	c.seq = p.seq;
	c.offset_a.fill(NAN);
	static const std::string kOffset = "calibration.current_offset_a";
	for (int32_t k = 0; k < p.n; ++k) {
		const std::string &key = p.keys[k];
		char *end = nullptr;
		const double v = std::strtod(p.values[k].c_str(), &end);
		const bool number = end != p.values[k].c_str() && *end == '\0' && std::isfinite(v);
		if (key.size() == kOffset.size() + 1 &&
		    key.compare(0, kOffset.size(), kOffset) == 0 && key.back() >= '0' &&
		    key.back() <= '3') {
			if (number && std::abs(v) < 1e3)
				c.offset_a[key.back() - '0'] = v;
		} else if (key == "calibration.samples") {
			if (number && v >= 0 && v < 1e9)
				c.samples = static_cast<int>(v);
		} else if (key == "calibration.fault_channels") {
			c.fault_channels = p.values[k];
		}
	}
	d.calibrations.push_back(c);
}

// The first robot_t with a layout a robot can have; later ones are the same robot's repeats.
void take_robot(const Event &ev, LogData &d)
{
	robot_t r{};
	if (!decode(r, ev.data, ev.len)) {
		++d.undecodable;
		return;
	}
	bool ok = plausible_count(r.utime) && (r.wheels == 3 || r.wheels == 4);
	for (int j = 0; ok && j < r.wheels; ++j)
		ok = std::isfinite(r.wheel_angle[j]) && r.wheel_distance[j] > 0 &&
		     r.wheel_distance[j] < 100 && std::isfinite(r.wheel_radius[j]);
	if (!ok) {
		++d.implausible;
		return;
	}
	if (d.robot.present)
		return;
	d.robot.present = true;
	d.robot.wheels = r.wheels;
	d.robot.l = r.l;
	for (int j = 0; j < 4; ++j) {
		d.robot.wheel_angle_rad[j] = r.wheel_angle[j];
		d.robot.wheel_distance_m[j] = r.wheel_distance[j];
		d.robot.wheel_radius_m[j] = r.wheel_radius[j];
	}
}

void take_event(const Event &ev, LogData &d)
{
	++d.events;
	if (ev.channel == OMNI4_CHANNEL_MOTORS)
		take_motors(ev, d);
	else if (ev.channel == OMNI4_CHANNEL_POSE)
		take_pose(ev, d);
	else if (ev.channel == OMNI4_CHANNEL_EXPERIMENT)
		take_mark(ev, d);
	else if (ev.channel == OMNI4_CHANNEL_PARAM_CHANGED)
		take_param_changed(ev, d);
	else if (ev.channel == OMNI4_CHANNEL_ROBOT)
		take_robot(ev, d);
	else
		++d.other_channels;
}

// Logs are written in time order; sort only what is not (e.g. merged recordings).
void sort_by_time(LogData &d)
{
	auto by_time = [](const auto &a, const auto &b) { return a.utime < b.utime; };
	auto sort = [&](auto &v) {
		if (!std::is_sorted(v.begin(), v.end(), by_time))
			std::stable_sort(v.begin(), v.end(), by_time);
	};
	sort(d.motors);
	sort(d.pose);
	sort(d.marks);
	if (!std::is_sorted(d.calibrations.begin(), d.calibrations.end(),
	                    [](const auto &a, const auto &b) { return a.seq < b.seq; }))
		std::stable_sort(d.calibrations.begin(), d.calibrations.end(),
		                 [](const auto &a, const auto &b) { return a.seq < b.seq; });
}

} // namespace

void reserve_huge(void *data, size_t bytes)
{
	// The 2 MB pages the block touches: a large block is a mapping of its own that the kernel
	// aligns to 2 MB, its data a few bytes past the start. (Only a hint: where the range
	// reaches past the mapping, the kernel applies it to what is mapped and says ENOMEM.)
	const uintptr_t page = 2u << 20, a = reinterpret_cast<uintptr_t>(data);
	const uintptr_t lo = a & ~(page - 1), hi = (a + bytes + page - 1) & ~(page - 1);
	if (bytes >= page)
		madvise(reinterpret_cast<void *>(lo), hi - lo, MADV_HUGEPAGE);
}

LogData read_log(const std::string &path)
{
	const Mapping map(path);
	LogData d;
	d.path = path;
	d.bytes_total = map.size;
	// An OMNI4_MOTORS event takes ~110 bytes: reserve once instead of growing.
	reserve_huge(d.motors, d.bytes_total / 100 + 16);
	size_t pos = 0;
	while (pos + kHeader <= map.size) {
		Event ev;
		const size_t len = event_at(map.data, map.size, pos, ev);
		if (len == 0) { // corrupt or truncated: skip a byte at a time to the next sync word
			++d.bytes_skipped;
			++pos;
			continue;
		}
		pos += len;
		take_event(ev, d);
	}
	d.bytes_skipped += map.size - pos; // a truncated last header
	if (d.events == 0)
		throw std::runtime_error(path + ": no intact LCM event in the file");
	if (d.seq_backwards > kInterleavedBackwardsMax)
		throw std::runtime_error(
		    path + ": OMNI4_MOTORS from two controllers interleaved (" +
		    std::to_string(d.seq_backwards) +
		    " samples whose seq goes backwards): record one controller per bus");
	sort_by_time(d);
	// Lost samples: the seq numbers missing between neighbours in time order (a pair that
	// arrived swapped is not a loss; a controller restart, seq back to 0, is none either).
	for (size_t k = 1; k < d.motors.size(); ++k) {
		const int64_t step = d.motors[k].seq - d.motors[k - 1].seq;
		if (step > 1)
			d.seq_gaps += static_cast<uint64_t>(step - 1);
	}
	return d;
}

std::vector<Segment> split_segments(const LogData &log)
{
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
		if (m.kind == OMNI4_MARK_END)
			continue;
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
		if (s.m1 > s.m0)
			out.push_back(s);
	}
	return out;
}

} // namespace omni4
