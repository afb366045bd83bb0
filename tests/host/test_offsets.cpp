// Tests for the current-sense offsets of identification (offsets.hpp), the calibration notices
// in the log reader, and the standard errors that carry what a method borrows.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "identify.hpp"
#include "omni4/core/vocab.h"
#include "logdata.hpp"
#include "offsets.hpp"
#include "omni4/motors_t.hpp"
#include "omni4/param_changed_t.hpp"
#include "regression.hpp"
#include "simexp.hpp"
#include "testlog.hpp"

using namespace omni4;

namespace
{

using omni4_test::temp_path;

constexpr double kNoiseA = 0.02; // the paper's current noise [A]

// A 1 kHz log: blocks of driven (VOLTAGE) and bridge-off (IDLE) samples. With the bridges off
// the reading is offset + N(0, kNoiseA), except for a decaying winding current (0.5 A, 3 ms time
// constant) right after each drive: the guard must keep it out.
LogData synthetic(const std::array<double, 4> &offset, unsigned seed, int blocks = 10)
{
	LogData d;
	d.path = "synthetic";
	std::mt19937 g(seed);
	std::normal_distribution<double> n(0, kNoiseA);
	int64_t seq = 0, t = 1000000, last_drive = -1;
	for (int b = 0; b < blocks; ++b) {
		for (int k = 0; k < 1000; ++k, ++seq, t += 1000) {
			MotorsSample s;
			s.utime = t;
			s.seq = seq;
			const bool driven = k < 300;
			s.mode = driven ? CTL_VOLTAGE : CTL_IDLE;
			if (driven)
				last_drive = t;
			const double tail =
			    last_drive >= 0 ? 0.5 * std::exp(-(t - last_drive) * 1e-6 / 0.003) : 0;
			for (int j = 0; j < 4; ++j) {
				s.u[j] = driven ? 6.0f : 0.0f;
				s.i[j] =
				    static_cast<float>(offset[j] + n(g) + (driven ? 0.8 : tail));
			}
			d.motors.push_back(s);
		}
	}
	return d;
}

} // namespace

TEST(Offsets, BridgeOffMeanIsTheOffsetWithinThreeStandardErrors)
{
	const std::array<double, 4> off = {0.050, -0.050, 0.030, -0.020};
	int outside = 0;
	for (unsigned seed = 1; seed <= 20; ++seed) {
		LogData d = synthetic(off, seed);
		const auto warnings = calibrate_currents(d);
		EXPECT_TRUE(warnings.empty());
		ASSERT_EQ(d.current_offsets.size(), 1u);
		const OffsetEpoch &e = d.current_offsets[0];
		ASSERT_TRUE(e.estimated && e.subtracted);
		// 10 blocks x 700 bridge-off samples, less those under 20 ms after the last drive
		// (the samples 1-19 ms after it).
		EXPECT_EQ(e.samples, 10u * (700 - 19));
		const double se_white = kNoiseA / std::sqrt(static_cast<double>(e.samples));
		for (int j = 0; j < 4; ++j) {
			EXPECT_NEAR(e.se_a[j], se_white,
			            0.3 * se_white); // batch means on white noise
			outside += std::abs(e.offset_a[j] - off[j]) > 3 * e.se_a[j];
		}
	}
	EXPECT_LE(outside, 1); // 80 estimates, P(|z| > 3) = 0.27 %
}

// Noise correlated over 16 samples (one draw held for 16 readings): the mean's SE is 4 times
// the white-noise figure, and the batch means (32 samples) must see it.
TEST(Offsets, CorrelatedNoiseWidensTheStandardErrorThroughTheBatchMeans)
{
	LogData d = synthetic({0, 0, 0, 0}, 13);
	std::mt19937 g(13);
	std::normal_distribution<double> n(0, kNoiseA);
	std::array<double, 4> held{};
	for (MotorsSample &s : d.motors) {
		if (s.seq % 16 == 0)
			for (double &h : held)
				h = n(g);
		if (s.mode == CTL_IDLE)
			for (int j = 0; j < 4; ++j)
				s.i[j] = static_cast<float>(held[j]);
	}
	calibrate_currents(d);
	const OffsetEpoch &e = d.current_offsets.at(0);
	const double se_white = kNoiseA / std::sqrt(static_cast<double>(e.samples));
	for (int j = 0; j < 4; ++j)
		EXPECT_NEAR(e.se_a[j], 4 * se_white, 0.3 * 4 * se_white) << j;
}

