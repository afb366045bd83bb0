// identify_stats.cpp - the statistics of identify(): the chi-square tail and the combination of
// the methods' estimates of one parameter.
#include "identify.hpp"

#include <algorithm>
#include <cmath>

namespace omni4
{

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

// Two or more estimates, each SE raised to at least method_floor of its value: their
// inverse-variance weighted mean when their chi-square agrees. When it does not, one of them is
// biased beyond its SE and a mean of the two would carry that bias halfway: the better-determined
// estimate (smallest SE) is kept, its SE scaled by the Birge ratio sqrt(chi2 / dof) so that it
// also covers the disagreement.
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
	const size_t best =
	    static_cast<size_t>(std::min_element(se.begin(), se.end()) - se.begin());
	const double birge = std::sqrt(ag.chi2 / ag.dof);
	ag.kept = static_cast<int>(best);
	ag.birge = birge;
	ag.rule = "methods disagree: the better-determined one";
	return {ok[best].value, se[best] * birge, ok[best].se_borrowed};
}

} // namespace

Estimate combine_methods(const std::vector<Estimate> &estimates, const IdentOptions &opt,
                         Agreement *agreement)
{
	Agreement ag;
	std::vector<Estimate> ok, weak;
	std::vector<int> ok_index; // of each ok estimate in estimates
	for (size_t k = 0; k < estimates.size(); ++k) {
		const Estimate &e = estimates[k];
		if (!e.ok())
			continue;
		// An estimate whose SE exceeds max_rel_se of its value neither informs nor checks
		// the others: it is reported, not combined (unless it is the only one).
		const bool too_uncertain = std::abs(e.se) > opt.max_rel_se * std::abs(e.value);
		(too_uncertain ? weak : ok).push_back(e);
		if (!too_uncertain)
			ok_index.push_back(static_cast<int>(k));
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
		if (ag.kept >= 0)
			ag.kept = ok_index[static_cast<size_t>(ag.kept)];
	}
	if (agreement)
		*agreement = ag;
	return out;
}

} // namespace omni4
