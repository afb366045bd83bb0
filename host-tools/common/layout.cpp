// layout.cpp - the wheel layout of the identification (layout.hpp).
#include "layout.hpp"

#include <cmath>
#include <cstdio>

#include "logdata.hpp"
#include "regression.hpp"

extern "C" {
#include "omni4/model/consts.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/kinematics.h"
}

namespace omni4
{

void Layout::body_velocity(double d, const double rim[4], double x[3]) const
{
	if (paper) {
		double r4[4] = {rim[0], rim[1], rim[2], rim[3]};
		fk_robot_velocity(d, r4, x);
		return;
	}
	wheel_body(&ph, rim, x);
}

void Layout::body_force(double d, const double f[4], double F[3]) const
{
	if (paper) {
		dyn_robot_forces(d, f, F);
		return;
	}
	wheel_body_force(&ph, f, F);
}

std::string Layout::describe() const
{
	std::string a, r;
	char b[32];
	for (int j = 0; j < n; ++j) {
		std::snprintf(b, sizeof b, "%s%.6g", j ? "/" : "", angle_deg[j]);
		a += b;
		if (dist_m[j] > 0)
			std::snprintf(b, sizeof b, "%s%.6g", j ? "/" : "", dist_m[j]);
		else
			std::snprintf(b, sizeof b, "%sd", j ? "/" : "");
		r += b;
	}
	return std::to_string(n) + " wheels at " + a + " deg, " + r + " m from the centre (" +
	       (paper ? "the paper's layout, " : "") + "from " + source + ")";
}

namespace
{

// angle a [deg] is k * 90 deg (mod 360) to rounding (robot_t carries radians).
bool at_quarter(double a, int k)
{
	const double e = std::remainder(a - 90.0 * k, 360.0);
	return std::abs(e) < 1e-9;
}

} // namespace

Layout make_layout(int n, const double angle_deg[4], const double dist_m[4],
                   const std::string &source)
{
	Layout L;
	L.source = source;
	L.n = n;
	wheel_geom g;
	if (wheel_geom_angles(n, angle_deg, dist_m, &g) || wheel_phys_layout(&L.ph, &g))
		throw IdentError("the wheel layout (" + source +
		                 ") does not drive v, vn and w: 3 or 4 wheels, finite angles, "
		                 "distances > 0 m");
	L.geom = g;
	for (int j = 0; j < 4; ++j) {
		L.angle_deg[j] = j < n ? angle_deg[j] : 0.0;
		L.dist_m[j] = j < n ? dist_m[j] : 0.0;
	}
	bool paper = n == 4;
	for (int j = 0; paper && j < 4; ++j)
		paper = at_quarter(angle_deg[j], j) && dist_m[j] == dist_m[0];
	L.paper = paper;
	for (int a = 0; a < 3; ++a)
		for (int b = 0; b < 3; ++b) {
			double s = 0;
			for (int j = 0; j < n; ++j)
				s += L.ph.row[j][a] * L.ph.row[j][b];
			L.gtg[a][b] = s;
		}
	return L;
}

Layout layout_of_settings(const ctl_settings &s, const std::string &source)
{
	double dist[4];
	for (int j = 0; j < 4; ++j)
		dist[j] = ctl_settings_wheel_distance(&s, j);
	return make_layout(s.layout.wheels, s.layout.angle_deg, dist, source);
}

Layout layout_of_description(int wheels, const double angle_rad[4], const double dist_m[4],
                             const std::string &source)
{
	double a[4];
	for (int j = 0; j < 4; ++j)
		a[j] = angle_rad[j] * 180.0 / MODEL_PI;
	return make_layout(wheels, a, dist_m, source);
}

bool same_layout(const Layout &a, const Layout &b)
{
	if (a.n != b.n)
		return false;
	for (int j = 0; j < a.n; ++j)
		if (std::fabs(std::remainder(a.angle_deg[j] - b.angle_deg[j], 360.0)) > 1e-3 ||
		    std::fabs(a.dist_m[j] - b.dist_m[j]) > 1e-6)
			return false;
	return true;
}

Layout layout_of_log(const LogData &log, bool &found)
{
	found = log.robot.present;
	if (!found)
		return Layout{};
	return layout_of_description(log.robot.wheels, log.robot.wheel_angle_rad.data(),
	                             log.robot.wheel_distance_m.data(), "the log " + log.path);
}

Layout layout_of_logs(const std::vector<const LogData *> &logs, const Layout &fallback)
{
	Layout out = fallback;
	bool have = false;
	for (const LogData *log : logs) {
		bool found = false;
		const Layout L = layout_of_log(*log, found);
		if (!found)
			continue;
		if (have &&
		    (L.n != out.n || L.angle_deg != out.angle_deg || L.dist_m != out.dist_m))
			throw IdentError("the logs describe different wheel layouts: " +
			                 out.describe() + "; " + L.describe());
		if (!have)
			out = L;
		have = true;
	}
	return out;
}

} // namespace omni4
