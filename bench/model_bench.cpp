// Model cost per control tick: fixed-point IK + feedforward (what the loop runs) beside the
// double twin, with Google Benchmark. Inputs cycle through a table of envelope points so the
// compiler cannot fold them.
#include <benchmark/benchmark.h>

#include <vector>

extern "C" {
#include "omni4/model/feedforward.h"
#include "omni4/model/kinematics.h"
#include "omni4/model/rng.h"
}

namespace
{

struct Point {
	double vel[3], acc[3];
	q16_t velq[3], accq[3];
};

std::vector<Point> points()
{
	std::vector<Point> pts(1024);
	rng g;
	rng_seed(&g, 1);
	for (Point &p : pts) {
		const double lim[3] = {3, 3, 20};
		for (int k = 0; k < 3; ++k) {
			p.vel[k] = rng_uniform(&g, -lim[k], lim[k]);
			p.acc[k] = rng_uniform(&g, -10, 10);
			p.velq[k] = q16_from_double(p.vel[k]);
			p.accq[k] = q16_from_double(p.acc[k]);
		}
	}
	return pts;
}

void BM_ik_ff_q16(benchmark::State &state)
{
	const auto pts = points();
	ff_q16 ff;
	ff_q16_init(&ff, &model_params_table3, 12.0);
	size_t i = 0;
	for (auto _ : state) {
		const Point &p = pts[i++ & 1023];
		q16_t wheel[4], u[4];
		ik_wheel_speeds_q16(ff.d, p.velq, wheel);
		ff_voltages_q16(&ff, p.velq, p.accq, u);
		benchmark::DoNotOptimize(wheel);
		benchmark::DoNotOptimize(u);
	}
}

void BM_ik_ff_double(benchmark::State &state)
{
	const auto pts = points();
	size_t i = 0;
	for (auto _ : state) {
		const Point &p = pts[i++ & 1023];
		double wheel[4], u[4];
		ik_wheel_speeds(model_params_table3.d, p.vel, wheel);
		ff_voltages(&model_params_table3, p.vel, p.acc, 12.0, u);
		benchmark::DoNotOptimize(wheel);
		benchmark::DoNotOptimize(u);
	}
}

} // namespace

// Repetitions come from the command line (bench/run: 15, randomly interleaved so that a slow
// spell of a shared machine falls on both).
BENCHMARK(BM_ik_ff_q16)->ReportAggregatesOnly(true);
BENCHMARK(BM_ik_ff_double)->ReportAggregatesOnly(true);
BENCHMARK_MAIN();
