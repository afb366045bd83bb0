// Tests for host-tools: filters, regressions, and identification accuracy on simulated robots.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "bootstrap.hpp"
#include "experiments.hpp"
#include "identify.hpp"
#include "logdata.hpp"
#include "omni4/experiment_t.hpp"
#include "omni4/motors_t.hpp"
#include "omni4/pose_t.hpp"
#include "regression.hpp"
#include "signals.hpp"
#include "simexp.hpp"
#include "testlog.hpp"
#include "traction_exp.hpp"
#include "validate.hpp"

extern "C" {
#include "omni4/model/dynamics.h"
}

using namespace omni4;

namespace
{

using omni4_test::temp_path;

model_params base_of(const model_params &p)
{
	model_params b = model_params_table3;
	b.d = p.d;
	b.r = p.r;
	b.l = p.l;
	b.M = p.M;
	return b;
}

double rel(double got, double want)
{
	return (got - want) / want;
}

} // namespace

// Experiment 3's inversions against model/'s forward state space (dyn_state_space, a separate
// derivation): on random robots, A, B, K -> theta -> the parameters again, to rounding.
TEST(StateSpace, InversionsUndoTheModelsStateSpace)
{
	std::mt19937 gen(7);
	std::uniform_real_distribution<double> scale(0.5, 2.0), volt(-12.0, 12.0);
	const char *dirs[3] = {"v", "vn", "w"};
	for (int n = 0; n < 200; ++n) {
		model_params p = model_params_table3;
		for (double *q : {&p.d, &p.r, &p.l, &p.Kv, &p.R, &p.M, &p.J, &p.Bv, &p.Bvn, &p.Bw,
		                  &p.Cv, &p.Cvn, &p.Cw})
			*q *= scale(gen);
		p.Kt = p.Kv;
		model_ss ss;
		dyn_state_space(&p, &ss);
		const double u[4] = {volt(gen), volt(gen), volt(gen), volt(gen)};
		double theta2[3];
		for (int axis = 0; axis < 3; ++axis) {
			// The column of B that multiplies the axis input: the whole row, applied to
			// any u.
			double bu = 0;
			for (int j = 0; j < 4; ++j)
				bu += ss.B[axis][j] * u[j];
			const int j_nz = axis == 0 ? 3 : 0;
			theta2[axis] = ss.B[axis][j_nz];
			EXPECT_NEAR(bu, theta2[axis] * axis_input(u, axis),
			            1e-12 * (1 + std::abs(bu)))
			    << dirs[axis];
		}
		model_params q = p; // what experiment 3 is given: geometry, M, Kt = Kv
		q.R = q.J = q.Bv = q.Bvn = q.Bw = q.Cv = q.Cvn = q.Cw = NAN;
		EXPECT_NEAR(rel(R_from_theta2(q, 0, theta2[0]), p.R), 0, 1e-12);
		EXPECT_NEAR(rel(R_from_theta2(q, 1, theta2[1]), p.R), 0, 1e-12);
		q.R = p.R;
		EXPECT_NEAR(rel(B_from_theta1(q, 0, ss.A[0]), p.Bv), 0, 1e-9);
		EXPECT_NEAR(rel(B_from_theta1(q, 1, ss.A[1]), p.Bvn), 0, 1e-9);
		EXPECT_NEAR(rel(C_from_theta3(q, 0, ss.K[0]), p.Cv), 0, 1e-12);
		EXPECT_NEAR(rel(C_from_theta3(q, 1, ss.K[1]), p.Cvn), 0, 1e-12);
		EXPECT_NEAR(rel(J_from_theta2(q, theta2[2]), p.J), 0, 1e-12);
		q.J = p.J;
		EXPECT_NEAR(rel(B_from_theta1(q, 2, ss.A[2]), p.Bw), 0, 1e-9);
		EXPECT_NEAR(rel(C_from_theta3(q, 2, ss.K[2]), p.Cw), 0, 1e-12);
	}
}

// The runner's drive patterns (experiments.cpp, one sign per wheel) against model/'s B (eq 26):
// each accelerates its own axis forward and no other, on any robot.
TEST(StateSpace, DrivePatternsAccelerateOnlyTheirOwnAxis)
{
	const char *dirs[3] = {"v", "vn", "w"};
	model_params p = model_params_table3;
	p.d *= 1.7; // nothing in the check depends on Table III's numbers
	p.M *= 0.6;
	model_ss ss;
	dyn_state_space(&p, &ss);
	for (int axis = 0; axis < 3; ++axis) {
		const std::array<double, 4> u = drive_pattern(dirs[axis]);
		for (int k = 0; k < 3; ++k) {
			double bu = 0;
			for (int j = 0; j < 4; ++j)
				bu += ss.B[k][j] * u[j];
			if (k == axis)
				EXPECT_GT(bu, 0) << dirs[axis];
			else
				EXPECT_EQ(bu, 0) << dirs[axis] << " moves axis " << dirs[k];
			EXPECT_EQ(axis_input(u.data(), k) != 0, k == axis)
			    << dirs[axis] << " on " << dirs[k];
		}
	}
	EXPECT_THROW(drive_pattern("x"), std::invalid_argument);
}

// Another layout's axis runs push along their axis alone with the least wheel forces; by hand
// for three wheels at 0/120/240 deg at one distance d (rows [0 1 d], [-sqrt3/2 -1/2 d],
// [sqrt3/2 -1/2 d], G^T G = diag(3/2, 3/2, 3 d^2), split G (G^T G)^-1): along v (0, -1, 1),
// along vn (1, -1/2, -1/2), along w (1, 1, 1), the largest |voltage| 1 per volt; slot 3 0.
TEST(Experiments, ThreeWheelPatternsAreTheHandComputedLeastNormPushes)
{
	const double ang[4] = {0, 120, 240, 0}, dist[4] = {0.11, 0.11, 0.11, 0};
	const Layout L = make_layout(3, ang, dist, "test");
	EXPECT_FALSE(L.paper);
	const std::map<std::string, std::array<double, 4>> hand = {
	    {"v", {0, -1, 1, 0}}, {"vn", {1, -0.5, -0.5, 0}}, {"w", {1, 1, 1, 0}}};
	for (const auto &[dir, want] : hand) {
		const std::array<double, 4> u = drive_pattern(dir, L);
		for (int j = 0; j < 4; ++j)
			EXPECT_NEAR(u[j], want[j], 1e-12) << dir << " wheel " << j;
	}
	EXPECT_THROW(drive_pattern("x", L), std::invalid_argument);
}