TEST(Offsets, SubtractedFromEveryReadingDrivenOrNot)
{
	const std::array<double, 4> off = {0.050, -0.050, 0.030, -0.020};
	LogData raw = synthetic(off, 3);
	LogData d = raw;
	calibrate_currents(d);
	const auto &e = d.current_offsets.at(0);
	for (size_t k = 0; k < d.motors.size(); k += 97)
		for (int j = 0; j < 4; ++j)
			EXPECT_EQ(d.motors[k].i[j],
			          static_cast<float>(raw.motors[k].i[j] - e.offset_a[j]));
}

TEST(Offsets, TheGuardAfterADriveKeepsTheWindingCurrentOut)
{
	// With no guard the 0.5 A tail would add 0.5 A x 3 ms / 700 ms = 2.1 mA to every mean.
	LogData d = synthetic({0, 0, 0, 0}, 5);
	OffsetOptions opt;
	calibrate_currents(d, opt);
	for (int j = 0; j < 4; ++j)
		EXPECT_LT(std::abs(d.current_offsets[0].offset_a[j]), 1.0e-3);
	LogData n = synthetic({0, 0, 0, 0}, 5);
	opt.guard_s = 0;
	calibrate_currents(n, opt);
	for (int j = 0; j < 4; ++j)
		EXPECT_GT(n.current_offsets[0].offset_a[j], 1.5e-3);
}

TEST(Offsets, FaultSamplesAreNotUsed)
{
	LogData d = synthetic({0.01, 0.01, 0.01, 0.01}, 7);
	for (MotorsSample &s : d.motors)
		if (s.mode == CTL_IDLE &&
		    s.seq % 1000 > 600) { // a saturated sensor in FAULT reads 10 A
			s.mode = CTL_FAULT;
			s.faults = CTL_FAULT_CURRENT_SENSOR;
			s.i = {10, 10, 10, 10};
		}
	calibrate_currents(d);
	for (int j = 0; j < 4; ++j)
		EXPECT_NEAR(d.current_offsets[0].offset_a[j], 0.01, 2e-3);
}

TEST(Offsets, EachCalibrationNoticeOpensAnEpochOfItsOwn)
{
	// The controller subtracted nothing up to seq 5000, then its own calibration: the residual
	// offsets differ on either side.
	LogData d = synthetic({0.04, -0.03, 0.02, 0.01}, 9);
	for (MotorsSample &s : d.motors)
		if (s.seq >= 5000)
			for (int j = 0; j < 4; ++j)
				s.i[j] = static_cast<float>(
				    s.i[j] - std::array<double, 4>{0.039, -0.031, 0.02, 0.0}[j]);
	CalibrationNotice n;
	n.seq = 5000;
	n.offset_a = {0.039, -0.031, 0.02, 0.0};
	n.samples = 256;
	d.calibrations.push_back(n);
	calibrate_currents(d);
	ASSERT_EQ(d.current_offsets.size(), 2u);
	const OffsetEpoch &a = d.current_offsets[0], &b = d.current_offsets[1];
	EXPECT_EQ(a.m1, 5000u);
	EXPECT_EQ(b.m0, 5000u);
	EXPECT_EQ(b.notice, 0);
	const std::array<double, 4> before = {0.04, -0.03, 0.02, 0.01},
	                            after = {0.001, 0.001, 0, 0.01};
	for (int j = 0; j < 4; ++j) {
		EXPECT_NEAR(a.offset_a[j], before[j], 4 * a.se_a[j]);
		EXPECT_NEAR(b.offset_a[j], after[j], 4 * b.se_a[j]);
	}
}

TEST(Offsets, ALogWithoutBridgeOffSamplesIsUsedAsLoggedWithAWarning)
{
	LogData d = synthetic({0.05, 0.05, 0.05, 0.05}, 11);
	for (MotorsSample &s : d.motors)
		s.mode = CTL_VOLTAGE;
	const auto raw = d.motors;
	const auto w = calibrate_currents(d);
	ASSERT_EQ(w.size(), 1u);
	EXPECT_NE(w[0].find("0 samples with the bridges off"), std::string::npos) << w[0];
	EXPECT_FALSE(d.current_offsets.at(0).subtracted);
	EXPECT_EQ(d.motors[123].i[2], raw[123].i[2]);
}

