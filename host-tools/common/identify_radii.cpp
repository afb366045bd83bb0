// identify_radii.cpp - each wheel's radius relative to the others, and their common scale.
//
// Rigid body: the rim speeds r_j w_j are eq 2 of one robot velocity, IK(d) x, and IK(d) has
// the left null vector n = (1, -1, 1, -1) (its rows [0 1 d], [-1 0 d], [0 -1 d], [1 0 d]), so
// sum_j n_j r_j w_j = 0 at every instant, and over any stretch for the wheel angles
// Delta_j = integral w_j dt. With rho_j = r_j / mean r: sum_j n_j rho_j Delta_j = 0, one
// homogeneous equation per stretch; sum rho = 4 sets the scale. Drives along v give rho1 / rho3,
// along vn rho0 / rho2, turns (rho0 + rho2) / (rho1 + rho3): all three ratios. The mean radius
// is not in it: the camera's displacements give it where poses are logged.
#include <algorithm>
#include <cmath>

#include "identify_wheels.hpp"

namespace omni4::ident
{

namespace
{

constexpr size_t kChunk = 100;            // samples per stretch (0.1 s at 1 kHz)
constexpr double kMinRate = 0.5;          // mean |wheel speed| of the fastest wheel [rad/s]
constexpr double kCameraStretch = 1.0;    // camera stretch [s]
constexpr double kMinDisplacement = 0.05; // [m] of odometry in a camera stretch

// The rows a = (Delta_0, -Delta_1, Delta_2, -Delta_3) of one log: stretches of kChunk
// contiguous samples (next seq, every wheel speed finite) with a wheel turning.
void radius_rows(const LogData &log, std::vector<std::array<double, 4>> &rows)
{
	const auto &m = log.motors;
	size_t a = 0;
	while (a + kChunk <= m.size()) {
		std::array<double, 4> sum{};
		size_t k = a;
		for (; k < a + kChunk; ++k) {
			if (k > a && m[k].seq != m[k - 1].seq + 1)
				break;
			for (int j = 0; j < 4; ++j)
				sum[j] += m[k].w[j];
		}
		if (k < a + kChunk || !std::isfinite(sum[0] + sum[1] + sum[2] + sum[3])) {
			a = std::max(k, a + 1);
			continue;
		}
		a = k;
		double top = 0;
		for (double s : sum)
			top = std::max(top, std::abs(s) / kChunk);
		if (top >= kMinRate)
			rows.push_back({sum[0], -sum[1], sum[2], -sum[3]});
	}
}

// sum_j a_j rho_j = 0 with rho_3 = 4 - rho_0 - rho_1 - rho_2: least squares in rho_0..2.
void solve_radii(const std::vector<std::array<double, 4>> &rows, WheelResult &w)
{
	const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
	Eigen::MatrixXd X(n, 3);
	Eigen::VectorXd y(n);
	for (Eigen::Index k = 0; k < n; ++k) {
		const auto &a = rows[static_cast<size_t>(k)];
		for (int j = 0; j < 3; ++j)
			X(k, j) = a[j] - a[3];
		y[k] = -4 * a[3];
	}
	const Fit f = least_squares(X, y, 1.0, "wheel radii (rigid-body consistency)");
	double rho3 = 4;
	for (int j = 0; j < 3; ++j) {
		w.rho[j] = {f.theta[j], std::sqrt(f.cov(j, j))};
		rho3 -= f.theta[j];
	}
	w.rho[3] = {rho3, std::sqrt(f.cov.sum())};
	const Eigen::Vector3d dev = f.theta - Eigen::Vector3d::Ones();
	w.radii_chi2 = dev.dot(f.cov.ldlt().solve(dev));
	w.radii_p = chi2_sf(w.radii_chi2, 3);
	w.radii_tested = true;
}

} // namespace

void estimate_radii(Prepared &P)
{
	WheelResult &w = P.radii;
	std::vector<const LogData *> logs;
	for (const Segment &s : P.segments)
		if (std::find(logs.begin(), logs.end(), s.log) == logs.end())
			logs.push_back(s.log);
	std::vector<std::array<double, 4>> rows;
	for (const LogData *log : logs)
		radius_rows(*log, rows);
	w.radii_rows = rows.size();
	if (rows.size() < 10)
		return;
	try {
		solve_radii(rows, w);
	} catch (const IdentError &) {
		return; // the drives did not move every wheel: the radii stay the measured one
	}
	w.radii_differ = w.radii_p < P.opt.agree_p;
	if (w.radii_differ)
		for (int j = 0; j < 4; ++j)
			w.shape.r[j] = w.rho[j].value;
}

namespace
{

// World displacement over camera frames [k0, k1] from the encoders (track at radius scale
// P.base.r), the heading integrated from the camera's at k0.
std::array<double, 2> odometry_step(const LogData &log, const EncoderTrack &enc,
                                    const CameraTrack &ct, size_t k0, size_t k1, size_t &m)
{
	const auto &ms = log.motors;
	const int64_t t0 = static_cast<int64_t>(std::llround(ct.t[k0] * 1e6));
	const int64_t t1 = static_cast<int64_t>(std::llround(ct.t[k1] * 1e6));
	while (m < ms.size() && ms[m].utime < t0)
		++m;
	double th = ct.theta[k0], dx = 0, dy = 0;
	for (size_t k = m; k + 1 < ms.size() && ms[k + 1].utime <= t1; ++k) {
		const double dt = (ms[k + 1].utime - ms[k].utime) * 1e-6;
		const auto &x = enc.raw[k];
		const double h = th + 0.5 * x[2] * dt;
		dx += (std::cos(h) * x[0] - std::sin(h) * x[1]) * dt;
		dy += (std::sin(h) * x[0] + std::cos(h) * x[1]) * dt;
		th += x[2] * dt;
	}
	return {dx, dy};
}

} // namespace

void camera_radius_scale(Prepared &P)
{
	WheelResult &w = P.radii;
	std::vector<double> cam, odo;
	for (const auto &[log, ct] : P.cam) {
		const EncoderTrack &enc = P.enc.at(log);
		size_t m = 0;
		for (size_t k0 = 0; k0 < ct.t.size();) {
			size_t k1 = k0;
			while (k1 + 1 < ct.t.size() && ct.t[k1 + 1] - ct.t[k0] <= kCameraStretch)
				++k1;
			if (k1 == k0 || ct.t[k1] - ct.t[k0] < 0.5 * kCameraStretch) {
				k0 = k1 + 1;
				continue;
			}
			const auto o = odometry_step(*log, enc, ct, k0, k1, m);
			if (std::hypot(o[0], o[1]) >= kMinDisplacement) {
				const auto &pose = log->pose;
				cam.insert(cam.end(),
				           {pose[k1].x - pose[k0].x, pose[k1].y - pose[k0].y});
				odo.insert(odo.end(), {o[0] / P.base.r, o[1] / P.base.r});
			}
			k0 = k1;
		}
	}
	if (cam.size() < 10) {
		w.r_scale_note =
		    "unobservable: no camera poses over drives (the mean radius is the "
		    "measured r)";
		return;
	}
	Eigen::MatrixXd X = Eigen::Map<Eigen::VectorXd>(odo.data(), odo.size());
	const Eigen::VectorXd y = Eigen::Map<Eigen::VectorXd>(cam.data(), cam.size());
	try {
		const Fit f = least_squares(X, y, 1.0, "mean wheel radius (camera)");
		w.r_scale = {f.theta[0], std::sqrt(f.cov(0, 0))};
	} catch (const IdentError &e) {
		w.r_scale_note = std::string("unobservable: ") + e.what();
	}
}

} // namespace omni4::ident
