// identify_motor.cpp - the motor test (eq 22): Kv and R of each motor and pooled.
#include "identify_context.hpp"
#include "identify_wheels.hpp"

#include <algorithm>
#include <cmath>

namespace omni4
{

namespace ident
{

namespace
{

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

// One Kv for all motors: the fit of every motor's points (the motors do not differ).
void pooled_kv(Context &c, const Eigen::VectorXd &off_se)
{
	IdentResult &res = c.res;
	try {
		const Fit all = fit_motor(res.motor_points, -1, nullptr);
		res.table["motor"]["Kv"] =
		    with_borrowed(all.theta[0], std::sqrt(all.cov(0, 0)),
		                  motor_borrowed(res.motor_points, -1, off_se)[0]);
	} catch (const IdentError &e) {
		c.missing(std::string("Kv: ") + e.what());
	}
}

// The motors differ: Kv is their mean (as R is), and the shape of the four drives (each
// motor's Kv and R over the mean) is what experiments 1 and 3 use. A motor without a fit of
// its own leaves the shape uniform (its drive is unknown) and says so.
void per_motor_kv(Context &c)
{
	IdentResult &res = c.res;
	double kv = 0, var = 0, var_b = 0, r = 0;
	for (int j = 0; j < 4; ++j) {
		const Estimate &k = res.Kv_motor[j];
		if (!k.ok() || !res.R_motor[j].ok()) {
			c.missing("per-wheel drives: motor " + std::to_string(j) +
			          " has no fit of its own; the robot keeps one Kv and R");
			res.wheels.motors_differ = false;
			pooled_kv(c, c.offset_se());
			return;
		}
		kv += k.value / 4;
		var += (k.se * k.se - k.se_borrowed * k.se_borrowed) / 16;
		var_b += k.se_borrowed * k.se_borrowed / 16;
		r += res.R_motor[j].value / 4;
	}
	res.table["motor"]["Kv"] = with_borrowed(kv, std::sqrt(var), std::sqrt(var_b));
	for (int j = 0; j < 4; ++j) {
		res.wheels.shape.kv[j] = res.Kv_motor[j].value / kv;
		res.wheels.shape.R[j] = res.R_motor[j].value / r;
	}
}

} // namespace

void motor_test(Context &c)
{
	IdentResult &res = c.res;
	if (current_drive(c)) {
		// The logged voltages are the controller's model voltages: a fit of eq 22 on them
		// returns the model's own R and Kv. They are the drive's.
		res.table["drive"]["Kv"] = {c.P.base.Kv, NAN};
		res.table["drive"]["R"] = {c.P.base.R, NAN};
		return;
	}
	if (c.segments_of("motor", nullptr) == 0) {
		c.missing("Kv, R (motor test, eq 22): no 'motor' segments; " +
		          record_hint("motor"));
		return;
	}
	collect_motor_points(c);
	const Eigen::VectorXd off_se = c.offset_se();
	RSum rs;
	for (int j = 0; j < c.P.opt.layout.n; ++j)
		fit_one_motor(c, j, off_se, rs);
	motors_differ_test(res.motor_points, res.wheels, c.P.opt);
	if (res.wheels.motors_differ && !c.P.opt.layout.paper)
		c.missing(
		    "per-wheel drives: the motors differ, but a layout other than the paper's "
		    "is fitted with one Kv and R for every motor");
	if (res.wheels.motors_differ && c.P.opt.layout.paper)
		per_motor_kv(c);
	else
		pooled_kv(c, off_se);
	// The paper averages R over the motors (here: over those with a fit). The motors' borrowed
	// parts are taken as independent (each motor has its own channel's offset).
	if (rs.n > 0)
		res.table["motor"]["R"] = with_borrowed(rs.sum / rs.n, std::sqrt(rs.var) / rs.n,
		                                        std::sqrt(rs.var_b) / rs.n);
	else
		c.missing("R (motor test): no motor has enough steady points");
}

} // namespace ident

} // namespace omni4
