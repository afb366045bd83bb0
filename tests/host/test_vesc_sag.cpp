// A VESC duty run on a sagging supply: the controller (omni4-fw's robot, [hal] motor = vesc,
// mode = duty) and omni4-motorsim's simulated VESCs and plant (host-tools/motorsim), in lockstep
// at 1 kHz, the CAN socket (sc_os) replaced at link time by a queue each way with the kernel's
// receive filters. The same velocity course twice: on a stiff 12 V supply and on one that sags
// 20 % (12 V -> 9.6 V over 2 s, then held). The duty is the wheel voltage over the input voltage
// each VESC measures (STATUS_5), so the applied voltage follows the controller's wish whatever
// the supply: the velocity tracking error (RMS of |v - v_cmd| over the course, the plant's true
// velocity) on the sagging supply stays within 1.2x the stiff run's. Deterministic: simulated
// time only. Prints both figures.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drive_loop.hpp"
#include "vesc_sag_robot.h"

namespace
{

constexpr double kDt = 0.001;     // 1 kHz, the default [loop] rate
constexpr double kCourseS = 6.0;  // the run
constexpr double kSupplyV = 12.0; // [limits] supply_v's default
constexpr double kSag = 0.20;     // the sagging supply ends 20 % lower

// The velocity course [m/s, m/s, rad/s] at t: smooth, within what 0.95 x 9.6 V drives.
void course(double t, double v[3])
{
	const double two_pi = 6.283185307179586;
	v[0] = 0.4 * std::sin(two_pi * t / 3.0);
	v[1] = 0.3 * std::sin(two_pi * t / 2.0 + 1.0);
	v[2] = 0.5 * std::sin(two_pi * t / 4.0);
}

// The open-circuit supply at t: stiff, or 12 V falling linearly to 9.6 V between 1 s and 3 s.
double supply_at(double t, bool sag)
{
	if (!sag || t < 1.0)
		return kSupplyV;
	return kSupplyV * (1.0 - kSag * std::fmin(1.0, (t - 1.0) / 2.0));
}

void deliver(const motorsim::Frames &out)
{
	for (const auto &f : out)
		sag_bus_deliver(&f);
}

struct RunResult {
	double rms_m_s;       // translational tracking error, RMS [m/s]
	double min_supply_v;  // the lowest supply the drives saw [V]
	int32_t faults;       // every fault bit seen
	int64_t driven_ticks; // ticks with the robot in VELOCITY
};

// One run of the course; the tracking error from 0.2 s on (the first command's start-up).
RunResult run(bool sag)
{
	model_params p{};
	sag_robot_model(&p);
	plant pl{};
	EXPECT_EQ(plant_init(&pl, &p), 0);
	motorsim::DriveLoop d;
	motorsim::VescOptions vo;
	drive_loop_init(d, motorsim::Protocol::vesc, vo, motorsim::OdriveOptions{},
	                motorsim::Supply{kSupplyV, 0.0}, &pl);
	int64_t clock_us = 1000000;
	sag_bus_reset(clock_us);
	drive_loop_advance(d, 0.0, kDt, {}); // the drives' first reports before the start
	deliver(d.out);
	char why[256];
	EXPECT_EQ(sag_robot_open(why, sizeof(why)), 0) << why;
	RunResult r{0, kSupplyV, 0, 0};
	double sum2 = 0;
	int64_t n = 0;
	for (int64_t k = 1; k * kDt <= kCourseS; ++k) {
		const double t = k * kDt;
		double v[3];
		course(t, v);
		clock_us += 1000;
		int32_t faults = 0;
		int in_velocity = 0;
		sag_robot_tick(clock_us, k, v, &faults, &in_velocity);
		r.faults |= faults;
		r.driven_ticks += in_velocity;
		d.supply.v = supply_at(t, sag);
		motorsim::Frames in(64);
		const int sent = sag_bus_take_sent(in.data(), static_cast<int>(in.size()));
		EXPECT_LE(sent, static_cast<int>(in.size()));
		in.resize(static_cast<size_t>(std::min<int>(sent, static_cast<int>(in.size()))));
		drive_loop_advance(d, t, kDt, in);
		deliver(d.out);
		r.min_supply_v = std::fmin(r.min_supply_v, d.view.supply_v);
		if (t >= 0.2) {
			const double ex = pl.x[0] - v[0], ey = pl.x[1] - v[1];
			sum2 += ex * ex + ey * ey;
			++n;
		}
	}
	sag_robot_close();
	r.rms_m_s = std::sqrt(sum2 / static_cast<double>(n));
	return r;
}

TEST(VescSag, DutyFollowsTheMeasuredSupply)
{
	const RunResult stiff = run(false);
	const RunResult sag = run(true);
	std::printf("vesc duty, velocity tracking error RMS: stiff %.2f V: %.5f m/s; sagging to "
	            "%.2f V: %.5f m/s; ratio %.3f\n",
	            stiff.min_supply_v, stiff.rms_m_s, sag.min_supply_v, sag.rms_m_s,
	            sag.rms_m_s / stiff.rms_m_s);
	// the runs are what they say: driven throughout, no fault, the supply 20 % down
	const int64_t ticks = static_cast<int64_t>(kCourseS / kDt);
	EXPECT_GE(stiff.driven_ticks, ticks - 2);
	EXPECT_GE(sag.driven_ticks, ticks - 2);
	EXPECT_EQ(stiff.faults, 0);
	EXPECT_EQ(sag.faults, 0);
	EXPECT_NEAR(sag.min_supply_v, kSupplyV * (1.0 - kSag), 1e-9);
	EXPECT_GT(stiff.rms_m_s, 0.0);
	EXPECT_LE(sag.rms_m_s, 1.2 * stiff.rms_m_s); // the requirement: within 1.2x
}

} // namespace
