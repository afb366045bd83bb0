// The traction experiment and the traction limit on simulated floors (hidden [sim]
// traction_mu, the default [sim] com_height):
// - the experiment (traction_exp.hpp) run on the simulated robot and analysed
//   (ident_traction.hpp) measures each floor's mu within 10 %;
// - identification on a floor of mu 0.5 with the runs' ramps under the limit (limit_ramps)
//   gives Table III within 1 % (the old 0.5 s ramps slip there);
// - the controller with the measured [limits] traction_mu and com_height holds 1 m/s VELOCITY
//   steps along v, vn and the diagonal with no slip (the plant's truth, the estimator's SLIP
//   flag) and within 10 % of the time the step takes at the measured limit, integrated here by
//   hand from the model: along v, (mu M g / 2 - Cv - Bv v) / M (wheels 1 and 3 push and carry
//   no load transfer); along the diagonal each axis' pair of wheels is limited by the wheel
//   ahead of the other axis' acceleration, mu (M g / 4 - M h a_other / (2 d)).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/Dense>

#include "ident_traction.hpp"
#include "identify.hpp"
#include "logdata.hpp"
#include "omni4/command_t.hpp"
#include "omni4/sim_truth_t.hpp"
#include "simexp.hpp"
#include "testlog.hpp"
#include "traction_exp.hpp"

extern "C" {
#include "omni4/lcmtypes/channels.h"
#include "omni4/core/est.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/plant.h"
}

using namespace omni4;

namespace
{

const model_params &P = model_params_table3;
constexpr double kG = 9.80665;

omni4_config floor_cfg(double mu, unsigned seed)
{
	omni4_config cfg;
	config_defaults(&cfg);
	cfg.sim.traction_mu = mu;
	cfg.sim.seed = static_cast<int>(seed);
	return cfg;
}

TractionResult measure(double mu, unsigned seed)
{
	const std::string log = omni4_test::temp_path(".lcmlog");
	run_phases(floor_cfg(mu, seed), P, true, log, traction_sequence(), 0, 0);
	const LogData d = read_log(log);
	std::remove(log.c_str());
	return identify_traction(split_segments(d), P);
}

struct StepOutcome {
	double t95 = NAN;       // first time the true speed along the step reaches 95 % [s]
	int32_t truth_slip = 0; // truth flags seen (bits 0-3)
	bool est_slip = false;  // the estimator's SLIP seen
};

void on_message(void *ctx, const char *channel, int64_t, const void *data, size_t len)
{
	if (std::string(channel) != OMNI4_CHANNEL_SIM_TRUTH)
		return;
	sim_truth_t t;
	if (t.decode(data, 0, static_cast<int>(len)) > 0)
		static_cast<StepOutcome *>(ctx)->truth_slip |= t.flags & 0x0f;
}

StepOutcome velocity_step(double mu, const TractionResult &m, const double dir[2])
{
	omni4_config cfg = floor_cfg(mu, 3);
	cfg.ctl.limits.traction_mu = m.mu;
	cfg.ctl.limits.com_height = m.have_com ? m.com_height : 0.0;
	cfg.ctl.limits.acc_lin_max = 50;
	char err[256];
	simrun *sr = simrun_create(&cfg, &P, true, nullptr, err, sizeof(err));
	EXPECT_NE(sr, nullptr) << err;
	StepOutcome out;
	simrun_set_tap(sr, on_message, &out);
	const double dt = simrun_period_s(sr);
	for (int k = 0; k < 300; ++k) // the offsets' calibration, at rest
		simrun_tick(sr);
	command_t c{};
	c.mode = command_t::MODE_VELOCITY;
	c.velocity[0] = dir[0];
	c.velocity[1] = dir[1];
	for (int k = 0; k < 1500; ++k) {
		if (k % 50 == 0) {
			c.utime = simrun_now_us(sr);
			c.seq = k;
			std::vector<uint8_t> buf(c.getEncodedSize());
			c.encode(buf.data(), 0, static_cast<int>(buf.size()));
			simrun_command(sr, buf.data(), buf.size());
		}
		simrun_tick(sr);
		double x[3], pose[3];
		simrun_truth(sr, x, pose);
		if (std::isnan(out.t95) && x[0] * dir[0] + x[1] * dir[1] >= 0.95)
			out.t95 = (k + 1) * dt;
		out.est_slip |= (simrun_estimate(sr)->flags & EST_FLAG_SLIP) != 0;
	}
	simrun_destroy(sr);
	return out;
}

// By hand: time to 95 % of a 1 m/s step at the limit mu (centre of mass h), Euler 0.1 ms.
double ideal_t95(double mu, double h, const double dir[2])
{
	const double target[2] = {dir[0], dir[1]};
	const double B[2] = {P.Bv, P.Bvn}, C[2] = {P.Cv, P.Cvn};
	double x[2] = {0, 0}, a[2] = {0, 0}, t = 0;
	const double q = P.M * kG / 4, k = P.M * h / (2 * P.d);
	while (x[0] * dir[0] + x[1] * dir[1] < 0.95 && t < 10) {
		double an[2];
		for (int i = 0; i < 2; ++i) {
			if (target[i] == 0 || x[i] >= target[i]) {
				an[i] = 0;
				continue;
			}
			// Axis i's wheels sit across it, on the other axis: its acceleration
			// unloads one.
			const double f = mu * (q - k * std::max(0.0, a[1 - i]));
			an[i] = (2 * f - C[i] - B[i] * x[i]) / P.M;
		}
		for (int i = 0; i < 2; ++i) {
			a[i] = an[i];
			x[i] += 1e-4 * a[i];
		}
		t += 1e-4;
	}
	return t;
}

} // namespace

