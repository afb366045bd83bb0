// ident_wheels.cpp - omni4-ident's per-wheel output (ident_wheels.hpp).
#include "ident_wheels.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

extern "C" {
#include "omni4/config/config.h"
}

namespace omni4
{

namespace
{

std::string value_se(const Estimate &e, const char *fmt)
{
	if (!e.ok())
		return "-";
	char buf[64];
	std::snprintf(buf, sizeof(buf), fmt, e.value, e.se);
	return buf;
}

// The error to truth in per cent, or "".
std::string err_pct(const Estimate &e, const model_wheels *truth, double t)
{
	if (!truth || !e.ok() || !(t != 0))
		return "";
	char buf[32];
	std::snprintf(buf, sizeof(buf), " (%+.2f %%)", 100 * (e.value / t - 1));
	return buf;
}

void print_tests(const WheelResult &w)
{
	if (w.motors_tested)
		std::printf("motors differ? F(%d, %d) = %.3g, p = %.3g: %s\n", w.motors_df1,
		            w.motors_df2, w.motors_F, w.motors_p,
		            w.motors_differ ? "yes, each motor its own R_j, Kv_j = Kt_j"
		                            : "no, one R and Kv (their mean and pooled fit)");
	else
		std::printf("motors differ? not tested (fewer than 2 motors with 3 points)\n");
	if (w.radii_tested)
		std::printf("radii differ? chi2 = %.3g (3 dof), p = %.3g over %zu stretches: %s\n",
		            w.radii_chi2, w.radii_p, w.radii_rows,
		            w.radii_differ ? "yes, each wheel its own r_j = r rho_j"
		                           : "no, one r (the measured one)");
	else
		std::printf("radii differ? not tested (%zu stretches with the wheels turning)\n",
		            w.radii_rows);
	if (w.r_scale.ok())
		std::printf("mean wheel radius from the camera: %.5g ±%.2g m (reported; the file "
		            "keeps the measured r)\n",
		            w.r_scale.value, w.r_scale.se);
	else
		std::printf("mean wheel radius: %s\n", w.r_scale_note.c_str());
}

} // namespace

void print_wheels(const IdentResult &r, const model_wheels *truth)
{
	const WheelResult &w = r.wheels;
	std::printf(
	    "per wheel        R_j [ohm]            Kv_j = Kt_j [V s/rad]     r_j / mean r\n");
	for (int j = 0; j < 4; ++j) {
		double tr = NAN;
		if (truth) {
			double mean = 0;
			for (int k = 0; k < 4; ++k)
				mean += truth->r[k] / 4;
			tr = truth->r[j] / mean;
		}
		const std::string R = value_se(r.R_motor[j], "%.4f ±%.2g") +
		                      err_pct(r.R_motor[j], truth, truth ? truth->R[j] : 0);
		const std::string K = value_se(r.Kv_motor[j], "%.5f ±%.2g") +
		                      err_pct(r.Kv_motor[j], truth, truth ? truth->Kv[j] : 0);
		const std::string P =
		    value_se(w.rho[j], "%.5f ±%.2g") + err_pct(w.rho[j], truth, tr);
		std::printf("  wheel %d  %-27s %-27s %s\n", j, R.c_str(), K.c_str(), P.c_str());
	}
	print_tests(w);
}

std::string wheel_keys_ini(const IdentResult &r)
{
	std::ostringstream out;
	const WheelResult &w = r.wheels;
	char v[40];
	auto key = [&](const char *name, int j, double x) {
		config_format_double(v, sizeof(v), x);
		out << name << '_' << j << " = " << v << '\n';
	};
	if (w.motors_differ) {
		out << "; each motor's own R, Kv = Kt (the scalars above are their mean)\n";
		for (int j = 0; j < 4; ++j) {
			key("R", j, r.final_wheels.R[j]);
			key("Kv", j, r.final_wheels.Kv[j]);
			key("Kt", j, r.final_wheels.Kt[j]);
		}
	}
	if (w.radii_differ) {
		out << "; each wheel's own radius (relative from the wheels' rigid-body "
		       "consistency; "
		       "their mean is r)\n";
		for (int j = 0; j < 4; ++j)
			key("r", j, r.final_wheels.r[j]);
	}
	return out.str();
}

std::string wheels_csv(const IdentResult &r, const model_wheels *truth)
{
	std::ostringstream f;
	f.precision(10);
	f << "wheel,quantity,value,se,true\n";
	double tmean = 0;
	for (int k = 0; truth && k < 4; ++k)
		tmean += truth->r[k] / 4;
	for (int j = 0; j < 4; ++j) {
		auto row = [&](const char *q, const Estimate &e, double t) {
			f << j << ',' << q << ',';
			if (e.ok())
				f << e.value << ',' << e.se;
			else
				f << ',';
			f << ',';
			if (truth)
				f << t;
			f << '\n';
		};
		row("R", r.R_motor[j], truth ? truth->R[j] : NAN);
		row("Kv", r.Kv_motor[j], truth ? truth->Kv[j] : NAN);
		row("rho", r.wheels.rho[j], truth ? truth->r[j] / tmean : NAN);
		row("r", r.wheels.r_wheel[j], truth ? truth->r[j] : NAN);
	}
	return f.str();
}

model_wheels load_wheels(const std::string &path, bool with_sim_errors)
{
	omni4_config cfg;
	config_error err;
	config_defaults(&cfg);
	if (config_load(path.c_str(), &cfg, &err)) {
		std::fprintf(stderr, "omni4-ident: %s\n", err.msg);
		std::exit(2);
	}
	model_wheels w;
	ctl_settings_wheels(&cfg.ctl, &w);
	if (!with_sim_errors)
		return w;
	for (int j = 0; j < 4; ++j) {
		w.R[j] *= 1 + cfg.sim.motor_R_error[j];
		w.Kv[j] *= 1 + cfg.sim.motor_Kv_error[j];
		w.Kt[j] *= 1 + cfg.sim.motor_Kv_error[j];
		w.r[j] *= 1 + cfg.sim.wheel_radius_error[j];
	}
	return w;
}

} // namespace omni4
