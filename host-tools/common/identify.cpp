// identify.cpp - motor test, experiments 1-3 on the windows found in the data, and their
// combination.
#include "identify.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <numeric>
#include <thread>

extern "C" {
#include "omni4/dynamics.h"
}

namespace omni4
{

const char *const kIdentParams[9] = {"Kv", "R", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw"};
const char *const kIdentMethods[6] = {"motor", "exp1", "exp2", "exp3_ls", "exp3_iv", "final"};

bool IdentResult::complete() const
{
	for (const char *p : kIdentParams) {
		const auto it = identified.find(p);
		if (it == identified.end() || !it->second)
			return false;
	}
	return true;
}

Estimate find_estimate(const IdentResult &r, const char *method, const char *param)
{
	const auto m = r.table.find(method);
	if (m == r.table.end())
		return {};
	const auto p = m->second.find(param);
	return p == m->second.end() ? Estimate{} : p->second;
}

double chi2_sf(double x, int dof)
{
	if (dof <= 0)
		return 1.0;
	if (!(x > 0))
		return 1.0;
	// Closed forms of the regularised upper incomplete gamma Q(dof/2, x/2) for integer dof.
	const double h = 0.5 * x;
	if (dof % 2 == 0) {
		double term = 1, sum = 1;
		for (int j = 1; j < dof / 2; ++j)
			sum += (term *= h / j);
		return std::exp(-h) * sum;
	}
	double term = std::sqrt(2 * x / M_PI) * std::exp(-h);
	double sum = 0;
	for (int j = 1; j <= (dof - 1) / 2; ++j) {
		sum += term;
		term *= x / (2 * j + 1);
	}
	return std::erfc(std::sqrt(h)) + sum;
}

namespace
{

// Two or more estimates: their inverse-variance weighted mean (each SE raised to at least
// method_floor of its value) when their chi-square agrees, else their plain mean.
Estimate combine_several(const std::vector<Estimate> &ok, const IdentOptions &opt, Agreement &ag)
{
	double wsum = 0, vsum = 0;
	std::vector<double> se(ok.size());
	for (size_t k = 0; k < ok.size(); ++k) {
		const double s = std::isfinite(ok[k].se) ? ok[k].se : 0.0;
		se[k] = std::max(std::hypot(s, opt.method_floor * std::abs(ok[k].value)), 1e-300);
		wsum += 1 / (se[k] * se[k]);
		vsum += ok[k].value / (se[k] * se[k]);
	}
	const double mean = vsum / wsum;
	for (size_t k = 0; k < ok.size(); ++k)
		ag.chi2 += std::pow((ok[k].value - mean) / se[k], 2);
	ag.dof = static_cast<int>(ok.size()) - 1;
	ag.p = chi2_sf(ag.chi2, ag.dof);
	ag.agree = ag.p >= opt.agree_p;
	if (ag.agree) {
		// The borrowed variance of a weighted mean, with the weights taken as fixed.
		double vb = 0;
		for (size_t k = 0; k < ok.size(); ++k)
			vb += std::pow(ok[k].se_borrowed / (se[k] * se[k] * wsum), 2);
		ag.rule = "weighted mean";
		return {mean, std::sqrt(1 / wsum), std::sqrt(vb)};
	}
	double m = 0, ss = 0;
	for (const Estimate &e : ok)
		m += e.value / static_cast<double>(ok.size());
	double vb = 0;
	for (const Estimate &e : ok) {
		ss += (e.value - m) * (e.value - m);
		vb += std::pow(e.se_borrowed / static_cast<double>(ok.size()), 2);
	}
	const double se_m =
	    std::sqrt(ss / static_cast<double>(ok.size() - 1) / static_cast<double>(ok.size()));
	ag.rule = "methods disagree: plain mean";
	return {m, se_m, std::min(se_m, std::sqrt(vb))};
}

} // namespace

Estimate combine_methods(const std::vector<Estimate> &estimates, const IdentOptions &opt,
                         Agreement *agreement)
{
	Agreement ag;
	std::vector<Estimate> ok, weak;
	for (const Estimate &e : estimates) {
		if (!e.ok())
			continue;
		// An estimate whose SE exceeds max_rel_se of its value neither informs nor checks
		// the others: it is reported, not combined (unless it is the only one).
		(std::abs(e.se) > opt.max_rel_se * std::abs(e.value) ? weak : ok).push_back(e);
	}
	ag.methods = static_cast<int>(ok.size());
	ag.too_uncertain = static_cast<int>(weak.size());
	if (ok.empty() && !weak.empty()) // all weak: the least uncertain one
		ok.push_back(*std::min_element(
		    weak.begin(), weak.end(), [](const Estimate &a, const Estimate &b) {
			    return std::abs(a.se / a.value) < std::abs(b.se / b.value);
		    }));
	Estimate out;
	if (ok.empty()) {
		ag.rule = "no method";
	} else if (ok.size() == 1) {
		out = ok[0];
		ag.rule = weak.empty() ? "one method" : "one method (the other too uncertain)";
	} else {
		out = combine_several(ok, opt, ag);
	}
	if (agreement)
		*agreement = ag;
	return out;
}

double axis_input(const double u_v[4], int axis)
{
	switch (axis) {
	case 0:
		return u_v[3] - u_v[1];
	case 1:
		return u_v[0] - u_v[2];
	default:
		return u_v[0] + u_v[1] + u_v[2] + u_v[3];
	}
}

// Inverting dyn_state_space: with b = l Kt / (r R) (eq 26) and emf = Kt Kv l^2 / (r^2 R),
//   along v, vn: theta2 = b / M,     theta1 = -(2 emf + B) / M,       theta3 = -C / M;
//   along w:     theta2 = b d / J,   theta1 = -(4 d^2 emf + Bw) / J,  theta3 = -Cw / J.
double R_from_theta2(const model_params &p, int /*axis*/, double theta2)
{
	return p.l * p.Kt / (p.r * p.M * theta2);
}
double J_from_theta2(const model_params &p, double theta2)
{
	return p.l * p.Kt * p.d / (p.r * p.R * theta2);
}
double B_from_theta1(const model_params &p, int axis, double theta1)
{
	const double emf = p.Kt * p.Kv * p.l * p.l / (p.r * p.r * p.R);
	return axis < 2 ? -p.M * theta1 - 2 * emf : -p.J * theta1 - 4 * p.d * p.d * emf;
}
double C_from_theta3(const model_params &p, int axis, double theta3)
{
	return -(axis < 2 ? p.M : p.J) * theta3;
}

namespace
{

constexpr const char *kDirs[3] = {"v", "vn", "w"};

double sgn(double x)
{
	return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0);
}

// A window together with its segment.
struct SegWindow {
	size_t seg;
	const Segment *s;
	Window w;
};

struct Context {
	const Prepared &P;
	const std::vector<size_t> &use;
	IdentResult &res;

	std::vector<SegWindow> windows(const char *kind, const char *dir,
	                               std::vector<Window> SegmentWindows::*which) const
	{
		std::vector<SegWindow> out;
		for (size_t i : use) {
			const Segment &s = P.segments[i];
			if (s.kind != kind || (dir && s.direction != dir))
				continue;
			for (const Window &w : P.windows[i].*which)
				out.push_back({i, &s, w});
		}
		return out;
	}
	size_t segments_of(const char *kind, const char *dir) const
	{
		size_t n = 0;
		for (size_t i : use)
			n += P.segments[i].kind == kind && (!dir || P.segments[i].direction == dir);
		return n;
	}
	void reject(const SegWindow &w, const std::string &what, const std::string &reason)
	{
		res.windows.push_back({w.seg, w.s->kind, w.s->direction, what,
		                       seg_time(*w.s, w.w.m0), seg_time(*w.s, w.w.m1 - 1), false,
		                       reason});
	}
	void missing(const std::string &line)
	{
		res.missing.push_back(line);
	}

	// Index into P.offset_epochs of the offsets in force at sample k of log (-1: none).
	int epoch_of(const LogData *log, size_t k) const
	{
		for (size_t e = 0; e < P.offset_epochs.size(); ++e) {
			const auto &[l, i] = P.offset_epochs[e];
			if (l == log && k >= l->current_offsets[i].m0 &&
			    k < l->current_offsets[i].m1)
				return static_cast<int>(e);
		}
		return -1;
	}
	// Standard errors of the offsets, 4 per epoch (the inputs of propagate_independent).
	Eigen::VectorXd offset_se() const
	{
		Eigen::VectorXd se(4 * static_cast<Eigen::Index>(P.offset_epochs.size()));
		for (size_t e = 0; e < P.offset_epochs.size(); ++e)
			for (int j = 0; j < 4; ++j)
				se[static_cast<Eigen::Index>(4 * e + j)] =
				    P.offset_epochs[e]
				        .first->current_offsets[P.offset_epochs[e].second]
				        .se_a[j];
		return se;
	}
};

// value with its own SE and the borrowed part added in quadrature.
Estimate with_borrowed(double value, double se_own, double se_borrowed)
{
	return {value, std::hypot(se_own, se_borrowed), se_borrowed};
}

std::string record_hint(const char *kind)
{
	const std::string k = kind;
	if (k == "coast")
		return "record them with 'omni4-ident run --only coast' (motor push) or "
		       "'omni4-ident run "
		       "--hand' (push by hand, bridges off)";
	return "record them with 'omni4-ident run --only " + k + "'";
}

// Mean of motors samples [a, b) of log m.
template <typename F> double mean_over(const std::vector<MotorsSample> &m, size_t a, size_t b, F f)
{
	double s = 0;
	for (size_t k = a; k < b; ++k)
		s += f(m[k]);
	return s / static_cast<double>(b - a);
}

// ---- motor test (eq 22) ----------------------------------------------------------------

// Eq 22 holds in every steady state with the bridges driven: the steady rotation windows of
// experiment 1 add their four motors' points to the motor test's. One point per driven motor
// and window: mean voltage, current and motor speed.
void collect_motor_points(Context &c)
{
	const double l = c.P.base.l;
	auto wins = c.windows("motor", nullptr, &SegmentWindows::steady);
	const auto rot = c.windows("steady_rotation", nullptr, &SegmentWindows::steady);
	wins.insert(wins.end(), rot.begin(), rot.end());
	for (const SegWindow &w : wins) {
		const auto &m = w.s->log->motors;
		for (int j = 0; j < 4; ++j) {
			const double u = mean_over(m, w.w.m0, w.w.m1,
			                           [&](const MotorsSample &s) { return s.u[j]; });
			const double i = mean_over(m, w.w.m0, w.w.m1,
			                           [&](const MotorsSample &s) { return s.i[j]; });
			const double wm =
			    l * mean_over(m, w.w.m0, w.w.m1,
			                  [&](const MotorsSample &s) { return s.w[j]; });
			if (std::abs(u) < 0.5)
				continue; // this motor is not driven in this run
			if (std::abs(i) < 0.05) {
				c.reject(w, "motor " + std::to_string(j) + " point",
				         "current " + std::to_string(i) + " A too small for u/i");
				continue;
			}
			c.res.motor_points.push_back({j, u, i, wm, c.epoch_of(w.s->log, w.w.m0)});
		}
	}
}

// Fit of one motor (or all: -1) with the offset of every epoch moved by delta (4 per epoch):
// the residual offsets' uncertainty is borrowed through it.
Fit fit_motor(const std::vector<MotorPoint> &points, int motor, const Eigen::VectorXd *delta)
{
	std::vector<const MotorPoint *> pts;
	for (const MotorPoint &p : points)
		if (motor < 0 || p.motor == motor)
			pts.push_back(&p);
	// Eq 22 as i = u / R - (Kv / R) w: the noise is in the measured current (the voltage is
	// what was applied and the window's mean speed is far more precise), so the current is
	// the regressand; Kv = -c_w / c_u and R = 1 / c_u, their covariance by propagation.
	Eigen::MatrixXd X(pts.size(), 2);
	Eigen::VectorXd y(pts.size());
	for (size_t k = 0; k < pts.size(); ++k) {
		double i = pts[k]->i;
		if (delta && pts[k]->epoch >= 0)
			i -= (*delta)[4 * pts[k]->epoch + pts[k]->motor];
		X(k, 0) = pts[k]->u;
		X(k, 1) = pts[k]->wm;
		y[k] = i;
	}
	const std::string what = motor < 0 ? "motor test (all motors)"
	                                   : "motor test (motor " + std::to_string(motor) + ")";
	const Fit g = least_squares(X, y, 1.0, what);
	if (!(g.theta[0] > 0))
		throw IdentError(what + ": the current does not grow with the voltage");
	Fit f = g;
	f.theta[0] = -g.theta[1] / g.theta[0]; // Kv
	f.theta[1] = 1 / g.theta[0];           // R
	Eigen::Matrix2d J;                     // d(Kv, R) / d(c_u, c_w)
	J << g.theta[1] / (g.theta[0] * g.theta[0]), -1 / g.theta[0],
	    -1 / (g.theta[0] * g.theta[0]), 0;
	f.cov = J * g.cov * J.transpose();
	return f;
}

// What the fit of one motor (or all: -1) borrows from the current offsets' standard errors.
Eigen::VectorXd motor_borrowed(const std::vector<MotorPoint> &points, int motor,
                               const Eigen::VectorXd &off_se)
{
	return propagate_independent(
	    [&](const Eigen::VectorXd &d) -> Eigen::VectorXd {
		    return fit_motor(points, motor, &d).theta;
	    },
	    Eigen::VectorXd::Zero(off_se.size()), off_se);
}

// The sums of the per-motor R (value, own and borrowed variance) the paper averages.
struct RSum {
	double sum = 0, var = 0, var_b = 0;
	int n = 0;
};

// Kv and R of motor j from its own points (at least 3), added to rs.
void fit_one_motor(Context &c, int j, const Eigen::VectorXd &off_se, RSum &rs)
{
	IdentResult &res = c.res;
	const size_t n = std::count_if(res.motor_points.begin(), res.motor_points.end(),
	                               [&](const MotorPoint &p) { return p.motor == j; });
	if (n < 3) {
		c.missing("R" + std::to_string(j) + ", Kv" + std::to_string(j) + " (motor " +
		          std::to_string(j) + "): " + std::to_string(n) +
		          " steady points with the motor driven, need 3 at different loads; the "
		          "pooled Kv and R come from the other motors");
		return;
	}
	try {
		const Fit f = fit_motor(res.motor_points, j, nullptr);
		const Eigen::VectorXd b = motor_borrowed(res.motor_points, j, off_se);
		res.Kv_motor[j] = with_borrowed(f.theta[0], std::sqrt(f.cov(0, 0)), b[0]);
		res.R_motor[j] = with_borrowed(f.theta[1], std::sqrt(f.cov(1, 1)), b[1]);
		rs.sum += f.theta[1];
		rs.var += f.cov(1, 1);
		rs.var_b += b[1] * b[1];
		++rs.n;
	} catch (const IdentError &e) {
		c.missing(std::string(e.what()) +
		          " (the runs give one operating point: vary the load)");
	}
}

void motor_test(Context &c)
{
	IdentResult &res = c.res;
	if (c.segments_of("motor", nullptr) == 0) {
		c.missing("Kv, R (motor test, eq 22): no 'motor' segments; " +
		          record_hint("motor"));
		return;
	}
	collect_motor_points(c);
	const Eigen::VectorXd off_se = c.offset_se();
	RSum rs;
	for (int j = 0; j < 4; ++j)
		fit_one_motor(c, j, off_se, rs);
	try {
		const Fit all = fit_motor(res.motor_points, -1, nullptr);
		res.table["motor"]["Kv"] =
		    with_borrowed(all.theta[0], std::sqrt(all.cov(0, 0)),
		                  motor_borrowed(res.motor_points, -1, off_se)[0]);
	} catch (const IdentError &e) {
		c.missing(std::string("Kv: ") + e.what());
	}
	// The paper averages R over the motors (here: over those with a fit). The motors' borrowed
	// parts are taken as independent (each motor has its own channel's offset).
	if (rs.n > 0)
		res.table["motor"]["R"] = with_borrowed(rs.sum / rs.n, std::sqrt(rs.var) / rs.n,
		                                        std::sqrt(rs.var_b) / rs.n);
	else
		c.missing("R (motor test): no motor has enough steady points");
}

// ---- experiment 1 (eq 16) ----------------------------------------------------------------

double slope(const std::vector<double> &t, const std::vector<double> &y)
{
	const double n = static_cast<double>(t.size());
	const double tm = std::accumulate(t.begin(), t.end(), 0.0) / n;
	const double ym = std::accumulate(y.begin(), y.end(), 0.0) / n;
	double num = 0, den = 0;
	for (size_t k = 0; k < t.size(); ++k) {
		num += (t[k] - tm) * (y[k] - ym);
		den += (t[k] - tm) * (t[k] - tm);
	}
	return den > 0 ? num / den : NAN;
}

// Camera: slope of the unwrapped heading over the window (NaN with fewer than 5 frames).
double camera_rate(const CameraTrack &ct, double ta, double tb)
{
	std::vector<double> t, th;
	for (size_t k = std::lower_bound(ct.t.begin(), ct.t.end(), ta) - ct.t.begin();
	     k < ct.t.size() && ct.t[k] <= tb; ++k) {
		t.push_back(ct.t[k]);
		th.push_back(ct.theta[k]);
	}
	return t.size() >= 5 ? slope(t, th) : NAN;
}

// The point of one steady rotation window (mean currents, their torque, encoder and camera
// rates) into res.rotation_points, or the window rejected.
void rotation_point(Context &c, const model_params &p, bool cam, const SegWindow &w)
{
	const auto &m = w.s->log->motors;
	const auto &enc = c.P.enc.at(w.s->log);
	double imean[4] = {0, 0, 0, 0}, wenc = 0;
	for (size_t k = w.w.m0; k < w.w.m1; ++k) {
		for (int j = 0; j < 4; ++j)
			imean[j] += m[k].i[j];
		wenc += enc.raw[k][2];
	}
	const double n = static_cast<double>(w.w.m1 - w.w.m0);
	for (double &i : imean)
		i /= n;
	wenc /= n;
	if (std::abs(wenc) < kStopSpeed[2]) {
		c.reject(w, "steady window",
		         "the robot did not turn (stiction): w " + std::to_string(wenc));
		return;
	}
	// The torque of the mean currents (eqs 11-13, linear in the currents): model/'s forces.
	double f[4], robot_f[3];
	dyn_wheel_forces(&p, imean, f);
	dyn_robot_forces(p.d, f, robot_f);
	const double torque = robot_f[2];
	const double wcam =
	    camera_rate(c.P.cam.at(w.s->log), m[w.w.m0].utime * 1e-6, m[w.w.m1 - 1].utime * 1e-6);
	if (cam && !std::isfinite(wcam)) {
		c.reject(w, "steady window", "fewer than 5 camera frames in the window");
		return;
	}
	RotationPoint pt{w.s->level, wcam, wenc, torque};
	for (int j = 0; j < 4; ++j)
		pt.imean[j] = imean[j];
	pt.epoch = c.epoch_of(w.s->log, w.w.m0);
	c.res.rotation_points.push_back(pt);
}

// T = Bw w + Cw, with the torque recomputed for a Kt and offsets moved by the inputs
// x = [Kt, delta (4 per offset epoch)] (none: as measured): what experiment 1 borrows.
Fit fit_rotation(const std::vector<RotationPoint> &points, const model_params &p, bool cam,
                 const Eigen::VectorXd *x)
{
	model_params q = p;
	if (x)
		q.Kt = (*x)[0];
	Eigen::MatrixXd X(points.size(), 2);
	Eigen::VectorXd y(points.size());
	for (size_t k = 0; k < points.size(); ++k) {
		const RotationPoint &pt = points[k];
		double i[4], f[4], robot_f[3];
		for (int j = 0; j < 4; ++j)
			i[j] =
			    pt.imean[j] - (x && pt.epoch >= 0 ? (*x)[1 + 4 * pt.epoch + j] : 0.0);
		dyn_wheel_forces(&q, i, f);
		dyn_robot_forces(q.d, f, robot_f);
		X(k, 0) = cam ? pt.omega_cam : pt.omega_enc;
		X(k, 1) = 1.0;
		y[k] = robot_f[2];
	}
	return least_squares(X, y, 1.0, "experiment 1 (T = Bw w + Cw)");
}

void experiment1(Context &c)
{
	IdentResult &res = c.res;
	if (c.segments_of("steady_rotation", nullptr) == 0) {
		c.missing("Bw, Cw (experiment 1, eq 16): no 'steady_rotation' segments; " +
		          record_hint("steady_rotation"));
		return;
	}
	const auto kv = res.table["motor"].find("Kv");
	if (kv == res.table["motor"].end() || !kv->second.ok()) {
		c.missing("Bw, Cw (experiment 1): the torque needs Kt = Kv from the motor test");
		return;
	}
	model_params p = c.P.base; // geometry; Kt = Kv of the motor test
	p.Kv = p.Kt = kv->second.value;
	const bool cam = c.P.opt.source == VelocitySource::Camera;
	for (const SegWindow &w : c.windows("steady_rotation", nullptr, &SegmentWindows::steady))
		rotation_point(c, p, cam, w);
	if (res.rotation_points.size() < 3) {
		c.missing("Bw, Cw (experiment 1): " + std::to_string(res.rotation_points.size()) +
		          " usable steady rotation windows, need 3 at different speeds; " +
		          record_hint("steady_rotation"));
		return;
	}
	try {
		const Fit f = fit_rotation(res.rotation_points, p, cam, nullptr);
		const Eigen::VectorXd off_se = c.offset_se();
		Eigen::VectorXd x0 = Eigen::VectorXd::Zero(1 + off_se.size()),
		                se(1 + off_se.size());
		x0[0] = p.Kt;
		se[0] = kv->second.se;
		se.tail(off_se.size()) = off_se;
		const Eigen::VectorXd b = propagate_independent(
		    [&](const Eigen::VectorXd &x) -> Eigen::VectorXd {
			    return fit_rotation(res.rotation_points, p, cam, &x).theta;
		    },
		    x0, se);
		res.table["exp1"]["Bw"] = with_borrowed(f.theta[0], std::sqrt(f.cov(0, 0)), b[0]);
		res.table["exp1"]["Cw"] = with_borrowed(f.theta[1], std::sqrt(f.cov(1, 1)), b[1]);
	} catch (const IdentError &e) {
		c.missing(std::string("Bw, Cw: ") + e.what());
	}
}

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

// ---- experiment 3 (eqs 31-35) ----------------------------------------------------------

double input_of(const MotorsSample &m, int axis)
{
	const double u[4] = {m.u[0], m.u[1], m.u[2], m.u[3]};
	return axis_input(u, axis);
}

// Rows of the driven step windows along `axis`: valid encoder samples moving faster than the
// stop speed. The filters of a row must not reach into a stretch where the robot stuck or
// stopped (there x' = theta1 x + theta2 u + theta3 sign(x) does not hold: stiction), so the
// first and last half-window of every moving stretch are dropped. A run of rows ends where
// the speed falls below the threshold or data are missing.
StateSpaceData axis_data(const Context &c, const std::vector<SegWindow> &wins, int axis)
{
	const double thr = kStopSpeed[axis];
	std::vector<std::array<double, 4>> rows; // x, input, sign, y
	StateSpaceData d;
	for (const SegWindow &w : wins) {
		const auto &enc = c.P.enc.at(w.s->log);
		const auto &m = w.s->log->motors;
		const int h = enc.half;
		d.half = h;
		const SgFilter f = savitzky_golay(h, 2);
		// Moving stretches [a, b) of valid samples whose input window is contiguous too
		// (the voltage logged at tick k-1 acts until tick k: the input window is shifted by
		// one).
		auto usable = [&](size_t k) {
			return k > static_cast<size_t>(h) && enc.ok[k] && enc.joined[k - h] &&
			       std::abs(enc.x[k][axis]) >= thr;
		};
		size_t k = w.w.m0;
		while (k < w.w.m1) {
			if (!usable(k)) {
				++k;
				continue;
			}
			size_t b = k;
			while (b < w.w.m1 && usable(b))
				++b;
			const size_t a0 = k + h, b0 = b > static_cast<size_t>(h) ? b - h : 0;
			k = b;
			if (b0 <= a0 + 2)
				continue;
			d.start.push_back(rows.size());
			for (size_t q = a0; q < b0; ++q) {
				double in = 0;
				for (int j = -h; j <= h; ++j)
					in += f.smooth[j + h] * input_of(m[q + j - 1], axis);
				const double x = enc.x[q][axis];
				rows.push_back({x, in, sgn(x), enc.dx[q][axis]});
				d.t.push_back(m[q].utime * 1e-6);
			}
		}
	}
	d.X.resize(rows.size(), 3);
	d.y.resize(rows.size());
	for (size_t r = 0; r < rows.size(); ++r) {
		d.X.row(r) << rows[r][0], rows[r][1], rows[r][2];
		d.y[r] = rows[r][3];
	}
	return d;
}

// The three axes' regressions are independent: one task each (the messages stay in order).
struct AxisFit {
	StateSpaceFits f;
	std::string error; // empty: f holds the fits
};

// The LS and IV fits of experiment 3 per axis; have[axis]: the axis has them.
struct Exp3Fits {
	std::array<Fit, 3> ls, iv;
	std::array<bool, 3> have{};
};

Exp3Fits fit_step_axes(Context &c)
{
	Exp3Fits out;
	std::array<std::future<AxisFit>, 3> pending;
	for (int axis = 0; axis < 3; ++axis) {
		const char *dir = kDirs[axis];
		auto wins = c.windows("step", dir, &SegmentWindows::step);
		if (wins.empty())
			continue;
		pending[axis] =
		    std::async(std::launch::async, [&c, axis, dir, w = std::move(wins)] {
			    AxisFit a;
			    try {
				    a.f = fit_state_space(axis_data(c, w, axis),
				                          std::string("experiment 3 along ") + dir);
			    } catch (const IdentError &e) {
				    a.error = e.what();
			    }
			    return a;
		    });
	}
	for (int axis = 0; axis < 3; ++axis) {
		const char *dir = kDirs[axis];
		const std::string names = axis == 0   ? "Bv, Cv"
		                          : axis == 1 ? "Bvn, Cvn"
		                                      : "J, Bw, Cw";
		if (!pending[axis].valid()) {
			const size_t nseg = c.segments_of("step", dir);
			c.missing(names + " (experiment 3 along " + dir + "): " +
			          (nseg
			               ? std::to_string(nseg) + " step segments but no usable drive"
				       : std::string("no step segments")) +
			          "; " + record_hint("step"));
			continue;
		}
		AxisFit a = pending[axis].get();
		if (!a.error.empty()) {
			c.missing(names + ": " + a.error);
			continue;
		}
		out.ls[axis] = a.f.ls;
		out.iv[axis] = a.f.iv;
		out.have[axis] = true;
	}
	return out;
}

// The derived parameters as functions of x = [theta_v, theta_vn, theta_w (3 each), Kv, R of
// the motor test]: the axis's own theta is the method's data; Kv (eq 26's b and the back-EMF
// term), R (through the other axes' theta2, or the motor test's R along w alone) are
// borrowed, each with its own standard error (block-diagonal covariance: the motor test's
// segments are not the steps'). Bv = -M theta1 - 2 emf(Kv, R) is a small difference of two
// large numbers, so a 1 % error of Kv or R can move it by 10 %: the SE says so.
struct Derivation {
	const IdentOptions &opt;
	model_params &p; // geometry and M; Kt = Kv of the motor test; R as found
	Eigen::VectorXd x0 = Eigen::VectorXd::Zero(11);
	Eigen::MatrixXd C = Eigen::MatrixXd::Zero(11, 11);
	std::vector<int> r_axes; // the axes R comes from (none: the motor test's)
	std::vector<double> rw;  // weights of the R combination

	Derivation(const IdentOptions &o, model_params &p_, const std::array<Fit, 3> &fits,
	           const std::array<bool, 3> &have, const Estimate &Kv, const Estimate &Rm)
	    : opt(o), p(p_)
	{
		for (int axis = 0; axis < 3; ++axis) {
			if (!have[axis])
				continue;
			x0.segment<3>(3 * axis) = fits[axis].theta;
			C.block<3, 3>(3 * axis, 3 * axis) = fits[axis].cov;
		}
		x0[9] = Kv.value;
		C(9, 9) = std::isfinite(Kv.se) ? Kv.se * Kv.se : 0.0;
		x0[10] = Rm.ok() ? Rm.value : NAN;
		C(10, 10) = Rm.ok() && std::isfinite(Rm.se) ? Rm.se * Rm.se : 0.0;
	}

	model_params with_kv(const Eigen::VectorXd &x) const
	{
		model_params q = p;
		q.Kv = q.Kt = x[9];
		return q;
	}
	// theta2 along v and vn gives R (eq 26): from each, combined. The axes are compared and
	// weighted on their own data only (Kv is common to both and cancels in the comparison).
	// False when there is nothing to derive (along w alone without a motor test R).
	bool r_weights(const std::array<bool, 3> &have, bool motor_R)
	{
		std::vector<Estimate> Rs;
		for (int axis = 0; axis < 2; ++axis) {
			if (!have[axis])
				continue;
			r_axes.push_back(axis);
			Rs.push_back(propagate(
			    [&](const Eigen::VectorXd &x) {
				    return R_from_theta2(with_kv(x0), axis, x[3 * axis + 1]);
			    },
			    x0, C, {3 * axis, 3 * axis + 1, 3 * axis + 2}));
		}
		if (Rs.empty())
			return motor_R;
		Agreement rag;
		combine_methods(Rs, opt, &rag);
		double wsum = 0;
		for (const Estimate &e : Rs) {
			const double se =
			    std::max(std::hypot(e.se, opt.method_floor * e.value), 1e-300);
			rw.push_back(rag.agree ? 1 / (se * se) : 1.0);
			wsum += rw.back();
		}
		for (double &w : rw)
			w /= wsum;
		return true;
	}
	double R_of(const Eigen::VectorXd &x) const
	{
		if (r_axes.empty())
			return x[10];
		double R = 0;
		for (size_t k = 0; k < r_axes.size(); ++k)
			R += rw[k] * R_from_theta2(with_kv(x), r_axes[k], x[3 * r_axes[k] + 1]);
		return R;
	}
	model_params params_of(const Eigen::VectorXd &x) const
	{
		model_params q = with_kv(x);
		q.R = R_of(x);
		return q;
	}
	Estimate prop(const std::function<double(const Eigen::VectorXd &)> &f,
	              const std::vector<Eigen::Index> &own) const
	{
		return propagate(f, x0, C, own);
	}

	// R from the driven axes' theta2.
	void derive_R(std::map<std::string, Estimate> &t)
	{
		std::vector<Eigen::Index> own_r;
		for (int axis : r_axes)
			for (int k = 0; k < 3; ++k)
				own_r.push_back(3 * axis + k);
		if (!r_axes.empty())
			t["R"] = prop([&](const Eigen::VectorXd &x) { return R_of(x); }, own_r);
		p.R = R_of(x0);
	}

	// Along v or vn: B with the R of this axis's own theta2: theta1 and theta2 come from one
	// fit and their errors are correlated, so B = -M (theta1 + 2 Kv l theta2 / r) is far more
	// precise than with an R that mixes in the other axis's noise. C with the combined R.
	void derive_linear(std::map<std::string, Estimate> &t, int axis) const
	{
		const std::vector<Eigen::Index> own = {3 * axis, 3 * axis + 1, 3 * axis + 2};
		auto own_R = [&](const Eigen::VectorXd &x) {
			model_params q = with_kv(x);
			q.R = R_from_theta2(q, axis, x[3 * axis + 1]);
			return q;
		};
		t[axis == 0 ? "Bv" : "Bvn"] = prop(
		    [&](const Eigen::VectorXd &x) {
			    return B_from_theta1(own_R(x), axis, x[3 * axis]);
		    },
		    own);
		t[axis == 0 ? "Cv" : "Cvn"] = prop(
		    [&](const Eigen::VectorXd &x) {
			    return C_from_theta3(params_of(x), axis, x[3 * axis + 2]);
		    },
		    own);
	}

	// Along w, J from theta2 first; Bw and Cw with that J (their SEs include J's).
	void derive_rotation(std::map<std::string, Estimate> &t) const
	{
		auto with_J = [&](const Eigen::VectorXd &x) {
			model_params q = params_of(x);
			q.J = J_from_theta2(q, x[7]);
			return q;
		};
		const std::vector<Eigen::Index> own = {6, 7, 8};
		t["J"] = prop([&](const Eigen::VectorXd &x) { return with_J(x).J; }, own);
		t["Bw"] = prop(
		    [&](const Eigen::VectorXd &x) { return B_from_theta1(with_J(x), 2, x[6]); },
		    own);
		t["Cw"] = prop(
		    [&](const Eigen::VectorXd &x) { return C_from_theta3(with_J(x), 2, x[8]); },
		    own);
	}
};

void experiment3(Context &c)
{
	IdentResult &res = c.res;
	const auto kv = res.table["motor"].find("Kv");
	if (c.segments_of("step", nullptr) == 0) {
		c.missing("R, Bv, Bvn, Cv, Cvn, J, Bw, Cw (experiment 3): no 'step' segments; " +
		          record_hint("step"));
		return;
	}
	if (kv == res.table["motor"].end() || !kv->second.ok()) {
		c.missing("experiment 3: the state-space parameters need Kv from the motor test");
		return;
	}
	model_params p = c.P.base; // geometry and M; Kt = Kv of the motor test; R and J as found
	p.Kv = p.Kt = kv->second.value;
	const Exp3Fits fits = fit_step_axes(c);
	const Estimate Rm = find_estimate(res, "motor", "R");
	for (const auto &[name, axis_fits] :
	     {std::pair<std::string, const std::array<Fit, 3> *>{"exp3_ls", &fits.ls},
	      {"exp3_iv", &fits.iv}}) {
		auto &t = res.table[name];
		Derivation d(c.P.opt, p, *axis_fits, fits.have, kv->second, Rm);
		if (!d.r_weights(fits.have, Rm.ok()))
			continue;
		d.derive_R(t);
		for (int axis = 0; axis < 2; ++axis)
			if (fits.have[axis])
				d.derive_linear(t, axis);
		if (fits.have[2])
			d.derive_rotation(t);
	}
}

// Instruments: the noise-free response of the current model to the logged input (Euler over
// the row times, from the first measured value of each run).
Eigen::MatrixXd instruments(const StateSpaceData &d, const Eigen::VectorXd &theta)
{
	Eigen::MatrixXd Z = d.X;
	for (size_t r = 0; r < d.start.size(); ++r) {
		const size_t a = d.start[r];
		const size_t b =
		    r + 1 < d.start.size() ? d.start[r + 1] : static_cast<size_t>(d.X.rows());
		double xb = d.X(a, 0);
		for (size_t k = a; k < b; ++k) {
			Z(k, 0) = xb;
			Z(k, 2) = sgn(xb);
			if (k + 1 < b)
				xb += (d.t[k + 1] - d.t[k]) *
				      (theta[0] * xb + theta[1] * d.X(k, 1) + theta[2] * sgn(xb));
		}
	}
	return Z;
}

} // namespace

StateSpaceFits fit_state_space(const StateSpaceData &d, const std::string &what)
{
	StateSpaceFits f;
	f.ls = least_squares(d.X, d.y, 2 * d.half + 1, what + " (LS)");
	Eigen::VectorXd theta = f.ls.theta;
	for (int it = 0; it < 3; ++it) {
		f.iv = instrumental_variables(instruments(d, theta), d.X, d.y, 2 * d.half + 1,
		                              what + " (IV)");
		theta = f.iv.theta;
	}
	return f;
}

size_t log_workers(size_t n_logs)
{
	// Up to two per core: with fewer logs than twice the cores (3 logs on 2 cores) every log
	// runs at once and the cores share them evenly, instead of the last one running alone.
	const size_t cores = std::max(1u, std::thread::hardware_concurrency());
	return std::max(cores, std::min(n_logs, 2 * cores));
}

Prepared prepare(const std::vector<Segment> &segments, const model_params &base,
                 const IdentOptions &opt)
{
	Prepared P;
	P.base = base;
	P.opt = opt;
	P.segments = segments;
	// The logs' tracks and the segments' windows are independent: on all cores, one log (with
	// its segments) per task.
	std::vector<const LogData *> logs;
	for (const Segment &s : segments)
		if (std::find(logs.begin(), logs.end(), s.log) == logs.end())
			logs.push_back(s.log);
	struct Tracks {
		EncoderTrack enc;
		CameraTrack cam;
		std::vector<std::pair<size_t, SegmentWindows>> windows; // by segment index
	};
	auto work = [&](const LogData *log) {
		Tracks t{encoder_track(*log, base.d, base.r), camera_track(*log), {}};
		for (size_t i = 0; i < segments.size(); ++i)
			if (segments[i].log == log)
				t.windows.emplace_back(
				    i, find_windows(segments[i], t.enc, opt.windows));
		return t;
	};
	const size_t workers = log_workers(logs.size());
	std::vector<std::future<Tracks>> pending;
	P.windows.resize(segments.size());
	size_t next = 0;
	for (size_t k = 0; k < logs.size(); ++k) {
		while (next < logs.size() && pending.size() < k + workers)
			pending.push_back(std::async(std::launch::async, work, logs[next++]));
		Tracks t = pending[k].get();
		for (auto &[i, w] : t.windows)
			P.windows[i] = std::move(w);
		P.enc.emplace(logs[k], std::move(t.enc));
		P.cam.emplace(logs[k], std::move(t.cam));
		for (size_t e = 0; e < logs[k]->current_offsets.size(); ++e) {
			const OffsetEpoch &ep = logs[k]->current_offsets[e];
			if (ep.subtracted && std::isfinite(ep.se_a[0]))
				P.offset_epochs.emplace_back(logs[k], e);
		}
	}
	return P;
}

namespace
{

// The report: every window found and every rejection.
void record_windows(const Prepared &P, IdentResult &res)
{
	for (size_t i = 0; i < P.segments.size(); ++i) {
		const Segment &s = P.segments[i];
		const SegmentWindows &w = P.windows[i];
		auto used = [&](const std::vector<Window> &ws, const char *what) {
			for (const Window &x : ws)
				res.windows.push_back({i, s.kind, s.direction, what,
				                       seg_time(s, x.m0), seg_time(s, x.m1 - 1),
				                       true, ""});
		};
		used(w.steady, "steady window");
		used(w.coast, "coast-down");
		used(w.step, "step");
		for (const Rejection &r : w.rejected)
			res.windows.push_back(
			    {i, s.kind, s.direction, r.what, r.t0_s, r.t1_s, false, r.reason});
	}
}

// Each parameter's final value from the methods that give it (combine_methods), into
// res.table["final"] and res.final. Returns how many were found.
size_t combine_final(const Prepared &P, IdentResult &res)
{
	auto &fin = res.table["final"];
	static const std::map<std::string, std::vector<const char *>> sources = {
	    {"Kv", {"motor"}},           {"R", {"motor", "exp3_iv"}},  {"J", {"exp2", "exp3_iv"}},
	    {"Bv", {"exp2", "exp3_iv"}}, {"Bvn", {"exp2", "exp3_iv"}}, {"Bw", {"exp1", "exp3_iv"}},
	    {"Cv", {"exp2", "exp3_iv"}}, {"Cvn", {"exp2", "exp3_iv"}}, {"Cw", {"exp1", "exp3_iv"}}};
	res.final = P.base;
	size_t found = 0;
	for (const char *p : kIdentParams) {
		std::vector<Estimate> est;
		for (const char *m : sources.at(p))
			est.push_back(find_estimate(res, m, p));
		Agreement ag;
		const Estimate e = combine_methods(est, P.opt, &ag);
		res.agreement[p] = ag;
		res.identified[p] = e.ok();
		if (!e.ok())
			continue;
		fin[p] = e;
		++found;
		for (int i = 0; i < MODEL_PARAMS_COUNT; ++i)
			if (std::string(p) == model_params_names[i])
				*model_params_field(&res.final, i) = e.value;
	}
	if (res.identified["Kv"])
		res.final.Kt = res.final.Kv;
	return found;
}

} // namespace

IdentResult identify(const Prepared &P, const std::vector<size_t> *use_in)
{
	std::vector<size_t> all(P.segments.size());
	std::iota(all.begin(), all.end(), 0);
	const std::vector<size_t> &use = use_in ? *use_in : all;
	IdentResult res;
	for (size_t i : use)
		++res.segments_used[P.segments[i].kind];
	if (!use_in)
		record_windows(P, res);
	Context c{P, use, res};
	motor_test(c);
	experiment1(c);
	experiment2(c);
	experiment3(c);
	if (combine_final(P, res) == 0) {
		std::string why = "nothing can be identified from these logs:";
		for (const std::string &m : res.missing)
			why += "\n  " + m;
		throw IdentError(why);
	}
	if (res.complete()) {
		int bad = -1;
		if (model_params_check(&res.final, &bad))
			throw IdentError(std::string("identified parameters are not physical: ") +
			                 model_params_names[bad] + " = " +
			                 std::to_string(model_params_get(&res.final, bad)));
	}
	return res;
}

IdentResult identify(const std::vector<Segment> &segments, const model_params &base,
                     const IdentOptions &opt)
{
	return identify(prepare(segments, base, opt));
}

} // namespace omni4
