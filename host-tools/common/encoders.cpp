// encoders.cpp - tick intervals and once-per-revolution ripple of wheel speeds (encoders.hpp).
#include "encoders.hpp"
#include "median.hpp"

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

// The median interval between consecutive samples (next seq).
double median_period_s(const std::vector<MotorsSample> &m)
{
	int64_t step = 0;
	const bool any = median_int64(
	    [&](auto visit) {
		    for (size_t k = 1; k < m.size(); ++k)
			    if (m[k].seq == m[k - 1].seq + 1)
				    visit(m[k].utime - m[k - 1].utime);
	    },
	    step);
	return any ? std::max<int64_t>(1, step) * 1e-6 : 0;
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
	// Sample k's factor (nominal period / true interval; 1 after a lost sample or a clock step)
	auto f = [&m, period = r.period_s](size_t k) {
		if (k == 0 || m[k].seq != m[k - 1].seq + 1)
			return 1.0;
		const double dt = (m[k].utime - m[k - 1].utime) * 1e-6;
		return dt > 0.25 * period ? period / dt : 1.0;
	};
	// One pass: the jitter of interval k (k = 1 .. n - 1 in order) and the second differences
	// around sample k, logged and rescaled.
	double jit2 = 0, s0 = 0, s1 = 0;
	size_t nj = 0, ns = 0;
	auto jitter = [&](size_t k) {
		if (m[k].seq != m[k - 1].seq + 1)
			return;
		const double dt = (m[k].utime - m[k - 1].utime) * 1e-6;
		if (!(dt > 0.25 * r.period_s))
			return; // a clock step: leave it
		jit2 += (dt - r.period_s) * (dt - r.period_s);
		++nj;
	};
	jitter(1);
	double fa = f(0), fb = f(1);
	for (size_t k = 1; k + 1 < n; ++k) {
		jitter(k + 1);
		const double fc = f(k + 1);
		if (m[k].seq == m[k - 1].seq + 1 && m[k + 1].seq == m[k].seq + 1) {
			for (int j = 0; j < 4; ++j) {
				const double a = m[k - 1].w[j], b = m[k].w[j], c = m[k + 1].w[j];
				s0 += (c - 2 * b + a) * (c - 2 * b + a);
				const double d2 = c * fc - 2 * b * fb + a * fa;
				s1 += d2 * d2;
			}
			++ns;
		}
		fa = fb;
		fb = fc;
	}
	r.jitter_s = nj ? std::sqrt(jit2 / static_cast<double>(nj)) : 0;
	if (ns == 0)
		return r;
	r.roughness_logged = s0 / static_cast<double>(4 * ns);
	r.roughness_rescaled = s1 / static_cast<double>(4 * ns);
	if (!(r.roughness_rescaled < 0.95 * r.roughness_logged))
		return r;
	for (size_t k = 0; k < n; ++k) {
		const double fk = f(k);
		for (int j = 0; j < 4; ++j)
			m[k].w[j] = static_cast<float>(m[k].w[j] * fk);
	}
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

// One stretch's regression rows for a motor: the detrended regressors x, the detrended speed e,
// and each row's group index and block (its cluster in the standard error).
struct RippleRows {
	std::vector<Eigen::Vector2d> x;
	std::vector<double> e;
	std::vector<size_t> group, block;
	void clear()
	{
		x.clear();
		e.clear();
		group.clear();
		block.clear();
	}
};

// The fit runs on means of q consecutive samples (at least 4 ms: the ripple, at most a few
// tens of Hz, loses under 1 % of its amplitude in such a mean), inside contiguous blocks; the
// correction is applied to every sample. The group means of the four motors come from one
// pass over the samples; the other work arrays serve one motor at a time.
struct RippleWork {
	const std::vector<MotorsSample> &m;
	double gear, dt;
	size_t q = 1;
	int hd = 2;                                     // half box width in groups
	std::vector<size_t> first;                      // first sample of each group
	std::vector<std::pair<size_t, size_t>> dblocks; // blocks of groups
	std::array<std::vector<double>, 4> y, thd;      // per motor: group speed and angle
	std::vector<std::array<double, 4>> th0;         // per stretch: angles at its first sample
	std::vector<double> ws, prefix;                 // slow speed
	std::array<std::vector<double>, 2> g, gb;       // regressors and their slow part

	RippleWork(const std::vector<MotorsSample> &m_, double gear_, double dt_, int h);

	// Angle step into sample k (k >= 1) of a wheel whose speed is w there and wp before: the
	// logged speed over the nominal period; across lost ticks, the mean of the speeds on
	// either side.
	double angle_step(size_t k, float w, float wp) const
	{
		const int64_t gap = m[k].seq - m[k - 1].seq;
		const double missed = gap > 1 ? static_cast<double>(gap - 1) : 0.0;
		return dt * (w + missed * 0.5 * (w + wp));
	}

	// The wheel angles of the four motors in one pass (angle 0 at the first sample): the group
	// means of speed and angle, and the angles where each stretch of fits starts.
	void angles_and_groups(const std::vector<RippleFit> &fits);

	// The slow speed ws and motor j's ripple regressors g = ws (cos, sin)(gear angle), with
	// their slow parts gb.
	void regressors(int j);

	// The rows of stretch f's regression (centres from i0 whose whole double window lies in
	// one block; advances i0 past the stretch).
	void rows(const RippleFit &f, int j, double min_speed, size_t &i0, RippleRows &out) const;
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
	for (int j = 0; j < 4; ++j) {
		y[j].resize(nd);
		thd[j].resize(nd);
	}
	ws.assign(nd, NAN);
	for (auto &v : g)
		v.assign(nd, 0);
	for (auto &v : gb)
		v.assign(nd, NAN);
}

void RippleWork::angles_and_groups(const std::vector<RippleFit> &fits)
{
	std::array<double, 4> th{}, sy{}, st{};
	th0.assign(fits.size(), {});
	const double qd = static_cast<double>(q);
	size_t gi = 0, fi = 0;
	for (size_t k = 0; k < m.size(); ++k) {
		if (k > 0)
			for (int j = 0; j < 4; ++j)
				th[j] += angle_step(k, m[k].w[j], m[k - 1].w[j]);
		for (; fi < fits.size() && fits[fi].m0 == k; ++fi)
			th0[fi] = th;
		if (gi == first.size() || k < first[gi])
			continue;
		for (int j = 0; j < 4; ++j) {
			sy[j] += m[k].w[j];
			st[j] += th[j];
		}
		if (k + 1 < first[gi] + q)
			continue;
		for (int j = 0; j < 4; ++j) {
			y[j][gi] = sy[j] / qd;
			thd[j][gi] = st[j] / qd;
			sy[j] = st[j] = 0;
		}
		++gi;
	}
}

// The slow speed ws and motor j's ripple regressors g = ws (cos, sin)(gear angle), with
// their slow parts gb.
void RippleWork::regressors(int j)
{
	for (const auto &[a, b] : dblocks)
		box(y[j], a, b, hd, prefix, ws); // the slow speed
	for (size_t i = 0; i < first.size(); ++i) {
		const double sp = std::isfinite(ws[i]) ? ws[i] : 0.0;
		if (std::abs(sp) < 1e-3) { // at rest: no ripple to carry
			g[0][i] = g[1][i] = 0;
			continue;
		}
		double sn, cs;
		::sincos(gear * thd[j][i], &sn, &cs); // glibc: one call for both
		g[0][i] = sp * cs;
		g[1][i] = sp * sn;
	}
	for (const auto &[a, b] : dblocks)
		for (int c = 0; c < 2; ++c)
			box(g[c], a, b, hd, prefix, gb[c]);
}

// The rows of stretch f's regression, on centres from i0 whose whole double window lies in one
// block; advances i0 past the stretch.
void RippleWork::rows(const RippleFit &f, int j, double min_speed, size_t &i0,
                      RippleRows &out) const
{
	const size_t nd = first.size();
	out.clear();
	for (size_t bi = 0; bi < dblocks.size(); ++bi) {
		const auto [a, b] = dblocks[bi];
		const size_t h2 = 2 * static_cast<size_t>(hd);
		for (size_t i = std::max(a + h2, i0); i + h2 < b && first[i] < f.m1; ++i) {
			if (first[i] < f.m0 || !(std::abs(ws[i]) >= min_speed))
				continue;
			out.x.emplace_back(g[0][i] - gb[0][i], g[1][i] - gb[1][i]);
			out.e.push_back(y[j][i] - ws[i]);
			out.group.push_back(i);
			out.block.push_back(bi);
		}
	}
	while (i0 < nd && first[i0] < f.m1)
		++i0;
}

// The clusters of a stretch's rows: runs of consecutive groups in one block, each at most
// `len` groups long. Returns each row's cluster and their count.
size_t ripple_clusters(const RippleRows &rw, size_t len, std::vector<size_t> &cluster)
{
	const size_t n = rw.e.size();
	cluster.resize(n);
	size_t c = 0, start = 0;
	for (size_t i = 0; i < n; ++i) {
		if (i > 0 &&
		    (rw.block[i] != rw.block[i - 1] || rw.group[i] != rw.group[i - 1] + 1 ||
		     rw.group[i] - rw.group[start] >= len)) {
			++c;
			start = i;
		}
		cluster[i] = c;
	}
	return n ? c + 1 : 0;
}

// Covariance of the least-squares coefficients from the scores x_i u_i summed per cluster
// (cluster-robust: the residuals may correlate within a cluster, not across), with the small-
// sample factor G / (G - 1). The residual is not white: besides the encoder's quantisation noise
// it carries what the moving average does not follow of the speed (a step's corners, a wheel
// breaking loose and gripping again), tenths of a second long; counted as independent samples
// it made a round disc's ripple significant in a quarter of a traction run's stretches.
Eigen::Matrix2d ripple_covariance(const RippleRows &rw, const Eigen::Vector2d &coef,
                                  const Eigen::LDLT<Eigen::Matrix2d> &ldlt,
                                  const std::vector<size_t> &cluster, size_t nclusters)
{
	std::vector<Eigen::Vector2d> score(nclusters, Eigen::Vector2d::Zero());
	for (size_t i = 0; i < rw.e.size(); ++i)
		score[cluster[i]] += rw.x[i] * (rw.e[i] - rw.x[i].dot(coef));
	Eigen::Matrix2d omega = Eigen::Matrix2d::Zero();
	for (const Eigen::Vector2d &sc : score)
		omega += sc * sc.transpose();
	const Eigen::Matrix2d ainv = ldlt.solve(Eigen::Matrix2d::Identity());
	const double g = static_cast<double>(nclusters);
	return g / (g - 1) * ainv * omega * ainv;
}

// Solves stretch f's regression for motor j and, if the ripple is significant, divides it out of
// the stretch's speeds.
void fit_and_remove(RippleWork &rw, RippleFit &f, size_t fi, int j, const RippleRows &rows,
                    const EccentricityOptions &opt, std::vector<MotorsSample> &m)
{
	const size_t used = rows.e.size();
	if (used < 50)
		return;
	Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
	Eigen::Vector2d r = Eigen::Vector2d::Zero();
	for (size_t i = 0; i < used; ++i) {
		A += rows.x[i] * rows.x[i].transpose();
		r += rows.x[i] * rows.e[i];
	}
	Eigen::LDLT<Eigen::Matrix2d> ldlt(A);
	if (ldlt.info() != Eigen::Success)
		return;
	const Eigen::Vector2d coef = ldlt.solve(r);
	const size_t len = std::max<size_t>(
	    1,
	    static_cast<size_t>(std::lround(opt.cluster_s / (static_cast<double>(rw.q) * rw.dt))));
	std::vector<size_t> cluster;
	const size_t nc = ripple_clusters(rows, len, cluster);
	f.motor_clusters[j] = static_cast<int>(nc);
	if (nc < 4)
		return; // too few independent stretches to tell a ripple from the speed's corners
	const Eigen::Matrix2d cov = ripple_covariance(rows, coef, ldlt, cluster, nc);
	if (!cov.allFinite())
		return;
	f.motor_eps[j] = std::hypot(coef[0], coef[1]);
	f.motor_se[j] = std::sqrt(0.5 * (cov(0, 0) + cov(1, 1)));
	// Hotelling: (G - 2) T^2 / (2 (G - 1)) is F(2, G - 2) with G clusters, whose upper tail is
	// (1 + 2 F / (G - 2))^(-(G - 2) / 2); it is set beside a normal pair's amplitude of z SE,
	// exp(-z^2 / 2), and given as that z.
	const Eigen::LDLT<Eigen::Matrix2d> cl(cov);
	const double t2 =
	    cl.info() == Eigen::Success ? std::max(0.0, coef.dot(cl.solve(coef))) : 0.0;
	const double g = static_cast<double>(nc), fstat = (g - 2) * t2 / (2 * (g - 1));
	const double log_p = -0.5 * (g - 2) * std::log1p(2 * fstat / (g - 2));
	f.motor_z[j] = std::sqrt(-2 * log_p);
	f.motor_removed[j] = f.motor_z[j] > opt.significance;
	if (!f.motor_removed[j])
		return;
	// The angles again from the stretch's first (as in angles_and_groups, on the speeds as
	// logged: wp keeps the previous sample's before its correction).
	double th = rw.th0[fi][j];
	float wp = 0;
	for (size_t k = f.m0; k < f.m1; ++k) {
		const float w = m[k].w[j];
		if (k > f.m0)
			th += rw.angle_step(k, w, wp);
		wp = w;
		double sn, cs;
		::sincos(rw.gear * th, &sn, &cs);
		m[k].w[j] = static_cast<float>(w / (1 + coef[0] * cs + coef[1] * sn));
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
	rw.angles_and_groups(fits);
	RippleRows rows;
	// Below this speed the ripple's period is longer than box_s / min_cycles: the moving
	// average takes most of it out with the slow speed, from the data and the regressors
	// alike, and what is left cannot be told from the speed's own bends.
	const double min_speed =
	    std::max(opt.min_speed, opt.min_cycles * 2 * M_PI / (gear * opt.box_s));
	for (int j = 0; j < 4; ++j) {
		rw.regressors(j);
		size_t i0 = 0;
		for (size_t fi = 0; fi < fits.size(); ++fi) {
			RippleFit &f = fits[fi];
			rw.rows(f, j, min_speed, i0, rows);
			if (j == 0)
				f.samples = rows.e.size() * rw.q;
			fit_and_remove(rw, f, fi, j, rows, opt, m);
		}
	}
	return fits;
}

} // namespace omni4
