// omni4-ident: identify the paper's model from LCM logs, validate it, run the experiments.
#include "cli.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <future>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "bootstrap.hpp"
#include "encoders.hpp"
#include "ident_traction.hpp"
#include "ident_wheels.hpp"
#include "identify.hpp"
#include "logdata.hpp"
#include "offsets.hpp"
#include "outfile.hpp"
#include "runner.hpp"
#include "traction_exp.hpp"
#include "validate.hpp"

extern "C" {
#include "omni4/config/config.h"
}

namespace
{

using namespace omni4;

[[noreturn]] void die(const std::string &msg, int code = 1)
{
	std::fprintf(stderr, "omni4-ident: %s\n", msg.c_str());
	std::exit(code);
}

// What was corrected in a log's sensors before use (encoders.hpp, offsets.hpp).
struct SensorFix {
	TickRescale tick;
	std::vector<RippleFit> ripple;
	std::vector<std::string> offset_warnings;
};

void print_encoder_fixes(const LogData &d, const SensorFix &fix)
{
	const TickRescale &t = fix.tick;
	if (t.applied)
		std::printf(
		    "%s: loop ticks jitter by %.0f us RMS and the wheel speeds carry it (counts "
		    "over the nominal %.3g ms): rescaled to the true intervals (second "
		    "differences %.0f %% smaller)\n",
		    d.path.c_str(), t.jitter_s * 1e6, t.period_s * 1e3,
		    100 * (1 - t.roughness_rescaled / t.roughness_logged));
	double worst = 0, worst_se = 0;
	int wheel = -1, removed = 0;
	for (const RippleFit &f : fix.ripple)
		for (int j = 0; j < 4; ++j) {
			removed += f.motor_removed[j];
			if (f.motor_eps[j] > worst)
				worst = f.motor_eps[j], worst_se = f.motor_se[j], wheel = j;
		}
	if (removed)
		std::printf("%s: encoder ripple once per motor revolution removed in %d of %zu "
		            "wheel-stretches (largest: wheel %d, %.2f %% ±%.2f)\n",
		            d.path.c_str(), removed, 4 * fix.ripple.size(), wheel, 100 * worst,
		            100 * worst_se);
	else
		std::printf("%s: no encoder ripple over 4 SE (largest %.2f %% ±%.2f)\n",
		            d.path.c_str(), 100 * worst, 100 * worst_se);
}

// Current-sense offsets of every log (estimated from its bridge-off samples and subtracted
// before the motor test and experiment 1), printed beside what the controller said it applied.
void print_offsets(const std::vector<LogData> &logs, const std::vector<std::string> &warnings)
{
	std::printf(
	    "current-sense offsets left in the logged currents, from the bridge-off samples "
	    "(subtracted before the motor test and experiment 1) [A]:\n");
	for (const LogData &d : logs) {
		for (const OffsetEpoch &e : d.current_offsets) {
			std::string from =
			    e.notice >= 0
			        ? " from seq " + std::to_string(d.calibrations[e.notice].seq)
			        : std::string();
			if (!e.subtracted) {
				std::printf("  %s%s: not estimated\n", d.path.c_str(),
				            from.c_str());
				continue;
			}
			std::printf("  %s%s: %zu samples%s\n   ", d.path.c_str(), from.c_str(),
			            e.samples,
			            e.pooled ? " (too few: the log's pooled estimate)" : "");
			for (int j = 0; j < 4; ++j)
				std::printf("  m%d %+.4f ±%.4f", j, e.offset_a[j], e.se_a[j]);
			std::printf("\n");
			if (e.notice >= 0) {
				const CalibrationNotice &n = d.calibrations[e.notice];
				std::printf("    the controller subtracted (its calibration over "
				            "%d samples):",
				            n.samples);
				for (int j = 0; j < 4; ++j)
					std::printf("  m%d %+.4f", j, n.offset_a[j]);
				std::printf("\n");
			}
		}
		if (d.calibrations.empty())
			std::printf("    (the log holds no calibration notice: the controller "
			            "subtracted nothing "
			            "that it announced)\n");
	}
	for (const std::string &w : warnings)
		std::printf("warning: %s\n", w.c_str());
}

// Reads the logs on all cores and, in the same tasks, corrects their sensors: wheel speeds that
// carry the loop's jitter, once-per-motor-revolution encoder ripple (gear: l), and with
// `offsets` the current-sense offsets. Prints what each log held and what was corrected.
std::vector<LogData> load_logs(const std::vector<std::string> &paths, double gear, bool offsets)
{
	struct Loaded {
		LogData d;
		SensorFix fix;
	};
	auto load = [gear, offsets](const std::string &path) {
		Loaded l{read_log(path), {}};
		l.fix.tick = rescale_to_tick_intervals(l.d);
		l.fix.ripple = remove_encoder_ripple(l.d, gear);
		if (offsets)
			l.fix.offset_warnings = calibrate_currents(l.d);
		return l;
	};
	std::vector<std::future<Loaded>> pending;
	const size_t workers = log_workers(paths.size());
	std::vector<LogData> logs;
	std::vector<std::string> warnings;
	logs.reserve(paths.size());
	size_t next = 0;
	auto launch = [&] {
		pending.push_back(std::async(std::launch::async, load, paths[next++]));
	};
	while (next < paths.size() && pending.size() < workers)
		launch();
	for (size_t i = 0; i < paths.size(); ++i) {
		Loaded l;
		try {
			l = pending[i].get();
		} catch (const std::exception &e) {
			die(e.what());
		}
		if (next < paths.size())
			launch();
		const LogData &d = l.d;
		std::printf("%s: %llu events (%zu motors, %zu poses, %zu marks)", paths[i].c_str(),
		            (unsigned long long)d.events, d.motors.size(), d.pose.size(),
		            d.marks.size());
		if (d.bytes_skipped || d.undecodable || d.implausible || d.seq_gaps)
			std::printf(
			    "; skipped %llu of %llu bytes (truncated or corrupt), %llu undecodable "
			    "events, %llu implausible (time, count or value out of range), %llu "
			    "lost "
			    "samples",
			    (unsigned long long)d.bytes_skipped, (unsigned long long)d.bytes_total,
			    (unsigned long long)d.undecodable, (unsigned long long)d.implausible,
			    (unsigned long long)d.seq_gaps);
		std::printf("\n");
		print_encoder_fixes(d, l.fix);
		warnings.insert(warnings.end(), l.fix.offset_warnings.begin(),
		                l.fix.offset_warnings.end());
		logs.push_back(std::move(l.d));
	}
	if (offsets)
		print_offsets(logs, warnings);
	return logs;
}

std::vector<Segment> segments_of(const std::vector<LogData> &logs)
{
	std::vector<Segment> all;
	for (const LogData &d : logs) {
		auto s = split_segments(d);
		all.insert(all.end(), s.begin(), s.end());
	}
	if (all.empty()) {
		size_t marks = 0, motors = 0;
		for (const LogData &d : logs) {
			marks += d.marks.size();
			motors += d.motors.size();
		}
		if (marks == 0)
			die("no experiment segments: the logs carry no OMNI4_EXPERIMENT marks "
			    "(record them with "
			    "'omni4-ident run' or 'omni4-sim --experiments')");
		if (motors == 0)
			die("no experiment segments: the logs carry " + std::to_string(marks) +
			    " OMNI4_EXPERIMENT marks but no OMNI4_MOTORS samples (no controller "
			    "was publishing "
			    "on the bus the log was recorded from)");
		die("no experiment segments: none of the " + std::to_string(marks) +
		    " OMNI4_EXPERIMENT marks has OMNI4_MOTORS samples after it");
	}
	return all;
}

// The per-wheel [model] keys a robot file gives (r_j Kv_j Kt_j R_j): their bits
// (CTL_WHEEL_KEY) and values.
struct WheelKeys {
	uint16_t keys = 0;
	model_wheels values{};
};

model_params load_params(const std::string &path, bool partial, uint32_t *seen_out = nullptr,
                         WheelKeys *wheels_out = nullptr, Layout *layout_out = nullptr)
{
	omni4_config cfg;
	config_error err;
	config_defaults(&cfg);
	uint32_t seen = 0;
	const int rc = partial ? config_load_partial(path.c_str(), &cfg, &seen, &err)
	                       : config_load(path.c_str(), &cfg, &err);
	if (rc)
		die(err.msg, 2);
	if (partial) {
		for (int i : {0, 1, 2, 6}) // d r l M
			if (!(seen & (1u << i)))
				die(path + ": the robot file must give the measured '" +
				        model_params_names[i] + "' in [model]",
				    2);
	}
	if (seen_out)
		*seen_out = partial ? seen : ~0u;
	if (wheels_out) {
		wheels_out->keys = cfg.ctl.wheel_keys;
		wheels_out->values = cfg.ctl.wheels;
	}
	if (layout_out) {
		try {
			*layout_out = layout_of_settings(cfg.ctl, path);
		} catch (const IdentError &e) {
			die(path + ": " + e.what(), 2);
		}
	}
	return cfg.ctl.model;
}

// Written as every output (outfile.hpp): never a half-written PARAMS file. A parameter that was
// not identified is taken from BASE.ini if it gives one (said in a comment), else left out, so
// that the firmware refuses the file ("missing key") instead of running on a guess.
// The robot file's per-wheel keys that wheel_keys_ini did not write: each identified one
// (identification measured that wheel: its drive in final_wheels, the scalar where the wheels
// do not differ) with the identified value, the others as the robot file gives them, each
// marked; for the keys wheel_keys_ini wrote, the robot file's value in a comment.
std::string robot_wheel_keys_ini(const IdentResult &r, const WheelKeys &base)
{
	static const char *const names[4] = {"r", "Kv", "Kt", "R"};
	const double *fin[4] = {r.final_wheels.r, r.final_wheels.Kv, r.final_wheels.Kt,
	                        r.final_wheels.R};
	const double *was[4] = {base.values.r, base.values.Kv, base.values.Kt, base.values.R};
	std::ostringstream out;
	char v[40], b[40];
	for (int q = 0; q < 4; ++q)
		for (int j = 0; j < 4; ++j) {
			if (!(base.keys & CTL_WHEEL_KEY(q, j)))
				continue;
			const bool motor = q > 0;
			const bool written = motor ? r.wheels.motors_differ : r.wheels.radii_differ;
			const bool measured =
			    motor ? (q == 3 ? r.R_motor[j].ok() : r.Kv_motor[j].ok())
			          : r.wheels.rho[j].ok();
			config_format_double(b, sizeof(b), was[q][j]);
			if (written) {
				out << "; " << names[q] << '_' << j
				    << " identified above (the robot file "
				    << "gave " << b << ")\n";
				continue;
			}
			if (measured) {
				config_format_double(v, sizeof(v), fin[q][j]);
				out << names[q] << '_' << j << " = " << v << " ; identified: the "
				    << (motor ? "motors" : "radii")
				    << " do not differ (the robot file "
				    << "gave " << b << ")\n";
			} else {
				out << names[q] << '_' << j << " = " << b
				    << " ; not identified: from the robot file\n";
			}
		}
	return out.str();
}

// The layout's [model] keys (a layout other than the paper's: the robot runs on them).
std::string layout_keys_ini(const Layout &L)
{
	if (L.paper)
		return "";
	std::string out =
	    "; the wheels' layout (" + L.describe() + ")\nwheels = " + std::to_string(L.n) + "\n";
	char v[40];
	for (int j = 0; j < L.n; ++j) {
		config_format_double(v, sizeof(v), L.angle_deg[j]);
		out += "wheel_angle_" + std::to_string(j) + " = " + v + "\n";
		config_format_double(v, sizeof(v), L.dist_m[j]);
		out += "d_" + std::to_string(j) + " = " + v + "\n";
	}
	return out;
}

// The layout of the logs (their OMNI4_ROBOT), else the robot file's (its [model] wheels,
// wheel_angle_j, d_j; none: the paper's), said in one line when it is not the paper's.
Layout layout_or_die(const std::vector<LogData> &logs, const Layout &file)
{
	std::vector<const LogData *> ptrs;
	for (const LogData &d : logs)
		ptrs.push_back(&d);
	try {
		Layout L = layout_of_logs(ptrs, file);
		if (!L.paper)
			std::printf("layout: %s\n", L.describe().c_str());
		return L;
	} catch (const IdentError &e) {
		die(e.what());
	}
	return {};
}

void write_params_to(FILE *f, const IdentResult &r, const model_params &base, uint32_t base_seen,
                     const WheelKeys &base_wheels, const std::string &comment,
                     const TractionResult *trac = nullptr)
{
	bool ok = std::fprintf(f, "; %s\n", comment.c_str()) > 0;
	if (r.complete()) {
		ok = ok && config_write_model(f, &r.final) == 0 &&
		     std::fputs(wheel_keys_ini(r).c_str(), f) >= 0;
	} else {
		ok = ok && std::fprintf(
		               f, "; partial identification: see the missing list of omni4-ident\n"
		                  "[model]\n") > 0;
		for (int i = 0; i < MODEL_PARAMS_COUNT; ++i) {
			const std::string name = model_params_names[i];
			const auto id = r.identified.find(name == "Kt" ? "Kv" : name);
			const bool measured =
			    name == "d" || name == "r" || name == "l" || name == "M";
			char v[40];
			if (measured || (id != r.identified.end() && id->second))
				ok = ok &&
				     config_format_double(v, sizeof(v),
				                          model_params_get(&r.final, i)) > 0 &&
				     std::fprintf(f, "%s = %s\n", name.c_str(), v) > 0;
			else if (base_seen & (1u << i))
				ok = ok &&
				     config_format_double(v, sizeof(v),
				                          model_params_get(&base, i)) > 0 &&
				     std::fprintf(f,
				                  "%s = %s ; not identified: from the robot file\n",
				                  name.c_str(), v) > 0;
			else
				ok = ok &&
				     std::fprintf(f, "; %s not identified\n", name.c_str()) > 0;
		}
	}
	ok = ok && std::fputs(robot_wheel_keys_ini(r, base_wheels).c_str(), f) >= 0;
	ok = ok && std::fputs(layout_keys_ini(r.wheels.shape.layout).c_str(), f) >= 0;
	if (trac)
		ok = ok && write_traction_limits(f, *trac);
	if (!ok && !std::ferror(f))
		throw OutError("a value cannot be written");
}

void write_params(const std::string &path, const IdentResult &r, const model_params &base,
                  uint32_t base_seen, const WheelKeys &base_wheels, const std::string &comment,
                  const TractionResult *trac = nullptr)
{
	try {
		OutFile out(path);
		write_params_to(out.file(), r, base, base_seen, base_wheels, comment, trac);
		out.commit();
	} catch (const OutError &e) { // the temporary is gone (out destroyed), the target as it was
		die(e.what());
	}
}

std::string fmt(const Estimate &e)
{
	if (!e.ok())
		return "";
	char buf[64];
	if (std::isfinite(e.se) && e.se_borrowed > 0.05 * e.se)
		std::snprintf(buf, sizeof(buf), "%.4g ±%.2g b%.0f", e.value, e.se,
		              100 * e.se_borrowed * e.se_borrowed / (e.se * e.se));
	else if (std::isfinite(e.se))
		std::snprintf(buf, sizeof(buf), "%.4g ±%.2g", e.value, e.se);
	else
		std::snprintf(buf, sizeof(buf), "%.4g", e.value);
	return buf;
}

double field(const model_params &p, const std::string &name)
{
	for (int i = 0; i < MODEL_PARAMS_COUNT; ++i)
		if (name == model_params_names[i])
			return model_params_get(&p, i);
	return NAN;
}

// A final estimate whose standard error exceeds 1 % of its value: the data do not pin it to
// the 2 % that identification aims at (two standard errors).
bool thin_estimate(const Estimate &e)
{
	return std::isfinite(e.se) && e.se > 0.01 * std::abs(e.value);
}

// One row per parameter: every method's estimate, the methods' agreement, the error to truth.
void print_estimates(const IdentResult &r, const model_params *truth)
{
	static const char *const headers[6] = {"motor test", "exp 1",    "exp 2",
	                                       "exp 3 LS",   "exp 3 IV", "final"};
	std::printf("\n%-5s", "param");
	for (const char *h : headers)
		std::printf(" %22s", h);
	std::printf(" %-12s", "methods");
	if (truth)
		std::printf(" %10s %8s", "true", "error");
	std::printf("\n");
	std::vector<const char *> rows(std::begin(kIdentParams), std::end(kIdentParams));
	if (r.identified.count("M")) // a current drive's
		rows.push_back("M");
	for (const char *p : rows) {
		std::printf("%-5s", p);
		for (const char *m : kIdentMethods)
			std::printf(" %22s", fmt(find_estimate(r, m, p)).c_str());
		if (r.table.count("drive") && r.table.at("drive").count(p)) {
			std::printf(" %-12s\n", "the drive's");
			continue;
		}
		const Agreement &ag = r.agreement.count(p) ? r.agreement.at(p) : Agreement{};
		char agree[32] = "";
		if (ag.methods >= 2)
			std::snprintf(agree, sizeof(agree), "%s p=%.2g",
			              ag.agree ? "agree" : "DISAGREE", ag.p);
		if (thin_estimate(find_estimate(r, "final", p)))
			std::strncat(agree, agree[0] ? " THIN" : "THIN",
			             sizeof(agree) - std::strlen(agree) - 1);
		std::printf(" %-12s", agree);
		const Estimate fin = find_estimate(r, "final", p);
		if (truth && fin.ok()) {
			const double t = field(*truth, p);
			std::printf(" %10.4g %+7.2f%%", t, 100 * (fin.value - t) / t);
		}
		std::printf("\n");
	}
}

// Disagreeing methods, and final values whose SE is over 1 % of the value.
void print_warnings(const IdentResult &r)
{
	for (const char *p : kIdentParams) {
		const Agreement &ag = r.agreement.at(p);
		if (ag.methods >= 2 && !ag.agree)
			std::printf(
			    "warning: the methods disagree on %s (chi-square %.1f, p = %.2g); "
			    "final = %s, the better-determined, its SE x%.1f for the "
			    "disagreement. Look at the rejected windows and the plots.\n",
			    p, ag.chi2, ag.p, ag.kept_method.c_str(), ag.birge);
	}
	// Thin data: a final SE over 1 % of the value cannot support 2 % (two SE).
	std::string thin;
	for (const char *p : kIdentParams) {
		const Estimate e = find_estimate(r, "final", p);
		if (e.ok() && thin_estimate(e)) {
			char buf[96];
			std::snprintf(buf, sizeof(buf), "%s%s ±%.1f %%", thin.empty() ? "" : ", ",
			              p, 100 * e.se / std::abs(e.value));
			thin += buf;
		}
	}
	if (!thin.empty())
		std::printf(
		    "warning: thin data: %s (standard error over 1 %%: not pinned to 2 %%; record "
		    "more runs of the experiments that give them, or longer ones)\n",
		    thin.c_str());
}

void print_table(const IdentResult &r, const model_params *truth, const model_wheels *truth_w)
{
	print_estimates(r, truth);
	std::printf(
	    "(± standard error, with what the method borrows (Kv, R, Bw, Cw, current "
	    "offsets) included; bNN: NN %% of its variance is borrowed. final: the methods' "
	    "estimates, each SE raised to at least 0.5 %% of its value, agree when their "
	    "chi-square p >= 0.01: inverse-variance "
	    "weighted mean; when they disagree: the better-determined one, its SE x "
	    "sqrt(chi2/dof). "
	    "Kt = Kv)\n");
	std::printf(
	    "units: Kv = Kt V s/rad (N m/A), R ohm, J kg m^2, Bv Bvn N s/m, Bw N m s/rad, Cv Cvn "
	    "N, Cw N m\n");
	if (r.table.count("drive"))
		std::printf(
		    "current drive: R = %.5g ohm and Kv = %.5g V s/rad are the drive's (the robot "
		    "file's model, not fitted: the logged voltages are the controller's model "
		    "voltages, on which eq 22 returns the model's own); Kt = %.5g N m/A from the "
		    "robot file; J, Bv..Cw and M from the measured currents (eq 23 in force form; "
		    "experiment 2's Bv..Cvn with the robot file's M)\n",
		    r.final.R, r.final.Kv, r.final.Kt);
	print_wheels(r, truth_w);
	print_warnings(r);
}

// Windows: used per kind, rejected per reason (every one with --verbose).
void print_windows(const IdentResult &r, const std::vector<Segment> &segs, bool verbose)
{
	std::map<std::string, size_t> used, rejected;
	for (const WindowRecord &w : r.windows) {
		if (w.used)
			++used[w.what + " (" + w.kind + ")"];
		else
			++rejected[w.what + " (" + w.kind +
			           "): " + w.reason.substr(0, w.reason.find(':'))];
	}
	std::printf("windows found in the data:");
	for (const auto &[k, n] : used)
		std::printf(" %zu %s;", n, k.c_str());
	size_t nrej = 0;
	for (const auto &[k, n] : rejected)
		nrej += n;
	std::printf(" %zu rejected%s\n", nrej, nrej && !verbose ? " (--verbose lists them):" : "");
	if (!verbose) {
		for (const auto &[k, n] : rejected)
			std::printf("  %4zu x %s\n", n, k.c_str());
		return;
	}
	for (const WindowRecord &w : r.windows) {
		if (w.used)
			continue;
		const Segment &s = segs[w.segment];
		std::printf(
		    "  rejected: %s, segment %zu (%s %s %.3g V at %.3f s in %s), %.2f-%.2f s: %s\n",
		    w.what.c_str(), w.segment, s.kind.c_str(), s.direction.c_str(), s.level,
		    s.t0 * 1e-6, s.log->path.c_str(), w.t0_s, w.t1_s, w.reason.c_str());
	}
}

void ensure_dir(const std::string &dir)
{
	if (dir.empty())
		return;
	std::string cmd;
	for (size_t k = 1; k <= dir.size(); ++k) {
		if (k == dir.size() || dir[k] == '/') {
			const std::string part = dir.substr(0, k);
			if (mkdir(part.c_str(), 0777) != 0 && errno != EEXIST)
				die(part + ": " + std::strerror(errno));
		}
	}
	struct stat st{};
	if (stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) // an existing file is not replaced
		die(dir + ": not a folder (--csv names a folder)");
}

// One file of a --csv folder: built in memory, written by close() as every output is.
class CsvFile : public std::ostringstream
{
      public:
	explicit CsvFile(std::string path) : path_(std::move(path))
	{
	}
	void close()
	{
		try {
			write_file(path_, str());
		} catch (const OutError &e) {
			die(e.what());
		}
	}

