// Tests for the wheel speeds' corrections (encoders.hpp): speeds that carry the loop's jitter,
// and the once-per-revolution ripple of an eccentric encoder disc. Synthetic logs from closed
// forms: a wheel speed profile with holds and ramps, an encoder that reads
// th_m + eps sin(th_m - phi) on the motor shaft (th_m = l th_wheel), counted and differenced.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "encoders.hpp"
#include "logdata.hpp"
#include "median.hpp"

using namespace omni4;

namespace
{

constexpr double kGear = 5.0;
constexpr double kCpr = 10240; // counts per wheel revolution

// True wheel speed [rad/s] at t [s]: ramps up to 20 rad/s, holds, ramps down, rests; wheel j
// runs at a different level so the four are not alike.
double speed(double t, int j)
{
	const double level = 12.0 + 3.0 * j;
	const double ph = std::fmod(t, 8.0);
	if (ph < 1.0)
		return level * ph;
	if (ph < 5.0)
		return level;
	if (ph < 6.0)
		return level * (6.0 - ph);
	return 0.0;
}

struct Synth {
	double eps = 0;                  // eccentricity (motor shaft)
	double jitter_us = 0;            // mean lateness of a tick
	bool speeds_carry_jitter = true; // count difference over the nominal period
};

// 1 kHz log of `seconds`; also returns the true wheel speeds averaged over each tick interval.
LogData make_log(const Synth &sy, double seconds, std::vector<std::array<double, 4>> *truth)
{
	std::mt19937 g(7);
	std::exponential_distribution<double> late(sy.jitter_us > 0 ? 1.0 / sy.jitter_us : 1.0);
	const std::array<double, 4> phi = {0.3, 2.0, 4.1, 5.5};
	LogData d;
	const int n = static_cast<int>(seconds * 1000);
	std::array<double, 4> angle{}, counts_prev{};
	double t_prev = 0;
	for (int k = 0; k < n; ++k) {
		const double t = k * 1e-3 + (sy.jitter_us > 0 && k > 0 ? late(g) * 1e-6 : 0.0);
		MotorsSample s;
		s.utime = 1000000 + static_cast<int64_t>(std::llround(t * 1e6));
		s.seq = k;
		s.mode = 2;
		for (int j = 0; j < 4; ++j) {
			// Exact angle: integrate the speed profile finely over [t_prev, t].
			const int sub = 20;
			for (int q = 0; q < sub; ++q) {
				const double a = t_prev + (t - t_prev) * (q + 0.5) / sub;
				angle[j] += speed(a, j) * (t - t_prev) / sub;
			}
			const double motor = kGear * angle[j];
			const double read = (motor + sy.eps * std::sin(motor - phi[j])) / kGear;
			const double counts = std::floor(read * kCpr / (2 * M_PI));
			const double interval =
			    sy.speeds_carry_jitter ? 1e-3 : std::max(t - t_prev, 1e-6);
			s.w[j] = static_cast<float>(
			    k ? (counts - counts_prev[j]) * 2 * M_PI / kCpr / interval : 0);
			counts_prev[j] = counts;
		}
		if (truth) {
			std::array<double, 4> w{};
			for (int j = 0; j < 4; ++j)
				w[j] = speed(0.5 * (t + t_prev), j);
			truth->push_back(w);
		}
		t_prev = t;
		d.motors.push_back(s);
	}
	return d;
}

// RMS over samples [a, b) of (logged - true) / true where the true speed is above 5 rad/s.
double rel_rms(const LogData &d, const std::vector<std::array<double, 4>> &truth, size_t a,
               size_t b)
{
	double s = 0;
	size_t n = 0;
	for (size_t k = a; k < b; ++k)
		for (int j = 0; j < 4; ++j)
			if (truth[k][j] > 5) {
				const double e = (d.motors[k].w[j] - truth[k][j]) / truth[k][j];
				s += e * e;
				++n;
			}
	return std::sqrt(s / static_cast<double>(n));
}

} // namespace

