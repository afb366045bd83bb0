// identify_exp2.cpp - experiment 2 (eqs 17-20): Bv, Cv, Bvn, Cvn and J from coast-downs.
#include "identify_context.hpp"

#include <algorithm>
#include <cmath>

namespace omni4
{

namespace ident
{

namespace
{

// ---- experiment 2 (eqs 17-20) ----------------------------------------------------------

// x' = -b x - c along the axis while coasting (sign removed). Returns theta = [per window...,
// b, c] and fills the coast curves.
struct CoastFit {
	Fit f;
	bool ok = false;
};

// Encoder velocities, integral form: x(t) = x0_w - b int x dt - c (t - t0_w). No numerical
// differentiation. One row per valid encoder sample of the windows.
struct EncoderRow {
	size_t win;
	double t, x, integral;
};

std::vector<EncoderRow> encoder_coast_rows(const Context &c, const std::vector<SegWindow> &wins,
                                           int axis, int &half)
{
	std::vector<EncoderRow> rows;
	for (size_t wi = 0; wi < wins.size(); ++wi) {
		const SegWindow &w = wins[wi];
		const auto &enc = c.P.enc.at(w.s->log);
		half = enc.half;
		const size_t first = rows.size();
		double integral = 0;
		for (size_t k = w.w.m0; k < w.w.m1; ++k) {
			if (!enc.ok[k])
				continue;
			const double t = seg_time(*w.s, k), x = w.w.sign * enc.x[k][axis];
			if (rows.size() > first)
				integral += 0.5 * (x + rows.back().x) * (t - rows.back().t);
			rows.push_back({wi, t, x, integral});
		}
	}
	return rows;
}

// Each window's start time and means of x, the integral and the time since its start.
struct WindowMeans {
	std::vector<double> t0, n_w, my, mi, mt;
	size_t used = 0; // windows with rows

