// ident_traction.cpp - the floor's traction from the traction experiment (ident_traction.hpp).
#include "ident_traction.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>

#include <Eigen/Dense>

#include "omni4/core/vocab.h"
#include "layout.hpp"
#include "regression.hpp"
#include "traction_exp.hpp"

extern "C" {
#include "omni4/model/consts.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/wheels.h"
}

namespace omni4
{

namespace
{

constexpr double kSlipAbs = 0.02;     // [m/s]: beyond the encoders' resolution, averaged
constexpr double kSlipRel = 0.03;     // share of the speed: beyond the model's error
constexpr int kSlipMean = 10;         // samples in the running mean of the difference
constexpr int kSmooth = 5;            // samples in the current's running mean
constexpr int kSlopeN = 25;           // samples in each acceleration fit
constexpr int kEnd = 20;              // last driven samples of a run: its kinetic force
constexpr double kComMinShare = 0.05; // least load transfer (rms share of the slipping wheels'
                                      // force) another layout's com_height is taken from
const char *const kDirections[] = {"v", "vn", "w", "diag"};

bool driven(int8_t mode)
{
	return mode_drives(mode); // the logged voltages applied
}

// The layout's part of the wheels' physics (model/wheels.h): rims, eqs 3-5, eqs 9-11. No
// drive: a partial identification's model is not a checked one.
wheel_phys phys_of(const model_params &p)
{
	wheel_geom g;
	wheel_phys ph{};
	wheel_geom_paper(p.d, &g);
	if (wheel_phys_layout(&ph, &g))
		throw IdentError("the traction fit: the wheel distance d = " + std::to_string(p.d) +
		                 " m gives no layout");
	return ph;
}

// What every step of the fit shares: the model, the layout's maps and each wheel's load at
// rest (the paper's: a quarter of the weight on each; another layout's: model/wheels.h's
// least-norm loads, which the plant's floor uses too).
struct Ctx {
	const model_params &p;
	const Layout &L;
	wheel_geom geom{};             // the rows and the loads' map
	wheel_phys ph{};               // eqs 3-5 and 9-11 of the layout
	std::array<double, 4> load0{}; // each wheel's load at rest [N] (0: no wheel)
};

Ctx ctx_of(const model_params &p, const Layout &L)
{
	Ctx c{p, L};
	if (L.paper) {
		wheel_geom_paper(p.d, &c.geom);
		c.ph = phys_of(p);
		c.load0.fill(p.M * MODEL_G_M_S2 / 4);
		return c;
	}
	c.geom = L.geom;
	c.ph = L.ph;
	for (int j = 0; j < L.n; ++j)
		c.load0[j] = L.geom.lmap[j][0] * p.M * MODEL_G_M_S2;
	return c;
}

// The driven wheels' mean of force / load at rest (their forces f [N], the pattern pat): when
// every driven wheel carries the same load (the paper's layout, equal distances), the mean
// force over that load, as the paper's quarter of the weight.
double load_share(const std::array<double, 4> &f, const std::array<double, 4> &pat, const Ctx &c)
{
	double sum = 0, ratio = 0, load = -1;
	bool same = true;
	int n = 0;
	for (int j = 0; j < 4; ++j)
		if (pat[j] != 0) {
			sum += f[j];
			ratio += f[j] / c.load0[j];
			same = same && (load < 0 || c.load0[j] == load);
			load = c.load0[j];
			++n;
		}
	if (!n)
		return 0.0;
	return same ? sum / n / load : ratio / n;
}

// True when no driven wheel of the direction's pattern changes its load with the acceleration
// the pattern gives (the centre of mass's acceleration along G^T u, or none for a rotation):
// the paper's v, vn and w, any layout's w.
bool no_transfer(const std::string &dir, const Ctx &c)
{
	const std::array<double, 4> pat = traction_pattern(dir, c.L);
	double F[3];
	wheel_body_force(&c.ph, pat.data(), F);
	const double scale = std::hypot(F[0], F[1], F[2] / c.p.d); // [N]; lmap's [1/m] times d
	for (int j = 0; j < 4; ++j)
		if (pat[j] != 0 &&
		    std::fabs(c.geom.lmap[j][1] * F[0] + c.geom.lmap[j][2] * F[1]) * c.p.d >
		        1e-9 * scale)
			return false;
	return true;
}

// Robot velocity (v, vn, d w) [m/s] from the wheel speeds (eqs 3-5).
std::array<double, 3> robot_velocity(const MotorsSample &s, const model_params &p,
                                     const wheel_phys &ph)
{
	double rim[4], x[3];
	for (int j = 0; j < 4; ++j)
		rim[j] = p.r * s.w[j];
	wheel_body(&ph, rim, x);
	return {x[0], x[1], p.d * x[2]};
}

// Each wheel's force [N] from its current (eqs 12-13), 0 when the bridges are off.
std::array<double, 4> forces(const MotorsSample &s, const model_params &p)
{
	std::array<double, 4> f{};
	if (driven(s.mode)) {
		const double i[4] = {s.i[0], s.i[1], s.i[2], s.i[3]};
		dyn_wheel_forces(&p, i, f.data());
	}
	return f;
}

// Largest distance between the encoders' velocity and the one the currents can give a
// gripping robot (eqs 9-13 and 23, Euler from the segment's first sample), as a running mean
// of kSlipMean samples, beyond the tolerance (> 0: slipped) and that distance.
// Each rim whose running mean off the gripping rim is beyond runaway's tolerance at speed.
std::array<bool, 4> rims_off(const std::array<std::array<double, 4>, kSlipMean> &rim_diff,
                             double speed)
{
	std::array<bool, 4> off{};
	for (int j = 0; j < 4; ++j) {
		double rim = 0;
		for (int q = 0; q < kSlipMean; ++q)
			rim += rim_diff[q][j] / kSlipMean;
		off[j] = std::fabs(rim) > kSlipAbs + kSlipRel * speed;
	}
	return off;
}

double runaway(const Segment &s, const Ctx &c, double *dist_out, bool *at_end,
               std::array<bool, 4> &wheel_at_end, std::array<double, 3> &body_end)
{
	const model_params &p = c.p;
	const auto &m = s.log->motors;
	const double inertia[3] = {p.M, p.M, p.J / (p.d * p.d)}; // the third axis as d w
	const double B[3] = {p.Bv, p.Bvn, p.Bw / (p.d * p.d)}, C[3] = {p.Cv, p.Cvn, p.Cw / p.d};
	const wheel_phys &ph = c.ph;
	std::array<double, 3> x = robot_velocity(m[s.m0], p, ph);
	double worst = 0, excess = -1e300;
	std::array<std::array<double, 3>, kSlipMean> diff{};
	std::array<std::array<double, 4>, kSlipMean> rim_diff{}; // each rim less its gripping speed
	std::array<double, kSlipMean> spd{};
	for (size_t k = s.m0; k + 1 < s.m1; ++k) {
		const double dt = (m[k + 1].utime - m[k].utime) * 1e-6;
		const std::array<double, 4> f = forces(m[k], p);
		double F[3];
		wheel_body_force(&ph, f.data(), F); // eqs 9-11
		F[2] /= p.d;                        // the third axis as d w
		for (int a = 0; a < 3; ++a) {
			const double sg = x[a] > 0 ? 1 : (x[a] < 0 ? -1 : 0);
			if (sg == 0 && std::fabs(F[a]) <= C[a])
				continue; // stiction
			const double xn = x[a] + dt *
			                             (F[a] - B[a] * x[a] -
			                              C[a] * (sg != 0 ? sg : (F[a] > 0 ? 1 : -1))) /
			                             inertia[a];
			x[a] = (sg != 0 && xn * sg < 0) ? 0.0 : xn;
		}
		const auto e = robot_velocity(m[k + 1], p, ph);
		const size_t n = k - s.m0;
		diff[n % kSlipMean] = {e[0] - x[0], e[1] - x[1], e[2] - x[2]};
		spd[n % kSlipMean] = std::hypot(e[0], e[1], e[2]);
		const double xb[3] = {x[0], x[1], x[2] / p.d};
		double grip[4];
		wheel_rims(&ph, xb, grip); // eq 2: the rims of the body the currents drive
		for (int j = 0; j < 4; ++j)
			rim_diff[n % kSlipMean][j] = p.r * m[k + 1].w[j] - grip[j];
		if (n + 1 < kSlipMean)
			continue;
		std::array<double, 3> mean{};
		double speed = 0;
		for (int q = 0; q < kSlipMean; ++q) {
			for (int a = 0; a < 3; ++a)
				mean[a] += diff[q][a] / kSlipMean;
			speed += spd[q] / kSlipMean;
		}
		const double d = std::hypot(mean[0], mean[1], mean[2]);
		worst = std::max(worst, d);
		excess = std::max(excess, d - kSlipAbs - kSlipRel * speed);
		if (!driven(m[k].mode))
			continue;
		*at_end = d > kSlipAbs + kSlipRel * speed;
		body_end = {xb[0], xb[1], xb[2]};
		wheel_at_end = rims_off(rim_diff, speed);
	}
	*dist_out = worst;
	return excess;
}

// Peak wheel force [N]: the largest 5-sample mean of l Kt |i_j| / r per driven wheel, averaged
// over the driven wheels; each driven wheel's in peak (0 for the others).
double peak_force(const Segment &s, const model_params &p, const std::array<double, 4> &pat,
                  std::array<double, 4> &peak)
{
	const auto &m = s.log->motors;
	double sum = 0;
	int n = 0;
	peak.fill(0.0);
	for (int j = 0; j < 4; ++j) {
		if (pat[j] == 0)
			continue;
		double best = 0;
		for (size_t k = s.m0; k + kSmooth <= s.m1; ++k) {
			double acc = 0;
			for (int q = 0; q < kSmooth; ++q)
				acc += driven(m[k + q].mode) ? m[k + q].i[j] : 0.0;
			best = std::max(best, std::fabs(acc / kSmooth));
		}
		double cur[4] = {0, 0, 0, 0}, fb[4];
		cur[j] = best;
		dyn_wheel_forces(&p, cur, fb); // eqs 12-13
		sum += fb[j];
		peak[j] = fb[j];
		++n;
	}
	return n ? sum / n : 0.0;
}

// Each wheel's mean force over kEnd driven samples [N] (signed), the last `skip` driven samples
// of the run left out; and each rim's acceleration over them (least-squares slope of r w_j)
// [m/s^2].
std::array<double, 4> window_forces(const Segment &s, const model_params &p, int skip,
                                    std::array<double, 4> &rim_acc)
{
	const auto &m = s.log->motors;
	std::array<double, 4> f{}, sy{}, sty{};
	double st = 0, stt = 0;
	int n = 0, seen = 0;
	for (size_t k = s.m1; k-- > s.m0 && n < kEnd;) {
		if (!driven(m[k].mode) || seen++ < skip)
			continue;
		const double t = (m[k].utime - m[s.m1 - 1].utime) * 1e-6;
		const std::array<double, 4> fk = forces(m[k], p);
		for (int j = 0; j < 4; ++j) {
			f[j] += fk[j];
			sy[j] += p.r * m[k].w[j];
			sty[j] += t * p.r * m[k].w[j];
		}
		st += t;
		stt += t * t;
		++n;
	}
	const double den = n * stt - st * st;
	for (int j = 0; j < 4; ++j) {
		f[j] = n ? f[j] / n : 0.0;
		rim_acc[j] = den > 0 ? (n * sty[j] - st * sy[j]) / den : 0.0;
	}
	return f;
}

// The driven wheels' mean |force| / load at rest (load_share) and their rims' mean
// acceleration along it.
void window_mu(const std::array<double, 4> &f, const std::array<double, 4> &acc,
               const std::array<double, 4> &pat, const Ctx &c, double *mu, double *rim_acc)
{
	std::array<double, 4> mag{};
	double a = 0;
	int n = 0;
	for (int j = 0; j < 4; ++j)
		if (pat[j] != 0) {
			mag[j] = std::fabs(f[j]);
			a += acc[j] * (f[j] < 0 ? -1 : 1);
			++n;
		}
	*mu = load_share(mag, pat, c);
	*rim_acc = a / n;
}

// The velocity along the direction (m/s; rad/s along w): the diagonal of another layout along
// the body force its pattern gives (the paper's: 45 deg).
double along(const std::string &dir, const std::array<double, 3> &x, const Ctx &c)
{
	if (dir == "v")
		return x[0];
	if (dir == "vn")
		return x[1];
	if (dir == "w")
		return x[2] / c.p.d;
	if (c.L.paper)
		return (x[0] + x[1]) / std::sqrt(2.0);
	const std::array<double, 4> pat = traction_pattern(dir, c.L);
	double F[3];
	wheel_body_force(&c.ph, pat.data(), F);
	return (F[0] * x[0] + F[1] * x[1]) / std::hypot(F[0], F[1]);
}

// Steepest kSlopeN-sample least-squares slope of the velocity along dir, and its SE.
void steepest(const Segment &s, const Ctx &c, double *acc, double *se)
{
	const model_params &p = c.p;
	const wheel_phys &ph = c.ph;
	const auto &m = s.log->motors;
	*acc = 0;
	*se = 0;
	for (size_t k = s.m0; k + kSlopeN <= s.m1; ++k) {
		double st = 0, sy = 0, stt = 0, sty = 0;
		const double t0 = m[k].utime * 1e-6;
		for (int q = 0; q < kSlopeN; ++q) {
			const double t = m[k + q].utime * 1e-6 - t0;
			const double y = along(s.direction, robot_velocity(m[k + q], p, ph), c);
			st += t, sy += y, stt += t * t, sty += t * y;
		}
		const double n = kSlopeN, den = n * stt - st * st;
		if (!(den > 0))
			continue;
		const double b = (n * sty - st * sy) / den, a = (sy - b * st) / n;
		if (std::fabs(b) <= std::fabs(*acc))
			continue;
		double rss = 0;
		for (int q = 0; q < kSlopeN; ++q) {
			const double t = m[k + q].utime * 1e-6 - t0;
			const double y = along(s.direction, robot_velocity(m[k + q], p, ph), c);
			rss += (y - a - b * t) * (y - a - b * t);
		}
		*acc = b;
		*se = std::sqrt(rss / (n - 2) / (stt - st * st / n));
	}
	*acc = std::fabs(*acc);
}

// Runs past their break-away: the rim's acceleration fading from the earlier window to the end
// one (a run whose wheels break away late has its end window at the break-away, its force
// still below the kinetic friction and its rim speeding up).
std::vector<const TractionRun *> settled(const std::vector<const TractionRun *> &runs)
{
	std::vector<const TractionRun *> out;
	for (const TractionRun *r : runs)
		if (r->end_rim_acc < r->early_rim_acc)
			out.push_back(r);
	return out;
}

// mu_run (M g / 4) = F + m_w s' (F = mu M g / 4, m_w = J_w / r^2, s' the rim's acceleration):
// intercept and slope by least squares on both windows of every run (s' fades within a run,
// so the slope is fitted from each run's own contrast), with the SE cluster-robust over the
// runs (a run's two windows share its noise: the run is the observation; G / (G - 1)). With
// the end windows alone taken as mu (the m_w s' term left in: +1-2 % on the simulated floors)
// and their samples as independent, the SE was 5-13 times too small. false: fewer than two
// runs.
// Least squares y = X coef with the SE of coef[0] cluster-robust over the runs (rows
// first[k] to first[k + 1] are run k's: the run is the observation; G / (G - 1)). false: the
// normal equations' rcond at most rcond_min, or a result not finite.
bool cluster_fit(const Eigen::MatrixXd &X, const Eigen::VectorXd &y,
                 const std::vector<size_t> &first, double rcond_min, Eigen::Vector2d *coef,
                 double *se0)
{
	const size_t g = first.size() - 1;
	const Eigen::Matrix2d A = X.transpose() * X;
	const Eigen::LDLT<Eigen::Matrix2d> ldlt(A);
	if (ldlt.info() != Eigen::Success || !(std::abs(ldlt.rcond()) > rcond_min))
		return false;
	*coef = ldlt.solve(X.transpose() * y);
	const Eigen::VectorXd u = y - X * *coef;
	Eigen::Matrix2d omega = Eigen::Matrix2d::Zero();
	for (size_t k = 0; k < g; ++k) {
		const Eigen::Index a = static_cast<Eigen::Index>(first[k]);
		const Eigen::Index n = static_cast<Eigen::Index>(first[k + 1] - first[k]);
		const Eigen::Vector2d sc = X.middleRows(a, n).transpose() * u.segment(a, n);
		omega += sc * sc.transpose();
	}
	const Eigen::Matrix2d ainv = ldlt.solve(Eigen::Matrix2d::Identity());
	const Eigen::Matrix2d cov =
	    static_cast<double>(g) / static_cast<double>(g - 1) * ainv * omega * ainv;
	*se0 = std::sqrt(std::max(0.0, cov(0, 0)));
	return std::isfinite((*coef)[0]) && std::isfinite(*se0);
}

bool kinetic_fit(const std::vector<const TractionRun *> &runs, double *mu, double *mu_se,
                 double *share)
{
	const size_t g = runs.size();
	if (g < 2)
		return false;
	Eigen::MatrixXd X(2 * g, 2);
	Eigen::VectorXd y(2 * g);
	for (size_t k = 0; k < g; ++k) {
		X.row(2 * k) << 1.0, runs[k]->end_rim_acc;
		X.row(2 * k + 1) << 1.0, runs[k]->early_rim_acc;
		y[2 * k] = runs[k]->end_mu;
		y[2 * k + 1] = runs[k]->early_mu;
	}
	std::vector<size_t> first;
	for (size_t k = 0; k <= g; ++k)
		first.push_back(2 * k);
	Eigen::Vector2d coef;
	if (!cluster_fit(X, y, first, 1e-9, &coef, mu_se))
		return false;
	*mu = coef[0];
	*share = coef[1];
	return true;
}

// Another layout's floor, per wheel: a slipping wheel pushes with l Kt i / r = mu N0_j + m_w s'
// (N0_j its load at rest, in a direction whose driven wheels keep their load; m_w = J_w / r^2,
// s' its rim's acceleration along the force), so mu and m_w by least squares over both windows
// of each wheel still slipping at its run's end (a wheel that grips pushes with less; with
// unequal loads the paper's mean over the wheels mixes them), the SE cluster-robust over the
// runs. false: fewer than two runs or no such wheel.
bool kinetic_fit_wheels(const std::vector<const TractionRun *> &runs, const Ctx &c, double *mu,
                        double *mu_se, double *m_w)
{
	std::vector<std::array<double, 3>> rows; // N0, s', |f|
	std::vector<size_t> first{0};
	for (const TractionRun *r : runs) {
		const std::array<double, 4> &pat = r->pattern;
		for (int j = 0; j < 4; ++j) {
			if (pat[j] == 0 || !r->wheel_slip_at_end[j])
				continue;
			for (int w = 0; w < 2; ++w) {
				const double f = w ? r->early_f[j] : r->end_f[j];
				const double acc = w ? r->early_acc[j] : r->end_acc[j];
				rows.push_back({c.load0[j], acc * (f < 0 ? -1 : 1), std::fabs(f)});
			}
		}
		first.push_back(rows.size());
	}
	const size_t g = runs.size();
	if (g < 2 || rows.empty())
		return false;
	Eigen::MatrixXd X(rows.size(), 2);
	Eigen::VectorXd y(rows.size());
	for (size_t k = 0; k < rows.size(); ++k) {
		X.row(k) << rows[k][0], rows[k][1];
		y[k] = rows[k][2];
	}
	Eigen::Vector2d coef;
	if (!cluster_fit(X, y, first, 1e-12, &coef, mu_se))
		return false;
	*mu = coef[0];
	*m_w = coef[1];
	return true;
}

// The top half by level of the runs slipping at their end (lower levels may grip again).
std::vector<const TractionRun *> kinetic_runs(std::vector<const TractionRun *> runs)
{
	std::sort(runs.begin(), runs.end(),
	          [](const TractionRun *a, const TractionRun *b) { return a->level < b->level; });
	std::vector<const TractionRun *> kinetic;
	for (const TractionRun *r : runs)
		if (r->slip_at_end)
			kinetic.push_back(r);
	kinetic.erase(kinetic.begin(), kinetic.begin() + kinetic.size() / 2);
	return kinetic;
}

TractionDirection summarise(const std::string &dir, std::vector<const TractionRun *> runs)
{
	TractionDirection d;
	d.direction = dir;
	d.runs = static_cast<int>(runs.size());
	std::sort(runs.begin(), runs.end(),
	          [](const TractionRun *a, const TractionRun *b) { return a->level < b->level; });
	double lower = 0;
	for (const TractionRun *r : runs) {
		if (!d.reached && !r->slipped) {
			++d.held;
			lower = std::max(lower, r->mu);
			d.level_held = r->level;
		}
		if (r->slipped && !d.reached) {
			d.reached = true;
			d.level_slip = r->level;
		}
	}
	const std::vector<const TractionRun *> kinetic = kinetic_runs(runs);
	d.reached = !kinetic.empty();
	if (!d.reached) {
		d.mu = lower; // a lower bound
	} else if (!kinetic_fit(settled(kinetic), &d.mu, &d.mu_se, &d.wheel_share)) {
		// too few settled runs: the end windows' mean, m_w s' left in, SE their spread
		double sum = 0, sum2 = 0;
		for (const TractionRun *r : kinetic) {
			sum += r->end_mu;
			sum2 += r->end_mu * r->end_mu;
		}
		const double n = static_cast<double>(kinetic.size());
		d.mu = sum / n;
		d.mu_se = n > 1 ? std::sqrt(std::max(0.0, sum2 / n - d.mu * d.mu) / (n - 1))
		                : 0.0; // one run: no spread to tell (printed so)
	}
	for (const TractionRun *r : runs) // the highest run that held below mu
		if (!r->slipped && r->mu <= d.mu && r->level <= d.level_held) {
			d.acc = r->acc;
			d.acc_se = r->acc_se;
		}
	return d;
}

// Centre of mass height from the diagonal's runs with all four wheels slipping.
bool com_from_diagonal(const std::vector<TractionRun> &runs, double level_slip, double mu,
                       double share, const model_params &p, double *h)
{
	double sum = 0;
	int n = 0;
	for (const TractionRun &r : runs) {
		if (r.direction != "diag" || !r.slip_at_end || r.level < 2 * level_slip)
			continue;
		std::array<double, 4> f = r.end_f;
		for (int j = 0; j < 4; ++j) // less the share that spins the rim up (kinetic_fit)
			f[j] -= share * p.M * MODEL_G_M_S2 / 4 * r.end_acc[j];
		const double a_v = (std::fabs(f[1]) + std::fabs(f[3]) - p.Cv) / p.M;
		const double a_vn = (std::fabs(f[0]) + std::fabs(f[2]) - p.Cvn) / p.M;
		if (!(a_v > 0.1 && a_vn > 0.1))
			continue;
		sum += (std::fabs(f[2]) - std::fabs(f[0])) * p.d / (mu * p.M * a_v);
		sum += (std::fabs(f[3]) - std::fabs(f[1])) * p.d / (mu * p.M * a_vn);
		n += 2;
	}
	if (!n)
		return false;
	*h = std::clamp(sum / n, 0.0, 1.0);
	return true;
}

// Another layout's centre of mass height, from the runs of the directions whose driven wheels
// change load (shifted) with every driven wheel slipping (twice the direction's first slipped
// level or more): a slipping wheel's floor force is mu N_j, N_j = N0_j - M h (lmap_j . a)
// (model/wheels.h), so mu N0_j - |f_j| = h mu M (lmap_j . a), with f_j less the share that
// spins the rim up and a = (G^T f - C) / M, the centre of mass's acceleration the floor forces
// give (the body's Coulomb friction against it); h by least squares over those wheels.
bool com_from_transfer(const std::vector<TractionRun> &runs,
                       const std::vector<TractionDirection> &shifted, double mu, double m_w,
                       const Ctx &c, double *h, double *transfer_share)
{
	const model_params &p = c.p;
	double sky = 0, skk = 0, sff = 0;
	for (const TractionRun &r : runs) {
		const auto d =
		    std::find_if(shifted.begin(), shifted.end(), [&](const TractionDirection &x) {
			    return x.direction == r.direction;
		    });
		if (d == shifted.end() || !d->reached || !r.slip_at_end ||
		    r.level < 2 * d->level_slip)
			continue;
		const std::array<double, 4> &pat = r.pattern;
		std::array<double, 4> f = r.end_f;
		for (int j = 0; j < 4; ++j) // less what spins the rim up (kinetic_fit_wheels)
			f[j] -= m_w * r.end_acc[j];
		double F[3];
		wheel_body_force(&c.ph, f.data(), F);
		const double Cb[2] = {p.Cv, p.Cvn};
		double a[3], ac[2];
		for (int k = 0; k < 2; ++k)
			a[k] = (F[k] - std::copysign(std::min(Cb[k], std::fabs(F[k])), F[k])) / p.M;
		a[2] = 0;
		wheel_com_accel(r.body_end.data(), a, ac); // with the turn's centripetal part
		a[0] = ac[0];
		a[1] = ac[1];
		if (!(std::hypot(a[0], a[1]) > 0.1))
			continue;
		for (int j = 0; j < 4; ++j) {
			if (pat[j] == 0 || !r.wheel_slip_at_end[j])
				continue; // a wheel that grips pushes with less than mu N_j
			const double k =
			    mu * p.M * (c.geom.lmap[j][1] * a[0] + c.geom.lmap[j][2] * a[1]);
			sky += k * (mu * c.load0[j] - std::fabs(f[j]));
			sff += f[j] * f[j];
			skk += k * k;
		}
	}
	if (!(skk > 0))
		return false;
	*h = std::clamp(sky / skk, 0.0, 1.0);
	*transfer_share = *h * std::sqrt(skk / sff);
	return true;
}

// Another layout's com_height into r (com_from_transfer), kept only when the transfer seen is a
// share of the force a 1 % error of the forces does not swamp: below kComMinShare h would be
// off by tens of % (the asymmetric four: 3.6 %, h 0.056 m against 0.04 m).
void layout_com(TractionResult &r, const std::vector<TractionDirection> &shifted, double m_w,
                const Ctx &c)
{
	double share_seen = 0;
	const bool got =
	    com_from_transfer(r.runs, shifted, r.mu, m_w, c, &r.com_height, &share_seen);
	r.have_com = got && share_seen >= kComMinShare;
	r.com_share = got ? share_seen : 0.0;
	r.com_from = "the runs whose wheels' loads shift:";
	for (const TractionDirection &d : shifted)
		r.com_from += " " + d.direction;
}

void combine(TractionResult &r, const Ctx &c,
             const std::map<std::string, std::vector<const TractionRun *>> &by_dir)
{
	const model_params &p = c.p;
	// One fit over the settled kinetic runs of the directions whose driven wheels keep their
	// load (the paper's v, vn and w): one floor, one wheel inertia.
	std::vector<const TractionRun *> pooled;
	std::vector<TractionDirection> shifted;
	for (const TractionDirection &d : r.directions) {
		if (!no_transfer(d.direction, c)) {
			shifted.push_back(d);
			continue;
		}
		r.pooled += (r.pooled.empty() ? "" : ", ") + d.direction;
		if (!d.reached || d.held == 0)
			continue;
		const auto k = settled(kinetic_runs(by_dir.at(d.direction)));
		pooled.insert(pooled.end(), k.begin(), k.end());
	}
	double share = NAN, m_w = NAN; // the rim's inertia: per M g / 4 (paper), in kg (others)
	if (c.L.paper ? kinetic_fit(pooled, &r.mu, &r.mu_se, &share)
	              : kinetic_fit_wheels(pooled, c, &r.mu, &r.mu_se, &m_w)) {
		r.ok = true;
		r.runs_fitted = static_cast<int>(pooled.size());
	}
	double w = 0, wm = 0;
	const TractionDirection *diag = nullptr;
	for (const TractionDirection &d : r.directions) {
		if (d.direction == "diag")
			diag = &d;
		if (!no_transfer(d.direction, c))
			continue;
		if (!d.reached || d.held == 0 || !(d.mu_se > 0))
			continue;
		const double se = std::max(d.mu_se, 1e-3 * d.mu);
		w += 1 / (se * se);
		wm += d.mu / (se * se);
	}
	if (!r.ok && w > 0) { // too few settled runs to pool: the directions' weighted mean
		r.ok = true;
		r.mu = wm / w;
		r.mu_se = 1 / std::sqrt(w);
	}
	if (r.ok && c.L.paper && diag && diag->reached) {
		r.have_com = com_from_diagonal(r.runs, diag->level_slip, r.mu,
		                               std::isfinite(share) ? share : diag->wheel_share, p,
		                               &r.com_height);
		r.com_from = "the diagonal: the wheels ahead unload";
	} else if (r.ok && !c.L.paper && !shifted.empty()) {
		layout_com(r, shifted, std::isfinite(m_w) ? m_w : 0.0, c);
	}
}

} // namespace

TractionResult identify_traction(const std::vector<Segment> &segs, const model_params &p,
                                 const Layout &L)
{
	const Ctx c = ctx_of(p, L);
	TractionResult r;
	std::map<std::string, std::vector<const TractionRun *>> by_dir;
	for (const Segment &s : segs) {
		if (s.kind != "traction" || s.m1 < s.m0 + kSlopeN)
			continue;
		std::array<double, 4> pat;
		try {
			pat = traction_pattern(s.direction, L);
		} catch (const std::invalid_argument &) {
			continue; // not a direction of this experiment
		}
		TractionRun run;
		run.direction = s.direction;
		run.pattern = pat;
		run.level = s.level;
		run.slipped = runaway(s, c, &run.slip, &run.slip_at_end, run.wheel_slip_at_end,
		                      run.body_end) > 0;
		run.slip_at_end = run.slip_at_end && run.slipped;
		std::array<double, 4> peak;
		run.force = peak_force(s, p, pat, peak);
		run.end_f = window_forces(s, p, 0, run.end_acc);
		window_mu(run.end_f, run.end_acc, pat, c, &run.end_mu, &run.end_rim_acc);
		run.early_f = window_forces(s, p, kEnd, run.early_acc);
		window_mu(run.early_f, run.early_acc, pat, c, &run.early_mu, &run.early_rim_acc);
		run.mu = load_share(peak, pat, c);
		steepest(s, c, &run.acc, &run.acc_se);
		r.runs.push_back(run);
	}
	for (const TractionRun &run : r.runs)
		by_dir[run.direction].push_back(&run);
	for (const char *dir : kDirections)
		if (by_dir.count(dir))
			r.directions.push_back(summarise(dir, by_dir[dir]));
	combine(r, c, by_dir);
	return r;
}

void print_traction(const TractionResult &r)
{
	if (r.runs.empty())
		return;
	std::printf("\ntraction (the floor): per direction, voltage steps from rest\n");
	std::printf("  %-5s %5s %10s %10s %16s %28s\n", "dir", "runs", "held to", "slips at",
	            "mu ± SE", "largest held acceleration");
	for (const TractionDirection &d : r.directions) {
		char mu[40], slip[24];
		if (d.reached && d.mu_se > 0)
			std::snprintf(mu, sizeof(mu), "%.4f ± %.4f", d.mu, d.mu_se);
		else
			std::snprintf(mu, sizeof(mu), d.reached ? "%.4f (1 run)" : ">= %.4f", d.mu);
		std::snprintf(slip, sizeof(slip), d.reached ? "%.2f V" : "none", d.level_slip);
		std::printf("  %-5s %5d %8.2f V %10s %16s %14.3f ± %.3f %s\n", d.direction.c_str(),
		            d.runs, d.level_held, slip, mu, d.acc, d.acc_se,
		            d.direction == "w" ? "rad/s^2" : "m/s^2");
	}
	if (r.ok && r.runs_fitted > 0)
		std::printf("  traction_mu %.4f ± %.4f (%s: their driving wheels carry no load "
		            "transfer; %d runs past their break-away, force against rim "
		            "acceleration)\n",
		            r.mu, r.mu_se, r.pooled.c_str(), r.runs_fitted);
	else if (r.ok)
		std::printf("  traction_mu %.4f ± %.4f (%s: their driving wheels carry no load "
		            "transfer; too few runs past their break-away: the directions' mean)\n",
		            r.mu, r.mu_se, r.pooled.c_str());
	else
		std::printf("  traction_mu not measured: no slip along %s (raise the cap, or "
		            "the floor holds more than the motors give)\n",
		            r.pooled.c_str());
	if (r.have_com)
		std::printf("  com_height %.4f m (from %s)\n", r.com_height, r.com_from.c_str());
	else if (r.com_share > 0)
		std::printf(
		    "  com_height not measured: the load transfer seen (%s) is %.1f %% of "
		    "the slipping wheels' force, under %.0f %% (a 1 %% force error would move "
		    "it by tens of %%): give [limits] com_height measured\n",
		    r.com_from.c_str(), 100 * r.com_share, 100 * kComMinShare);
}

void export_traction_csv(const std::string &dir, const TractionResult &r)
{
	if (dir.empty() || r.runs.empty())
		return;
	std::ofstream f(dir + "/traction_runs.csv");
	f << "direction,level_v,slipped,slip_m_s,force_n,mu,acc,acc_se,slip_at_end,end_mu,"
	     "end_rim_acc,early_mu,early_rim_acc\n";
	for (const TractionRun &x : r.runs)
		f << x.direction << ',' << x.level << ',' << (x.slipped ? 1 : 0) << ',' << x.slip
		  << ',' << x.force << ',' << x.mu << ',' << x.acc << ',' << x.acc_se << ','
		  << (x.slip_at_end ? 1 : 0) << ',' << x.end_mu << ',' << x.end_rim_acc << ','
		  << x.early_mu << ',' << x.early_rim_acc << '\n';
	std::ofstream g(dir + "/traction.csv");
	g << "direction,runs,held,reached,mu,mu_se,acc,acc_se,level_held_v,level_slip_v\n";
	for (const TractionDirection &d : r.directions)
		g << d.direction << ',' << d.runs << ',' << d.held << ',' << (d.reached ? 1 : 0)
		  << ',' << d.mu << ',' << d.mu_se << ',' << d.acc << ',' << d.acc_se << ','
		  << d.level_held << ',' << d.level_slip << '\n';
}

bool write_traction_limits(FILE *f, const TractionResult &r)
{
	if (r.runs.empty())
		return true;
	bool ok = std::fprintf(f, "\n[limits]\n; the traction experiment: the floor's friction "
	                          "coefficient (mu +- SE, largest held acceleration +- SE)\n") > 0;
	for (const TractionDirection &d : r.directions)
		ok = ok &&
		     std::fprintf(f, "; %s: mu %s%.4f +- %.4f, held %.4g +- %.2g %s\n",
		                  d.direction.c_str(), d.reached ? "" : ">= ", d.mu, d.mu_se, d.acc,
		                  d.acc_se, d.direction == "w" ? "rad/s^2" : "m/s^2") > 0;
	if (r.ok)
		ok = ok && std::fprintf(f, "traction_mu = %.4f ; +- %.4f\n", r.mu, r.mu_se) > 0;
	else
		ok = ok &&
		     std::fprintf(f, "; traction_mu not measured (no slip along v, vn, w)\n") > 0;
	if (r.have_com)
		ok = ok && std::fprintf(f, "com_height = %.4f\n", r.com_height) > 0;
	return ok;
}

} // namespace omni4