      private:
	std::string path_;
};

CsvFile open_csv(const std::string &dir, const std::string &name)
{
	return CsvFile(dir + "/" + name);
}

void export_ident_csv(const std::string &dir, const IdentResult &r, const model_params *truth)
{
	ensure_dir(dir);
	auto f = open_csv(dir, "motor_points.csv");
	f << "motor,u_V,i_A,wm_rad_s\n";
	for (const auto &p : r.motor_points)
		f << p.motor << ',' << p.u << ',' << p.i << ',' << p.wm << '\n';
	f.close();
	auto g = open_csv(dir, "rotation_points.csv");
	g << "level_V,omega_cam_rad_s,omega_enc_rad_s,torque_Nm\n";
	for (const auto &p : r.rotation_points)
		g << p.level << ',' << p.omega_cam << ',' << p.omega_enc << ',' << p.torque << '\n';
	g.close();
	auto h = open_csv(dir, "coast_curves.csv");
	h << "direction,segment,t_s,measured,fitted\n";
	for (const auto &[dir_name, pts] : r.coast_curves)
		for (const auto &p : pts)
			h << dir_name << ',' << p.segment << ',' << p.t << ',' << p.measured << ','
			  << p.fitted << '\n';
	h.close();
	auto w = open_csv(dir, "windows.csv");
	w << "segment,kind,direction,what,t0_s,t1_s,used,reason\n";
	for (const auto &x : r.windows)
		w << x.segment << ',' << x.kind << ',' << x.direction << ',' << x.what << ','
		  << x.t0_s << ',' << x.t1_s << ',' << (x.used ? 1 : 0) << ",\"" << x.reason
		  << "\"\n";
	w.close();
	auto a = open_csv(dir, "agreement.csv");
	a << "param,methods,chi2,dof,p,agree,rule\n";
	for (const char *p : kIdentParams) {
		const Agreement &ag = r.agreement.at(p);
		a << p << ',' << ag.methods << ',' << ag.chi2 << ',' << ag.dof << ',' << ag.p << ','
		  << (ag.agree ? 1 : 0) << ',' << ag.rule << '\n';
	}
	a.close();
	auto t = open_csv(dir, "params.csv");
	t << "param,method,value,se,se_borrowed\n";
	for (const auto &[m, row] : r.table)
		for (const auto &[p, e] : row)
			t << p << ',' << m << ',' << e.value << ',' << e.se << ',' << e.se_borrowed
			  << '\n';
	if (truth)
		for (const char *p : kIdentParams)
			t << p << ",true," << field(*truth, p) << ",,\n";
	t.close();
}

void print_bootstrap(const IdentResult &r, const BootstrapResult &b, size_t runs)
{
	std::printf(
	    "\nbootstrap: %d replicates of the %zu runs, resampled within each experiment kind "
	    "and direction (motor test: and motors driven; %d could not be identified and were "
	    "skipped)\n",
	    b.replicates, runs, b.failed);
	std::printf("%-5s %12s %12s %12s %25s\n", "param", "final", "SE analytic", "SE bootstrap",
	            "95 % interval (bootstrap)");
	for (const char *p : kIdentParams) {
		const auto it = b.final.find(p);
		const Estimate e = find_estimate(r, "final", p);
		if (!e.ok() ||
		    find_estimate(r, "drive", p).ok()) // the drive's: nothing to resample
			continue;
		if (it == b.final.end()) {
			std::printf("%-5s %12.5g %12.2g %12s\n", p, e.value, e.se, "-");
			continue;
		}
		std::printf("%-5s %12.5g %12.2g %12.2g   [%10.5g, %10.5g]\n", p, e.value, e.se,
		            it->second.se, it->second.lo95, it->second.hi95);
	}
}

void export_offsets_csv(const std::string &dir, const std::vector<LogData> &logs)
{
	auto f = open_csv(dir, "current_offsets.csv");
	f << "log,motor,offset_a,se_a,epoch,from_seq,samples,pooled,controller_offset_a\n";
	for (const LogData &d : logs)
		for (size_t e = 0; e < d.current_offsets.size(); ++e) {
			const OffsetEpoch &ep = d.current_offsets[e];
			if (!ep.subtracted)
				continue;
			for (int j = 0; j < 4; ++j) {
				f << d.path << ',' << j << ',' << ep.offset_a[j] << ','
				  << ep.se_a[j] << ',' << e << ','
				  << (ep.notice >= 0 ? d.calibrations[ep.notice].seq : -1) << ','
				  << ep.samples << ',' << ep.pooled << ',';
				if (ep.notice >= 0)
					f << d.calibrations[ep.notice].offset_a[j];
				f << '\n';
			}
		}
	f.close();
}

void export_bootstrap_csv(const std::string &dir, const IdentResult &r, const BootstrapResult &b)
{
	ensure_dir(dir);
	auto f = open_csv(dir, "bootstrap.csv");
	f << "param,final,se_analytic,se_bootstrap,lo95,hi95\n";
	for (const char *p : kIdentParams) { // the table's order
		const auto it = b.final.find(p);
		if (it == b.final.end())
			continue;
		const Estimate e = find_estimate(r, "final", p);
		const BootstrapStats &s = it->second;
		f << p << ',' << e.value << ',' << e.se << ',' << s.se << ',' << s.lo95 << ','
		  << s.hi95 << '\n';
	}
	f.close();
	auto g = open_csv(dir, "bootstrap_samples.csv");
	g << "param,value\n";
	for (const auto &[p, xs] : b.samples)
		for (double x : xs)
			g << p << ',' << x << '\n';
	g.close();
}

struct IdentifyArgs {
	std::string robot, out, truth, csv, source = "encoder", drive = "voltage";
	int boot_n = 0;
	bool verbose = false;
	double steady_tol_pct = 0.3;
	std::vector<std::string> logs;
};

IdentOptions ident_options(const std::string &source, double steady_tol_pct,
                           const std::string &drive = "voltage")
{
	IdentOptions opt;
	if (source == "camera")
		opt.source = VelocitySource::Camera;
	else if (source != "encoder")
		die("--velocity must be 'encoder' or 'camera'", 2);
	if (drive == "current")
		opt.drive = DriveKind::Current;
	else if (drive != "voltage")
		die("--drive must be 'voltage' or 'current'", 2);
	opt.windows.steady_tol = steady_tol_pct / 100;
	return opt;
}

// An output must be writable before any work is done (it is written at the end, outfile.hpp):
// its folder exists and is writable, or it is a device or FIFO; a directory is refused.
void check_writable(const std::string &path)
{
	try {
		check_out(path);
	} catch (const OutError &e) {
		die(e.what());
	}
}

// What was not identified and why (partial), or the notes; the file written.
void print_outcome(const IdentResult &r, const std::string &out)
{
	if (!r.complete()) {
		std::string which;
		for (const char *p : kIdentParams)
			if (!r.identified.at(p))
				which += std::string(which.empty() ? "" : ", ") + p;
		std::printf("\npartial identification: not identified: %s\n", which.c_str());
		for (const std::string &m : r.missing)
			std::printf("  missing: %s\n", m.c_str());
		std::printf(
		    "wrote %s with the identified parameters only (values the robot file gives are "
		    "kept, marked; the firmware refuses a [model] with missing keys)\n",
		    out.c_str());
		return;
	}
	for (const std::string &m : r.missing)
		std::printf("note: %s\n", m.c_str());
	std::printf("wrote %s\n", out.c_str());
}

// A log with only the traction experiment: the model from the robot file (traction needs M J d r
// l Kt B C), nothing identified.
static IdentResult model_from_robot_file(const std::string &robot, const model_params &base,
                                         uint32_t base_seen)
{
	IdentResult r;

	for (int i : {3, 4, 7, 8, 9, 10, 11, 12, 13})
		if (!(base_seen & (1u << i)))
			die(robot +
			        ": a log with only the traction experiment needs the model in the "
			        "robot "
			        "file; it lacks '" +
			        std::string(model_params_names[i]) + "'",
			    2);
	r.final = base;
	for (const char *q : kIdentParams)
		r.identified[q] = false;
	std::printf("traction experiment only: the model taken from %s\n", robot.c_str());
	return r;
}

static IdentResult identify_or_die(const std::vector<Segment> &segs, const model_params &base,
                                   const IdentOptions &opt)
{
	try {
		return identify(segs, base, opt);
	} catch (const IdentError &e) {
		die(e.what());
	}
	return {};
}

// The model's CSVs: the identified parameters, the current offsets, each wheel's values.
static void export_model_csvs(const std::string &dir, const IdentResult &r,
                              const std::vector<LogData> &logs, const model_params *truth,
                              const model_wheels *truth_w)
{
	export_ident_csv(dir, r, truth);
	export_offsets_csv(dir, logs);
	auto wc = open_csv(dir, "wheels.csv");
	wc << wheels_csv(r, truth_w);
	wc.close();
	const Layout &L = r.wheels.shape.layout;
	if (L.paper)
		return;
	auto lc = open_csv(dir, "layout.csv"); // the report draws it
	lc.precision(10);
	lc << "wheel,angle_deg,d_m\n";
	for (int j = 0; j < L.n; ++j)
		lc << j << ',' << L.angle_deg[j] << ',' << L.dist_m[j] << '\n';
	lc.close();
}

// The traction experiment's fit (ident_traction.hpp); a model it cannot take: one line, exit 1.
static TractionResult traction_or_die(const std::vector<Segment> &segs, const model_params &p,
                                      const Layout &L)
{
	try {
		return identify_traction(segs, p, L);
	} catch (const IdentError &e) {
		die(e.what());
	}
}

int cmd_identify(const IdentifyArgs &a)
{
	check_writable(a.out);
	ensure_dir(a.csv);
	uint32_t base_seen = 0;
	WheelKeys base_wheels;
	Layout file_layout;
	const model_params base =
	    load_params(a.robot, true, &base_seen, &base_wheels, &file_layout);
	const model_params truth = a.truth.empty() ? model_params{} : load_params(a.truth, false);
	const model_wheels truth_w = a.truth.empty() ? model_wheels{} : load_wheels(a.truth, true);
	IdentOptions opt = ident_options(a.source, a.steady_tol_pct, a.drive);
	auto logs = load_logs(a.logs, base.l, true);
	opt.layout = layout_or_die(logs, file_layout);
	const auto segs = segments_of(logs);
	const bool traction_only = std::all_of(segs.begin(), segs.end(), [](const Segment &s) {
		return s.kind == "traction" || s.kind == OMNI4_MARK_END;
	});
	const IdentResult r = traction_only ? model_from_robot_file(a.robot, base, base_seen)
	                                    : identify_or_die(segs, base, opt);
	const TractionResult trac = traction_or_die(segs, r.final, opt.layout);
	std::printf("segments:");
	for (const auto &[k, n] : r.segments_used)
		std::printf(" %s %zu", k.c_str(), n);
	std::printf("; robot velocities from the %s; %s drive\n", a.source.c_str(),
	            a.drive.c_str());
	print_windows(r, segs, a.verbose);
	if (!traction_only)
		print_table(r, a.truth.empty() ? nullptr : &truth,
		            a.truth.empty() ? nullptr : &truth_w);
	print_traction(trac);
	BootstrapResult boot;
	if (a.boot_n > 0 && !traction_only) {
		const bool tty = isatty(STDERR_FILENO);
		boot = bootstrap_runs(segs, base, opt, a.boot_n, 1, [&](int done, int total) {
			if (tty || done == total)
				std::fprintf(stderr, "%somni4-ident: bootstrap %d/%d%s",
				             tty ? "\r" : "", done, total,
				             done == total ? "\n" : "");
		});
		print_bootstrap(r, boot, segs.size());
	}
	write_params(a.out, r, base, base_seen, base_wheels,
	             "omni4-ident identify from " + std::to_string(a.logs.size()) + " log(s)",
	             &trac);
	export_traction_csv(a.csv, trac);
	if (!a.csv.empty() && !traction_only)
		export_model_csvs(a.csv, r, logs, a.truth.empty() ? nullptr : &truth,
		                  a.truth.empty() ? nullptr : &truth_w);
	if (!a.csv.empty() && a.boot_n > 0)
		export_bootstrap_csv(a.csv, r, boot);
	if (traction_only)
		std::printf("wrote %s: [model] from the robot file, [limits] from the traction "
		            "experiment\n",
		            a.out.c_str());
	else
		print_outcome(r, a.out);
	return 0;
}

void write_json(const std::string &path, const Validation &v)
{
	{
		std::ostringstream f;
		static const char *const names[3] = {"v", "vn", "w"};
		f << "{";
		// An axis without validation data is null, never a perfect 0.
		for (int a = 0; a < 3; ++a) {
			char buf[200];
			const AxisErrors &ax = v.axis[a];
			if (ax.n == 0)
				std::snprintf(buf, sizeof(buf),
				              "%s\"%s\": {\"e_max\": null, \"e_mean\": null, "
				              "\"sigma\": null, \"n\": 0}",
				              a ? ", " : "", names[a]);
			else
				std::snprintf(buf, sizeof(buf),
				              "%s\"%s\": {\"e_max\": %.6g, \"e_mean\": %.6g, "
				              "\"sigma\": %.6g, \"n\": %zu}",
				              a ? ", " : "", names[a], ax.e_max, ax.e_mean,
				              ax.sigma, ax.n);
			f << buf;
		}
		f << "}\n";
		try {
			write_file(path, f.str());
		} catch (const OutError &e) {
			die(e.what());
		}
	}
}

// Table IV layout: e_max, mean, sigma per velocity, one block per parameter set.
void print_validation(const std::vector<std::string> &params, const std::vector<Validation> &vals,
                      const IdentOptions &opt)
{
	for (const WindowRecord &w : vals[0].rejected)
		std::printf("not validated: %s, segment %zu (%s %s), %.2f-%.2f s: %s\n",
		            w.what.c_str(), w.segment, w.kind.c_str(), w.direction.c_str(), w.t0_s,
		            w.t1_s, w.reason.c_str());
	std::printf("\nvalidation on %zu step runs (measured = %s; simulated = model driven by the "
	            "logged voltages from the encoder velocity at the start of each drive)\n%-5s",
	            vals[0].runs,
	            opt.source == VelocitySource::Camera
	                ? "camera poses, local quadratic over 0.36 s"
			: "wheel encoders, eqs 3-5",
	            "vel");
	for (const auto &p : params)
		std::printf(" | %-32.32s", p.c_str());
	std::printf("\n%-5s", "");
	for (size_t k = 0; k < params.size(); ++k)
		std::printf(" | %10s %10s %10s", "e_max", "mean", "sigma");
	std::printf("   [m/s for v, vn; rad/s for w]");
	std::printf("\n");
	static const char *const names[3] = {"v", "vn", "w"};
	for (int a = 0; a < 3; ++a) {
		std::printf("%-5s", names[a]);
		for (const auto &v : vals)
			if (v.axis[a].n == 0)
				std::printf(" | %-32s", "no data (no step run along it)");
			else
				std::printf(" | %10.4f %10.4f %10.4f", v.axis[a].e_max,
				            v.axis[a].e_mean, v.axis[a].sigma);
		std::printf("\n");
	}
	std::printf("paper Table IV (final): v 0.061 0.008 0.024 | vn 0.068 -0.009 0.026 | "
	            "w 2.504 -0.452 0.732\n");
}

// Measured and simulated velocities, one CSV per parameter set.
void write_validation_csv(const std::string &csv, const std::vector<Validation> &vals)
{
	ensure_dir(csv);
	for (size_t k = 0; k < vals.size(); ++k) {
		auto f = open_csv(csv, k == 0 ? "validation.csv"
		                              : "validation_" + std::to_string(k) + ".csv");
		f << "segment,direction,level_V,t_s,v,vn,w,v_sim,vn_sim,w_sim\n";
		for (const auto &p : vals[k].points)
			f << p.segment << ',' << p.direction << ',' << p.level << ',' << p.t << ','
			  << p.measured[0] << ',' << p.measured[1] << ',' << p.measured[2] << ','
			  << p.simulated[0] << ',' << p.simulated[1] << ',' << p.simulated[2]
			  << '\n';
		f.close();
	}
}

struct ValidateArgs {
	std::vector<std::string> params;
	std::string json, csv, source = "encoder";
	std::vector<std::string> logs;
};

int cmd_validate(const ValidateArgs &va)
{
	check_writable(va.json);
	ensure_dir(va.csv);
	IdentOptions opt = ident_options(va.source, 0.3);
	if (va.params.empty() || va.params.size() > 2)
		die("give --params once or twice", 2);
	std::vector<model_params> sets;
	std::vector<model_wheels> wheels;
	std::vector<Layout> file_layouts;
	for (const auto &p : va.params) {
		file_layouts.emplace_back();
		sets.push_back(load_params(p, false, nullptr, nullptr, &file_layouts.back()));
		wheels.push_back(load_wheels(p, false));
	}
	const auto logs = load_logs(va.logs, sets[0].l, false);
	// The logs' layout decides; without one the files must agree on theirs.
	const bool logs_say =
	    std::any_of(logs.begin(), logs.end(), [](const LogData &d) { return d.robot.present; });
	if (!logs_say && file_layouts.size() == 2 && !same_layout(file_layouts[0], file_layouts[1]))
		die("--params " + va.params[0] + " (" + file_layouts[0].describe() + ") and " +
		        va.params[1] + " (" + file_layouts[1].describe() +
		        ") describe different wheel layouts and the log describes none: validate "
		        "each "
		        "against its own robot's logs",
		    2);
	opt.layout = layout_or_die(logs, file_layouts.back());
	const auto segs = segments_of(logs);
	std::vector<Validation> vals;
	try {
		for (size_t k = 0; k < sets.size(); ++k)
			vals.push_back(validate(segs, sets[k], wheels[k], opt));
	} catch (const IdentError &e) {
		die(e.what());
	}
	print_validation(va.params, vals, opt);
	write_json(va.json, vals[0]);
	std::printf("wrote %s\n", va.json.c_str());
	if (!va.csv.empty())
		write_validation_csv(va.csv, vals);
	return 0;
}

int cmd_run_hand(const RunOptions &ropt, HandRunOptions hopt, const std::string &robot)
{
	const model_params base = robot.empty()
	                              ? model_params_table3
	                              : load_params(robot, true, nullptr, nullptr, &hopt.layout);
	hopt.d_m = base.d;
	hopt.r_m = base.r;
	return run_hand(ropt, hopt);
}

CLI::App *add_identify(CLI::App &app, IdentifyArgs &ia)
{
	auto *id =
	    app.add_subcommand("identify", "identify the model parameters from experiment logs");
	id->add_option("--robot", ia.robot, "BASE.ini with the measured d, r, l, M in [model]")
	    ->required();
	id->add_option("--out", ia.out, "PARAMS.ini to write (firmware-loadable [model] section)")
	    ->required();
	id->add_option("--truth", ia.truth,
	               "known parameters (simulation): print the error of each");
	id->add_option("--csv", ia.csv,
	               "export every segment, window and fit as CSV into this folder");
	id->add_option("--velocity", ia.source,
	               "robot velocity source: encoder (default) or camera");
	id->add_option(
	    "--drive", ia.drive,
	    "what drove the motors: voltage (default: H-bridges, the logged voltages "
	    "reached the windings) or current (ODrive torque, VESC current: J, B, C and M "
	    "from the measured currents; R and Kv are the drive's)");
	id->add_option("--bootstrap", ia.boot_n,
	               "also estimate the uncertainty by resampling whole runs, "
	               "N replicates (0: off)")
	    ->check(CLI::Range(0, 100000))
	    ->capture_default_str();
	id->add_option(
	      "--steady-tol", ia.steady_tol_pct,
	      "steady window: speed within this % of its final value (plus 2 mm/s, 0.01 rad/s)")
	    ->check(CLI::Range(0.01, 20.0))
	    ->capture_default_str();
	id->add_flag("--verbose,-v", ia.verbose, "list every rejected window with its reason");
	id->add_option("logs", ia.logs, "LCM event logs with OMNI4_EXPERIMENT marks")->required();
	return id;
}

CLI::App *add_validate(CLI::App &app, ValidateArgs &v)
{
	auto *va =
	    app.add_subcommand("validate", "simulate the model on the logged inputs (Table IV)");
	va->add_option("--params", v.params, "PARAMS.ini (give twice to compare two sets)")
	    ->required();
	va->add_option("--json", v.json, "write e_max, e_mean, sigma per velocity (first --params)")
	    ->required();
	va->add_option("--csv", v.csv, "export measured and simulated velocities as CSV");
	va->add_option("--velocity", v.source, "measured velocity: encoder (default) or camera");
	va->add_option("logs", v.logs, "LCM event logs")->required();
	return va;
}

struct RunArgs {
	RunOptions ropt;
	HandRunOptions hopt;
	std::string hand_robot;
	std::string limits; // ROBOT.ini whose [model] and [limits] traction_mu ramp the runs
	CLI::Option *hand = nullptr; // --hand given
};

CLI::App *add_run(CLI::App &app, RunArgs &r)
{
	auto *ru =
	    app.add_subcommand("run", "drive a robot (or omni4-fw on the sim backend) through "
	                              "the experiment sequence over LCM, recording a log");
	RunOptions &ropt = r.ropt;
	HandRunOptions &hopt = r.hopt;
	ru->add_option("--lcm", ropt.url, "LCM URL")->capture_default_str();
	ru->add_option("--out", ropt.out, "event log to record")->required();
	auto *only =
	    ru->add_option("--only", ropt.only,
	                   "run only these kinds (steady_rotation coast motor step traction)");
	auto *hold = ru->add_option("--hold", ropt.hold_s, "constant-voltage part of each run [s]")
	                 ->check(CLI::Range(0.2, 60.0))
	                 ->capture_default_str();
	auto *settle =
	    ru->add_option("--settle", ropt.settle_s, "coasting to rest between runs [s]")
	        ->check(CLI::Range(0.2, 60.0))
	        ->capture_default_str();
	auto *hand =
	    ru->add_flag("--hand", "experiment 2 by hand: the bridges stay disabled, you push "
	                           "the robot along each direction and let it coast to rest "
	                           "(e.g. run --hand --robot base.ini --out hand.lcmlog)")
	        ->excludes(only, hold, settle);
	r.hand = hand;
	ru->add_option("--limits", r.limits,
	               "ROBOT.ini: with its [limits] traction_mu, every run's ramp is long enough "
	               "that no wheel of its [model] needs more than the traction")
	    ->excludes(hand);
	ru->add_option("--robot", r.hand_robot,
	               "BASE.ini: d and r for the robot velocity (eqs 3-5, --hand); its wheel "
	               "layout ([model] wheels, wheel_angle_j, d_j) for the runs' voltage patterns "
	               "and the motor test's motors; Table III and the paper's layout otherwise");
	ru->add_option("--pushes", hopt.pushes, "counted pushes per direction")
	    ->check(CLI::Range(1, 100))
	    ->capture_default_str()
	    ->needs(hand);
	ru->add_option("--directions", hopt.directions, "directions to push along, comma separated")
	    ->delimiter(',')
	    ->check(CLI::IsMember({"v", "vn", "w"}))
	    ->capture_default_str()
	    ->needs(hand);
	ru->add_option("--push-timeout", hopt.push_timeout_s, "wait for each push and its stop [s]")
	    ->check(CLI::Range(1.0, 3600.0))
	    ->capture_default_str()
	    ->needs(hand);
	return ru;
}

} // namespace