TEST(TractionSim, ExperimentMeasuresEachFloorWithinTenPercentAndTheLimitHoldsTheSteps)
{
	const double s = 1 / std::sqrt(2.0);
	const double dirs[3][2] = {{1, 0}, {0, 1}, {s, s}};
	const char *const names[3] = {"v", "vn", "diagonal"};
	for (double mu : {0.4, 0.7, 1.0}) {
		const TractionResult m = measure(mu, 11);
		ASSERT_TRUE(m.ok) << "floor mu " << mu;
		std::printf(
		    "floor mu %.2f: measured %.4f ± %.4f (%+.1f %%), com_height %.4f m (sim "
		    "%.2f)\n",
		    mu, m.mu, m.mu_se, 100 * (m.mu / mu - 1), m.com_height, 0.04);
		for (const TractionDirection &d : m.directions)
			std::printf("  %-4s mu %.4f ± %.4f  held %.3f ± %.3f\n",
			            d.direction.c_str(), d.mu, d.mu_se, d.acc, d.acc_se);
		EXPECT_NEAR(m.mu, mu, 0.1 * mu);
		for (int i = 0; i < 3; ++i) {
			const StepOutcome o = velocity_step(mu, m, dirs[i]);
			const double ideal =
			    ideal_t95(m.mu, m.have_com ? m.com_height : 0.0, dirs[i]);
			std::printf(
			    "  1 m/s step along %-8s t95 %.4f s, at the measured limit %.4f s "
			    "(%+.1f %%), truth slip 0x%x, SLIP %d\n",
			    names[i], o.t95, ideal, 100 * (o.t95 / ideal - 1), o.truth_slip,
			    o.est_slip);
			EXPECT_EQ(o.truth_slip, 0) << names[i];
			EXPECT_FALSE(o.est_slip) << names[i];
			EXPECT_LE(o.t95, 1.10 * ideal) << names[i];
		}
	}
}

// Identification on a low-traction floor (mu 0.5: the paper's runs, ramped over 0.5 s, ask a
// wheel for up to ~1.1 M g / 4 and slip) with the runs' ramps kept under the limit
// (limit_ramps) gives the parameters within 1 % of Table III, as on a floor that never slips.
TEST(TractionSim, IdentificationOnALowTractionFloorWithTheRampsKeptUnderTheLimit)
{
	omni4_config cfg = floor_cfg(0.5, 5);
	std::vector<Phase> phases = selected_sequence({}, 3.0, 3.0);
	limit_ramps(phases, P, traction_hold_n(P, 0.5, 0.02));
	const std::string log = omni4_test::temp_path(".lcmlog");
	run_phases(cfg, P, true, log, phases, 0, 0);
	const LogData d = read_log(log);
	std::remove(log.c_str());
	const IdentResult r = identify(split_segments(d), P);
	for (const char *name : kIdentParams) {
		const double got = r.table.at("final").at(name).value;
		int i = 0;
		while (std::string(model_params_names[i]) != name)
			++i;
		const double want = model_params_get(&P, i);
		std::printf("  %-4s %.6g (Table III %.6g, %+.2f %%)\n", name, got, want,
		            100 * (got / want - 1));
		EXPECT_NEAR(got, want, 0.01 * want) << name;
	}
}

