// signals.cpp - Savitzky-Golay filters and velocity series.
#include "signals.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>

extern "C" {
#include "omni4/model/kinematics.h"
}

namespace omni4
{

SgFilter savitzky_golay(int half, int order)
{
	const int n = 2 * half + 1;
	if (half < 1 || order < 1 || order >= n)
		throw std::invalid_argument("bad SG window");
	Eigen::MatrixXd V(n, order + 1);
	for (int k = -half; k <= half; ++k)
		for (int p = 0; p <= order; ++p)
			V(k + half, p) = std::pow(k, p);
	// Rows of the least-squares solver (V^T V)^-1 V^T give the polynomial coefficients.
	const Eigen::MatrixXd P = (V.transpose() * V).ldlt().solve(V.transpose());
	SgFilter f;
	f.half = half;
	f.smooth.resize(n);
	f.deriv.resize(n);
	for (int k = 0; k < n; ++k) {
		f.smooth[k] = P(0, k);
		f.deriv[k] = P(1, k);
	}
	return f;
}

void unwrap(std::vector<double> &a)
{
	double offset = 0;
	for (size_t k = 1; k < a.size(); ++k) {
		const double raw = a[k] + offset;
		const double jump = raw - a[k - 1];
		if (jump > M_PI)
			offset -= 2 * M_PI * std::round(jump / (2 * M_PI));
		else if (jump < -M_PI)
			offset += 2 * M_PI * std::round(-jump / (2 * M_PI));
		a[k] += offset;
	}
}

int find_axis(const std::string &direction)
{
	if (direction == "v")
		return 0;
	if (direction == "vn")
		return 1;
	if (direction == "w")
		return 2;
	return -1;
}

namespace
{

// The robot velocity of every sample (eqs 3-5), the filter's time step and half width, and
// whether each sample joins the previous one (next seq, about one step later).
void raw_velocities(const std::vector<MotorsSample> &m, double d, const std::array<double, 4> &r,
                    double half_s, EncoderTrack &out)
{
	const size_t n = m.size();
	std::vector<int64_t> steps(n - 1);
	for (size_t k = 1; k < n; ++k)
		steps[k - 1] = m[k].utime - m[k - 1].utime;
	std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
	const int64_t step_us = std::max<int64_t>(1, steps[steps.size() / 2]);
	out.dt = step_us * 1e-6;
	out.half = std::max(2, static_cast<int>(std::lround(half_s / out.dt)));
	for (size_t k = 0; k < n; ++k) {
		double vw[4], x[3];
		for (int j = 0; j < 4; ++j)
			vw[j] = m[k].w[j] * r[j];
		fk_robot_velocity(d, vw, x);
		out.raw[k] = {x[0], x[1], x[2]};
		if (k > 0) {
			const int64_t gap = m[k].utime - m[k - 1].utime;
			out.joined[k] = m[k].seq == m[k - 1].seq + 1 && 2 * gap > step_us &&
			                2 * gap < 3 * step_us;
		}
	}
}

// The samples' three axes as one flat array: element 3 k + axis.
static_assert(sizeof(std::array<double, 3>) == 3 * sizeof(double), "no padding");
double *flat(std::vector<std::array<double, 3>> &v)
{
	return reinterpret_cast<double *>(v.data());
}

// Two doubles as one value (GCC and Clang vector extensions): + and * per element, exactly as
// on two doubles, in whatever vector registers the target has.
typedef double Pair __attribute__((vector_size(16)));
Pair load_pair(const double *p)
{
	Pair v;
	std::memcpy(&v, p, sizeof v);
	return v;
}

// The filter over the contiguous block [a, b) (at least one whole window long). In the flat
// arrays the three axes are one series whose taps are 3 elements apart, so 8 neighbouring
// outputs (of any axes) are summed at once in registers, tap by tap in the filter's order: the
// same sums as one output at a time, without work arrays.
void filter_block(const SgFilter &f, size_t a, size_t b, EncoderTrack &out)
{
	constexpr size_t kPairs = 4; // 8 outputs
	const size_t h = static_cast<size_t>(out.half), taps = 2 * h + 1;
	const double *cs = f.smooth.data(), *cd = f.deriv.data();
	const double *raw = flat(out.raw);
	double *x = flat(out.x), *dx = flat(out.dx);
	const size_t i1 = 3 * (b - h); // outputs [3 (a + h), 3 (b - h))
	size_t i = 3 * (a + h);
	const Pair dt = {out.dt, out.dt};
	for (; i + 2 * kPairs <= i1; i += 2 * kPairs) {
		Pair s[kPairs] = {}, ds[kPairs] = {};
		const double *src = raw + (i - 3 * h);
		for (size_t q = 0; q < taps; ++q, src += 3) {
			const Pair c = {cs[q], cs[q]}, e = {cd[q], cd[q]};
			for (size_t j = 0; j < kPairs; ++j) {
				const Pair y = load_pair(src + 2 * j);
				s[j] += c * y;
				ds[j] += e * y;
			}
		}
		for (size_t j = 0; j < kPairs; ++j) {
			const Pair d = ds[j] / dt;
			std::memcpy(x + i + 2 * j, &s[j], sizeof(Pair));
			std::memcpy(dx + i + 2 * j, &d, sizeof(Pair));
		}
	}
	for (; i < i1; ++i) {
		double s = 0, ds = 0;
		const double *src = raw + (i - 3 * h);
		for (size_t q = 0; q < taps; ++q, src += 3) {
			s += cs[q] * *src;
			ds += cd[q] * *src;
		}
		x[i] = s;
		dx[i] = ds / out.dt;
	}
	for (size_t k = a + h; k + h < b; ++k)
		out.ok[k] = 1;
}

} // namespace

EncoderTrack encoder_track(const LogData &log, double d, double r, double half_s)
{
	return encoder_track(log, d, std::array<double, 4>{r, r, r, r}, half_s);
}

EncoderTrack encoder_track(const LogData &log, double d, const std::array<double, 4> &r,
                           double half_s)
{
	EncoderTrack out;
	const auto &m = log.motors;
	const size_t n = m.size();
	reserve_huge(out.raw, n);
	reserve_huge(out.x, n);
	reserve_huge(out.dx, n);
	out.raw.resize(n);
	out.x.assign(n, {NAN, NAN, NAN});
	out.dx.assign(n, {NAN, NAN, NAN});
	out.ok.assign(n, 0);
	out.joined.assign(n, 0);
	if (n < 3)
		return out;
	raw_velocities(m, d, r, half_s, out);
	const int h = out.half;
	const SgFilter f = savitzky_golay(h, 2);
	// Contiguous blocks [a, b): the filter runs inside each, never across a gap.
	size_t a = 0;
	for (size_t b = 1; b <= n; ++b) {
		if (b < n && out.joined[b])
			continue;
		if (b >= a + 2 * h + 1)
			filter_block(f, a, b, out);
		a = b;
	}
	return out;
}

CameraTrack pose_velocity(const std::vector<double> &t, const std::vector<double> &px,
                          const std::vector<double> &py, const std::vector<double> &theta,
                          double half_s)
{
	CameraTrack out;
	const size_t n = t.size();
	out.t = t;
	out.theta = theta;
	unwrap(out.theta);
	out.heading.assign(n, NAN);
	out.x.assign(n, {NAN, NAN, NAN});
	out.ok.assign(n, 0);
	size_t lo = 0, hi = 0;
	for (size_t k = 0; k < n; ++k) {
		while (out.t[lo] < out.t[k] - half_s)
			++lo;
		while (hi < n && out.t[hi] <= out.t[k] + half_s)
			++hi;
		// A local quadratic needs frames on both sides: at least 2 before and 2 after.
		if (k < lo + 2 || hi < k + 3 || hi - lo < 5)
			continue;
		Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
		Eigen::Matrix<double, 3, 3> B =
		    Eigen::Matrix<double, 3, 3>::Zero(); // rhs: x, y, theta
		for (size_t j = lo; j < hi; ++j) {
			const double tau = out.t[j] - out.t[k];
			const Eigen::Vector3d phi(1, tau, tau * tau);
			A += phi * phi.transpose();
			B.col(0) += phi * px[j];
			B.col(1) += phi * py[j];
			B.col(2) += phi * out.theta[j];
		}
		const Eigen::Matrix3d c = A.ldlt().solve(B); // rows: value, slope, curvature
		out.heading[k] = c(0, 2);
		const double xw[3] = {c(1, 0), c(1, 1), c(1, 2)};
		double xr[3];
		frame_world_to_robot(out.heading[k], xw, xr);
		out.x[k] = {xr[0], xr[1], xr[2]};
		out.ok[k] = std::isfinite(xr[0]) && std::isfinite(xr[1]) && std::isfinite(xr[2]);
	}
	return out;
}

CameraTrack camera_track(const LogData &log, double half_s)
{
	const auto &p = log.pose;
	std::vector<double> t(p.size()), x(p.size()), y(p.size()), th(p.size());
	for (size_t k = 0; k < p.size(); ++k) {
		t[k] = p[k].utime * 1e-6;
		x[k] = p[k].x;
		y[k] = p[k].y;
		th[k] = p[k].theta;
	}
	return pose_velocity(t, x, y, th, half_s);
}

} // namespace omni4
