// compare.cpp - one robot's figures for omni4-compare (compare.hpp, docs/compare.md).
#include "compare.hpp"

#include <cerrno>
#include <cmath>
#include <limits>

extern "C" {
#include "omni4/config/config.h"
#include "omni4/model/consts.h"
#include "plan_moves.h"
}

namespace omni4::compare
{

namespace
{

constexpr double kPi = MODEL_PI;

// A direction's component this small counts as none (no Coulomb friction along that axis).
double sgn(double x)
{
	return std::fabs(x) < 1e-12 ? 0.0 : (x > 0.0 ? 1.0 : -1.0);
}

std::string stem(const std::string &path)
{
	const size_t slash = path.find_last_of('/');
	std::string n = slash == std::string::npos ? path : path.substr(slash + 1);
	if (n.size() > 4 && n.compare(n.size() - 4, 4, ".ini") == 0)
		n.resize(n.size() - 4);
	return n;
}

// Tightens b with the row k s + c <= bound (s >= 0) of wheel j: the largest s it allows; 0 when
// s = 0 already breaks it.
void tighten(Bound &b, double k, double c, double bound, int j, const char *kind)
{
	double s = std::numeric_limits<double>::infinity();
	if (c > bound)
		s = 0.0;
	else if (k > 0.0)
		s = (bound - c) / k;
	if (s < b.value) {
		b.value = s;
		b.wheel = j;
		b.kind = kind;
	}
}

// Wheel j's force f_j = k s + c for the body force F = s Fs + F0 (least-norm split).
void split_lin(const wheel_phys &ph, int j, const double Fs[3], const double F0[3], double *k,
               double *c)
{
	*k = ph.split[j][0] * Fs[0] + ph.split[j][1] * Fs[1] + ph.split[j][2] * Fs[2];
	*c = ph.split[j][0] * F0[0] + ph.split[j][1] * F0[1] + ph.split[j][2] * F0[2];
}

} // namespace

Robot load_robot(const std::string &path)
{
	omni4_config cfg;
	config_error err;
	config_defaults(&cfg);
	if (config_load(path.c_str(), &cfg, &err)) // missing, unreadable or a bad key: its line
		throw CompareError(err.msg);
	Robot r;
	r.name = stem(path);
	r.path = path;
	r.s = cfg.ctl;
	if (ctl_settings_geom(&r.s, &r.geom))
		throw CompareError(path +
		                   ": [model] wheels: the layout does not drive v, vn and w");
	ctl_settings_wheels(&r.s, &r.w);
	if (wheel_phys_init(&r.ph, &r.geom, &r.s.model, &r.w, r.s.limits.com_height))
		throw CompareError(path + ": [limits] com_height: not usable");
	r.mu = r.s.limits.traction_mu > 0.0 ? r.s.limits.traction_mu : r.s.goal.floor_mu;
	r.supply_v = r.s.limits.supply_v;
	return r;
}

void heading_dir(double heading_deg, double e[3])
{
	const double q = heading_deg / 90.0;
	if (q == std::round(q)) { // exact on the axes
		const long k = ((long)std::round(q) % 4 + 4) % 4;
		const double c[4] = {1.0, 0.0, -1.0, 0.0}, s[4] = {0.0, 1.0, 0.0, -1.0};
		e[0] = c[k];
		e[1] = s[k];
	} else {
		e[0] = std::cos(heading_deg * kPi / 180.0);
		e[1] = std::sin(heading_deg * kPi / 180.0);
	}
	e[2] = 0.0;
}

Bound top_speed(const Robot &r, const double e[3])
{
	const model_params &p = r.s.model;
	const double B[3] = {p.Bv, p.Bvn, p.Bw}, C[3] = {p.Cv, p.Cvn, p.Cw};
	double Fs[3], F0[3];
	for (int k = 0; k < 3; k++) {
		Fs[k] = B[k] * e[k]; // viscous friction at unit speed
		F0[k] = C[k] * sgn(e[k]);
	}
	Bound b;
	b.value = std::numeric_limits<double>::infinity();
	double rim[4]; // each rim's speed at unit speed along e (eq 2)
	wheel_rims(&r.ph, e, rim);
	for (int j = 0; j < r.ph.n; j++) {
		double k, c;
		split_lin(r.ph, j, Fs, F0, &k, &c);
		const double ku = r.ph.vpn[j] * k + r.ph.kemf[j] * rim[j], cu = r.ph.vpn[j] * c;
		tighten(b, ku, cu, r.supply_v, j, "voltage"); // u_j <= supply_v
		tighten(b, -ku, -cu, r.supply_v, j, "voltage");
	}
	return b;
}

Bound envelope(const Robot &r, const double e[3])
{
	const model_params &p = r.s.model;
	const double I[3] = {p.M, p.M, p.J}, C[3] = {p.Cv, p.Cvn, p.Cw};
	double Fs[3], F0[3];
	for (int k = 0; k < 3; k++) {
		Fs[k] = I[k] * e[k];
		F0[k] = C[k] * sgn(e[k]);
	}
	Bound b;
	b.value = std::numeric_limits<double>::infinity();
	for (int j = 0; j < r.ph.n; j++) {
		double k, c;
		split_lin(r.ph, j, Fs, F0, &k, &c);
		// the load N_j = n0 + a n1: the centre of mass accelerates at a (e_v, e_vn)
		const double n0 = r.ph.load0[j],
		             n1 = r.ph.load_a[j][0] * e[0] + r.ph.load_a[j][1] * e[1];
		tighten(b, r.ph.vpn[j] * k, r.ph.vpn[j] * c, r.supply_v, j, "voltage");
		tighten(b, -r.ph.vpn[j] * k, -r.ph.vpn[j] * c, r.supply_v, j, "voltage");
		tighten(b, k - r.mu * n1, c, r.mu * n0, j, "traction"); // f_j <= mu N_j
		tighten(b, -k - r.mu * n1, -c, r.mu * n0, j, "traction");
	}
	return b;
}

WheelState at_rest(const Robot &r, const double e[3], double acc)
{
	const model_params &p = r.s.model;
	const double F[3] = {p.M * acc * e[0] + p.Cv * sgn(e[0]),
	                     p.M * acc * e[1] + p.Cvn * sgn(e[1]),
	                     p.J * acc * e[2] + p.Cw * sgn(e[2])};
	const double ac[2] = {acc * e[0], acc * e[1]};
	WheelState w{};
	wheel_split(&r.ph, F, w.force_n);
	wheel_loads(&r.ph, ac, w.load_n);
	for (int j = 0; j < r.ph.n; j++)
		w.voltage_v[j] = r.ph.vpn[j] * w.force_n[j];
	return w;
}

double energy_per_m(const Robot &r, const double e[3], double speed)
{
	const model_params &p = r.s.model;
	const double x[3] = {speed * e[0], speed * e[1], speed * e[2]};
	const double F[3] = {p.Bv * x[0] + p.Cv * sgn(x[0]), p.Bvn * x[1] + p.Cvn * sgn(x[1]),
	                     p.Bw * x[2] + p.Cw * sgn(x[2])};
	double f[4], rim[4], power_w = 0.0;
	wheel_split(&r.ph, F, f);
	wheel_rims(&r.ph, x, rim);
	for (int j = 0; j < r.ph.n; j++) {
		const double u = r.ph.vpn[j] * f[j] + r.ph.kemf[j] * rim[j];
		// eqs 12, 13: i_j = f_j r_j / (l Kt_j) = f_j vpn_j / R_j
		power_w += u * f[j] * r.ph.vpn[j] / r.w.R[j];
	}
	return power_w / speed;
}

const std::vector<Move> &moves()
{
	static const std::vector<Move> m = {
	    {"1 m along v", 1.0, 0.0, 0.0},
	    {"1 m along vn", 0.0, 1.0, 0.0},
	    {"1 m diagonal", std::sqrt(0.5), std::sqrt(0.5), 0.0},
	    {"90 deg turn", 0.0, 0.0, kPi / 2.0},
	    {"1 m along v with a 90 deg turn", 1.0, 0.0, kPi / 2.0},
	};
	return m;
}

std::vector<double> move_times(const Robot &r)
{
	std::vector<double> t;
	for (const Move &m : moves()) {
		const double goal[3] = {m.x_m, m.y_m, m.theta_rad};
		double d = 0.0;
		const int rc = compare_plan_move(&r.s, &r.geom, goal, &d);
		if (rc == -EINVAL) { // no acceleration at rest: nothing to plan
			t.assign(moves().size(), std::numeric_limits<double>::quiet_NaN());
			return t;
		}
		if (rc)
			throw CompareError(r.path + ": the planner refuses the move '" + m.name +
			                   "'");
		t.push_back(d);
	}
	return t;
}

} // namespace omni4::compare