// The asymmetric four (60/135/225/300 deg, four distances): each axis's pattern pushes along
// that axis alone (G^T u has no other component), is a least-norm force (in G's column space:
// u = G c, checked by solving the normal equations here) and peaks at 1; the paper's layout
// given by angles keeps the paper's patterns to the bit.
TEST(Experiments, AsymmetricPatternsPushAlongTheirAxisAloneWithLeastNorm)
{
	const double ang[4] = {60, 135, 225, 300}, dist[4] = {0.082, 0.090, 0.095, 0.085};
	const Layout L = make_layout(4, ang, dist, "test");
	const char *dirs[3] = {"v", "vn", "w"};
	for (int axis = 0; axis < 3; ++axis) {
		const std::array<double, 4> u = drive_pattern(dirs[axis], L);
		Eigen::Matrix<double, 4, 3> G;
		for (int j = 0; j < 4; ++j) {
			const double a = ang[j] * M_PI / 180;
			G.row(j) << -std::sin(a), std::cos(a), dist[j];
		}
		const Eigen::Vector4d uv(u[0], u[1], u[2], u[3]);
		const Eigen::Vector3d F = G.transpose() * uv;
		for (int k = 0; k < 3; ++k) {
			if (k != axis) {
				EXPECT_NEAR(F[k] / std::fabs(F[axis]), 0, 1e-12) << dirs[axis];
			}
		}
		EXPECT_GT(F[axis], 0) << dirs[axis];
		const Eigen::Vector3d c = (G.transpose() * G).ldlt().solve(G.transpose() * uv);
		EXPECT_LT((G * c - uv).norm(), 1e-12) << dirs[axis] << ": not least norm";
		EXPECT_NEAR(uv.cwiseAbs().maxCoeff(), 1.0, 1e-15) << dirs[axis];
	}
	const double pa[4] = {0, 90, 180, 270}, pd[4] = {0.089, 0.089, 0.089, 0.089};
	const Layout P = make_layout(4, pa, pd, "test");
	EXPECT_TRUE(P.paper);
	for (const char *dir : dirs)
		EXPECT_EQ(drive_pattern(dir, P), drive_pattern(dir)) << dir;
}

// A three-wheel robot's sequence: the motor test drives motors 0-2 only, every phase holds 0 V
// in slot 3, and each axis run's voltages are its level times the layout's pattern.
TEST(Experiments, AThreeWheelSequenceDrivesThreeMotorsAndTheLayoutsPatterns)
{
	const double ang[4] = {60, 180, 300, 0}, dist[4] = {0.09, 0.1, 0.085, 0};
	SequenceOptions opt;
	opt.layout = make_layout(3, ang, dist, "test");
	std::map<int, int> motor_runs;
	for (const Phase &ph : paper_sequence(opt)) {
		EXPECT_EQ(ph.voltage[3], 0.0);
		if (ph.mark_kind == "motor")
			for (int j = 0; j < 4; ++j)
				motor_runs[j] += ph.voltage[j] != 0;
		if (ph.mark_kind == "step" || ph.mark_kind == "steady_rotation") {
			const std::array<double, 4> u =
			    drive_pattern(ph.mark_direction, opt.layout);
			for (int j = 0; j < 4; ++j)
				EXPECT_EQ(ph.voltage[j], ph.mark_level * u[j]) << ph.mark_kind;
		}
	}
	const int per_motor = static_cast<int>(2 * opt.motor_levels.size());
	EXPECT_EQ(motor_runs,
	          (std::map<int, int>{{0, per_motor}, {1, per_motor}, {2, per_motor}, {3, 0}}));
}

// The runner's motor test (docs/identification.md): each motor alone, the other three at 0 V in
// VOLTAGE mode (bridges driven), at each of the motor levels 4, 8 and 11 V forwards and
// backwards; every run marked "motor" with direction "" and the motor's voltage as level, then
// closed by "end" while the robot coasts to rest.
TEST(Experiments, TheMotorTestDrivesOneMotorAtATimeAtEachLevelBothWays)
{
	const std::vector<Phase> seq = paper_sequence();
	std::map<int, std::vector<double>> driven; // motor -> its runs' voltages [V]
	for (size_t k = 0; k < seq.size(); ++k) {
		const Phase &ph = seq[k];
		if (ph.mark_kind != "motor")
			continue;
		EXPECT_EQ(ph.mode, 2); // command_t::MODE_VOLTAGE
		EXPECT_EQ(ph.mark_direction, "");
		int n = 0, j = -1;
		for (int m = 0; m < 4; ++m)
			if (ph.voltage[m] != 0) {
				++n;
				j = m;
			}
		ASSERT_EQ(n, 1) << "motor run " << k << " drives " << n << " motors";
		EXPECT_EQ(ph.mark_level, ph.voltage[j]);
		driven[j].push_back(ph.voltage[j]);
		ASSERT_LT(k + 1, seq.size());
		EXPECT_TRUE(seq[k + 1].end_mark && seq[k + 1].mode == 3) << k; // MODE_COAST
	}
	ASSERT_EQ(driven.size(), 4u);
	for (auto &[j, u] : driven) {
		std::sort(u.begin(), u.end());
		EXPECT_EQ(u, (std::vector<double>{-11, -8, -4, 4, 8, 11})) << "motor " << j;
	}
}

namespace
{

// Steady force [N] of wheel j driven alone at u [V] with the other three motors shorted (0 V,
// bridges driven), a gripping uniform robot p: eq 21 per wheel (f = k (u_j - e s_j), k = l Kt /
// (r R), e = l Kv / r, s_j the wheel's ground speed) balanced against eq 16-19's friction
// along the wheel's own axis (two wheels, the other pair's back-EMF cancels) and about w (all
// four). Closed form, from the paper's equations alone.
double one_wheel_steady_force(const model_params &p, int j, double u)
{
	const double k = p.l * p.Kt / (p.r * p.R), e = p.l * p.Kv / p.r, a = std::fabs(u);
	const double B = j % 2 ? p.Bv : p.Bvn, C = j % 2 ? p.Cv : p.Cvn;
	const double x = std::max(0.0, (k * a - C) / (2 * k * e + B));
	const double w = std::max(0.0, (p.d * k * a - p.Cw) / (4 * k * e * p.d * p.d + p.Bw));
	return k * (a - e * (x + p.d * w));
}

} // namespace

// On a floor that cannot hold one wheel pushing the robot against the other three's braking
// (mu 0.4: 2.25 N a wheel with the 2 % margin; 11 V alone needs 4.6 N steady), limit_ramps scales
// every one-motor run by one factor (their loads stay apart for eq 22), no more than needed:
// the hardest run's steady force is within 10 % under the limit, none above it.
TEST(Experiments, OneMotorRunsAreScaledTogetherUnderTheFloorsLimit)
{
	const model_params &p = model_params_table3;
	const std::vector<Phase> full = paper_sequence();
	std::vector<Phase> seq = full;
	const double hold_n = traction_hold_n(p, 0.4, 0.02);
	limit_ramps(seq, p, hold_n);
	ASSERT_EQ(seq.size(), full.size());
	double factor = -1, hardest = 0;
	for (size_t k = 0; k < seq.size(); ++k) {
		if (seq[k].mark_kind != "motor")
			continue;
		for (int j = 0; j < 4; ++j) {
			if (full[k].voltage[j] == 0) {
				EXPECT_EQ(seq[k].voltage[j], 0);
				continue;
			}
			const double s = seq[k].voltage[j] / full[k].voltage[j];
			if (factor < 0)
				factor = s;
			EXPECT_NEAR(s, factor, 1e-12) << "run " << k;
			EXPECT_NEAR(seq[k].mark_level, seq[k].voltage[j], 1e-12);
			const double f = one_wheel_steady_force(p, j, seq[k].voltage[j]);
			EXPECT_LE(f, hold_n) << "run " << k << " motor " << j;
			hardest = std::max(hardest, f);
		}
	}
	std::printf("one-motor runs scaled by %.4f: hardest steady force %.3f N, limit %.3f N\n",
	            factor, hardest, hold_n);
	EXPECT_GT(factor, 0);
	EXPECT_LT(factor, 1);
	EXPECT_GE(hardest, 0.9 * hold_n);
	// Where the floor holds them (mu 1.0 with the 2 % margin: 5.6 N) nothing is scaled.
	std::vector<Phase> firm = full;
	limit_ramps(firm, p, traction_hold_n(p, 1.0, 0.02));
	for (size_t k = 0; k < firm.size(); ++k) {
		if (firm[k].mark_kind == "motor") {
			EXPECT_EQ(firm[k].voltage, full[k].voltage) << "run " << k;
		}
	}
}

