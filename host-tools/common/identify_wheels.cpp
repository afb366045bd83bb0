// identify_wheels.cpp - the per-wheel part of the identification: the wheels' shape (each drive
// relative to the mean), the F-test of whether the motors differ, each wheel's radius relative
// to the others from the rigid-body consistency of the four wheel speeds, and the per-wheel
// axis inputs and inverses of experiment 3.
#include "identify_wheels.hpp"

#include <cmath>
#include <math.h> // lgamma_r (glibc, BSD)

namespace omni4
{

bool WheelShape::uniform() const
{
	for (int j = 0; j < 4; ++j)
		if (kv[j] != 1.0 || R[j] != 1.0 || r[j] != 1.0)
			return false;
	return true;
}

double WheelShape::beta(int j) const
{
	return kv[j] / (R[j] * r[j]);
}

double WheelShape::eps(int j) const
{
	return kv[j] * kv[j] / (R[j] * r[j] * r[j]);
}

model_wheels WheelShape::wheels(const model_params &p) const
{
	model_wheels w;
	for (int j = 0; j < 4; ++j) {
		w.r[j] = p.r * r[j];
		w.Kv[j] = p.Kv * kv[j];
		w.Kt[j] = p.Kt * kv[j];
		w.R[j] = p.R * R[j];
	}
	return w;
}

bool WheelResult::per_wheel() const
{
	return motors_differ || radii_differ;
}

double axis_beta(const WheelShape &s, int axis)
{
	if (axis == 0)
		return 0.5 * (s.beta(1) + s.beta(3));
	if (axis == 1)
		return 0.5 * (s.beta(0) + s.beta(2));
	return 0.25 * (s.beta(0) + s.beta(1) + s.beta(2) + s.beta(3));
}

double axis_input_wheels(const model_params &p, const WheelShape &s, const double u[4],
                         const double x[3], int axis)
{
	const double bb = axis_beta(s, axis), k = p.l * p.Kv / (p.r * bb);
	const double e31 = s.eps(3) - s.eps(1), e02 = s.eps(0) - s.eps(2);
	if (axis == 0)
		return (s.beta(3) * u[3] - s.beta(1) * u[1]) / bb - k * p.d * e31 * x[2];
	if (axis == 1)
		return (s.beta(0) * u[0] - s.beta(2) * u[2]) / bb - k * p.d * e02 * x[2];
	double sum = 0;
	for (int j = 0; j < 4; ++j)
		sum += s.beta(j) * u[j];
	return sum / bb - k * (e31 * x[0] + e02 * x[1]);
}

namespace
{

// Continued fraction of the regularised incomplete beta function (modified Lentz).
double beta_cf(double a, double b, double x)
{
	const double tiny = 1e-300;
	double c = 1, d = 1 - (a + b) * x / (a + 1);
	d = 1 / (std::abs(d) < tiny ? tiny : d);
	double h = d;
	for (int m = 1; m <= 300; ++m) {
		for (int odd = 0; odd < 2; ++odd) {
			const double aa =
			    odd ? -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))
			        : m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m));
			d = 1 + aa * d;
			d = 1 / (std::abs(d) < tiny ? tiny : d);
			c = 1 + aa / c;
			c = std::abs(c) < tiny ? tiny : c;
			h *= d * c;
			if (odd && std::abs(d * c - 1) < 1e-15)
				return h;
		}
	}
	return h;
}

// ln Γ(x) without std::lgamma's write to the global signgam (a data race when bootstrap
// replicates run on several threads).
double log_gamma(double x)
{
	int sign = 0;
	return lgamma_r(x, &sign);
}

// I_x(a, b).
double inc_beta(double a, double b, double x)
{
	if (x <= 0)
		return 0;
	if (x >= 1)
		return 1;
	const double front = std::exp(log_gamma(a + b) - log_gamma(a) - log_gamma(b) +
	                              a * std::log(x) + b * std::log1p(-x));
	if (x < (a + 1) / (a + b + 2))
		return front * beta_cf(a, b, x) / a;
	return 1 - front * beta_cf(b, a, 1 - x) / b;
}

} // namespace

double f_sf(double f, int df1, int df2)
{
	if (!(f > 0) || df1 <= 0 || df2 <= 0)
		return 1.0;
	// P(F > f) = I_{df2 / (df2 + df1 f)}(df2 / 2, df1 / 2).
	return inc_beta(0.5 * df2, 0.5 * df1, df2 / (df2 + df1 * f));
}

namespace ident
{

namespace
{

// Residual sum of squares of eq 22 (i on u and l w) over the points of one motor (or all: -1).
double motor_rss(const std::vector<MotorPoint> &points, int motor, size_t &n)
{
	std::vector<const MotorPoint *> pts;
	for (const MotorPoint &p : points)
		if (motor < 0 || p.motor == motor)
			pts.push_back(&p);
	n = pts.size();
	Eigen::MatrixXd X(pts.size(), 2);
	Eigen::VectorXd y(pts.size());
	for (size_t k = 0; k < pts.size(); ++k) {
		X(k, 0) = pts[k]->u;
		X(k, 1) = pts[k]->wm;
		y[k] = pts[k]->i;
	}
	const Eigen::VectorXd theta = X.colPivHouseholderQr().solve(y);
	return (y - X * theta).squaredNorm();
}

} // namespace

void motors_differ_test(const std::vector<MotorPoint> &points, WheelResult &w,
                        const IdentOptions &opt)
{
	double rss_sep = 0;
	size_t n_sep = 0;
	int fitted = 0;
	std::vector<MotorPoint> pooled; // the points of the motors with a fit of their own
	for (int j = 0; j < 4; ++j) {
		size_t n = 0;
		for (const MotorPoint &p : points)
			n += p.motor == j;
		if (n < 3)
			continue;
		rss_sep += motor_rss(points, j, n);
		n_sep += n;
		++fitted;
		for (const MotorPoint &p : points)
			if (p.motor == j)
				pooled.push_back(p);
	}
	if (fitted < 2)
		return;
	size_t n_all = 0;
	const double rss_all = motor_rss(pooled, -1, n_all);
	w.motors_df1 = 2 * fitted - 2;
	w.motors_df2 = static_cast<int>(n_sep) - 2 * fitted;
	if (w.motors_df2 <= 0 || n_all != n_sep)
		return;
	w.motors_tested = true;
	const double s2 = std::max(rss_sep / w.motors_df2, 1e-300);
	w.motors_F = std::max(0.0, rss_all - rss_sep) / w.motors_df1 / s2;
	w.motors_p = f_sf(w.motors_F, w.motors_df1, w.motors_df2);
	w.motors_differ = w.motors_p < opt.agree_p;
}

} // namespace ident

} // namespace omni4
