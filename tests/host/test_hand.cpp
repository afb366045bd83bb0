// Tests for the hand-push detector of `omni4-ident run --hand` (host-tools/common/hand.hpp).
// Sample streams come from closed forms of the paper's null-traction dynamics (eqs 17-19):
// a push that raises the speed smoothly to v0, then the free coast-down
//   v(t) = (v0 + C/B) exp(-B t / M) - C/B,   stopping at t_stop = (M/B) ln(1 + B v0 / C).
// Thresholds and times are the spec's (at rest: |v|, |vn| < 0.05 m/s, |w| < 0.5 rad/s for
// 0.5 s; a push: above 3x that along the axis; velocities smoothed over ~20 ms), written out
// here, not taken from HandOptions.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "hand.hpp"

using namespace omni4;
using Event = HandDetector::Event;
using State = HandDetector::State;
using Vel = std::array<double, 3>;

namespace
{

constexpr double kRestLin = 0.05;   // [m/s]
constexpr double kRestRot = 0.5;    // [rad/s]
constexpr double kRestTime = 0.5;   // [s]
constexpr double kSmoothLag = 0.03; // smoothing over ~20 ms delays a crossing by <= this [s]
constexpr double kDt = 0.001;       // 1 kHz samples [s]
constexpr int64_t kT0 = 1'700'000'000'000'000; // a wall-clock-like utime origin [us]

// Table III coasting along v.
constexpr double kM = 2.34, kB = 0.4978, kC = 1.8738;

struct Seen {
	Event ev;
	double t; // [s] from kT0
};

int64_t utime_of(double t)
{
	return kT0 + std::llround(t * 1e6);
}

// Feeds x(t) sampled every kDt on [t_from, t_to); returns every event with its time.
std::vector<Seen> play(HandDetector &det, const std::function<Vel(double)> &x, double t_from,
                       double t_to)
{
	std::vector<Seen> seen;
	const long n = std::lround((t_to - t_from) / kDt);
	for (long k = 0; k < n; ++k) {
		const double t = t_from + k * kDt;
		const Event ev = det.feed(utime_of(t), x(t));
		if (ev != Event::None)
			seen.push_back({ev, t});
	}
	return seen;
}

// A push from rest at t_push raising the speed as v0 sin^2 over rise_s, then the free
// coast-down (closed form) to rest. Speed along one axis [m/s or rad/s].
struct PushProfile {
	double t_push, rise_s, v0, M, B, C;
	double peak_t() const
	{
		return t_push + rise_s;
	}
	double stop_t() const
	{
		return peak_t() + (M / B) * std::log1p(B * std::abs(v0) / C);
	}
	// First time the speed falls below `below` after the peak.
	double below_t(double below) const
	{
		return peak_t() + (M / B) * std::log((std::abs(v0) + C / B) / (below + C / B));
	}
	// First time the speed rises above `above` during the push.
	double above_t(double above) const
	{
		return t_push + rise_s * 2 / M_PI * std::asin(std::sqrt(above / std::abs(v0)));
	}
	double operator()(double t) const
	{
		const double s = v0 < 0 ? -1.0 : 1.0;
		if (t < t_push)
			return 0;
		if (t < peak_t())
			return v0 * std::pow(std::sin(M_PI / 2 * (t - t_push) / rise_s), 2);
		if (t >= stop_t())
			return 0;
		const double tc = t - peak_t();
		return s * ((std::abs(v0) + C / B) * std::exp(-B * tc / M) - C / B);
	}
};

Vel along(int axis, double speed)
{
	Vel x{};
	x[axis] = speed;
	return x;
}

const Seen *find(const std::vector<Seen> &seen, Event ev)
{
	for (const Seen &s : seen)
		if (s.ev == ev)
			return &s;
	return nullptr;
}

// A detector at rest at t = 1 s, armed for axis.
HandDetector armed_at_rest(int axis, double timeout_s = 30)
{
	HandDetector det;
	play(det, [](double) { return Vel{}; }, 0, 1.0);
	EXPECT_EQ(det.state(), State::AtRest);
	EXPECT_TRUE(det.expect_push(axis, timeout_s));
	return det;
}

} // namespace

// ---- at rest ----------------------------------------------------------------------------------

TEST(HandDetector, AtRestAfterHalfASecondBelowTheThresholds)
{
	HandDetector det;
	const auto seen = play(det, [](double) { return Vel{}; }, 0, 1.0);
	ASSERT_EQ(seen.size(), 1u);
	EXPECT_EQ(seen[0].ev, Event::AtRest);
	EXPECT_NEAR(seen[0].t, kRestTime, kDt / 2);
	EXPECT_EQ(det.state(), State::AtRest);
}