// The controller's notice as omni4-fw sends it, read back from a real event log; a notice with
// an impossible count of keys is undecodable, not a crash or a huge allocation.
TEST(Offsets, CalibrationNoticesAreReadFromTheLog)
{
	const std::string path = temp_path(".lcmlog");
	omni4_test::EventLogWriter log(path);
	ASSERT_TRUE(log.ok());
	auto put = [&](const char *channel, const std::vector<uint8_t> &buf) {
		ASSERT_TRUE(log.put_bytes(channel, buf));
	};
	auto encode = [](const auto &msg) { return omni4_test::EventLogWriter::encode(msg); };
	for (int k = 0; k < 10; ++k) {
		omni4::motors_t m{};
		m.utime = 1000000 + 1000 * k;
		m.seq = k;
		put("OMNI4_MOTORS", encode(m));
	}
	omni4::param_changed_t p{};
	p.utime = 1005000;
	p.seq = 6;
	p.source = "calibration";
	p.path = "";
	p.keys = {"calibration.current_offset_a0", "calibration.current_offset_a1",
	          "calibration.current_offset_a2", "calibration.current_offset_a3",
	          "calibration.samples"};
	p.values = {"0.050000", "-0.049000", "0.031000", "-0.020500", "256"};
	p.old_values = {"0", "0", "0", "0", "0"};
	p.n = static_cast<int32_t>(p.keys.size());
	put("OMNI4_PARAM_CHANGED", encode(p));
	omni4::param_changed_t s = p; // a parameter change: not a calibration
	s.source = "set";
	put("OMNI4_PARAM_CHANGED", encode(s));
	std::vector<uint8_t> bad = encode(p);
	// n sits after fingerprint, 3 int64 and the two strings "calibration" (4 + 12) and "" (4 +
	// 1).
	const size_t npos = 8 + 24 + 16 + 5;
	bad[npos] = 0x7f;
	put("OMNI4_PARAM_CHANGED", bad);
	log.close();

	const LogData d = read_log(path);
	std::remove(path.c_str());
	EXPECT_EQ(d.undecodable, 1u);
	ASSERT_EQ(d.calibrations.size(), 1u);
	const CalibrationNotice &n = d.calibrations[0];
	EXPECT_EQ(n.seq, 6);
	EXPECT_EQ(n.samples, 256);
	EXPECT_DOUBLE_EQ(n.offset_a[1], -0.049);
	EXPECT_DOUBLE_EQ(n.offset_a[3], -0.0205);
}

// ---- borrowed uncertainty --------------------------------------------------------------------

TEST(Borrowed, PropagateSplitsOwnAndBorrowedVariance)
{
	// f = x0 x1 + x2: own x0, borrowed x1 and x2; closed form of both parts.
	Eigen::VectorXd x(3);
	x << 2.0, 3.0, 1.0;
	Eigen::MatrixXd C = Eigen::MatrixXd::Zero(3, 3);
	C(0, 0) = 0.01;
	C(1, 1) = 0.04;
	C(2, 2) = 0.09;
	const Estimate e =
	    propagate([](const Eigen::VectorXd &q) { return q[0] * q[1] + q[2]; }, x, C, {0});
	EXPECT_NEAR(e.value, 7.0, 1e-12);
	const double own2 = 3.0 * 3.0 * 0.01, borrowed2 = 2.0 * 2.0 * 0.04 + 0.09;
	EXPECT_NEAR(e.se, std::sqrt(own2 + borrowed2), 1e-6);
	EXPECT_NEAR(e.se_borrowed, std::sqrt(borrowed2), 1e-6);
	const Eigen::VectorXd s = propagate_independent(
	    [](const Eigen::VectorXd &q) {
		    Eigen::VectorXd out(2);
		    out << q[0] * q[1], q[2];
		    return out;
	    },
	    x, Eigen::Vector3d(0.1, 0.2, 0.3));
	EXPECT_NEAR(s[0], std::hypot(3.0 * 0.1, 2.0 * 0.2), 1e-12);
	EXPECT_NEAR(s[1], 0.3, 1e-12);
}

namespace
{

LogData sim_log(unsigned seed, const std::array<double, 4> &offset)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.sim.seed = static_cast<int>(seed);
	const std::string path = temp_path(".lcmlog");
	run_simulation(cfg, cfg.ctl.model, true, path, true, 0, 0);
	LogData d = read_log(path);
	std::remove(path.c_str());
	// The sensor's offset and noise on every reading, the bridge-off ones included.
	std::mt19937 g(seed);
	std::normal_distribution<double> n(0, kNoiseA);
	for (MotorsSample &s : d.motors)
		for (int j = 0; j < 4; ++j)
			s.i[j] = static_cast<float>(s.i[j] + offset[j] +
			                            (mode_drives(s.mode) ? 0 : n(g)));
	return d;
}

model_params base_table3()
{
	model_params b = model_params_table3;
	return b;
}

} // namespace

