// signals.cpp - Savitzky-Golay filters and velocity series.
#include "signals.hpp"
#include "median.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>

extern "C" {
#include "omni4/model/consts.h"
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
		if (jump > MODEL_PI)
			offset -= 2 * MODEL_PI * std::round(jump / (2 * MODEL_PI));
		else if (jump < -MODEL_PI)
			offset += 2 * MODEL_PI * std::round(-jump / (2 * MODEL_PI));
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

// The robot velocity of every sample (eqs 3-5), appended to out.raw (reserved), the filter's
// time step and half width, and whether each sample joins the previous one (next seq, about
// one step later).
void raw_velocities(const std::vector<MotorsSample> &m, const Layout &layout, double d,
                    const std::array<double, 4> &r, double half_s, EncoderTrack &out)
{
	const size_t n = m.size();
	int64_t step_us = 1;
	median_int64(
	    [&](auto visit) {
		    for (size_t k = 1; k < n; ++k)
			    visit(m[k].utime - m[k - 1].utime);
	    },
	    step_us);
	step_us = std::max<int64_t>(1, step_us);
	out.dt = step_us * 1e-6;
	out.half = std::max(2, static_cast<int>(std::lround(half_s / out.dt)));
	for (size_t k = 0; k < n; ++k) {
		double vw[4], x[3];
		for (int j = 0; j < 4; ++j)
			vw[j] = m[k].w[j] * r[j];
		layout.body_velocity(d, vw, x);
		out.raw.push_back({x[0], x[1], x[2]});
		if (k > 0) {
			const int64_t gap = m[k].utime - m[k - 1].utime;
			out.joined[k] = m[k].seq == m[k - 1].seq + 1 && 2 * gap > step_us &&
			                2 * gap < 3 * step_us;
		}
	}
}

// The samples' three axes as one flat array: element 3 k + axis.
static_assert(sizeof(std::array<double, 3>) == 3 * sizeof(double), "no padding");
const double *flat(const std::vector<std::array<double, 3>> &v)
{
	return reinterpret_cast<const double *>(v.data());
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

// Appends `count` samples (3 count doubles from p) to v, whose capacity holds them.
void append(std::vector<std::array<double, 3>> &v, const double *p, size_t count)
{
	const auto *s = reinterpret_cast<const std::array<double, 3> *>(p);
	v.insert(v.end(), s, s + count);
}

void append_nan(EncoderTrack &out, size_t count)
{
	out.x.insert(out.x.end(), count, {NAN, NAN, NAN});
	out.dx.insert(out.dx.end(), count, {NAN, NAN, NAN});
}

// 8 neighbouring outputs (of any axes) of the filter from the flat input at src (its first
// tap), summed at once in registers, tap by tap in the filter's order: the same sums as one
// output at a time. Values to x, derivatives to dx.
void filter8(const SgFilter &f, size_t taps, const double *src, double dt, double *x, double *dx)
{
	constexpr size_t kPairs = 4;
	const double *cs = f.smooth.data(), *cd = f.deriv.data();
	Pair s[kPairs] = {}, ds[kPairs] = {};
	for (size_t q = 0; q < taps; ++q, src += 3) {
		const Pair c = {cs[q], cs[q]}, e = {cd[q], cd[q]};
		for (size_t j = 0; j < kPairs; ++j) {
			const Pair y = load_pair(src + 2 * j);
			s[j] += c * y;
			ds[j] += e * y;
		}
	}
	const Pair dtp = {dt, dt};
	for (size_t j = 0; j < kPairs; ++j) {
		const Pair d = ds[j] / dtp;
		std::memcpy(x + 2 * j, &s[j], sizeof(Pair));
		std::memcpy(dx + 2 * j, &d, sizeof(Pair));
	}
}

// The filter over the contiguous block [a, b) (at least one whole window long), appended to
// out.x and out.dx: NaN for the half windows at its ends. In the flat arrays the three axes
// are one series whose taps are 3 elements apart; the outputs go through a small buffer of 8
// samples, so the arrays are written once (no fill that the filter then overwrites).
void filter_block(const SgFilter &f, size_t a, size_t b, EncoderTrack &out)
{
	constexpr size_t kChunk = 8; // samples: 24 outputs, 3 passes of filter8
	const size_t h = static_cast<size_t>(out.half), taps = 2 * h + 1;
	const double *raw = flat(out.raw);
	append_nan(out, h);
	size_t k = a + h;
	for (; k + kChunk + h <= b; k += kChunk) {
		double x[3 * kChunk], dx[3 * kChunk];
		for (size_t o = 0; o < 3 * kChunk; o += 8)
			filter8(f, taps, raw + 3 * (k - h) + o, out.dt, x + o, dx + o);
		append(out.x, x, kChunk);
		append(out.dx, dx, kChunk);
	}
	for (; k + h < b; ++k) {
		double x[3], dx[3];
		for (size_t ax = 0; ax < 3; ++ax) {
			double s = 0, ds = 0;
			const double *src = raw + 3 * (k - h) + ax;
			for (size_t q = 0; q < taps; ++q, src += 3) {
				s += f.smooth[q] * *src;
				ds += f.deriv[q] * *src;
			}
			x[ax] = s;
			dx[ax] = ds / out.dt;
		}
		append(out.x, x, 1);
		append(out.dx, dx, 1);
	}
	append_nan(out, h);
	for (size_t i = a + h; i + h < b; ++i)
		out.ok[i] = 1;
}

} // namespace

EncoderTrack encoder_track(const LogData &log, double d, double r, double half_s)
{
	return encoder_track(log, d, std::array<double, 4>{r, r, r, r}, half_s);
}

EncoderTrack encoder_track(const LogData &log, double d, const std::array<double, 4> &r,
                           double half_s)
{
	return encoder_track(log, Layout{}, d, r, half_s);
}

EncoderTrack encoder_track(const LogData &log, const Layout &layout, double d,
                           const std::array<double, 4> &r, double half_s)
{
	EncoderTrack out;
	const auto &m = log.motors;
	const size_t n = m.size();
	// Reserved, then written once in sample order (no value-initialised arrays that are then
	// overwritten: the pages are first touched by their final values).
	reserve_huge(out.raw, n);
	reserve_huge(out.x, n);
	reserve_huge(out.dx, n);
	out.ok.assign(n, 0);
	out.joined.assign(n, 0);
	if (n < 3) {
		out.raw.resize(n);
		append_nan(out, n);
		return out;
	}
	raw_velocities(m, layout, d, r, half_s, out);
	const size_t h = static_cast<size_t>(out.half);
	const SgFilter f = savitzky_golay(out.half, 2);
	// Contiguous blocks [a, b): the filter runs inside each, never across a gap.
	size_t a = 0;
	for (size_t b = 1; b <= n; ++b) {
		if (b < n && out.joined[b])
			continue;
		if (b >= a + 2 * h + 1)
			filter_block(f, a, b, out);
		else
			append_nan(out, b - a);
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
