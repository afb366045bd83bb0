// The slip flag holds while a wheel slips, against the simulator's truth (OMNI4_SIM_TRUTH's
// per-wheel slip bits and true velocity), in the lockstep simulator (simulated time only):
// voltage steps from rest on a mu 0.4 floor that slip every wheel (a rotation step), two (along
// v) or all four with load transfer (the diagonal), held until the wheels grip again:
// - EST_FLAG_SLIP is set on every tick from its first (at most 50 ms after the truth's onset)
//   until the grip: the truth's fastest slipping wheel slower than twice slip_model_threshold
//   (the flag sees no slip below its threshold); the longest gap is 0 (the gap up to the
//   truth's last flagged tick is printed);
// - the estimate's velocity (v, vn, d w) against the truth during the slip: RMS within 0.2 m/s,
//   max 0.3 m/s (it does not follow the spinning wheels: they gave 0.4-0.7 and 0.6-1.2), and
//   within 0.05 m/s from 200 ms after the slip (the slipping readings taught the wheels' scale
//   calibration nothing);
// - no SLIP 50 ms after the truth's last slipping tick.
// And a push along the motion (a false SLIP of the model's witness): the flag ends, the
// estimate is back on the truth after it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "omni4/command_t.hpp"
#include "omni4/sim_truth_t.hpp"
#include "traction_exp.hpp"

extern "C" {
#include "omni4/lcmtypes/channels.h"
#include "omni4/config/config.h"
#include "omni4/core/est.h"
#include "omni4/sil/simrun.h"
// slip_push.c: an external force along v on the simulated body [N].
void slip_push_set(struct simrun *sr, double force_v_n);
}