// Experiment 3's Bv with R from its own theta2 is Bv = -M theta1 - 2 Kv l M theta2 / r, so the
// SE it borrows from Kv is 2 l M theta2 / r x SE(Kv) = 2 l^2 Kv SE(Kv) / (r^2 R): the table's
// borrowed part against that closed form, on steps along v alone.
TEST(Borrowed, ExperimentThreeBvBorrowsKvsErrorAsTheClosedFormSays)
{
	LogData d = sim_log(21, {0, 0, 0, 0});
	calibrate_currents(d);
	std::vector<Segment> segs;
	for (const Segment &s : split_segments(d))
		if (s.kind == "motor" || (s.kind == "step" && s.direction == "v"))
			segs.push_back(s);
	const IdentResult r = identify(segs, base_table3());
	const Estimate kv = r.table.at("motor").at("Kv");
	const model_params &p = model_params_table3;
	for (const char *m : {"exp3_ls", "exp3_iv"}) {
		const Estimate R = r.table.at(m).at("R"), Bv = r.table.at(m).at("Bv");
		const double want = 2 * p.l * p.l * kv.value * kv.se / (p.r * p.r * R.value);
		EXPECT_NEAR(Bv.se_borrowed, want, 0.02 * want) << m;
		// R = l Kt / (r M theta2) borrows Kv's relative error one to one.
		EXPECT_NEAR(R.se_borrowed / R.value, kv.se / kv.value, 1e-3 * kv.se / kv.value)
		    << m;
		EXPECT_GE(Bv.se, Bv.se_borrowed) << m;
	}
}

// Offsets of tens of mA move experiment 1's Cw by tens of percent; estimated from the log's
// bridge-off samples and subtracted, identification is as good as without them.
TEST(Offsets, IdentificationWithOffsetsIsAsGoodAsWithoutOnceCalibrated)
{
	const std::array<double, 4> off = {0.045, -0.02, 0.05, 0.035};
	const model_params &t = model_params_table3;
	LogData raw = sim_log(31, off);
	const IdentResult bad = identify(split_segments(raw), base_table3());
	const double cw_bad = (bad.table.at("exp1").at("Cw").value - t.Cw) / t.Cw;
	// Torque offset d l Kt / r x sum(offsets) = 0.3546 N m/A x 0.11 A = 0.039 N m: +28 % of Cw
	// (the fit's intercept takes it whole), with the Kt the motor test identified from the
	// same offset currents: the one-motor runs' fits (no intercept) take the driven motor's
	// offset into Kt (-2.8 % here), which scales experiment 1's torque, Cw with it:
	// Cw' / Cw - 1 = Kt' / Kt - 1 + d l Kt' sum(offsets) / (r Cw) (measured +24.55 % against
	// +24.59 %). The offsets make the motors' eq 22 fits differ, so the F-test may take them as
	// different motors: then the torque is d l / r sum Kt_j off_j with each motor's own
	// (offset-biased) Kt_j.
	const double kt_bad = bad.table.at("motor").at("Kv").value;
	double torque_off = t.d * t.l * kt_bad / t.r * 0.11 + (kt_bad / t.Kt - 1) * t.Cw;
	if (bad.wheels.motors_differ) {
		torque_off = 0;
		for (int j = 0; j < 4; ++j)
			torque_off += t.d * t.l / t.r * bad.Kv_motor[j].value * off[j];
	}
	std::printf("Cw with the offsets left in: %+.1f %% (motors %s)\n", 100 * cw_bad,
	            bad.wheels.motors_differ ? "taken as different" : "taken as equal");
	EXPECT_NEAR(cw_bad, torque_off / t.Cw, 0.03);
	LogData d = raw;
	calibrate_currents(d);
	const auto &e = d.current_offsets.at(0);
	for (int j = 0; j < 4; ++j)
		EXPECT_NEAR(e.offset_a[j], off[j], 4 * e.se_a[j] + 1e-4);
	const IdentResult good = identify(split_segments(d), base_table3());
	EXPECT_LT(std::abs(good.table.at("exp1").at("Cw").value - t.Cw) / t.Cw, 0.01);
	EXPECT_LT(std::abs(good.table.at("motor").at("R").value - t.R) / t.R, 0.006);
	EXPECT_LT(std::abs(good.table.at("final").at("Cw").value - t.Cw) / t.Cw, 0.01);
	// The offsets' SE reaches experiment 1 as a borrowed part.
	EXPECT_GT(good.table.at("exp1").at("Cw").se_borrowed, 0);
}