TEST(SavitzkyGolay, ExactOnQuadratics)
{
	const SgFilter f = savitzky_golay(6, 2);
	std::vector<double> y;
	for (int k = -6; k <= 6; ++k)
		y.push_back(3.0 + 2.0 * k - 0.5 * k * k);
	double s = 0, d = 0;
	for (int k = 0; k < 13; ++k) {
		s += f.smooth[k] * y[k];
		d += f.deriv[k] * y[k];
	}
	EXPECT_NEAR(s, 3.0, 1e-12); // value at the centre
	EXPECT_NEAR(d, 2.0, 1e-12); // slope at the centre
}

TEST(Regression, LeastSquaresRecoversExactParametersAndRefusesSingular)
{
	Eigen::MatrixXd X(50, 2);
	Eigen::VectorXd y(50);
	for (int k = 0; k < 50; ++k) {
		X(k, 0) = k * 0.1;
		X(k, 1) = 1.0;
		y[k] = 0.7 * X(k, 0) - 1.3;
	}
	const Fit f = least_squares(X, y, 1, "line");
	EXPECT_NEAR(f.theta[0], 0.7, 1e-12);
	EXPECT_NEAR(f.theta[1], -1.3, 1e-12);
	X.col(1) = X.col(0) * 2.0;
	EXPECT_THROW(least_squares(X, y, 1, "collinear"), IdentError);
}

TEST(Regression, InstrumentalVariablesRemoveErrorsInVariablesBias)
{
	// y = 2 x_true; the regressor is measured with noise, the instrument is noise-free.
	std::mt19937 g(1);
	std::normal_distribution<double> n(0, 0.5);
	const int N = 20000;
	Eigen::MatrixXd X(N, 1), Z(N, 1);
	Eigen::VectorXd y(N);
	for (int k = 0; k < N; ++k) {
		const double xt = std::sin(k * 0.01);
		X(k, 0) = xt + n(g);
		Z(k, 0) = xt;
		y[k] = 2 * xt;
	}
	const double ls = least_squares(X, y, 1, "ls").theta[0];
	const double iv = instrumental_variables(Z, X, y, 1, "iv").theta[0];
	EXPECT_LT(ls, 1.5); // attenuated towards zero
	EXPECT_NEAR(iv, 2.0, 0.03);
}

TEST(Regression, AgreeingMethodsAreWeightedByInverseVariance)
{
	IdentOptions opt;
	opt.method_floor = 0;
	opt.max_rel_se = 1; // keep both (the 20 % one is "too uncertain" by default)
	Agreement ag;
	const Estimate e = combine_methods({{1.0, 0.1}, {1.2, 0.2}, {}}, opt, &ag);
	EXPECT_NEAR(e.value, (1.0 / 0.01 + 1.2 / 0.04) / (1 / 0.01 + 1 / 0.04), 1e-12);
	EXPECT_NEAR(e.se, std::sqrt(1 / (1 / 0.01 + 1 / 0.04)), 1e-12);
	EXPECT_EQ(ag.methods, 2);
	EXPECT_EQ(ag.dof, 1);
	// chi2 about the weighted mean 1.04: (0.04/0.1)^2 + (0.16/0.2)^2 = 0.8
	EXPECT_NEAR(ag.chi2, 0.8, 1e-12);
	EXPECT_NEAR(ag.p, 0.37109336952269756, 1e-12); // chi-square(1) tail at 0.8
	EXPECT_TRUE(ag.agree);
}

TEST(Regression, DisagreeingMethodsKeepTheBetterDeterminedOneWithItsSeScaled)
{
	// A camera coast-down's Cv 14 % off (3.6 SE) beside experiment 3's (0.14 % off): a mean of
	// the two would carry half the coast-down's bias. Two estimates: chi2 about the weighted
	// mean is (a - b)^2 / (sa^2 + sb^2); each SE is first raised to 0.5 % of its value.
	const double a = 1.14, b = 1.0014;
	const double sa = std::hypot(0.039, 0.005 * a), sb = std::hypot(0.002, 0.005 * b);
	const double chi2 = (a - b) * (a - b) / (sa * sa + sb * sb);
	Agreement ag;
	const Estimate e = combine_methods({{a, 0.039}, {b, 0.002, 0.001}}, IdentOptions{}, &ag);
	EXPECT_FALSE(ag.agree);
	EXPECT_NEAR(ag.chi2, chi2, 1e-12);
	EXPECT_NEAR(ag.p, std::erfc(std::sqrt(chi2 / 2)), 1e-12); // chi-square(1) tail
	EXPECT_EQ(ag.kept, 1);
	EXPECT_EQ(e.value, b);
	EXPECT_NEAR(e.se, sb * std::sqrt(chi2), 1e-15); // Birge ratio sqrt(chi2 / 1)
	EXPECT_NEAR(ag.birge, std::sqrt(chi2), 1e-12);
	EXPECT_EQ(e.se_borrowed, 0.001);
	// The order does not matter; a third estimate that is not ok() is skipped, not counted.
	const Estimate f =
	    combine_methods({{}, {b, 0.002, 0.001}, {a, 0.039}}, IdentOptions{}, &ag);
	EXPECT_EQ(f.value, b);
	EXPECT_EQ(ag.kept, 1);
}

TEST(Regression, AnEstimateWithASeAboveTenPercentIsShownButNotCombined)
{
	// A camera coast-down's Bv of 1.18 +- 0.21 (18 %) beside experiment 3's 0.506 +- 0.015.
	Agreement ag;
	const Estimate e = combine_methods({{1.184, 0.21}, {0.506, 0.015}}, IdentOptions{}, &ag);
	EXPECT_EQ(e.value, 0.506);
	EXPECT_EQ(ag.methods, 1);
	EXPECT_EQ(ag.too_uncertain, 1);
	// All too uncertain: the least uncertain one.
	const Estimate f = combine_methods({{1.0, 0.5}, {2.0, 0.4}}, IdentOptions{}, &ag);
	EXPECT_EQ(f.value, 2.0);
}

TEST(Regression, ChiSquareTailMatchesTables)
{
	// Upper 5 % and 1 % points of the chi-square distribution (any statistics table).
	EXPECT_NEAR(chi2_sf(3.841458820694124, 1), 0.05, 1e-9);
	EXPECT_NEAR(chi2_sf(5.991464547107979, 2), 0.05, 1e-9);
	EXPECT_NEAR(chi2_sf(11.344866730144373, 3), 0.01, 1e-9);
	EXPECT_NEAR(chi2_sf(13.276704135987622, 4), 0.01, 1e-9);
	EXPECT_EQ(chi2_sf(0, 3), 1.0);
}

struct Robot {
	const char *name;
	model_params p;
};