namespace
{

struct Run {
	simrun *sr = nullptr;
	int32_t truth = 0;  // the truth's flags of the last tick
	float slip_m_s = 0; // the fastest flagged wheel's slip (rim - ground) of the last tick
};

void on_message(void *ctx, const char *channel, int64_t, const void *data, size_t len)
{
	omni4::sim_truth_t t;
	if (std::string(channel) == OMNI4_CHANNEL_SIM_TRUTH &&
	    t.decode(data, 0, static_cast<int>(len)) > 0) {
		Run *r = static_cast<Run *>(ctx);
		r->truth = t.flags;
		r->slip_m_s = 0;
		for (int j = 0; j < 4; ++j)
			if (t.flags >> j & 1)
				r->slip_m_s = std::max(r->slip_m_s, std::fabs(t.wheel_slip[j]));
	}
}

void voltage_command(simrun *sr, const double u[4], long seq)
{
	omni4::command_t c{};
	c.utime = simrun_now_us(sr);
	c.seq = seq;
	c.mode = omni4::command_t::MODE_VOLTAGE;
	for (int j = 0; j < 4; ++j)
		c.voltage[j] = u[j];
	std::vector<uint8_t> buf(c.getEncodedSize());
	c.encode(buf.data(), 0, static_cast<int>(buf.size()));
	simrun_command(sr, buf.data(), buf.size());
}

// The flag can see a slip only beyond the model witness's threshold (slip_model_threshold,
// 0.03 m/s averaged): the wheel grips, for the gap below, once the truth's fastest slipping
// wheel is slower than twice that.
constexpr double kGripMS = 2 * 0.03;

struct Hold {
	double onset_ms = NAN, grip_ms = NAN, end_ms = NAN; // the truth's first slipping tick,
	                                                    // the grip, its last flagged tick
	double flag_ms = NAN;                               // the first SLIP
	double gap_ms = 0;     // longest run without SLIP between the first SLIP and the grip
	double gap_end_ms = 0; // the same up to the truth's last flagged tick
	double err_rms = 0;    // |estimate - truth| (v, vn, d w) over the slipping ticks [m/s]
	double err_max = 0;    // [m/s]
	long slipping = 0;     // ticks the truth says a wheel slips
	long false_ticks = 0;  // SLIP ticks 50 ms after the truth's last flagged tick
	double err_after = 0;  // the largest error from 200 ms after the slip to the end [m/s]
};

struct Tick {
	bool truth, flag;
	double slip, err; // the truth's fastest slipping wheel, the estimate's error [m/s]
};

// Longest run of ticks without the flag in from .. to.
double gap(const std::vector<Tick> &ticks, long from, long to, double dt_ms)
{
	long run = 0, most = 0;
	for (long k = from; k <= to; ++k) {
		run = ticks[k].flag ? 0 : run + 1;
		most = std::max(most, run);
	}
	return most * dt_ms;
}

Hold summarise(const std::vector<Tick> &ticks, double dt_ms)
{
	Hold h;
	long first = -1, last = -1, grip = -1, flag = -1;
	for (size_t k = 0; k < ticks.size(); ++k) {
		const long n = static_cast<long>(k);
		if (ticks[k].truth) {
			first = first < 0 ? n : first;
			last = n;
			grip = ticks[k].slip > kGripMS ? n : grip;
		}
		if (ticks[k].flag && flag < 0)
			flag = n;
	}
	if (first < 0 || flag < 0 || grip < flag)
		return h;
	h.onset_ms = (first + 1) * dt_ms;
	h.grip_ms = (grip + 1) * dt_ms;
	h.end_ms = (last + 1) * dt_ms;
	h.flag_ms = (flag + 1) * dt_ms;
	h.gap_ms = gap(ticks, flag, grip, dt_ms);
	h.gap_end_ms = gap(ticks, flag, last, dt_ms);
	double ss = 0;
	for (long k = first; k <= last; ++k) {
		if (!ticks[k].truth)
			continue;
		++h.slipping;
		ss += ticks[k].err * ticks[k].err;
		h.err_max = std::max(h.err_max, ticks[k].err);
	}
	h.err_rms = std::sqrt(ss / std::max(1L, h.slipping));
	for (size_t k = last + 1 + static_cast<size_t>(std::lround(50 / dt_ms)); k < ticks.size();
	     ++k)
		h.false_ticks += ticks[k].flag;
	for (size_t k = last + 1 + static_cast<size_t>(std::lround(200 / dt_ms)); k < ticks.size();
	     ++k)
		h.err_after = std::max(h.err_after, ticks[k].err);
	return h;
}

// Voltages u (volts per unit of the direction's pattern) held from rest on a floor of mu for
// ticks.
Hold voltage_step(const std::string &dir, double u, long ticks)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.sim.traction_mu = 0.4;
	cfg.sim.seed = 7;
	char err[256];
	Run r;
	r.sr = simrun_create(&cfg, &cfg.ctl.model, true, nullptr, err, sizeof(err));
	EXPECT_NE(r.sr, nullptr) << err;
	if (!r.sr)
		return {};
	simrun_set_tap(r.sr, on_message, &r);
	for (int k = 0; k < 300; ++k) // the offsets' calibration, at rest
		simrun_tick(r.sr);
	const auto pattern = omni4::traction_pattern(dir);
	const double volts[4] = {u * pattern[0], u * pattern[1], u * pattern[2], u * pattern[3]};
	const double d = cfg.ctl.model.d;
	std::vector<Tick> log;
	for (long k = 0; k < ticks; ++k) {
		if (k % 50 == 0)
			voltage_command(r.sr, volts, k + 1);
		simrun_tick(r.sr);
		double x[3], pose[3];
		simrun_truth(r.sr, x, pose);
		const est_output *o = simrun_estimate(r.sr);
		const double e[3] = {o->vel[0] - x[0], o->vel[1] - x[1], d * (o->vel[2] - x[2])};
		log.push_back({(r.truth & 0x0f) != 0, (o->flags & EST_FLAG_SLIP) != 0, r.slip_m_s,
		               std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])});
	}
	const Hold h = summarise(log, simrun_period_s(r.sr) * 1e3);
	simrun_destroy(r.sr);
	return h;
}

} // namespace

TEST(SlipHold, TheFlagHoldsFromOnsetToGripAndTheEstimateFollowsTheBody)
{
	struct Case {
		const char *dir;
		double volts;
	};
	for (const Case c : {Case{"w", 6.0}, Case{"v", 8.0}, Case{"diag", 6.0}}) {
		const Hold h = voltage_step(c.dir, c.volts, 2500);
		std::printf(
		    "%-4s %4.1f V: truth slips %.0f-%.0f ms (%ld ticks; faster than %.2f m/s "
		    "until %.0f ms), SLIP from %.0f ms, longest gap to the grip %.0f ms (to "
		    "the truth's last flagged tick %.0f ms); estimate error in the slip RMS "
		    "%.4f max %.4f m/s, after it max %.4f m/s; SLIP ticks after the slip %ld\n",
		    c.dir, c.volts, h.onset_ms, h.end_ms, h.slipping, kGripMS, h.grip_ms, h.flag_ms,
		    h.gap_ms, h.gap_end_ms, h.err_rms, h.err_max, h.err_after, h.false_ticks);
		ASSERT_GT(h.slipping, 100)
		    << c.dir << ": the floor must slip for this to mean anything";
		EXPECT_LE(h.flag_ms - h.onset_ms, 50.0) << c.dir;
		EXPECT_EQ(h.gap_ms, 0.0) << c.dir;
		EXPECT_LE(h.err_rms, 0.2)
		    << c.dir; // measured 0.06-0.09 (following the wheels: 0.4-0.7)
		EXPECT_LE(h.err_max, 0.3)
		    << c.dir; // measured 0.11-0.14 (following the wheels: 0.6-1.2)
		EXPECT_EQ(h.false_ticks, 0) << c.dir;
		// measured 0.003-0.024 (slipping readings learnt as scale errors: 0.08)
		EXPECT_LE(h.err_after, 0.05) << c.dir;
	}
}

