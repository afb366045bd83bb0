// hand.hpp - experiment 2 by hand (null traction, the robot pushed by a person): finds, in a
// stream of robot velocities, when the robot is at rest, when a push along the expected axis
// starts, when the free coast-down begins and when the robot has stopped again. Pure: no LCM, no
// clock; time is the samples' utime.
//
//   Unsettled --(at rest for rest_s)--> AtRest --expect_push()--> Armed
//   Armed --(one axis above push_factor x its rest threshold)--> Pushing   (PushStarted)
//                                          or, mostly another axis --> Unsettled   (WrongAxis)
//   Armed --(timeout_s without a push)--> AtRest   (NoPush)
//   Pushing --(speed fell drop_frac below its peak)--> Coasting   (Coasting)
//   Pushing, Coasting --(at rest for rest_s)--> AtRest   (Stopped)
//   Pushing, Coasting --(timeout_s after the push without stopping)--> Unsettled   (NotStopped)
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <utility>

namespace omni4
{

struct HandOptions {
	std::array<double, 3> rest_speed{0.05, 0.05,
	                                 0.5}; // at rest: every |x| below [m/s, m/s, rad/s]
	double rest_s = 0.5;                   // ... for this long [s]
	double push_factor = 3.0; // a push: speed along one axis above this x its rest threshold
	double drop_frac = 0.03;  // coasting: speed this fraction below its peak ...
	double drop_min_s = 0.05; // ... and this long after the peak [s]
	double smooth_s = 0.02;   // moving average of the velocities over this window [s]
};

enum class HandState { Unsettled, AtRest, Armed, Pushing, Coasting };
enum class HandEvent {
	None,
	AtRest,
	PushStarted,
	WrongAxis,
	NoPush,
	Coasting,
	Stopped,
	NotStopped
};

// The present (or last) push. Times in the samples' clock [us].
struct HandPush {
	int axis = 0;           // expected axis: 0 v, 1 vn, 2 w
	int moved_axis = 0;     // the axis the robot moved along most (WrongAxis: not `axis`)
	double moved_speed = 0; // its smoothed speed when the push was seen [m/s or rad/s]
	double peak = 0;        // signed peak speed along `axis` (smoothed) [m/s or rad/s]
	int64_t armed_utime = 0, start_utime = 0, peak_utime = 0, still_utime = 0, stop_utime = 0;
	double push_s() const
	{
		return (peak_utime - start_utime) * 1e-6;
	} // detection to peak
	double coast_s() const
	{
		return (still_utime - peak_utime) * 1e-6;
	} // peak to below rest
};

class HandDetector
{
      public:
	using State = HandState;
	using Event = HandEvent;
	using Push = HandPush;

	explicit HandDetector(const HandOptions &opt = {});

	// One sample: robot velocity x = [v, vn, w] [m/s, m/s, rad/s] at utime [us]. Samples that
	// do not advance the clock are ignored. Returns the state change it caused, if any.
	Event feed(int64_t utime, const std::array<double, 3> &x);

	// Expect a push along axis (0 v, 1 vn, 2 w) within timeout_s [s] (the samples' clock); only
	// in state AtRest. Returns false otherwise.
	bool expect_push(int axis, double timeout_s);

	State state() const
	{
		return state_;
	}
	const Push &push() const
	{
		return push_;
	}
	const std::array<double, 3> &smoothed() const
	{
		return mean_;
	}
	bool at_rest_now() const; // every smoothed |x| below its rest threshold

      private:
	std::array<double, 3> smooth(int64_t utime, const std::array<double, 3> &x);
	void track_rest(int64_t utime);
	bool rested(int64_t utime) const;
	int dominant_axis() const; // largest |x| relative to its rest threshold
	Event on_armed(int64_t utime);
	Event on_moving(int64_t utime);

	HandOptions opt_;
	State state_ = State::Unsettled;
	Push push_;
	double timeout_s_ = 0;
	std::deque<std::pair<int64_t, std::array<double, 3>>> window_;
	std::array<double, 3> mean_{};
	int64_t last_utime_ = INT64_MIN;
	int64_t rest_since_ = -1; // utime the robot came to rest; -1 while moving
};

const char *hand_axis_name(int axis); // "v", "vn", "w"

} // namespace omni4