double truth_of(const model_params &p, const std::string &name)
{
	for (int i = 0; i < MODEL_PARAMS_COUNT; ++i)
		if (name == model_params_names[i])
			return model_params_get(&p, i);
	ADD_FAILURE() << "no parameter " << name;
	return NAN;
}

// Relative error bound of every parameter each method gives on the project's simulated runs.
const std::map<std::string, std::map<std::string, double>> &method_bounds()
{
	// Worst measured |error| over the 5 robots below, in %: motor Kv 0.05 R 0.23; exp1 Bw 0.51
	// Cw 0.38; exp2 Bv Bvn Cv Cvn 0.01 J 0.22; exp3 (LS and IV) Bv 0.71 Bvn 0.72 Bw 0.45 Cv
	// 0.09 Cvn 0.09 Cw 0.13 J 0.04 R 0.11. Bounds at 2.5x, at least 0.05 %.
	static const std::map<std::string, double> exp3 = {
	    {"R", 0.003},    {"Bv", 0.018}, {"Cv", 0.0025}, {"Bvn", 0.018},
	    {"Cvn", 0.0025}, {"J", 0.001},  {"Bw", 0.012},  {"Cw", 0.0035}};
	static const std::map<std::string, std::map<std::string, double>> b = {
	    {"motor", {{"Kv", 0.0013}, {"R", 0.006}}},
	    {"exp1", {{"Bw", 0.013}, {"Cw", 0.01}}},
	    {"exp2",
	     {{"Bv", 0.0005}, {"Cv", 0.0005}, {"Bvn", 0.0005}, {"Cvn", 0.0005}, {"J", 0.0055}}},
	    {"exp3_ls", exp3},
	    {"exp3_iv", exp3},
	};
	return b;
}

// Runs the experiment sequence on robot p (paper-grade noise), identifies, validates.
void identify_robot(const model_params &p, unsigned seed, double bound)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.ctl.model = p;
	cfg.sim.seed = static_cast<int>(seed);
	const std::string log = temp_path(".lcmlog");
	run_simulation(cfg, p, true, log, true, 0, 0);
	const LogData d = read_log(log);
	std::remove(log.c_str());
	const auto segs = split_segments(d);
	const IdentResult r = identify(segs, base_of(p));
	std::string line;
	double worst = 0;
	for (const char *name : kIdentParams) {
		const double e = rel(r.table.at("final").at(name).value, truth_of(p, name));
		worst = std::max(worst, std::abs(e));
		char buf[48];
		std::snprintf(buf, sizeof(buf), " %s %+.2f%%", name, 100 * e);
		line += buf;
		EXPECT_LT(std::abs(e), bound) << name;
	}
	// Each method alone, against its own bound (method_bounds): a bug
	// in one method (a one-tick input shift, a narrower filter) hides in the combined value.
	for (const auto &[method, bounds] : method_bounds()) {
		std::string mline;
		for (const auto &[name, b] : bounds) {
			const auto m = r.table.find(method);
			ASSERT_TRUE(m != r.table.end() && m->second.count(name))
			    << method << " " << name;
			const double e = rel(m->second.at(name).value, truth_of(p, name));
			char buf[48];
			std::snprintf(buf, sizeof(buf), " %s %+.2f%%", name.c_str(), 100 * e);
			mline += buf;
			EXPECT_LT(std::abs(e), b) << method << " " << name;
		}
		std::printf("  %-8s%s\n", method.c_str(), mline.c_str());
	}
	const Validation v = validate(segs, r.final);
	std::printf("  errors:%s | worst %.2f%% | validation e_max v %.4f vn %.4f w %.4f, sigma "
	            "v %.4f vn %.4f w %.4f\n",
	            line.c_str(), 100 * worst, v.axis[0].e_max, v.axis[1].e_max, v.axis[2].e_max,
	            v.axis[0].sigma, v.axis[1].sigma, v.axis[2].sigma);
	// No worse than the paper's Table IV (final).
	EXPECT_LT(v.axis[0].e_max, 0.061);
	EXPECT_LT(v.axis[1].e_max, 0.068);
	EXPECT_LT(v.axis[2].e_max, 2.504);
	EXPECT_LT(v.axis[0].sigma, 0.024);
	EXPECT_LT(v.axis[1].sigma, 0.026);
	EXPECT_LT(v.axis[2].sigma, 0.732);
}

namespace
{

// Rows of experiment 3 along one axis from a first-order plant solved exactly per 1 ms tick
// (zero-order hold: x_{k+1} = x_ss + (x_k - x_ss) e^(theta1 dt)), measured with white noise of
// sigma [m/s], filtered like the logs (Savitzky-Golay, +-20 samples). The input ramps at 50 V/s
// to a new level in 4-10 V every 0.5 s, so the robot never stops (sign(x) = +1).
StateSpaceData first_order_rows(const Eigen::Vector3d &theta, double sigma, int runs, int seed)
{
	const double dt = 1e-3;
	const int h = 20, n = 4000;
	const SgFilter f = savitzky_golay(h, 2);
	std::mt19937 gen(static_cast<unsigned>(seed));
	std::normal_distribution<double> noise(0.0, sigma);
	std::uniform_real_distribution<double> level(4.0, 10.0);
	std::vector<std::array<double, 4>> rows; // x, input, sign, y
	StateSpaceData d;
	d.half = h;
	for (int r = 0; r < runs; ++r) {
		std::vector<double> x(n + 1), u(n), xm(n + 1);
		double target = 0;
		x[0] = 0.5;
		for (int k = 0; k < n; ++k) {
			if (k % 500 == 0)
				target = level(gen);
			u[k] = k == 0 ? target
			              : u[k - 1] +
			                    std::clamp(target - u[k - 1], -0.05, 0.05); // 50 V/s
			const double xss = -(theta[1] * u[k] + theta[2]) / theta[0];
			x[k + 1] = xss + (x[k] - xss) * std::exp(theta[0] * dt);
		}
		for (int k = 0; k <= n; ++k)
			xm[k] = x[k] + noise(gen);
		d.start.push_back(rows.size());
		for (int q = h + 1; q + h < n; ++q) {
			double xs = 0, dx = 0, in = 0;
			for (int j = -h; j <= h; ++j) {
				xs += f.smooth[j + h] * xm[q + j];
				dx += f.deriv[j + h] * xm[q + j] / dt;
				in += f.smooth[j + h] * 0.5 *
				      (u[q + j - 1] + u[q + j]); // input at the tick boundary
			}
			rows.push_back({xs, in, 1.0, dx});
			d.t.push_back((r * (n + 1000) + q) * dt);
		}
	}
	d.X.resize(static_cast<Eigen::Index>(rows.size()), 3);
	d.y.resize(static_cast<Eigen::Index>(rows.size()));
	for (size_t r = 0; r < rows.size(); ++r) {
		d.X.row(static_cast<Eigen::Index>(r)) << rows[r][0], rows[r][1], rows[r][2];
		d.y[static_cast<Eigen::Index>(r)] = rows[r][3];
	}
	return d;
}

} // namespace