TEST(HandDetector, RestShorterThanHalfASecondIsNotRest)
{
	HandDetector det;
	// 0.47 s still, a 0.2 s wobble at 0.2 m/s, 0.47 s still, ... never 0.5 s in one piece.
	const auto x = [](double t) {
		const double phase = std::fmod(t, 0.67);
		return phase < 0.47 ? Vel{} : Vel{0.2, 0, 0};
	};
	EXPECT_TRUE(play(det, x, 0, 5.0).empty());
	EXPECT_EQ(det.state(), State::Unsettled);
	EXPECT_FALSE(det.expect_push(0, 30)); // only from rest
}

TEST(HandDetector, RestThresholdsPerAxis)
{
	struct Case {
		Vel x;
		bool rest;
	};
	const Case cases[] = {
	    {{0.049, 0, 0}, true}, {{-0.049, 0, 0}, true},  {{0.051, 0, 0}, false},
	    {{0, 0.049, 0}, true}, {{0, -0.051, 0}, false}, {{0, 0, 0.49}, true},
	    {{0, 0, -0.49}, true}, {{0, 0, 0.51}, false},   {{0.049, -0.049, 0.49}, true},
	};
	for (const Case &c : cases) {
		HandDetector det;
		const auto seen = play(det, [&](double) { return c.x; }, 0, 2.0);
		EXPECT_EQ(!seen.empty() && seen[0].ev == Event::AtRest, c.rest)
		    << c.x[0] << " " << c.x[1] << " " << c.x[2];
	}
}

// ---- a full run: rest -> push -> coast-down -> stop ---------------------------------------------

TEST(HandDetector, PushCoastStopAlongV)
{
	HandDetector det = armed_at_rest(0);
	const PushProfile p{1.8, 0.3, 0.9, kM, kB, kC};
	const auto seen = play(det, [&](double t) { return along(0, p(t)); }, 1.0, 6.0);
	const Seen *push = find(seen, Event::PushStarted), *coast = find(seen, Event::Coasting),
	           *stop = find(seen, Event::Stopped);
	ASSERT_TRUE(push && coast && stop);
	ASSERT_EQ(seen.size(), 3u);
	// Detection: the speed crosses 3 x 0.05 m/s.
	EXPECT_GE(push->t, p.above_t(3 * kRestLin));
	EXPECT_LE(push->t, p.above_t(3 * kRestLin) + kSmoothLag);
	// Coasting is seen after the peak, well before the stop.
	EXPECT_GT(coast->t, p.peak_t());
	EXPECT_LT(coast->t, p.peak_t() + 0.3);
	// Stopped: below the rest threshold, then 0.5 s at rest.
	EXPECT_GE(stop->t, p.below_t(kRestLin) + kRestTime);
	EXPECT_LE(stop->t, p.below_t(kRestLin) + kRestTime + kSmoothLag);
	const auto &r = det.push();
	EXPECT_EQ(r.axis, 0);
	EXPECT_NEAR(r.peak, p.v0, 0.01 * p.v0);
	EXPECT_NEAR(r.peak_utime * 1e-6 - kT0 * 1e-6, p.peak_t(), kSmoothLag);
	EXPECT_NEAR(r.coast_s(), p.below_t(kRestLin) - p.peak_t(), kSmoothLag);
	EXPECT_GT(r.push_s(), 0);
	EXPECT_EQ(det.state(), State::AtRest); // ready for the next push at once
	EXPECT_TRUE(det.expect_push(0, 30));
}

TEST(HandDetector, PushBackwardsAndAboutW)
{
	{
		HandDetector det = armed_at_rest(1);
		const PushProfile p{1.5, 0.25, -0.7, kM, 0.6763, 2.2198}; // -vn, Table III
		const auto seen = play(det, [&](double t) { return along(1, p(t)); }, 1.0, 6.0);
		ASSERT_TRUE(find(seen, Event::PushStarted) && find(seen, Event::Stopped));
		EXPECT_NEAR(det.push().peak, p.v0, 0.01 * std::abs(p.v0));
	}
	{
		HandDetector det = armed_at_rest(2);
		const PushProfile p{1.5, 0.3, 7.5, 0.0228, 0.0141, 0.1385}; // w, Table III J Bw Cw
		const auto seen = play(det, [&](double t) { return along(2, p(t)); }, 1.0, 6.0);
		const Seen *push = find(seen, Event::PushStarted),
		           *stop = find(seen, Event::Stopped);
		ASSERT_TRUE(push && stop);
		EXPECT_GE(push->t, p.above_t(3 * kRestRot));
		EXPECT_LE(push->t, p.above_t(3 * kRestRot) + kSmoothLag);
		EXPECT_NEAR(det.push().coast_s(), p.below_t(kRestRot) - p.peak_t(), kSmoothLag);
	}
}

