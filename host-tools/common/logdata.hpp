// logdata.hpp - an omni4 LCM event log read into memory, and its experiment segments.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace omni4
{

// Reserves n elements of v and asks the kernel for transparent huge pages behind them (2 MB
// pages: one page fault per 2 MB instead of one per 4 kB when the elements are first written;
// a hint, ignored where THP is off). For the per-sample arrays of a log (~200000 per log).
void reserve_huge(void *data, size_t bytes);
template <class T> void reserve_huge(std::vector<T> &v, size_t n)
{
	v.reserve(n);
	reserve_huge(v.data(), n * sizeof(T));
}

struct MotorsSample {
	int64_t utime = 0;
	int64_t seq = 0;
	int8_t mode = 0;
	int32_t faults = 0;
	std::array<float, 4> u{}; // applied voltage [V] (motors_t carries floats)
	std::array<float, 4> i{}; // current [A]
	std::array<float, 4> w{}; // wheel speed after the gearbox [rad/s]
};

struct PoseSample {
	int64_t utime = 0;
	double x = 0, y = 0, theta = 0; // world [m, m, rad]
};

struct Mark {
	int64_t utime = 0;
	std::string kind, direction;
	double level = 0;
};

// What the controller said it subtracts from the current readings from tick `seq` on (an
// OMNI4_PARAM_CHANGED notice with source "calibration").
struct CalibrationNotice {
	int64_t utime = 0;
	int64_t seq = 0;                  // first motors_t.seq with these offsets subtracted
	std::array<double, 4> offset_a{}; // [A]; NaN for a channel the notice does not give
	int samples = 0;                  // samples the controller averaged (0 if not given)
	std::string fault_channels;       // channels over the offset limit ("" if none)
};

// A stretch of a log over which the same current offsets were in force, and the offsets left
// in its logged currents as estimated from its own bridge-off samples (offsets.hpp).
struct OffsetEpoch {
	size_t m0 = 0, m1 = 0;  // motors index range [m0, m1)
	int notice = -1;        // index into LogData::calibrations that opened it; -1: none
	size_t samples = 0;     // bridge-off samples averaged
	bool estimated = false; // offset_a / se_a come from this stretch's own samples
	bool pooled = false;    // too few samples here: the estimate of the whole log was used
	std::array<double, 4> offset_a{}; // residual offset in the logged current [A]
	std::array<double, 4> se_a{};     // its standard error [A]
	bool subtracted = false;          // offset_a has been subtracted from motors[m0, m1)
};

// The robot's own description of its wheels: the log's first OMNI4_ROBOT (robot_t) that holds
// a plausible layout (3 or 4 wheels, finite angles, distances > 0).
struct RobotDescription {
	bool present = false;
	int wheels = 4;
	std::array<double, 4> wheel_angle_rad{}, wheel_distance_m{}, wheel_radius_m{};
	double l = 0;
};

struct LogData {
	std::string path;
	RobotDescription robot; // present: the log carries OMNI4_ROBOT
	std::vector<MotorsSample> motors;
	std::vector<PoseSample> pose;
	std::vector<Mark> marks;
	std::vector<CalibrationNotice> calibrations; // in seq order
	std::vector<OffsetEpoch> current_offsets;    // filled by calibrate_currents (offsets.hpp)
	uint64_t events = 0;                         // events read
	uint64_t undecodable = 0;                    // events on our channels that failed to decode
	uint64_t implausible = 0; // decoded, but a time, sequence number or value no log can hold
	uint64_t other_channels = 0;
	uint64_t bytes_total = 0; // file size
	uint64_t bytes_skipped =
	    0;                 // file bytes after the last intact event (truncation/corruption)
	uint64_t seq_gaps = 0; // missing motors_t samples (seq jumps)
	uint64_t seq_backwards = 0; // motors_t samples whose seq is at or below the previous one's
	                            // in file order (an exact repeat, same seq and utime, is not)
};

// More motors_t samples than this going backwards in one log: two controllers' streams
// interleaved (docs/log-contract.md); read_log refuses the log.
constexpr uint64_t kInterleavedBackwardsMax = 50;

// Reads a log; throws std::runtime_error("PATH: ...") if it cannot be opened or holds nothing.
// A truncated or corrupt tail is skipped and counted, never fatal. Throws "PATH: OMNI4_MOTORS
// from two controllers interleaved ..." if more than kInterleavedBackwardsMax samples go back.
LogData read_log(const std::string &path);

struct Segment {
	std::string kind, direction;
	double level = 0;
	const LogData *log = nullptr;
	size_t m0 = 0, m1 = 0;  // motors index range [m0, m1)
	size_t p0 = 0, p1 = 0;  // pose index range [p0, p1)
	int64_t t0 = 0, t1 = 0; // [us]
};

// Splits a log by its OMNI4_EXPERIMENT marks: each mark other than "end" opens a segment that
// the next mark closes (or the end of the log).
std::vector<Segment> split_segments(const LogData &log);

} // namespace omni4
