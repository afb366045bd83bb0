// regression.hpp - least squares (eq 32), instrumental variables (eq 35), error propagation.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace omni4
{

struct IdentError : std::runtime_error {
	using std::runtime_error::runtime_error;
};

struct Fit {
	Eigen::VectorXd theta;
	Eigen::MatrixXd cov; // covariance of theta
	double sigma2 = 0;   // residual variance
	size_t n = 0;
};

// theta = argmin |X theta - y|^2, solved by column-pivoting QR (never an explicit inverse).
// corr_len: samples per independent error (the filter length for filtered series): the naive
// covariance sigma^2 (X^T X)^-1 is scaled by it. Throws IdentError("what: singular ...") when
// X is rank deficient.
Fit least_squares(const Eigen::MatrixXd &X, const Eigen::VectorXd &y, double corr_len,
                  const std::string &what);

// theta = (Z^T X)^-1 Z^T y with instruments Z (same shape as X).
Fit instrumental_variables(const Eigen::MatrixXd &Z, const Eigen::MatrixXd &X,
                           const Eigen::VectorXd &y, double corr_len, const std::string &what);

struct Estimate {
	double value = std::numeric_limits<double>::quiet_NaN();
	double se = std::numeric_limits<double>::quiet_NaN(); // standard error, all sources
	// The part of se that comes from other parameters the method borrows (Kv, R, Bw, Cw, the
	// current offsets): se^2 = own^2 + se_borrowed^2 (independent sources).
	double se_borrowed = 0;
	bool ok() const
	{
		return std::isfinite(value);
	}
};

// f(theta) with its standard error by first-order propagation (central differences).
// own: the indices of theta that are the method's own data; the variance from the others is
// reported as se_borrowed (own and borrowed entries must be uncorrelated in cov). Empty: all own.
Estimate propagate(const std::function<double(const Eigen::VectorXd &)> &f,
                   const Eigen::VectorXd &theta, const Eigen::MatrixXd &cov,
                   const std::vector<Eigen::Index> &own = {});

// Standard deviations of the outputs of f caused by independent inputs x0 with standard errors
// se (first order, central differences with a step of one SE; an input with a zero or
// non-finite SE contributes nothing).
Eigen::VectorXd
propagate_independent(const std::function<Eigen::VectorXd(const Eigen::VectorXd &)> &f,
                      const Eigen::VectorXd &x0, const Eigen::VectorXd &se);

} // namespace omni4