TEST(StateSpace, InstrumentalVariablesAreUnbiasedWhereLeastSquaresIsNot)
{
	// Along v of the Table III robot: theta1 = -(Bv + l^2 Kt Kv / (r^2 R)) / M (eq 26, about
	// -3.67 /s), theta2 = l Kt / (r R M) [m/s^2/V], theta3 = -Cv / M [m/s^2].
	const model_params &p = model_params_table3;
	const double l = p.l, r = p.r;
	const Eigen::Vector3d theta(-(p.Bv + l * l * p.Kt * p.Kv / (r * r * p.R)) / p.M,
	                            l * p.Kt / (r * p.R * p.M), -p.Cv / p.M);
	auto worst = [&](const Fit &f) {
		double e = 0;
		for (int k = 0; k < 3; ++k)
			e = std::max(e, std::abs(f.theta[k] / theta[k] - 1));
		return e;
	};
	// Without noise both recover the plant to the filter's approximation.
	const StateSpaceFits clean = fit_state_space(first_order_rows(theta, 0.0, 4, 1), "clean");
	std::printf("noise-free: worst relative error LS %.2e, IV %.2e (theta %+.4f %+.4f %+.4f)\n",
	            worst(clean.ls), worst(clean.iv), clean.ls.theta[0] / theta[0] - 1,
	            clean.ls.theta[1] / theta[1] - 1, clean.ls.theta[2] / theta[2] - 1);
	EXPECT_LT(worst(clean.ls), 1e-2); // measured 5.1e-3: the quadratic filter on exponentials
	EXPECT_LT(worst(clean.iv), 1e-2);
	// With 0.2 m/s white measurement noise (after the filter ~0.04 m/s against speeds of
	// 0.5-2 m/s) LS is attenuated; IV, whose instruments are free of the noise, is not. One
	// record is noisy (per-record sd of theta1: LS 2.1 %, IV 2.6 %), so the bias is the mean
	// over 16.
	const int records = 16;
	std::array<double, 3> ls_mean{}, iv_mean{};
	for (int seed = 1; seed <= records; ++seed) {
		const StateSpaceFits f =
		    fit_state_space(first_order_rows(theta, 0.2, 8, seed), "noisy");
		for (int k = 0; k < 3; ++k) {
			ls_mean[k] += 100 * (f.ls.theta[k] / theta[k] - 1) / records;
			iv_mean[k] += 100 * (f.iv.theta[k] / theta[k] - 1) / records;
		}
	}
	std::printf(
	    "mean error over %d records: theta1 LS %+.2f %%, IV %+.2f %%; theta2 LS %+.2f %%, "
	    "IV %+.2f %%; theta3 LS %+.2f %%, IV %+.2f %%\n",
	    records, ls_mean[0], iv_mean[0], ls_mean[1], iv_mean[1], ls_mean[2], iv_mean[2]);
	// Measured: theta1 LS -5.5, IV -0.2; theta3 LS +5.8, IV -0.2 (standard errors of a mean of
	// 16: 0.5-0.7 % for theta1, 1.2-1.3 % for theta3). Bounds at ~3 standard errors.
	EXPECT_LT(ls_mean[0], -3.0);
	EXPECT_LT(std::abs(iv_mean[0]), 2.0);
	EXPECT_GT(ls_mean[2], 2.0);
	EXPECT_LT(std::abs(iv_mean[2]), 3.5);
}

TEST(Identification, Table3RobotWithinOnePercent)
{
	std::printf("Table III robot:\n");
	identify_robot(model_params_table3, 1, 0.01); // measured worst 0.29 %
}

TEST(Identification, PerturbedRobotsWithinOnePercent)
{
	std::mt19937 g(2024);
	std::uniform_real_distribution<double> s(0.7, 1.3);
	for (int k = 0; k < 4; ++k) {
		model_params p = model_params_table3;
		for (double *f : {&p.J, &p.Bv, &p.Bvn, &p.Bw, &p.Cv, &p.Cvn, &p.Cw, &p.R})
			*f *= s(g);
		p.Kv *= s(g);
		p.Kt = p.Kv;
		std::printf(
		    "perturbed robot %d: R %.3f Kv %.4f J %.4f Bv %.3f Bvn %.3f Bw %.4f Cv %.3f "
		    "Cvn %.3f Cw %.4f\n",
		    k, p.R, p.Kv, p.J, p.Bv, p.Bvn, p.Bw, p.Cv, p.Cvn, p.Cw);
		identify_robot(p, 100 + k, 0.01); // measured worst 0.29 %
	}
}

LogData simulated_log(unsigned seed)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.sim.seed = static_cast<int>(seed);
	const std::string log = temp_path(".lcmlog");
	run_simulation(cfg, cfg.ctl.model, true, log, true, 0, 0);
	LogData d = read_log(log);
	std::remove(log.c_str());
	return d;
}

TEST(Bootstrap, SameSeedSameResultAndUnidentifiableReplicatesAreCounted)
{
	const LogData d = simulated_log(1);
	const auto segs = split_segments(d);
	const model_params base = base_of(model_params_table3);
	const BootstrapResult a = bootstrap_runs(segs, base, {}, 24, 7);
	const BootstrapResult b = bootstrap_runs(segs, base, {}, 24, 7);
	const BootstrapResult c = bootstrap_runs(segs, base, {}, 24, 8);
	ASSERT_EQ(a.final.size(), 9u);
	EXPECT_EQ(a.failed, 0);
	int differs = 0;
	for (const char *p : kIdentParams) {
		EXPECT_EQ(a.final.at(p).se, b.final.at(p).se) << p; // independent of thread timing
		EXPECT_EQ(a.samples.at(p), b.samples.at(p)) << p;
		EXPECT_LE(a.final.at(p).lo95, a.final.at(p).hi95) << p;
		differs += a.final.at(p).se != c.final.at(p).se;
	}
	EXPECT_GT(differs, 0); // the seed is used
	// Without the motor test (Kt for experiments 1 and 3) and coast-downs nothing can be
	// identified: every replicate is skipped and counted.
	std::vector<Segment> none;
	for (const Segment &s : segs)
		if (s.kind != "coast" && s.kind != "motor")
			none.push_back(s);
	const BootstrapResult e = bootstrap_runs(none, base, {}, 6, 7);
	EXPECT_EQ(e.failed, 6);
	EXPECT_TRUE(e.final.empty());
}

// Kv and R (motor runs, noisy currents) and Bw, Cw (steady rotation, torque from the noisy
// currents) vary with the simulation's sensor noise: for them the bootstrap over the runs of
// one log must match the spread over independent logs (other noise seeds) within a factor of
// 3. The others come from encoder speeds and commanded voltages, which the noise does not
// touch (quantisation is deterministic): their spread over seeds is ~0, and their bootstrap SE
// shows how much the runs of one log disagree instead. They are printed, not asserted.
TEST(Bootstrap, RunResamplingMatchesTheSpreadOverIndependentLogs)
{
	const model_params base = base_of(model_params_table3);
	const LogData d = simulated_log(1);
	const IdentResult r = identify(split_segments(d), base);
	const BootstrapResult boot = bootstrap_runs(split_segments(d), base, {}, 100, 3);
	std::map<std::string, std::vector<double>> over_seeds;
	for (unsigned seed = 11; seed < 19; ++seed) {
		const LogData di = simulated_log(seed);
		const IdentResult ri = identify(split_segments(di), base);
		for (const char *p : kIdentParams)
			over_seeds[p].push_back(ri.table.at("final").at(p).value);
	}
	for (const char *p : kIdentParams) {
		const auto &x = over_seeds[p];
		double mean = 0, ss = 0;
		for (double v : x)
			mean += v / static_cast<double>(x.size());
		for (double v : x)
			ss += (v - mean) * (v - mean);
		const double sd = std::sqrt(ss / static_cast<double>(x.size() - 1));
		const double se = boot.final.at(p).se;
		std::printf(
		    "  %-4s SE analytic %.2g, bootstrap %.2g; sd over 8 independent logs %.2g\n", p,
		    r.table.at("final").at(p).se, se, sd);
		const std::string name = p;
		if (name == "Kv" || name == "R" || name == "Bw" || name == "Cw") {
			EXPECT_GT(se, sd / 3) << p;
			EXPECT_LT(se, sd * 3) << p;
		}
	}
}