TEST(HandDetector, PushThresholdIsThreeTimesTheRestThreshold)
{
	// A slow push: 0.3 s ramp to `level`, held 0.5 s, 0.3 s ramp down (smoothing leaves the
	// plateau unchanged).
	const auto trapezoid = [](double t0, double level) {
		return [=](double t) {
			const double s = t - t0;
			const double up = std::clamp(s / 0.3, 0.0, 1.0),
			             down = std::clamp((1.1 - s) / 0.3, 0.0, 1.0);
			return along(0, level * std::min(up, down));
		};
	};
	HandDetector det = armed_at_rest(0);
	// 0.149 m/s: not a push (it leaves rest; the detector stays armed).
	EXPECT_TRUE(play(det, trapezoid(1.5, 0.149), 1.0, 4.0).empty());
	EXPECT_EQ(det.state(), State::Armed);
	const auto seen = play(det, trapezoid(4.5, 0.151), 4.0, 7.0);
	ASSERT_FALSE(seen.empty());
	EXPECT_EQ(seen[0].ev, Event::PushStarted);
}

// ---- wrong axis, no push, no stop -------------------------------------------------------------

TEST(HandDetector, PushAlongTheWrongAxis)
{
	HandDetector det = armed_at_rest(0);
	// Sideways along vn with 5 % leaking into v: mostly vn.
	const PushProfile p{1.5, 0.3, 0.8, kM, 0.6763, 2.2198};
	const auto x = [&](double t) { return Vel{0.05 * p(t), p(t), 0}; };
	const auto seen = play(det, x, 1.0, 6.0);
	ASSERT_FALSE(seen.empty());
	EXPECT_EQ(seen[0].ev, Event::WrongAxis);
	EXPECT_EQ(det.push().moved_axis, 1);
	EXPECT_GT(det.push().moved_speed, 3 * kRestLin);
	// Afterwards: waits for rest again (0.5 s after the sideways coast-down), then AtRest.
	ASSERT_EQ(seen.size(), 2u);
	EXPECT_EQ(seen[1].ev, Event::AtRest);
	EXPECT_GE(seen[1].t, p.below_t(kRestLin) + kRestTime);
	EXPECT_LE(seen[1].t, p.below_t(kRestLin) + kRestTime + kSmoothLag);
}

TEST(HandDetector, DiagonalPushGoesToTheLargerAxis)
{
	{ // 45 deg between v and vn, vn 20 % larger: wrong when v is expected
		HandDetector det = armed_at_rest(0);
		const PushProfile p{1.5, 0.3, 0.6, kM, kB, kC};
		const auto seen =
		    play(det, [&](double t) { return Vel{p(t), 1.2 * p(t), 0}; }, 1.0, 2.0);
		ASSERT_FALSE(seen.empty());
		EXPECT_EQ(seen[0].ev, Event::WrongAxis);
	}
	{ // a turn with a small sideways slip (0.02 m/s per rad/s): along w
		HandDetector det = armed_at_rest(2);
		const PushProfile p{1.5, 0.3, 6.0, 0.0228, 0.0141, 0.1385};
		const auto seen =
		    play(det, [&](double t) { return Vel{0, 0.02 * p(t), p(t)}; }, 1.0, 2.0);
		ASSERT_FALSE(seen.empty());
		EXPECT_EQ(seen[0].ev, Event::PushStarted);
	}
	{ // a push along v off the centre, turning slightly (2 rad/s per m/s: 0.3 rad/s when v
	  // reaches 0.15 m/s): along v, though the number |w| in rad/s exceeds |v| in m/s
		HandDetector det = armed_at_rest(0);
		const PushProfile p{1.5, 0.3, 0.8, kM, kB, kC};
		const auto seen =
		    play(det, [&](double t) { return Vel{p(t), 0, 2.0 * p(t)}; }, 1.0, 2.0);
		ASSERT_FALSE(seen.empty());
		EXPECT_EQ(seen[0].ev, Event::PushStarted);
	}
	{ // a push along v when a turn is expected
		HandDetector det = armed_at_rest(2);
		const PushProfile p{1.5, 0.3, 0.8, kM, kB, kC};
		const auto seen = play(det, [&](double t) { return along(0, p(t)); }, 1.0, 2.0);
		ASSERT_FALSE(seen.empty());
		EXPECT_EQ(seen[0].ev, Event::WrongAxis);
		EXPECT_EQ(det.push().moved_axis, 0);
	}
}