	WindowMeans(const std::vector<EncoderRow> &rows, size_t nw)
	    : t0(nw, NAN), n_w(nw, 0), my(nw, 0), mi(nw, 0), mt(nw, 0)
	{
		for (const EncoderRow &r : rows)
			if (std::isnan(t0[r.win]))
				t0[r.win] = r.t;
		for (const EncoderRow &r : rows) {
			n_w[r.win] += 1;
			my[r.win] += r.x;
			mi[r.win] += r.integral;
			mt[r.win] += r.t - t0[r.win];
		}
		for (size_t w = 0; w < nw; ++w) {
			if (n_w[w] == 0)
				continue;
			++used;
			my[w] /= n_w[w];
			mi[w] /= n_w[w];
			mt[w] /= n_w[w];
		}
	}
};

// theta = [x0 per window with rows..., b, c] of the shared fit bc; the fitted coast curves.
void encoder_coast_result(Context &c, const std::vector<SegWindow> &wins,
                          const std::vector<EncoderRow> &rows, const WindowMeans &wm, const Fit &bc,
                          double dof_fix, const std::string &dir, CoastFit &out)
{
	out.f.theta = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(wm.used) + 2);
	out.f.cov = Eigen::MatrixXd::Zero(out.f.theta.size(), out.f.theta.size());
	const Eigen::Index nb = out.f.theta.size() - 2;
	const double b = bc.theta[0], cc = bc.theta[1];
	std::vector<double> x0(wins.size(), NAN);
	Eigen::Index col = 0;
	for (size_t w = 0; w < wins.size(); ++w) {
		if (wm.n_w[w] == 0)
			continue;
		x0[w] = wm.my[w] + b * wm.mi[w] + cc * wm.mt[w];
		out.f.theta[col++] =
		    x0[w]; // intercepts: values only (their covariance is not used)
	}
	out.f.theta[nb] = b;
	out.f.theta[nb + 1] = cc;
	out.f.cov.bottomRightCorner(2, 2) = bc.cov * dof_fix;
	out.f.sigma2 = bc.sigma2 * dof_fix;
	out.f.n = bc.n;
	out.ok = true;
	for (const EncoderRow &r : rows)
		c.res.coast_curves[dir].push_back(
		    {wins[r.win].seg, r.t - wm.t0[r.win], r.x,
		     x0[r.win] - b * r.integral - cc * (r.t - wm.t0[r.win])});
}

CoastFit coast_fit_encoder(Context &c, const std::vector<SegWindow> &wins, int axis,
                           const std::string &dir)
{
	int half = 20;
	const std::vector<EncoderRow> rows = encoder_coast_rows(c, wins, axis, half);
	CoastFit out;
	if (rows.size() < 10)
		return out;
	// One x0 per window and shared b, c: the window intercepts are taken out by subtracting
	// each window's means (Frisch-Waugh-Lovell: the same b, c and covariance as the regression
	// with a column per window, without a QR of a matrix as wide as the windows are many).
	const WindowMeans wm(rows, wins.size());
	const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
	if (n <= static_cast<Eigen::Index>(wm.used + 2))
		throw IdentError("experiment 2 (coast-down along " + dir + "): too few samples");
	Eigen::MatrixXd X(n, 2);
	Eigen::VectorXd y(n);
	for (Eigen::Index k = 0; k < n; ++k) {
		const EncoderRow &r = rows[static_cast<size_t>(k)];
		X(k, 0) = -(r.integral - wm.mi[r.win]);
		X(k, 1) = -((r.t - wm.t0[r.win]) - wm.mt[r.win]);
		y[k] = r.x - wm.my[r.win];
	}
	const Fit bc =
	    least_squares(X, y, 2 * half + 1, "experiment 2 (coast-down along " + dir + ")");
	// Residual variance with the intercepts' degrees of freedom counted.
	const double dof_fix = static_cast<double>(n - 2) /
	                       static_cast<double>(n - 2 - static_cast<Eigen::Index>(wm.used));
	encoder_coast_result(c, wins, rows, wm, bc, dof_fix, dir, out);
	return out;
}

// Camera poses, in the position domain (no differentiation of 25 Hz poses): with p the
// displacement along the axis (robot frame) and tau the time since the window start,
// p = p0 + (x0 + b p0) tau - b int p dtau - c tau^2 / 2. One p0 and one slope per window.
struct CameraRow {
	size_t win;
	double tau, p, integral, measured;
};

// The displacement along axis between camera frames prev and k (robot frame).
double frame_step(const CameraTrack &ct, const std::vector<PoseSample> &pose, int axis, size_t prev,
                  size_t k)
{
	if (axis == 2)
		return ct.theta[k] - ct.theta[prev];
	const double h = std::isfinite(ct.heading[k]) && std::isfinite(ct.heading[prev])
	                     ? 0.5 * (ct.heading[k] + ct.heading[prev])
	                     : 0.5 * (ct.theta[k] + ct.theta[prev]);
	const double dx = pose[k].x - pose[prev].x, dy = pose[k].y - pose[prev].y;
	return axis == 0 ? std::cos(h) * dx + std::sin(h) * dy
	                 : -std::sin(h) * dx + std::cos(h) * dy;
}

// One row per camera frame of the windows; a window with fewer than 6 frames is rejected.
std::vector<CameraRow> camera_coast_rows(Context &c, const std::vector<SegWindow> &wins, int axis)
{
	std::vector<CameraRow> rows;
	for (size_t wi = 0; wi < wins.size(); ++wi) {
		const SegWindow &w = wins[wi];
		const CameraTrack &ct = c.P.cam.at(w.s->log);
		const auto &pose = w.s->log->pose;
		const auto &m = w.s->log->motors;
		const double ta = m[w.w.m0].utime * 1e-6, tb = m[w.w.m1 - 1].utime * 1e-6;
		size_t k = std::lower_bound(ct.t.begin(), ct.t.end(), ta) - ct.t.begin();
		const double t_first = k < ct.t.size() ? ct.t[k] : ta; // tau = 0 at the first frame
		const size_t first = rows.size();
		double p = 0, integral = 0;
		for (size_t prev = k; k < ct.t.size() && ct.t[k] <= tb; prev = k++) {
			if (k != prev)
				p += frame_step(ct, pose, axis, prev, k);
			const double ps = w.w.sign * p;
			const double tau = ct.t[k] - t_first;
			if (rows.size() > first)
				integral += 0.5 * (ps + rows.back().p) * (tau - rows.back().tau);
			rows.push_back(
			    {wi, tau, ps, integral, ct.ok[k] ? w.w.sign * ct.x[k][axis] : NAN});
		}
		if (rows.size() - first < 6) {
			c.reject(w, "coast-down", "fewer than 6 camera frames in the window");
			rows.resize(first);
		}
	}
	return rows;
}

// Fitted velocity x(tau) = x0 - b (p - p0) - c tau with x0 = slope - b p0, from the fit over
// the kept columns (p0 per window, slope per window, b, c).
void camera_coast_curves(Context &c, const std::vector<SegWindow> &wins,
                         const std::vector<CameraRow> &rows, const std::vector<Eigen::Index> &keep,
                         const Fit &f, const std::string &dir)
{
	const size_t nw = wins.size();
	const Eigen::Index nk = static_cast<Eigen::Index>(keep.size());
	const double b = f.theta[nk - 2], cc = f.theta[nk - 1];
	std::vector<double> p0(nw, 0), s0(nw, 0);
	for (Eigen::Index col = 0; col < nk - 2; ++col) {
		const size_t orig = static_cast<size_t>(keep[static_cast<size_t>(col)]);
		if (orig < nw)
			p0[orig] = f.theta[col];
		else
			s0[orig - nw] = f.theta[col];
	}
	for (const CameraRow &r : rows) {
		const double x0 = s0[r.win] - b * p0[r.win];
		c.res.coast_curves[dir].push_back(
		    {wins[r.win].seg, r.tau, r.measured, x0 - b * (r.p - p0[r.win]) - cc * r.tau});
	}
}

CoastFit coast_fit_camera(Context &c, const std::vector<SegWindow> &wins, int axis,
                          const std::string &dir)
{
	const std::vector<CameraRow> rows = camera_coast_rows(c, wins, axis);
	CoastFit out;
	if (rows.size() < 12)
		return out;
	const size_t nw = wins.size();
	Eigen::MatrixXd X = Eigen::MatrixXd::Zero(rows.size(), 2 * nw + 2);
	Eigen::VectorXd y(rows.size());
	for (size_t k = 0; k < rows.size(); ++k) {
		X(k, rows[k].win) = 1.0;
		X(k, nw + rows[k].win) = rows[k].tau;
		X(k, 2 * nw) = -rows[k].integral;
		X(k, 2 * nw + 1) = -0.5 * rows[k].tau * rows[k].tau;
		y[k] = rows[k].p;
	}
	std::vector<Eigen::Index> keep;
	for (size_t col = 0; col < 2 * nw + 2; ++col)
		if (X.col(col).cwiseAbs().sum() > 0)
			keep.push_back(col);
	Eigen::MatrixXd Xk(X.rows(), keep.size());
	for (size_t col = 0; col < keep.size(); ++col)
		Xk.col(col) = X.col(keep[col]);
	out.f = least_squares(Xk, y, 1.0, "experiment 2 (coast-down along " + dir + ", camera)");
	out.ok = true;
	camera_coast_curves(c, wins, rows, keep, out.f, dir);
	return out;
}

// J from the coast-down about w (its fit x' = -b x - c) and Bw, Cw of experiment 1: eq 20.
void coast_J(Context &c, const Estimate &b, const Estimate &cst)
{
	IdentResult &res = c.res;
	const auto &e1 = res.table["exp1"];
	const auto bw = e1.find("Bw"), cw = e1.find("Cw");
	if (bw == e1.end() || cw == e1.end()) {
		c.missing("J (experiment 2, eq 20): needs Bw and Cw of experiment 1");
		return;
	}
	const Estimate Bw = bw->second, Cw = cw->second;
	// eq 20 over the coast-down: J (b w + c) = Bw w + Cw in the least-squares sense.
	double num = 0, den = 0;
	for (const CurvePoint &p : res.coast_curves["w"]) {
		const double a = b.value * p.fitted + cst.value;
		num += a * (Bw.value * p.fitted + Cw.value);
		den += a * a;
	}
	const double J = num / den;
	// Relative errors of b, c (own) and of Bw, Cw (borrowed) add (first order).
	const double rel_own = std::hypot(b.se / b.value, cst.se / cst.value);
	const double rel_b = std::hypot(Bw.se / Bw.value, Cw.se / Cw.value);
	res.table["exp2"]["J"] = with_borrowed(J, std::abs(J) * rel_own, std::abs(J) * rel_b);
}

} // namespace

void experiment2(Context &c)
{
	IdentResult &res = c.res;
	const model_params &base = c.P.base;
	for (int axis = 0; axis < 3; ++axis) {
		const char *dir = kDirs[axis];
		const std::string names = axis == 0 ? "Bv, Cv" : axis == 1 ? "Bvn, Cvn" : "J";
		const auto wins = c.windows("coast", dir, &SegmentWindows::coast);
		if (wins.empty()) {
			const size_t nseg = c.segments_of("coast", dir);
			c.missing(names + " (experiment 2 along " + dir + "): " +
			          (nseg ? std::to_string(nseg) +
			                      " coast segments but no usable coast-down (see "
			                      "the rejected windows)"
			                : std::string("no coast segments")) +
			          "; " + record_hint("coast"));
			continue;
		}
		CoastFit cf;
		try {
			cf = c.P.opt.source == VelocitySource::Camera
			         ? coast_fit_camera(c, wins, axis, dir)
			         : coast_fit_encoder(c, wins, axis, dir);
		} catch (const IdentError &e) {
			c.missing(names + ": " + e.what());
			continue;
		}
		if (!cf.ok) {
			c.missing(names + " (experiment 2 along " + dir +
			          "): the coast-downs hold too few samples");
			continue;
		}
		const Fit &f = cf.f;
		const Eigen::Index nb = f.theta.size() - 2, nc = f.theta.size() - 1;
		const Estimate b{f.theta[nb], std::sqrt(f.cov(nb, nb))};
		const Estimate cst{f.theta[nc], std::sqrt(f.cov(nc, nc))};
		if (axis < 2) {
			const std::string B = axis == 0 ? "Bv" : "Bvn",
			                  C = axis == 0 ? "Cv" : "Cvn";
			res.table["exp2"][B] = {base.M * b.value, base.M * b.se}; // eqs 17-18
			res.table["exp2"][C] = {base.M * cst.value, base.M * cst.se};
			continue;
		}
		coast_J(c, b, cst);
	}
}

} // namespace ident

} // namespace omni4