TEST(BadInput, TruncatedLogIsReadUpToTheCutAndTheMissingKindIsNamed)
{
	omni4_config cfg;
	config_defaults(&cfg);
	const std::string log = temp_path(".lcmlog");
	run_simulation(cfg, cfg.ctl.model, true, log, true, 0, 0);
	const LogData full = read_log(log);
	// Cut in the middle of an event, at 60 %.
	const long cut = static_cast<long>(full.bytes_total * 0.6) + 7;
	ASSERT_EQ(truncate(log.c_str(), cut), 0);
	const LogData part = read_log(log);
	EXPECT_GT(part.bytes_skipped, 0u);
	EXPECT_LT(part.bytes_skipped, 200u);
	EXPECT_GT(part.motors.size(), full.motors.size() / 2);
	EXPECT_LT(part.motors.size(), full.motors.size());
	// The cut log has no step runs: experiment 3 is missing and named, the rest is identified.
	const IdentResult r = identify(split_segments(part), base_of(cfg.ctl.model));
	EXPECT_TRUE(r.table.count("exp3_iv") == 0 || r.table.at("exp3_iv").empty());
	bool named = false;
	for (const std::string &m : r.missing)
		named |= m.find("no 'step' segments") != std::string::npos;
	EXPECT_TRUE(named);
	EXPECT_TRUE(r.complete()); // motor test and experiments 1, 2 give all nine
	std::remove(log.c_str());
}

TEST(BadInput, CorruptBytesInTheMiddleAreSkippedAndTheRestIsRead)
{
	omni4_config cfg;
	config_defaults(&cfg);
	const std::string log = temp_path(".lcmlog");
	run_simulation(cfg, cfg.ctl.model, false, log, false, 5.0, 0);
	const LogData full = read_log(log);
	{
		// The junk starts on the first event header after the middle of the file, so that
		// it always hits a header (junk inside an event's data would decode as garbage
		// values).
		std::fstream f(log, std::ios::in | std::ios::out | std::ios::binary);
		std::vector<char> bytes(full.bytes_total);
		f.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
		const char sync[4] = {'\xED', '\xA1', '\xDA', '\x01'};
		const auto at =
		    std::search(bytes.begin() + static_cast<std::ptrdiff_t>(bytes.size() / 2),
		                bytes.end(), sync, sync + 4);
		ASSERT_NE(at, bytes.end());
		f.clear();
		f.seekp(at - bytes.begin());
		const char junk[64] = {0x55};
		f.write(junk, sizeof(junk));
	}
	const LogData part = read_log(log);
	std::printf(
	    "corrupt middle: %zu of %zu motors samples read, %llu lost (seq gaps), %llu bytes "
	    "skipped\n",
	    part.motors.size(), full.motors.size(), (unsigned long long)part.seq_gaps,
	    (unsigned long long)part.bytes_skipped);
	// Only the events the junk overwrote are lost; reading resumes at the next sync word.
	EXPECT_GE(part.motors.size(), full.motors.size() - 5);
	EXPECT_LT(part.motors.size(), full.motors.size());
	EXPECT_EQ(part.seq_gaps, full.motors.size() - part.motors.size());
	EXPECT_GT(part.bytes_skipped, 0u);
	std::remove(log.c_str());
}

TEST(BadInput, ImpossibleTimesCountsAndValuesAreDroppedAndCounted)
{
	// A log whose messages decode but hold what no clock, counter or sensor gives: utime and
	// seq at the int64 limits, NaN and infinite floats. Differences of such times overflow
	// int64.
	const std::string path = temp_path(".lcmlog");
	omni4_test::EventLogWriter log(path);
	ASSERT_TRUE(log.ok());
	auto put = [&](const char *channel, const auto &msg) {
		ASSERT_TRUE(log.put(channel, msg));
	};
	omni4::experiment_t mark{};
	mark.utime = 1000000;
	mark.kind = "step";
	mark.direction = "v";
	mark.level = 6;
	put("OMNI4_EXPERIMENT", mark);
	int good = 0;
	for (int64_t k = 0; k < 300; ++k) {
		omni4::motors_t m{};
		m.utime = 1000000 + 1000 * k;
		m.seq = k;
		m.mode = 2;
		for (int j = 0; j < 4; ++j)
			m.voltage[j] = 6.0f;
		if (k == 10)
			m.utime = INT64_MAX;
		if (k == 11)
			m.utime = INT64_MIN;
		if (k == 12)
			m.seq = INT64_MAX;
		if (k == 13)
			m.seq = -5;
		if (k == 14)
			m.voltage[2] = NAN;
		if (k == 15)
			m.current[1] = INFINITY;
		if (k == 16)
			m.wheel_speed[0] = -INFINITY;
		good += k < 10 || k > 16;
		put("OMNI4_MOTORS", m);
	}
	omni4::pose_t q{};
	q.utime = INT64_MIN;
	put("OMNI4_POSE", q);
	q.utime = 1100000;
	q.theta = NAN;
	put("OMNI4_POSE", q);
	mark.utime = INT64_MAX;
	mark.kind = "end";
	put("OMNI4_EXPERIMENT", mark);
	mark.utime = 1200000;
	mark.level = INFINITY;
	put("OMNI4_EXPERIMENT", mark);
	log.close();

	const LogData d = read_log(path);
	EXPECT_EQ(d.implausible, 11u);
	EXPECT_EQ(d.undecodable, 0u);
	EXPECT_EQ(d.motors.size(), static_cast<size_t>(good));
	EXPECT_EQ(d.seq_gaps, 7u);
	EXPECT_TRUE(d.pose.empty());
	ASSERT_EQ(d.marks.size(), 1u);
	// What is left identifies nothing (one short step) and says so; nothing overflows (the
	// sanitizer builds run this test with -fno-sanitize-recover).
	const auto segs = split_segments(d);
	EXPECT_THROW(identify(segs, model_params_table3), IdentError);
	std::remove(path.c_str());
}

TEST(BadInput, NotAnEventLogIsAClearError)
{
	const std::string path = temp_path(".txt");
	std::ofstream(path) << "hello, not a log\n";
	EXPECT_THROW(read_log(path), std::runtime_error);
	EXPECT_THROW(read_log("/nonexistent/omni4.lcmlog"), std::runtime_error);
	std::remove(path.c_str());
}

// ---- windows found in the data -------------------------------------------------------------
// Synthetic segments built from closed forms (not from the window finder's code): 1 kHz samples
// of a robot moving along v only, wheel speeds from eq 2 (v_1 = -v, v_3 = v, wheel = v / r).

