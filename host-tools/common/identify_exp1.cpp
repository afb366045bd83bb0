// identify_exp1.cpp - experiment 1 (eq 16): Bw, Cw from steady rotation.
#include "identify_context.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

extern "C" {
#include "omni4/model/dynamics.h"
}

namespace omni4
{

namespace ident
{

void wheel_forces(const model_params &p, const WheelShape &s, const double i[4], double f[4])
{
	if (s.uniform()) {
		dyn_wheel_forces(&p, i, f);
		return;
	}
	const model_wheels w = s.wheels(p);
	dyn_wheel_forces_wheels(&p, &w, i, f);
}

namespace
{

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
	wheel_forces(p, c.res.wheels.shape, imean, f);
	c.P.opt.layout.body_force(p.d, f, robot_f);
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
Fit fit_rotation(const std::vector<RotationPoint> &points, const model_params &p,
                 const WheelShape &shape, const Layout &layout, bool cam, const Eigen::VectorXd *x)
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
		wheel_forces(q, shape, i, f);
		layout.body_force(q.d, f, robot_f);
		X(k, 0) = cam ? pt.omega_cam : pt.omega_enc;
		X(k, 1) = 1.0;
		y[k] = robot_f[2];
	}
	return least_squares(X, y, 1.0, "experiment 1 (T = Bw w + Cw)");
}

} // namespace

void experiment1(Context &c)
{
	IdentResult &res = c.res;
	if (c.segments_of("steady_rotation", nullptr) == 0) {
		c.missing("Bw, Cw (experiment 1, eq 16): no 'steady_rotation' segments; " +
		          record_hint("steady_rotation"));
		return;
	}
	const Estimate kt = torque_constant(c);
	if (!kt.ok()) {
		c.missing("Bw, Cw (experiment 1): the torque needs Kt = Kv from the motor test");
		return;
	}
	model_params p = c.P.base; // geometry; Kt = Kv of the motor test (or the drive's Kt)
	if (!current_drive(c))
		p.Kv = p.Kt = kt.value;
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
		const Fit f = fit_rotation(res.rotation_points, p, res.wheels.shape, c.P.opt.layout,
		                           cam, nullptr);
		const Eigen::VectorXd off_se = c.offset_se();
		Eigen::VectorXd x0 = Eigen::VectorXd::Zero(1 + off_se.size()),
		                se(1 + off_se.size());
		x0[0] = p.Kt;
		se[0] = kt.se;
		se.tail(off_se.size()) = off_se;
		const Eigen::VectorXd b = propagate_independent(
		    [&](const Eigen::VectorXd &x) -> Eigen::VectorXd {
			    return fit_rotation(res.rotation_points, p, res.wheels.shape,
			                        c.P.opt.layout, cam, &x)
			        .theta;
		    },
		    x0, se);
		res.table["exp1"]["Bw"] = with_borrowed(f.theta[0], std::sqrt(f.cov(0, 0)), b[0]);
		res.table["exp1"]["Cw"] = with_borrowed(f.theta[1], std::sqrt(f.cov(1, 1)), b[1]);
	} catch (const IdentError &e) {
		c.missing(std::string("Bw, Cw: ") + e.what());
	}
}

} // namespace ident

} // namespace omni4
