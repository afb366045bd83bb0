// identify_exp3.cpp - experiment 3 (eqs 31-35): LS and IV on the ramped steps, and the
// parameters derived from the state-space coefficients.
#include "identify_context.hpp"

#include <array>
#include <cmath>
#include <functional>
#include <future>

extern "C" {
#include "omni4/model/dynamics.h"
}

namespace omni4
{

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
// Per wheel (WheelShape): b and emf are the mean wheel's, theta2 carries axis_beta and theta1's
// back-EMF term the axis's eps sum.
// Any other layout (G its rows, one drive for every wheel): the axis input is (G^T u)_axis
// less the back-EMF the other axes' velocities put on this one, Kv l / r sum_k (G^T G)[axis][k]
// x_k (k != axis), so along every axis theta2 = b / m_axis, theta1 = -((G^T G)[axis][axis]
// emf + B_axis) / m_axis, theta3 = -C_axis / m_axis (m = M, M, J).
double R_from_theta2(const model_params &p, int axis, double theta2, const WheelShape &s)
{
	if (s.uniform() || !s.layout.paper)
		return p.l * p.Kt / (p.r * p.M * theta2);
	return p.l * p.Kt * axis_beta(s, axis) / (p.r * p.M * theta2);
}
double J_from_theta2(const model_params &p, double theta2, const WheelShape &s)
{
	if (!s.layout.paper)
		return p.l * p.Kt / (p.r * p.R * theta2);
	if (s.uniform())
		return p.l * p.Kt * p.d / (p.r * p.R * theta2);
	return p.l * p.Kt * p.d * axis_beta(s, 2) / (p.r * p.R * theta2);
}
double B_from_theta1(const model_params &p, int axis, double theta1, const WheelShape &s)
{
	const double emf = p.Kt * p.Kv * p.l * p.l / (p.r * p.r * p.R);
	if (!s.layout.paper)
		return -(axis < 2 ? p.M : p.J) * theta1 - s.layout.gtg[axis][axis] * emf;
	if (s.uniform())
		return axis < 2 ? -p.M * theta1 - 2 * emf : -p.J * theta1 - 4 * p.d * p.d * emf;
	const double e0 = s.eps(0), e1 = s.eps(1), e2 = s.eps(2), e3 = s.eps(3);
	if (axis == 0)
		return -p.M * theta1 - (e1 + e3) * emf;
	if (axis == 1)
		return -p.M * theta1 - (e0 + e2) * emf;
	return -p.J * theta1 - p.d * p.d * (e0 + e1 + e2 + e3) * emf;
}
double C_from_theta3(const model_params &p, int axis, double theta3)
{
	return -(axis < 2 ? p.M : p.J) * theta3;
}

namespace ident
{

namespace
{

// ---- experiment 3 (eqs 31-35) ----------------------------------------------------------

// The axis input of one sample's voltages (per wheel: the voltage part of axis_input_wheels).
double input_of(const MotorsSample &m, int axis, const model_params &p, const WheelShape &s)
{
	const double u[4] = {m.u[0], m.u[1], m.u[2], m.u[3]};
	if (!s.layout.paper) {
		double in = 0;
		for (int j = 0; j < s.layout.n; ++j)
			in += s.layout.ph.row[j][axis] * u[j];
		return in;
	}
	if (s.uniform())
		return axis_input(u, axis);
	const double x0[3] = {0, 0, 0};
	return axis_input_wheels(p, s, u, x0, axis);
}

// Current drive: the body force along axis of one sample's measured currents (eqs 9-13; each
// wheel's Kt and radius where the shape says they differ) [N, N m].
double force_of(const MotorsSample &m, int axis, const model_params &p, const WheelShape &s)
{
	const double i[4] = {m.i[0], m.i[1], m.i[2], m.i[3]};
	double f[4], body[3];
	wheel_forces(p, s, i, f);
	s.layout.body_force(p.d, f, body);
	return body[axis];
}

// Per wheel: the back-EMF coupling of the other axes at the filtered velocity x.
double coupling_of(const std::array<double, 3> &x, int axis, const model_params &p,
                   const WheelShape &s)
{
	if (!s.layout.paper) {
		double emf = 0;
		for (int k = 0; k < 3; ++k)
			emf += k == axis ? 0.0 : s.layout.gtg[axis][k] * x[k];
		return -p.Kv * p.l / p.r * emf;
	}
	if (s.uniform())
		return 0.0;
	const double u0[4] = {0, 0, 0, 0}, xv[3] = {x[0], x[1], x[2]};
	return axis_input_wheels(p, s, u0, xv, axis);
}

// Rows of the driven step windows along `axis`: valid encoder samples moving faster than the
// stop speed. The filters of a row must not reach into a stretch where the robot stuck or
// stopped (there x' = theta1 x + theta2 u + theta3 sign(x) does not hold: stiction), so the
// first and last half-window of every moving stretch are dropped. A run of rows ends where
// the speed falls below the threshold or data are missing. With a current drive the input is
// the body force of the measured currents: the current read at tick k flowed over the period
// ending there (the voltage written at k - 1), and no back-EMF coupling.
StateSpaceData axis_data(const Context &c, const std::vector<SegWindow> &wins, int axis,
                         const model_params &p)
{
	const bool force = current_drive(c);
	const WheelShape &shape = c.res.wheels.shape;
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
					in += f.smooth[j + h] *
					      (force ? force_of(m[q + j], axis, p, shape)
					             : input_of(m[q + j - 1], axis, p, shape));
				if (!force)
					in += coupling_of(enc.x[q], axis, p, shape);
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

Exp3Fits fit_step_axes(Context &c, const model_params &p)
{
	Exp3Fits out;
	std::array<std::future<AxisFit>, 3> pending;
	for (int axis = 0; axis < 3; ++axis) {
		const char *dir = kDirs[axis];
		auto wins = c.windows("step", dir, &SegmentWindows::step);
		if (wins.empty())
			continue;
		pending[axis] =
		    std::async(std::launch::async, [&c, &p, axis, dir, w = std::move(wins)] {
			    AxisFit a;
			    try {
				    a.f = fit_state_space(axis_data(c, w, axis, p),
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
	WheelShape s;    // the wheels' drives relative to the mean
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

	model_params with_kv(const Eigen::VectorXd &x) const;
	// theta2 along v and vn gives R (eq 26): from each, combined. The axes are compared and
	// weighted on their own data only (Kv is common to both and cancels in the comparison).
	// False when there is nothing to derive (along w alone without a motor test R).
	bool r_weights(const std::array<bool, 3> &have, bool motor_R);
	double R_of(const Eigen::VectorXd &x) const;
	model_params params_of(const Eigen::VectorXd &x) const;
	Estimate prop(const std::function<double(const Eigen::VectorXd &)> &f,
	              const std::vector<Eigen::Index> &own) const;
	// R from the driven axes' theta2.
	void derive_R(std::map<std::string, Estimate> &t);
	// Along v or vn: B with the R of this axis's own theta2: theta1 and theta2 come from one
	// fit and their errors are correlated, so B = -M (theta1 + 2 Kv l theta2 / r) is far more
	// precise than with an R that mixes in the other axis's noise. C with the combined R.
	void derive_linear(std::map<std::string, Estimate> &t, int axis) const;
	// Along w, J from theta2 first; Bw and Cw with that J (their SEs include J's).
	void derive_rotation(std::map<std::string, Estimate> &t) const;
};

model_params Derivation::with_kv(const Eigen::VectorXd &x) const
{
	model_params q = p;
	q.Kv = q.Kt = x[9];
	return q;
}

// theta2 along v and vn gives R (eq 26): from each, combined. The axes are compared and
// weighted on their own data only (Kv is common to both and cancels in the comparison).
// False when there is nothing to derive (along w alone without a motor test R).
bool Derivation::r_weights(const std::array<bool, 3> &have, bool motor_R)
{
	std::vector<Estimate> Rs;
	for (int axis = 0; axis < 2; ++axis) {
		if (!have[axis])
			continue;
		r_axes.push_back(axis);
		Rs.push_back(propagate(
		    [&](const Eigen::VectorXd &x) {
			    return R_from_theta2(with_kv(x0), axis, x[3 * axis + 1], s);
		    },
		    x0, C, {3 * axis, 3 * axis + 1, 3 * axis + 2}));
	}
	if (Rs.empty())
		return motor_R;
	Agreement rag;
	combine_methods(Rs, opt, &rag);
	double wsum = 0;
	for (const Estimate &e : Rs) {
		const double se = std::max(std::hypot(e.se, opt.method_floor * e.value), 1e-300);
		rw.push_back(rag.agree ? 1 / (se * se) : 1.0);
		wsum += rw.back();
	}
	for (double &w : rw)
		w /= wsum;
	return true;
}

double Derivation::R_of(const Eigen::VectorXd &x) const
{
	if (r_axes.empty())
		return x[10];
	double R = 0;
	for (size_t k = 0; k < r_axes.size(); ++k)
		R += rw[k] * R_from_theta2(with_kv(x), r_axes[k], x[3 * r_axes[k] + 1], s);
	return R;
}

model_params Derivation::params_of(const Eigen::VectorXd &x) const
{
	model_params q = with_kv(x);
	q.R = R_of(x);
	return q;
}

Estimate Derivation::prop(const std::function<double(const Eigen::VectorXd &)> &f,
                          const std::vector<Eigen::Index> &own) const
{
	return propagate(f, x0, C, own);
}

// R from the driven axes' theta2.
void Derivation::derive_R(std::map<std::string, Estimate> &t)
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
void Derivation::derive_linear(std::map<std::string, Estimate> &t, int axis) const
{
	const std::vector<Eigen::Index> own = {3 * axis, 3 * axis + 1, 3 * axis + 2};
	auto own_R = [&](const Eigen::VectorXd &x) {
		model_params q = with_kv(x);
		q.R = R_from_theta2(q, axis, x[3 * axis + 1], s);
		return q;
	};
	t[axis == 0 ? "Bv" : "Bvn"] = prop(
	    [&](const Eigen::VectorXd &x) { return B_from_theta1(own_R(x), axis, x[3 * axis], s); },
	    own);
	t[axis == 0 ? "Cv" : "Cvn"] = prop(
	    [&](const Eigen::VectorXd &x) {
		    return C_from_theta3(params_of(x), axis, x[3 * axis + 2]);
	    },
	    own);
}

// Along w, J from theta2 first; Bw and Cw with that J (their SEs include J's).
void Derivation::derive_rotation(std::map<std::string, Estimate> &t) const
{
	auto with_J = [&](const Eigen::VectorXd &x) {
		model_params q = params_of(x);
		q.J = J_from_theta2(q, x[7], s);
		return q;
	};
	const std::vector<Eigen::Index> own = {6, 7, 8};
	t["J"] = prop([&](const Eigen::VectorXd &x) { return with_J(x).J; }, own);
	t["Bw"] = prop(
	    [&](const Eigen::VectorXd &x) { return B_from_theta1(with_J(x), 2, x[6], s); }, own);
	t["Cw"] =
	    prop([&](const Eigen::VectorXd &x) { return C_from_theta3(with_J(x), 2, x[8]); }, own);
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

// Current drive, eq 23 in force form along one axis: x' = theta1 x + theta2 F + theta3 sgn x
// with theta2 = 1 / M (1 / J along w), theta1 = -B / M, theta3 = -C / M: the inertia, B and C
// from the axis's own fit alone (nothing borrowed; Kt and r are the base model's).
void derive_force(std::map<std::string, Estimate> &t, const Fit &f, int axis)
{
	static const char *const B[3] = {"Bv", "Bvn", "Bw"}, *const C[3] = {"Cv", "Cvn", "Cw"};
	t[axis == 2 ? "J" : (axis == 0 ? "M_v" : "M_vn")] =
	    propagate([](const Eigen::VectorXd &x) { return 1.0 / x[1]; }, f.theta, f.cov);
	t[B[axis]] =
	    propagate([](const Eigen::VectorXd &x) { return -x[0] / x[1]; }, f.theta, f.cov);
	t[C[axis]] =
	    propagate([](const Eigen::VectorXd &x) { return -x[2] / x[1]; }, f.theta, f.cov);
}

// M of the two linear axes' fits combined (the chi-square rule of the final values).
void combine_axes_mass(std::map<std::string, Estimate> &t, const IdentOptions &opt)
{
	std::vector<Estimate> m;
	for (const char *k : {"M_v", "M_vn"})
		if (t.count(k))
			m.push_back(t[k]);
	t.erase("M_v");
	t.erase("M_vn");
	if (!m.empty())
		t["M"] = combine_methods(m, opt);
}

void experiment3_force(Context &c)
{
	model_params p = c.P.base; // geometry and Kt: the base model's
	const Exp3Fits fits = fit_step_axes(c, p);
	for (const auto &[name, axis_fits] :
	     {std::pair<std::string, const std::array<Fit, 3> *>{"exp3_ls", &fits.ls},
	      {"exp3_iv", &fits.iv}}) {
		auto &t = c.res.table[name];
		for (int axis = 0; axis < 3; ++axis)
			if (fits.have[axis])
				derive_force(t, (*axis_fits)[axis], axis);
		combine_axes_mass(t, c.P.opt);
	}
}

} // namespace

void experiment3(Context &c)
{
	IdentResult &res = c.res;
	const auto kv = res.table["motor"].find("Kv");
	if (c.segments_of("step", nullptr) == 0) {
		c.missing("R, Bv, Bvn, Cv, Cvn, J, Bw, Cw (experiment 3): no 'step' segments; " +
		          record_hint("step"));
		return;
	}
	if (current_drive(c)) {
		experiment3_force(c);
		return;
	}
	if (kv == res.table["motor"].end() || !kv->second.ok()) {
		c.missing("experiment 3: the state-space parameters need Kv from the motor test");
		return;
	}
	model_params p = c.P.base; // geometry and M; Kt = Kv of the motor test; R and J as found
	p.Kv = p.Kt = kv->second.value;
	const Exp3Fits fits = fit_step_axes(c, p);
	const Estimate Rm = find_estimate(res, "motor", "R");
	for (const auto &[name, axis_fits] :
	     {std::pair<std::string, const std::array<Fit, 3> *>{"exp3_ls", &fits.ls},
	      {"exp3_iv", &fits.iv}}) {
		auto &t = res.table[name];
		Derivation d(c.P.opt, p, *axis_fits, fits.have, kv->second, Rm);
		d.s = res.wheels.shape;
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

} // namespace ident

StateSpaceFits fit_state_space(const StateSpaceData &d, const std::string &what)
{
	StateSpaceFits f;
	f.ls = least_squares(d.X, d.y, 2 * d.half + 1, what + " (LS)");
	Eigen::VectorXd theta = f.ls.theta;
	for (int it = 0; it < 3; ++it) {
		f.iv = instrumental_variables(ident::instruments(d, theta), d.X, d.y,
		                              2 * d.half + 1, what + " (IV)");
		theta = f.iv.theta;
	}
	return f;
}

} // namespace omni4