namespace
{

constexpr double kR = 0.0325, kD = 0.089;

MotorsSample sample_at(int64_t k, int8_t mode, double u_v, double v)
{
	MotorsSample s;
	s.utime = 1000000 + k * 1000;
	s.seq = k;
	s.mode = mode;
	const float u = static_cast<float>(u_v), w = static_cast<float>(v / kR);
	s.u = {0, -u, 0, u}; // motors_t carries floats
	s.w = {0, -w, 0, w};
	return s;
}

Segment whole(const LogData &log)
{
	Segment s;
	s.kind = "step";
	s.direction = "v";
	s.log = &log;
	s.m0 = 0;
	s.m1 = log.motors.size();
	s.t0 = log.motors.front().utime;
	s.t1 = log.motors.back().utime + 1;
	return s;
}

} // namespace

TEST(Windows, SteadyWindowHoldsNeitherRampNorTransientNorRampDown)
{
	// Rest in IDLE 1 s, ramp 0 -> 6 V in 0.5 s, hold 3 s, ramp down in 0.3 s, rest 1 s. Along
	// the hold the speed approaches x_ss = 1 m/s with tau = 0.3 s from 0.2 m/s.
	const double tau = 0.3, xss = 1.0, x0 = 0.2;
	LogData log;
	int64_t k = 0;
	for (; k < 1000; ++k)
		log.motors.push_back(sample_at(k, 0, 0, 0));
	for (int q = 0; q < 500; ++q, ++k)
		log.motors.push_back(sample_at(k, 2, 6.0 * q / 500, x0 * q / 500));
	for (int q = 0; q < 3000; ++q, ++k)
		log.motors.push_back(
		    sample_at(k, 2, 6.0, xss - (xss - x0) * std::exp(-q * 1e-3 / tau)));
	for (int q = 0; q < 300; ++q, ++k)
		log.motors.push_back(sample_at(k, 2, 6.0 * (1 - q / 300.0), xss * (1 - q / 300.0)));
	for (int q = 0; q < 1000; ++q, ++k)
		log.motors.push_back(sample_at(k, 0, 0, 0));
	Segment s = whole(log);
	s.kind = "motor";
	const WindowOptions opt;
	const SegmentWindows w = find_windows(s, encoder_track(log, kD, kR), opt);
	ASSERT_EQ(w.steady.size(), 1u);
	// Settled when |x - xss| <= 0.3 % xss + 2 mm/s: (xss - x0) e^(-t/tau) = 0.005.
	const double t_settle = 1.5 + tau * std::log((xss - x0) / 0.005);
	const double t_start = seg_time(s, w.steady[0].m0), t_end = seg_time(s, w.steady[0].m1 - 1);
	std::printf("steady window %.3f-%.3f s (settled at %.3f s, hold ends at 4.499 s)\n",
	            t_start, t_end, t_settle);
	EXPECT_GE(t_start, t_settle - 0.05); // one 50 ms block of resolution
	EXPECT_LE(t_start, t_settle + 0.05);
	// The ramp-down starts at 4.5 s, 20 V/s: its samples within the 0.05 V band (0.02 V + 0.5 %
	// of 6 V) of the hold may stay in, no later one.
	EXPECT_GE(t_end, 4.499 - 1e-9);
	EXPECT_LE(t_end, 4.5 + 0.05 / 20 + 1e-9);
	// A hold too short to settle is rejected with its reason.
	LogData shortlog;
	for (int q = 0; q < 600; ++q)
		shortlog.motors.push_back(
		    sample_at(q, 2, 6.0, xss - (xss - x0) * std::exp(-q * 1e-3 / tau)));
	Segment s2 = whole(shortlog);
	s2.kind = "motor";
	const SegmentWindows w2 = find_windows(s2, encoder_track(shortlog, kD, kR), opt);
	EXPECT_TRUE(w2.steady.empty());
	ASSERT_EQ(w2.rejected.size(), 1u);
	EXPECT_NE(w2.rejected[0].reason.find("not settled"), std::string::npos)
	    << w2.rejected[0].reason;
}

TEST(Windows, NoisySpeedsStillGiveASteadyWindowThatHoldsNoTransient)
{
	// The hold of the test above with correlated speed noise on every wheel (AR(1), 0.3 rad/s,
	// 20 ms: about 1 % of the wheel speed, the level of a coarse encoder's speed estimate). The
	// fixed 0.3 % + 2 mm/s band alone is narrower than the noise of a 50 ms block mean.
	const double tau = 0.3, xss = 1.0, x0 = 0.2, sigma = 0.3, corr = 0.02;
	std::mt19937 gen(11);
	std::normal_distribution<double> normal(0.0, 1.0);
	const double a = std::exp(-1e-3 / corr), b = sigma * std::sqrt(1 - a * a);
	std::array<double, 4> n{};
	LogData log;
	for (int q = 0; q < 3000; ++q) {
		MotorsSample s = sample_at(q, 2, 6.0, xss - (xss - x0) * std::exp(-q * 1e-3 / tau));
		for (int j = 0; j < 4; ++j) {
			n[j] = a * n[j] + b * normal(gen);
			s.w[j] += n[j];
		}
		log.motors.push_back(s);
	}
	Segment s = whole(log);
	s.kind = "motor";
	const SegmentWindows w = find_windows(s, encoder_track(log, kD, kR), WindowOptions{});
	ASSERT_EQ(w.steady.size(), 1u) << (w.rejected.empty() ? "" : w.rejected[0].reason);
	const double t_start = seg_time(s, w.steady[0].m0);
	// The band grows by 3 standard deviations of a block mean's noise: along v that is 0.3
	// rad/s x r / sqrt(2) = 6.9 mm/s per sample, ~6.2 mm/s per 50 ms block (tau_n = 20 ms), so
	// a transient up to 0.3 % + 2 + 3 x 6.2 = 24 mm/s may be left at the start...
	const double t_band = tau * std::log((xss - x0) / 0.025);
	// ... and the true mean speed over the window stays within 0.5 % of the final value.
	const double t_end = seg_time(s, w.steady[0].m1 - 1);
	const double mean = xss - (xss - x0) * tau *
	                              (std::exp(-t_start / tau) - std::exp(-t_end / tau)) /
	                              (t_end - t_start);
	std::printf(
	    "noisy hold: steady window %.3f-%.3f s (transient < 25 mm/s after %.3f s), true "
	    "mean %.4f of the final speed\n",
	    t_start, t_end, t_band, mean / xss);
	EXPECT_GE(t_start, t_band);
	EXPECT_GT(mean / xss, 0.994); // measured 0.9968
	EXPECT_LE(t_start, 3.0 - 0.4);
}

