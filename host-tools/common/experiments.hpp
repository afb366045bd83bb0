// experiments.hpp - the paper's experiment sequence as a timeline of phases, and a player that
// turns it into OMNI4_CMD commands (re-sent as keep-alives) and OMNI4_EXPERIMENT marks.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "layout.hpp"

namespace omni4
{

struct Phase {
	double duration_s = 0;
	int8_t mode = 0;                  // command_t::MODE_*
	std::array<double, 4> voltage{};  // [V]
	std::array<double, 3> velocity{}; // [m/s, m/s, rad/s]
	double ramp_s = 0;                // [s]
	std::string mark_kind;            // non-empty: OMNI4_EXPERIMENT at the phase start
	std::string mark_direction;
	double mark_level = 0; // [V]
	bool end_mark = false; // OMNI4_EXPERIMENT "end" at the phase start
	std::string group;     // phases a runner may skip together (SequencePlayer::skip_rest)
};

// Encoded OMNI4_EXPERIMENT mark and a bare OMNI4_CMD of one mode (no velocity, no voltage).
std::vector<uint8_t> encode_mark(int64_t utime, const std::string &kind,
                                 const std::string &direction = "", double level = 0);
std::vector<uint8_t> encode_command(int64_t utime, int64_t seq, int8_t mode);

// Channel voltage pattern per volt of drive along "v", "vn" or "w" (columns of eq 26).
std::array<double, 4> drive_pattern(const std::string &direction);
// The same for a layout: the least-norm wheel forces that push along that axis alone (the
// layout's split column, model/wheels.h; with one drive for every wheel the voltages at rest
// are proportional to them), scaled so that the largest |voltage| is 1 per volt; the paper's
// layout: the pattern above, to the bit. A three-wheel robot's slot 3 holds 0.
std::array<double, 4> drive_pattern(const std::string &direction, const Layout &layout);

struct SequenceOptions {
	std::vector<double> rotation_levels{3, 4, 5, 6, 7, 8}; // experiment 1 [V]
	std::vector<double> coast_levels{6, 9};     // push-off voltage before coasting [V]
	std::vector<double> motor_levels{4, 8, 11}; // motor test, each motor alone, +- [V]
	std::vector<double> step_levels{4, 6, 8};   // experiment 3 ramped steps [V]
	double ramp_s = 0.5;
	double hold_s = 3.0;
	double settle_s = 3.0; // coasting to rest between runs
	Layout layout;         // the axis runs' patterns (drive_pattern), motors in the motor test
};

// The whole sequence: steady rotation, null-traction coast-downs along v, vn, w, motor runs
// (one motor at a time, each of the layout's motors), ramped steps along v, vn, w (the
// layout's patterns). Every measured segment is opened by a mark
// and closed by "end".
std::vector<Phase> paper_sequence(const SequenceOptions &opt = {});

double total_duration_s(const std::vector<Phase> &phases);

// Plays a timeline: call due() with the present time since start; it returns what to publish.
class SequencePlayer
{
      public:
	struct Output {
		bool has_command = false;
		std::vector<uint8_t> command;            // encoded command_t
		std::vector<std::vector<uint8_t>> marks; // encoded experiment_t, in order
	};

	SequencePlayer(std::vector<Phase> phases, double keepalive_s = 0.05);
	// t_s: time since start; utime: the clock stamped into the messages [us].
	Output due(double t_s, int64_t utime);
	bool done() const
	{
		return index_ >= phases_.size();
	}
	size_t phase_index() const
	{
		return index_;
	}
	size_t phase_count() const
	{
		return phases_.size();
	}
	// The phase playing now (nullptr before the start and after the end).
	const Phase *current() const
	{
		return started_ && index_ < phases_.size() ? &phases_[index_] : nullptr;
	}
	// The later runs of the present phase's group are skipped (their phases take no time and
	// send nothing); the present run (up to the next phase with a mark) plays to its end.
	void skip_rest();
	// A zero-voltage IDLE command (safe stop).
	static std::vector<uint8_t> stop_command(int64_t utime, int64_t seq);

      private:
	std::vector<Phase> phases_;
	double keepalive_s_;
	size_t index_ = 0;
	double phase_start_s_ = 0;
	double last_sent_s_ = -1e9;
	bool started_ = false;
	int64_t seq_ = 0;
};

} // namespace omni4