namespace
{

// Each wheel's load at rest [N] of wheels at angle_deg, dist_m from the centre: the least-norm
// loads with the weight carried and no moment (N = P^T (P P^T)^-1 (M g, 0, 0), P the rows 1,
// p_v, p_vn), written here from the angles, not from model/wheels.h.
std::array<double, 4> loads_at_rest(const double angle_deg[4], const double dist_m[4], int n)
{
	Eigen::MatrixXd Pm(3, n);
	for (int j = 0; j < n; ++j) {
		const double a = angle_deg[j] * M_PI / 180;
		Pm(0, j) = 1;
		Pm(1, j) = dist_m[j] * std::cos(a);
		Pm(2, j) = dist_m[j] * std::sin(a);
	}
	const Eigen::VectorXd N =
	    Pm.transpose() * (Pm * Pm.transpose()).ldlt().solve(Eigen::Vector3d(P.M * kG, 0, 0));
	std::array<double, 4> out{};
	for (int j = 0; j < n; ++j)
		out[j] = N[j];
	return out;
}

// limit_ramps's longest ramp [s] (traction_exp.hpp): a run it leaves there asks more than the
// hold whatever its ramp (its steady force: the motor runs alone are scaled down).
constexpr double kLongestRampS = 6.0;

// Each wheel's largest |force| [N] over the phases limit_ramps ramps (voltage phases from
// rest, not the traction experiment's) to less than its longest ramp, each run from rest on
// the layout's plant for its ramp and up to 1 s of its hold, as limit_ramps judges them.
std::array<double, 4> worst_from_rest(const std::vector<Phase> &phases, const wheel_geom &g)
{
	std::array<double, 4> worst{};
	bool at_rest = true;
	for (const Phase &ph : phases) {
		const bool from_rest = at_rest;
		at_rest = ph.mode != command_t::MODE_VOLTAGE && (at_rest || ph.duration_s >= 0.2);
		if (ph.mode != command_t::MODE_VOLTAGE || !from_rest ||
		    ph.mark_kind == "traction" || ph.ramp_s <= 0 || ph.ramp_s >= kLongestRampS)
			continue;
		struct plant pl;
		EXPECT_EQ(plant_init(&pl, &P), 0);
		EXPECT_EQ(plant_set_geom(&pl, &g), 0);
		const double run_s = ph.ramp_s + std::min(ph.duration_s - ph.ramp_s, 1.0);
		for (double t = 1e-3; t <= run_s + 1e-9; t += 1e-3) {
			const double k = std::min(1.0, t / ph.ramp_s),
			             u[4] = {k * ph.voltage[0], k * ph.voltage[1],
				             k * ph.voltage[2], k * ph.voltage[3]};
			plant_step(&pl, u, true, 1e-3);
			double f[4];
			dyn_wheel_forces(&P, pl.current_a, f);
			for (int j = 0; j < 4; ++j)
				worst[j] = std::max(worst[j], std::fabs(f[j]));
		}
	}
	return worst;
}

} // namespace

// limit_ramps on another layout (the asymmetric four of ident_independent_robocup): every
// phase it ramps asks no wheel for more than the floor holds under that wheel's own load,
// (1 - margin) mu N0_j; the paper's quarter-weight hold, used for this layout, would ask the
// lightest wheel for more.
TEST(TractionSim, RampsOnAnotherLayoutKeepEachWheelUnderItsOwnLoad)
{
	const double angle[4] = {60, 135, 225, 300}, dist[4] = {0.082, 0.090, 0.095, 0.085};
	const Layout L = make_layout(4, angle, dist, "the test");
	const double mu = 0.4, margin = 0.02, hold = traction_hold_n(P, mu, margin);
	const std::array<double, 4> N0 = loads_at_rest(angle, dist, 4);
	std::vector<Phase> fitted = selected_sequence({}, 3.0, 3.0, L), paper = fitted;
	limit_ramps(fitted, P, hold, L);
	limit_ramps(paper, P, hold);
	const std::array<double, 4> got = worst_from_rest(fitted, L.geom),
	                            old = worst_from_rest(paper, L.geom);
	bool over = false;
	for (int j = 0; j < 4; ++j) {
		const double allowed = (1 - margin) * mu * N0[j];
		std::printf("  wheel %d: load %.3f N, holds %.3f N; ramped for it %.3f N, for the "
		            "paper's quarter weight %.3f N\n",
		            j, N0[j], allowed, got[j], old[j]);
		EXPECT_LE(got[j], allowed * (1 + 1e-3)) << "wheel " << j;
		over = over || old[j] > allowed * (1 + 1e-3);
	}
	EXPECT_TRUE(over) << "the quarter-weight hold keeps every wheel of this layout too: the "
	                     "test would not tell the layout's loads from it";
}
