// encoders.cpp - tick intervals and once-per-revolution ripple of wheel speeds (encoders.hpp).
#include "encoders.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace omni4
{

namespace
{

// Centred moving average of y over [k - h, k + h] for the k of [a + h, b - h), by prefix sums
// (per block, so the sums stay small); other entries of out untouched.
void box(const std::vector<double> &y, size_t a, size_t b, int h, std::vector<double> &prefix,
         std::vector<double> &out)
{
	const size_t n = b - a, w = 2 * static_cast<size_t>(h) + 1;
	if (n < w)
		return;
	prefix.resize(n + 1);
	prefix[0] = 0;
	for (size_t i = 0; i < n; ++i)
		prefix[i + 1] = prefix[i] + y[a + i];
	for (size_t i = static_cast<size_t>(h); i + h < n; ++i)
		out[a + i] = (prefix[i + h + 1] - prefix[i - h]) / static_cast<double>(w);
}

double median_period_s(const std::vector<MotorsSample> &m)
{
	std::vector<int64_t> steps;
	steps.reserve(m.size());
	for (size_t k = 1; k < m.size(); ++k)
		if (m[k].seq == m[k - 1].seq + 1)
			steps.push_back(m[k].utime - m[k - 1].utime);
	if (steps.empty())
		return 0;
	std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
	return std::max<int64_t>(1, steps[steps.size() / 2]) * 1e-6;
}

} // namespace

TickRescale rescale_to_tick_intervals(LogData &log)
{
	TickRescale r;
	auto &m = log.motors;
	const size_t n = m.size();
	r.period_s = median_period_s(m);
	if (n < 16 || !(r.period_s > 0))
		return r;
	std::vector<double> f(n, 1.0);
	double jit2 = 0;
	size_t nj = 0;
	for (size_t k = 1; k < n; ++k) {
		if (m[k].seq != m[k - 1].seq + 1)
			continue;
		const double dt = (m[k].utime - m[k - 1].utime) * 1e-6;
		if (!(dt > 0.25 * r.period_s))
			continue; // a clock step: leave it
		f[k] = r.period_s / dt;
		jit2 += (dt - r.period_s) * (dt - r.period_s);
		++nj;
	}
	r.jitter_s = nj ? std::sqrt(jit2 / static_cast<double>(nj)) : 0;
	double s0 = 0, s1 = 0;
	size_t ns = 0;
	for (size_t k = 1; k + 1 < n; ++k) {
		if (m[k].seq != m[k - 1].seq + 1 || m[k + 1].seq != m[k].seq + 1)
			continue;
		for (int j = 0; j < 4; ++j) {
			const double a = m[k - 1].w[j], b = m[k].w[j], c = m[k + 1].w[j];
			s0 += (c - 2 * b + a) * (c - 2 * b + a);
			const double d2 = c * f[k + 1] - 2 * b * f[k] + a * f[k - 1];
			s1 += d2 * d2;
		}
		++ns;
	}
	if (ns == 0)
		return r;
	r.roughness_logged = s0 / static_cast<double>(4 * ns);
	r.roughness_rescaled = s1 / static_cast<double>(4 * ns);
	if (!(r.roughness_rescaled < 0.95 * r.roughness_logged))
		return r;
	for (size_t k = 0; k < n; ++k)
		for (int j = 0; j < 4; ++j)
			m[k].w[j] = static_cast<float>(m[k].w[j] * f[k]);
	r.applied = true;
	return r;
}

namespace
{

// Contiguous blocks [a, b) of samples (consecutive seq).
std::vector<std::pair<size_t, size_t>> contiguous_blocks(const std::vector<MotorsSample> &m)
{
	const size_t n = m.size();
	std::vector<std::pair<size_t, size_t>> blocks;
	for (size_t a = 0, k = 1; k <= n; ++k)
		if (k == n || m[k].seq != m[k - 1].seq + 1) {
			blocks.emplace_back(a, k);
			a = k;
		}
	return blocks;
}

// One fit per stretch of chunk_s, with its samples [m0, m1).
std::vector<RippleFit> stretches(const std::vector<MotorsSample> &m, double chunk_s)
{
	const size_t n = m.size();
	const int64_t t0 = m.front().utime;
	auto chunk_of = [&](size_t k) {
		return static_cast<size_t>((m[k].utime - t0) * 1e-6 / chunk_s);
	};
	const size_t nchunks = chunk_of(n - 1) + 1;
	std::vector<RippleFit> fits(nchunks);
	for (size_t c = 0, k = 0; c < nchunks; ++c) {
		fits[c].m0 = k;
		while (k < n && chunk_of(k) == c)
			++k;
		fits[c].m1 = k;
	}
	return fits;
}

// The fit runs on means of q consecutive samples (at least 4 ms: the ripple, at most a few
// tens of Hz, loses under 1 % of its amplitude in such a mean), inside contiguous blocks; the
// correction is applied to every sample. The work arrays of one motor at a time.
struct RippleWork {
	const std::vector<MotorsSample> &m;
	double gear, dt;
	size_t q = 1;
	int hd = 2;                                     // half box width in groups
	std::vector<size_t> first;                      // first sample of each group
	std::vector<std::pair<size_t, size_t>> dblocks; // blocks of groups
	std::vector<double> th, y, thd, ws, prefix;     // angle; group speed, angle, slow speed
	std::array<std::vector<double>, 2> g, gb;       // regressors and their slow part

	RippleWork(const std::vector<MotorsSample> &m_, double gear_, double dt_, int h);

	// Wheel angle of motor j: the logged speed over the nominal period; across lost ticks, the
	// mean of the speeds on either side. Then the group means of speed and angle.
	void angle_and_groups(int j);

	// The slow speed ws and the ripple's regressors g = ws (cos, sin)(gear angle), with their
	// slow parts gb.
	void regressors();

	// Normal equations of stretch f, on centres from i0 whose whole double window lies in one
	// block; advances i0 past the stretch. Returns the groups used.
	size_t normal_equations(const RippleFit &f, double min_speed, size_t &i0,
	                        Eigen::Matrix2d &A, Eigen::Vector2d &r, double &yy) const;
};

RippleWork::RippleWork(const std::vector<MotorsSample> &m_, double gear_, double dt_, int h)
    : m(m_), gear(gear_), dt(dt_)
{
	q = std::max<size_t>(1, static_cast<size_t>(0.004 / dt + 1e-9));
	hd = std::max(2, static_cast<int>(std::lround(static_cast<double>(h) / q)));
	for (const auto &[a, b] : contiguous_blocks(m)) {
		const size_t d0 = first.size();
		for (size_t k = a; k + q <= b; k += q)
			first.push_back(k);
		if (first.size() > d0)
			dblocks.emplace_back(d0, first.size());
	}
	const size_t nd = first.size();
	th.resize(m.size());
	y.resize(nd);
	thd.resize(nd);
	ws.assign(nd, NAN);
	for (auto &v : g)
		v.assign(nd, 0);
	for (auto &v : gb)
		v.assign(nd, NAN);
}

// Wheel angle of motor j: the logged speed over the nominal period; across lost ticks, the
// mean of the speeds on either side. Then the group means of speed and angle.
void RippleWork::angle_and_groups(int j)
{
	th[0] = 0;
	for (size_t k = 1; k < m.size(); ++k) {
		const int64_t gap = m[k].seq - m[k - 1].seq;
		const double missed = gap > 1 ? static_cast<double>(gap - 1) : 0.0;
		th[k] = th[k - 1] + dt * (m[k].w[j] + missed * 0.5 * (m[k].w[j] + m[k - 1].w[j]));
	}
	for (size_t i = 0; i < first.size(); ++i) {
		double sy = 0, st = 0;
		for (size_t k = first[i]; k < first[i] + q; ++k) {
			sy += m[k].w[j];
			st += th[k];
		}
		y[i] = sy / static_cast<double>(q);
		thd[i] = st / static_cast<double>(q);
	}
}

// The slow speed ws and the ripple's regressors g = ws (cos, sin)(gear angle), with their
// slow parts gb.
void RippleWork::regressors()
{
	for (const auto &[a, b] : dblocks)
		box(y, a, b, hd, prefix, ws); // the slow speed
	for (size_t i = 0; i < first.size(); ++i) {
		const double sp = std::isfinite(ws[i]) ? ws[i] : 0.0;
		if (std::abs(sp) < 1e-3) { // at rest: no ripple to carry
			g[0][i] = g[1][i] = 0;
			continue;
		}
		double sn, cs;
		::sincos(gear * thd[i], &sn, &cs); // glibc: one call for both
		g[0][i] = sp * cs;
		g[1][i] = sp * sn;
	}
	for (const auto &[a, b] : dblocks)
		for (int c = 0; c < 2; ++c)
			box(g[c], a, b, hd, prefix, gb[c]);
}

// Normal equations of stretch f, on centres from i0 whose whole double window lies in one
// block; advances i0 past the stretch. Returns the groups used.
size_t RippleWork::normal_equations(const RippleFit &f, double min_speed, size_t &i0,
                                    Eigen::Matrix2d &A, Eigen::Vector2d &r, double &yy) const
{
	const size_t nd = first.size();
	A = Eigen::Matrix2d::Zero();
	r = Eigen::Vector2d::Zero();
	yy = 0;
	size_t used = 0;
	for (const auto &[a, b] : dblocks) {
		const size_t h2 = 2 * static_cast<size_t>(hd);
		for (size_t i = std::max(a + h2, i0); i + h2 < b && first[i] < f.m1; ++i) {
			if (first[i] < f.m0 || !(std::abs(ws[i]) >= min_speed))
				continue;
			Eigen::Vector2d x;
			for (int c = 0; c < 2; ++c)
				x[c] = g[c][i] - gb[c][i];
			const double e = y[i] - ws[i];
			A += x * x.transpose();
			r += x * e;
			yy += e * e;
			++used;
		}
	}
	while (i0 < nd && first[i0] < f.m1)
		++i0;
	return used;
}

// Solves stretch f's normal equations for motor j and, if the ripple is significant, divides
// it out of the stretch's speeds.
void fit_and_remove(RippleWork &rw, RippleFit &f, int j, const Eigen::Matrix2d &A,
                    const Eigen::Vector2d &r, double yy, size_t used,
                    const EccentricityOptions &opt, std::vector<MotorsSample> &m)
{
	if (used < 50)
		return;
	Eigen::LDLT<Eigen::Matrix2d> ldlt(A);
	if (ldlt.info() != Eigen::Success)
		return;
	const Eigen::Vector2d coef = ldlt.solve(r);
	const double rss = std::max(0.0, yy - coef.dot(r));
	// The residual is mostly the encoder's quantisation noise, a difference of counts:
	// neighbours correlate negatively, so the white-noise variance does not understate it.
	const double sigma2 = rss / static_cast<double>(used - 2);
	const Eigen::Matrix2d cov = sigma2 * ldlt.solve(Eigen::Matrix2d::Identity());
	if (!cov.allFinite())
		return;
	f.motor_eps[j] = std::hypot(coef[0], coef[1]);
	f.motor_se[j] = std::sqrt(0.5 * (cov(0, 0) + cov(1, 1)));
	f.motor_removed[j] = f.motor_eps[j] > opt.significance * f.motor_se[j];
	if (!f.motor_removed[j])
		return;
	for (size_t k = f.m0; k < f.m1; ++k) {
		double sn, cs;
		::sincos(rw.gear * rw.th[k], &sn, &cs);
		m[k].w[j] = static_cast<float>(m[k].w[j] / (1 + coef[0] * cs + coef[1] * sn));
	}
}

} // namespace

std::vector<RippleFit> remove_encoder_ripple(LogData &log, double gear,
                                             const EccentricityOptions &opt)
{
	auto &m = log.motors;
	const size_t n = m.size();
	std::vector<RippleFit> fits;
	if (n < 16 || !(gear > 0))
		return fits;
	const double dt = median_period_s(m);
	if (!(dt > 0))
		return fits;
	const int h = std::max(2, static_cast<int>(std::lround(0.5 * opt.box_s / dt)));
	fits = stretches(m, opt.chunk_s);
	RippleWork rw(m, gear, dt, h);
	for (int j = 0; j < 4; ++j) {
		rw.angle_and_groups(j);
		rw.regressors();
		size_t i0 = 0;
		for (RippleFit &f : fits) {
			Eigen::Matrix2d A;
			Eigen::Vector2d r;
			double yy;
			const size_t used = rw.normal_equations(f, opt.min_speed, i0, A, r, yy);
			if (j == 0)
				f.samples = used * rw.q;
			fit_and_remove(rw, f, j, A, r, yy, used, opt, m);
		}
	}
	return fits;
}

} // namespace omni4