TEST(Windows, HandPushCoastDownStartsAfterThePeakAndEndsAtTheStop)
{
	// Bridges off throughout: rest 1 s, a push raises v linearly to 1 m/s in 0.3 s, then free
	// deceleration v(t) = (v0 + C/B) e^(-B t / M) - C/B (eq 17), then rest.
	const double M = 2.34, B = 0.5, C = 1.87, v0 = 1.0;
	const double t_stop = M / B * std::log(1 + B * v0 / C);
	LogData log;
	int64_t k = 0;
	for (; k < 1000; ++k)
		log.motors.push_back(sample_at(k, 3, 0, 0));
	for (int q = 0; q < 300; ++q, ++k)
		log.motors.push_back(sample_at(k, 3, 0, v0 * q / 300.0));
	for (int q = 0; q * 1e-3 < t_stop; ++q, ++k) {
		const double t = q * 1e-3;
		log.motors.push_back(
		    sample_at(k, 3, 0, (v0 + C / B) * std::exp(-B * t / M) - C / B));
	}
	for (int q = 0; q < 1000; ++q, ++k)
		log.motors.push_back(sample_at(k, 3, 0, 0));
	Segment s = whole(log);
	s.kind = "coast";
	const SegmentWindows w = find_windows(s, encoder_track(log, kD, kR), WindowOptions{});
	ASSERT_EQ(w.coast.size(), 1u);
	EXPECT_TRUE(w.rejected.empty());
	const double t_start = seg_time(s, w.coast[0].m0), t_end = seg_time(s, w.coast[0].m1 - 1);
	// Starts 50 ms after the peak (1.3 s) at the earliest, once 3 % below it: v(t) = 0.97 v0.
	const double t97 = 1.3 + M / B * std::log((v0 + C / B) / (0.97 * v0 + C / B));
	// Ends at the stop speed 0.05 m/s.
	const double t05 = 1.3 + M / B * std::log((v0 + C / B) / (0.05 + C / B));
	std::printf("coast-down window %.3f-%.3f s (expected %.3f-%.3f s)\n", t_start, t_end,
	            std::max(t97, 1.35), t05);
	EXPECT_NEAR(t_start, std::max(t97, 1.35),
	            0.01); // measured 5 ms: the SG filter rounds the peak
	EXPECT_NEAR(t_end, t05, 0.005);
	EXPECT_GT(w.coast[0].sign, 0);
}

TEST(Windows, AStepSegmentAlongAnUnknownDirectionIsRejectedWithItsReason)
{
	LogData log;
	for (int64_t k = 0; k < 2000; ++k)
		log.motors.push_back(sample_at(k, 2, 6, 0.5));
	Segment s = whole(log);
	s.direction = "x";
	const SegmentWindows w = find_windows(s, encoder_track(log, kD, kR), WindowOptions{});
	EXPECT_TRUE(w.step.empty());
	ASSERT_EQ(w.rejected.size(), 1u);
	EXPECT_NE(w.rejected[0].reason.find("unknown direction 'x'"), std::string::npos);
	// Validation and identification say what is missing; nothing else escapes.
	EXPECT_THROW(validate({s}, model_params_table3), IdentError);
	EXPECT_THROW(identify({s}, model_params_table3), IdentError);
}

TEST(Windows, LostSamplesEndAFilterBlockAndNothingIsFilteredAcrossThem)
{
	LogData log;
	for (int64_t k = 0; k < 2000; ++k) {
		if (k >= 1000 && k < 1005)
			continue; // 5 lost samples
		log.motors.push_back(sample_at(k, 2, 6, 0.5));
	}
	const EncoderTrack t = encoder_track(log, kD, kR);
	EXPECT_NEAR(t.dt, 1e-3, 1e-12);
	EXPECT_EQ(t.half, 20); // +-20 ms at 1 kHz
	// Index 1000 holds seq 1005: the 20 samples on each side of the gap have no full window.
	for (size_t i = 980; i < 1020; ++i)
		EXPECT_FALSE(t.ok[i]) << i;
	EXPECT_TRUE(t.ok[979]);
	EXPECT_TRUE(t.ok[1020]);
	EXPECT_FALSE(t.joined[1000]);
	EXPECT_NEAR(t.x[979][0], 0.5, 4e-8); // 0.5 / r rounded to motors_t's float: 1.4e-8 off
}

// A second-order Savitzky-Golay filter reproduces a ramp exactly: its value and its slope at
// every sample with a full window, up to motors_t's float rounding. Blocks of 41 to 64 samples
// (one window up to a few more, between single lost samples) reach every sample of each
// block's filtered part, its last ones included.
TEST(Windows, EncoderFilterReproducesARampInEveryBlock)
{
	LogData log;
	int64_t k = 0;
	for (int len = 41; len <= 64; ++len, ++k) // k skips one seq: a lost sample
		for (int i = 0; i < len; ++i, ++k)
			log.motors.push_back(sample_at(k, 2, 6, 0.1 + 0.5 * (k * 1e-3)));
	const EncoderTrack t = encoder_track(log, kD, kR);
	ASSERT_EQ(t.half, 20);
	size_t ok = 0;
	for (size_t i = 0; i < log.motors.size(); ++i) {
		if (!t.ok[i])
			continue;
		++ok;
		const double v = 0.1 + 0.5 * (log.motors[i].seq * 1e-3);
		EXPECT_NEAR(t.x[i][0], v, 1e-6) << i;
		EXPECT_NEAR(t.dx[i][0], 0.5, 1e-3) << i;
		EXPECT_NEAR(t.x[i][1], 0.0, 1e-6) << i;
		EXPECT_NEAR(t.dx[i][1], 0.0, 1e-3) << i;
		EXPECT_NEAR(t.x[i][2], 0.0, 1e-6) << i;
		EXPECT_NEAR(t.dx[i][2], 0.0, 1e-3) << i;
	}
	EXPECT_EQ(ok, size_t{(1 + 24) * 24 / 2}); // len - 40 per block
}

// Validation with the true parameters on exact sensors: the measured and simulated velocities
// differ only by the filter's own error where its window lies inside the drive. A window that
// reaches past the drive's end (bridges off, decelerating) would add its lag to the last
// samples of every run.
TEST(Validation, RunsEndWhereTheFilterStillSeesOnlyTheDrive)
{
	omni4_config cfg;
	config_defaults(&cfg);
	const std::string log = temp_path(".lcmlog");
	run_simulation(cfg, cfg.ctl.model, false, log, true, 0, 0);
	const LogData d = read_log(log);
	std::remove(log.c_str());
	const Validation v = validate(split_segments(d), cfg.ctl.model);
	std::printf("exact sensors, true parameters: e_max v %.2e vn %.2e w %.2e\n",
	            v.axis[0].e_max, v.axis[1].e_max, v.axis[2].e_max);
	// Measured 5.8e-5, 5.8e-5 m/s, 1.1e-3 rad/s (with the runs' ends inside the filter window:
	// 1.7e-3, 2.0e-3, 0.026).
	EXPECT_LT(v.axis[0].e_max, 1.5e-4);
	EXPECT_LT(v.axis[1].e_max, 1.5e-4);
	EXPECT_LT(v.axis[2].e_max, 2.5e-3);
}

// Lost samples are the seq numbers missing in time order: a pair that reached the log swapped
// is no loss, a seq that never came is one.
TEST(BadInput, ASwappedPairIsNotALostSample)
{
	const std::string path = temp_path(".lcmlog");
	{
		omni4_test::EventLogWriter log(path);
		ASSERT_TRUE(log.ok());
		for (int64_t k = 0; k < 100; ++k) {
			if (k == 50)
				continue; // lost
			const int64_t seq = k == 10   ? 11
			                    : k == 11 ? 10
			                              : k; // 10 and 11 swapped in the file
			omni4::motors_t m{};
			m.utime = 1000000 + 1000 * seq;
			m.seq = seq;
			ASSERT_TRUE(log.put("OMNI4_MOTORS", m));
		}
	}
	const LogData d = read_log(path);
	std::remove(path.c_str());
	EXPECT_EQ(d.motors.size(), 99u);
	EXPECT_EQ(d.seq_gaps, 1u);
	EXPECT_EQ(d.motors[10].seq, 10); // back in time order
}