TEST(TickIntervals, SpeedsThatCarryTheJitterAreRescaledToTheTrueIntervals)
{
	std::vector<std::array<double, 4>> truth;
	LogData d = make_log({0, 30, true}, 16, &truth);
	const double before = rel_rms(d, truth, 1, d.motors.size());
	const TickRescale r = rescale_to_tick_intervals(d);
	const double after = rel_rms(d, truth, 1, d.motors.size());
	std::printf("jitter %.1f us RMS: speed error %.2f %% RMS as logged, %.2f %% rescaled\n",
	            r.jitter_s * 1e6, 100 * before, 100 * after);
	EXPECT_TRUE(r.applied);
	EXPECT_NEAR(r.period_s, 1e-3, 2e-6);
	// Exponential lateness of mean 30 us: intervals differ by the difference of two, 42 us RMS.
	EXPECT_NEAR(r.jitter_s * 1e6, 30 * std::sqrt(2.0), 6);
	// As logged: the 4.2 % interval noise; rescaled: only quantisation (0.61 rad/s / 12-21
	// rad/s uniform: about 1.5 % RMS).
	EXPECT_GT(before, 0.035);
	EXPECT_LT(after, 0.6 * before);
}

TEST(TickIntervals, SpeedsOverTheTrueIntervalsAreLeftAsLogged)
{
	LogData d = make_log({0, 30, false}, 16, nullptr);
	const LogData raw = d;
	const TickRescale r = rescale_to_tick_intervals(d);
	EXPECT_FALSE(r.applied);
	for (size_t k = 0; k < d.motors.size(); k += 101)
		EXPECT_EQ(d.motors[k].w[2], raw.motors[k].w[2]);
}

TEST(Ripple, AnEccentricDiscOnTheMotorShaftIsFoundAndDividedOut)
{
	std::vector<std::array<double, 4>> truth;
	LogData d = make_log({0.01, 0, true}, 40, &truth);
	const double before = rel_rms(d, truth, 1, d.motors.size());
	const auto fits = remove_encoder_ripple(d, kGear);
	const double after = rel_rms(d, truth, 1, d.motors.size());
	std::printf("ripple 1 %%: speed error %.3f %% RMS as logged, %.3f %% after\n", 100 * before,
	            100 * after);
	ASSERT_EQ(fits.size(), 2u); // 40 s in 20 s stretches
	for (const RippleFit &f : fits)
		for (int j = 0; j < 4; ++j) {
			EXPECT_TRUE(f.motor_removed[j]);
			EXPECT_NEAR(f.motor_eps[j], 0.01, 0.0005)
			    << j; // the disc's eps, within 5 %
		}
	// A 1 % ripple is 0.71 % RMS; quantisation adds about 1.5 % RMS to both figures.
	EXPECT_LT(after * after, before * before - 0.5 * 0.0071 * 0.0071);
}

TEST(Ripple, ARoundDiscIsLeftAlone)
{
	LogData d = make_log({0, 0, true}, 40, nullptr);
	const LogData raw = d;
	const auto fits = remove_encoder_ripple(d, kGear);
	for (const RippleFit &f : fits)
		for (int j = 0; j < 4; ++j) {
			EXPECT_FALSE(f.motor_removed[j]) << j;
			EXPECT_LT(f.motor_eps[j], 0.001);
		}
	for (size_t k = 0; k < d.motors.size(); k += 101)
		EXPECT_EQ(d.motors[k].w[1], raw.motors[k].w[1]);
}

// The histogram median against a sorted copy (an independent computation): narrow series
// (the histogram), series wider than it and with outliers (the fallback), even and odd sizes.
TEST(Median, MatchesTheSortedCopyOnNarrowWideAndOutlyingSeries)
{
	std::mt19937_64 rng(7);
	for (int trial = 0; trial < 300; ++trial) {
		const size_t n = 1 + rng() % 400;
		const int64_t spread = trial % 3 == 0 ? 40 : trial % 3 == 1 ? 3000 : 5000000;
		std::vector<int64_t> v(n);
		for (auto &x : v)
			x = 1000 + static_cast<int64_t>(rng() % (2 * spread + 1)) - spread;
		if (trial % 7 == 0)
			v[rng() % n] = -(int64_t{1} << 50); // one far outlier
		int64_t got = 0;
		ASSERT_TRUE(median_int64(
		    [&](auto visit) {
			    for (int64_t x : v)
				    visit(x);
		    },
		    got));
		std::vector<int64_t> sorted = v;
		std::sort(sorted.begin(), sorted.end());
		EXPECT_EQ(got, sorted[n / 2]) << "trial " << trial << ", n " << n;
	}
	int64_t none = 0;
	EXPECT_FALSE(median_int64([](auto) {}, none));
}