namespace
{

struct Push {
	long slip_ticks = 0;    // SLIP during the push
	double clear_ms = NAN;  // the flag's last tick after the push ends [ms after it]
	double err_after = 0;   // the largest estimate error from 200 ms after the push [m/s]
	double err_push = 0;    // the largest estimate error during the push [m/s]
	int32_t truth_slip = 0; // the truth's slip flags seen
};

// 4 V along v on a mu 1 floor (the robot cruising, no wheel beyond its traction), then a push of
// force_n along the motion for 0.5 s: the wheels grip, the body runs ahead of the model.
Push push_along(double force_n)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.sim.traction_mu = 1.0;
	cfg.sim.seed = 7;
	char err[256];
	Run r;
	r.sr = simrun_create(&cfg, &cfg.ctl.model, true, nullptr, err, sizeof(err));
	EXPECT_NE(r.sr, nullptr) << err;
	if (!r.sr)
		return {};
	simrun_set_tap(r.sr, on_message, &r);
	const auto pattern = omni4::traction_pattern("v");
	const double volts[4] = {4 * pattern[0], 4 * pattern[1], 4 * pattern[2], 4 * pattern[3]};
	const double dt = simrun_period_s(r.sr), d = cfg.ctl.model.d;
	const long on = 2300, off = 2800, end = 4800;
	Push p;
	long last_flag = -1;
	for (long k = 0; k < end; ++k) {
		if (k >= 300 && k % 50 == 0)
			voltage_command(r.sr, volts, k + 1);
		slip_push_set(r.sr, k >= on && k < off ? force_n : 0.0);
		simrun_tick(r.sr);
		double x[3], pose[3];
		simrun_truth(r.sr, x, pose);
		const est_output *o = simrun_estimate(r.sr);
		const double e[3] = {o->vel[0] - x[0], o->vel[1] - x[1], d * (o->vel[2] - x[2])};
		const double en = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
		const bool flag = (o->flags & EST_FLAG_SLIP) != 0;
		p.truth_slip |= k >= 300 ? r.truth & 0x0f : 0;
		if (k >= on && k < off) {
			p.slip_ticks += flag;
			p.err_push = std::max(p.err_push, en);
		}
		last_flag = flag ? k : last_flag;
		if (k >= off + std::lround(0.2 / dt))
			p.err_after = std::max(p.err_after, en);
	}
	p.clear_ms = last_flag >= off ? (last_flag + 1 - off) * dt * 1e3 : 0.0;
	simrun_destroy(r.sr);
	return p;
}

} // namespace

// A push along the motion looks like a slip to the model's witness (the wheels run ahead of the
// prediction; the camera, slower, would not confirm it). Flagged, the wheels are left out and
// the model and the camera carry the estimate, which misses the push while the flag lasts; the
// flag ends (the motor's force turns against the motion once the body runs past its speed, or
// the wheels agree with the estimate again): no lock-in, the estimate back on the truth.
TEST(SlipHold, APushAlongTheMotionEndsWithThePushAndLeavesTheEstimateOnTheTruth)
{
	for (double f : {5.0, 15.0}) {
		const Push p = push_along(f);
		std::printf(
		    "push %.0f N along v for 0.5 s at 4 V: SLIP %ld of 500 ticks, flag clear "
		    "%.0f ms after it, estimate error during it max %.4f, from 200 ms after it "
		    "max %.4f m/s; truth slip 0x%x\n",
		    f, p.slip_ticks, p.clear_ms, p.err_push, p.err_after, p.truth_slip);
		EXPECT_EQ(p.truth_slip, 0);
		EXPECT_LE(p.clear_ms, 100.0); // measured 0: the flag ends within the push
		EXPECT_LE(p.err_after, 0.01); // measured 0.0032-0.0036
		// The price of leaving the wheels out on a false SLIP: measured 0.33 m/s at 15 N
		// (the wheels trusted: 0.031); the model does not know the push.
		EXPECT_LE(p.err_push, 0.7);
	}
}
