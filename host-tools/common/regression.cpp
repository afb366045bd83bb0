// regression.cpp - LS / IV solvers on Eigen.
#include "regression.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace omni4
{

Fit least_squares(const Eigen::MatrixXd &X, const Eigen::VectorXd &y, double corr_len,
                  const std::string &what)
{
	const Eigen::Index n = X.rows(), p = X.cols();
	if (n <= p)
		throw IdentError(what + ": too few samples (" + std::to_string(n) + ") for " +
		                 std::to_string(p) + " parameters");
	Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
	qr.setThreshold(1e-10);
	if (qr.rank() < p)
		throw IdentError(what + ": singular regression (regressors are collinear)");
	Fit f;
	f.theta = qr.solve(y);
	const Eigen::VectorXd r = y - X * f.theta;
	f.n = static_cast<size_t>(n);
	f.sigma2 = r.squaredNorm() / static_cast<double>(n - p);
	const Eigen::MatrixXd XtX = X.transpose() * X;
	f.cov =
	    f.sigma2 * std::max(1.0, corr_len) * XtX.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
	return f;
}

Fit instrumental_variables(const Eigen::MatrixXd &Z, const Eigen::MatrixXd &X,
                           const Eigen::VectorXd &y, double corr_len, const std::string &what)
{
	const Eigen::Index n = X.rows(), p = X.cols();
	if (n <= p)
		throw IdentError(what + ": too few samples for instrumental variables");
	const Eigen::MatrixXd ZtX = Z.transpose() * X;
	Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(ZtX);
	if (qr.rank() < p)
		throw IdentError(what + ": singular instrumental-variable system");
	Fit f;
	f.theta = qr.solve(Z.transpose() * y);
	const Eigen::VectorXd r = y - X * f.theta;
	f.n = static_cast<size_t>(n);
	f.sigma2 = r.squaredNorm() / static_cast<double>(n - p);
	const Eigen::MatrixXd inv = qr.solve(Eigen::MatrixXd::Identity(p, p));
	f.cov = f.sigma2 * std::max(1.0, corr_len) * inv * (Z.transpose() * Z) * inv.transpose();
	return f;
}

Estimate propagate(const std::function<double(const Eigen::VectorXd &)> &f,
                   const Eigen::VectorXd &theta, const Eigen::MatrixXd &cov,
                   const std::vector<Eigen::Index> &own)
{
	Estimate e;
	e.value = f(theta);
	Eigen::VectorXd g(theta.size());
	for (Eigen::Index k = 0; k < theta.size(); ++k) {
		const double h = 1e-6 * std::max(1e-6, std::abs(theta[k]));
		Eigen::VectorXd a = theta, b = theta;
		a[k] += h;
		b[k] -= h;
		g[k] = (f(a) - f(b)) / (2 * h);
	}
	const double total = std::max(0.0, g.dot(cov * g));
	e.se = std::sqrt(total);
	if (!own.empty()) {
		Eigen::VectorXd go = Eigen::VectorXd::Zero(g.size());
		for (Eigen::Index k : own)
			go[k] = g[k];
		e.se_borrowed = std::sqrt(std::max(0.0, total - go.dot(cov * go)));
	}
	return e;
}

Eigen::VectorXd
propagate_independent(const std::function<Eigen::VectorXd(const Eigen::VectorXd &)> &f,
                      const Eigen::VectorXd &x0, const Eigen::VectorXd &se)
{
	Eigen::VectorXd var;
	for (Eigen::Index k = 0; k < x0.size(); ++k) {
		if (!(se[k] > 0) || !std::isfinite(se[k]))
			continue;
		Eigen::VectorXd a = x0, b = x0;
		a[k] += se[k];
		b[k] -= se[k];
		const Eigen::VectorXd g = 0.5 * (f(a) - f(b));
		if (var.size() == 0)
			var = Eigen::VectorXd::Zero(g.size());
		var += g.cwiseProduct(g);
	}
	if (var.size() == 0)
		return Eigen::VectorXd::Zero(f(x0).size());
	return var.cwiseSqrt();
}

} // namespace omni4
