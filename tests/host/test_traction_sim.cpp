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

#include <cmath>
#include <cstdio>
#include <string>

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