TEST(HandDetector, NoPushWithinTheTimeout)
{
	HandDetector det = armed_at_rest(0, 30);
	// 30 s at rest with two nudges that stay below a push (0.12, 0.14 m/s).
	const PushProfile n1{5, 0.4, 0.12, kM, kB, kC}, n2{20, 0.4, 0.14, kM, kB, kC};
	const auto x = [&](double t) { return along(0, n1(t) + n2(t)); };
	const auto early = play(det, x, 1.0, 1.0 + 30 - 0.002);
	EXPECT_TRUE(early.empty());
	const auto seen = play(det, x, 1.0 + 30 - 0.002, 32.0);
	ASSERT_EQ(seen.size(), 1u);
	EXPECT_EQ(seen[0].ev, Event::NoPush);
	EXPECT_NEAR(seen[0].t, 1.0 + 30 - kDt, kDt / 2); // armed at the last sample before t = 1 s
	EXPECT_EQ(det.state(), State::AtRest);
}

TEST(HandDetector, StillMovingAfterTheTimeout)
{
	HandDetector det = armed_at_rest(0, 3);
	// Pushed to 0.5 m/s and then carried along at that speed.
	const auto x = [](double t) {
		return along(0, t < 1.5 ? 0 : std::min(0.5, (t - 1.5) * 2));
	};
	const auto seen = play(det, x, 1.0, 6.0);
	ASSERT_EQ(seen.size(), 2u);
	EXPECT_EQ(seen[0].ev, Event::PushStarted);
	EXPECT_EQ(seen[1].ev, Event::NotStopped);
	EXPECT_NEAR(seen[1].t - seen[0].t, 3.0, kDt);
	EXPECT_EQ(det.state(), State::Unsettled);
}

TEST(HandDetector, SamplesThatDoNotAdvanceTheClockAreIgnored)
{
	HandDetector det;
	play(det, [](double) { return Vel{}; }, 0, 1.0);
	ASSERT_TRUE(det.expect_push(0, 30));
	// A late sample with an old time stamp and a huge speed changes nothing.
	EXPECT_EQ(det.feed(utime_of(0.5), Vel{5, 0, 0}), Event::None);
	EXPECT_EQ(det.state(), State::Armed);
}

// ---- noise ------------------------------------------------------------------------------------

TEST(HandDetector, NoisySpeedsThreePushes)
{
	// Encoder-like noise (sigma 0.03 m/s on v, vn and 0.3 rad/s on w per sample) on three runs.
	std::mt19937 rng(12345);
	std::normal_distribution<double> lin(0, 0.03), rot(0, 0.3);
	HandDetector det;
	auto noisy = [&](Vel x) { return Vel{x[0] + lin(rng), x[1] + lin(rng), x[2] + rot(rng)}; };
	double t = 0;
	auto seen = play(det, [&](double) { return noisy({}); }, t, t + 1.0);
	ASSERT_FALSE(seen.empty());
	EXPECT_EQ(seen[0].ev, Event::AtRest);
	t += 1.0;
	for (int run = 0; run < 3; ++run) {
		ASSERT_TRUE(det.expect_push(0, 30)) << run;
		const PushProfile p{t + 0.7, 0.3, 0.6 + 0.2 * run, kM, kB, kC};
		seen = play(det, [&](double s) { return noisy(along(0, p(s))); }, t, t + 6.0);
		const Seen *push = find(seen, Event::PushStarted),
		           *stop = find(seen, Event::Stopped);
		ASSERT_TRUE(push && stop) << run;
		EXPECT_EQ(seen.front().ev, Event::PushStarted) << run;
		EXPECT_NEAR(push->t, p.above_t(3 * kRestLin), 0.04) << run;
		EXPECT_NEAR(det.push().peak, p.v0, 0.05 * p.v0) << run;
		// The stop: 0.5 s after falling below 0.05 m/s (noise moves that crossing by a few
		// ms).
		EXPECT_NEAR(stop->t, p.below_t(kRestLin) + kRestTime, 0.05) << run;
		EXPECT_NEAR(det.push().coast_s(), p.below_t(kRestLin) - p.peak_t(), 0.05) << run;
		t += 6.0;
	}
}