int main(int argc, char **argv)
{
	CLI::App app{
	    "omni4 identification: fit the paper's model to LCM logs and validate it.\n"
	    "Examples:\n"
	    "  omni4-ident identify --robot base.ini --out params.ini sim.lcmlog\n"
	    "  omni4-ident validate --params params.ini --json val.json sim.lcmlog\n"
	    "  omni4-ident run --out robot.lcmlog\n"
	    "  omni4-ident run --hand --robot base.ini --out hand.lcmlog\n"
	    "identify --out, validate --json and the --csv files: a file is replaced through a\n"
	    "temporary beside it; a symbolic link's target is replaced, the link kept; a FIFO\n"
	    "or device is written in place (every write checked); a directory is refused.",
	    "omni4-ident"};
	omni4_cli_setup(app);
	app.require_subcommand(1);
	IdentifyArgs ia;
	ValidateArgs vargs;
	RunArgs rargs;
	auto *id = add_identify(app, ia);
	auto *va = add_validate(app, vargs);
	auto *ru = add_run(app, rargs);

	// A mistyped command: say which ones there are (CLI11 would say only that one is required).
	const auto named = app.get_subcommands(
	    [&](CLI::App *sc) { return argc > 1 && sc->get_name() == argv[1]; });
	if (argc > 1 && argv[1][0] != '-' && named.empty()) {
		std::fprintf(stderr,
		             "omni4-ident: unknown command '%s' (identify, validate or run; see "
		             "omni4-ident --help)\n",
		             argv[1]);
		return 2;
	}
	OMNI4_CLI_PARSE(app, argc, argv);
	if (id->parsed())
		return cmd_identify(ia);
	if (va->parsed())
		return cmd_validate(vargs);
	if (ru->parsed() && *rargs.hand)
		return cmd_run_hand(rargs.ropt, rargs.hopt, rargs.hand_robot);
	if (ru->parsed() && !rargs.hand_robot.empty())
		load_params(rargs.hand_robot, true, nullptr, nullptr, &rargs.ropt.layout);
	if (ru->parsed() && !rargs.limits.empty()) {
		omni4_config lc;
		config_error err;
		config_defaults(&lc);
		if (config_load(rargs.limits.c_str(), &lc, &err))
			die(err.msg, 2);
		rargs.ropt.model = lc.ctl.model;
		rargs.ropt.traction_hold_n = traction_hold_n(
		    lc.ctl.model, lc.ctl.limits.traction_mu, lc.ctl.limits.traction_margin);
	}
	if (ru->parsed())
		return run_experiments(rargs.ropt);
	return 2;
}
