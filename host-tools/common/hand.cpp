// hand.cpp - push / coast-down / stop detection for experiment 2 by hand (see hand.hpp).
#include "hand.hpp"

#include <cmath>

namespace omni4
{

namespace
{

int64_t to_us(double s)
{
	return std::llround(s * 1e6);
}

} // namespace

const char *hand_axis_name(int axis)
{
	static const char *const names[3] = {"v", "vn", "w"};
	return axis >= 0 && axis < 3 ? names[axis] : "?";
}

HandDetector::HandDetector(const HandOptions &opt) : opt_(opt)
{
}

std::array<double, 3> HandDetector::smooth(int64_t utime, const std::array<double, 3> &x)
{
	window_.emplace_back(utime, x);
	while (window_.front().first <= utime - to_us(opt_.smooth_s))
		window_.pop_front();
	std::array<double, 3> m{};
	for (const auto &s : window_)
		for (int a = 0; a < 3; ++a)
			m[a] += s.second[a];
	for (double &v : m)
		v /= static_cast<double>(window_.size());
	return m;
}

bool HandDetector::at_rest_now() const
{
	for (int a = 0; a < 3; ++a)
		if (!(std::abs(mean_[a]) < opt_.rest_speed[a]))
			return false;
	return true;
}

void HandDetector::track_rest(int64_t utime)
{
	if (!at_rest_now())
		rest_since_ = -1;
	else if (rest_since_ < 0)
		rest_since_ = utime;
}

bool HandDetector::rested(int64_t utime) const
{
	return rest_since_ >= 0 && utime - rest_since_ >= to_us(opt_.rest_s);
}

int HandDetector::dominant_axis() const
{
	int best = 0;
	for (int a = 1; a < 3; ++a)
		if (std::abs(mean_[a]) / opt_.rest_speed[a] >
		    std::abs(mean_[best]) / opt_.rest_speed[best])
			best = a;
	return best;
}

bool HandDetector::expect_push(int axis, double timeout_s)
{
	if (state_ != State::AtRest || axis < 0 || axis > 2)
		return false;
	push_ = Push{};
	push_.axis = axis;
	push_.armed_utime = last_utime_;
	timeout_s_ = timeout_s;
	state_ = State::Armed;
	return true;
}

HandDetector::Event HandDetector::on_armed(int64_t utime)
{
	const int ax = dominant_axis();
	if (std::abs(mean_[ax]) > opt_.push_factor * opt_.rest_speed[ax]) {
		push_.moved_axis = ax;
		push_.moved_speed = mean_[ax];
		push_.start_utime = utime;
		if (ax != push_.axis) {
			state_ = State::Unsettled;
			return Event::WrongAxis;
		}
		push_.peak = mean_[ax];
		push_.peak_utime = utime;
		state_ = State::Pushing;
		return Event::PushStarted;
	}
	if (utime - push_.armed_utime >= to_us(timeout_s_)) {
		state_ = rested(utime) ? State::AtRest : State::Unsettled;
		return Event::NoPush;
	}
	return Event::None;
}

HandDetector::Event HandDetector::on_moving(int64_t utime)
{
	const double sign = push_.peak < 0 ? -1.0 : 1.0;
	const double speed = sign * mean_[push_.axis]; // along the push [m/s or rad/s]
	if (speed > std::abs(push_.peak)) {            // still accelerating (or pushed again)
		push_.peak = mean_[push_.axis];
		push_.peak_utime = utime;
		state_ = State::Pushing;
	}
	if (rest_since_ >= 0)
		push_.still_utime = rest_since_;
	if (rested(utime)) {
		push_.stop_utime = utime;
		state_ = State::AtRest;
		return Event::Stopped;
	}
	if (utime - push_.start_utime >= to_us(timeout_s_)) {
		state_ = State::Unsettled;
		return Event::NotStopped;
	}
	if (state_ == State::Pushing && speed <= (1 - opt_.drop_frac) * std::abs(push_.peak) &&
	    utime - push_.peak_utime >= to_us(opt_.drop_min_s)) {
		state_ = State::Coasting;
		return Event::Coasting;
	}
	return Event::None;
}

HandDetector::Event HandDetector::feed(int64_t utime, const std::array<double, 3> &x)
{
	if (utime <= last_utime_)
		return Event::None;
	last_utime_ = utime;
	mean_ = smooth(utime, x);
	track_rest(utime);
	switch (state_) {
	case State::Unsettled:
		if (!rested(utime))
			return Event::None;
		state_ = State::AtRest;
		return Event::AtRest;
	case State::AtRest:
		if (rest_since_ < 0)
			state_ = State::Unsettled;
		return Event::None;
	case State::Armed:
		return on_armed(utime);
	case State::Pushing:
	case State::Coasting:
		return on_moving(utime);
	}
	return Event::None;
}

} // namespace omni4
