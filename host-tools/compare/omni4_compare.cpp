// omni4-compare: the paper's comparison of robots with different wheel layouts, side by side
// from each robot's INI (docs/compare.md): a Markdown table and CSVs for the figures
// (host-tools/plots/compare_plots.py).
#include "cli.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "compare.hpp"
#include "outfile.hpp"

using namespace omni4::compare;

namespace
{

constexpr int kHeadings = 360;       // the sweeps' headings: every 1 deg
constexpr double kEnergySpeed = 1.0; // [m/s]

struct Result {
	Robot r;
	Bound top[3];                 // along v, vn [m/s], w [rad/s]
	std::vector<Bound> speed;     // top speed per heading [m/s]
	std::vector<Bound> env;       // largest acceleration per heading [m/s^2]
	Bound env_w;                  // about w [rad/s^2]
	int slowest = 0, weakest = 0; // headings [deg] of the least speed, the least acceleration
	WheelState worst{};           // the wheels at the weakest point of the envelope
	double margin[4]{};           // traction margin there, 1 - |f_j| / (mu N_j) [-]
	double energy[2]{};           // [J/m] at kEnergySpeed along v, vn
	std::vector<double> times;    // moves() [s]
};

Result compute(const std::string &path)
{
	Result o;
	o.r = load_robot(path);
	const Robot &r = o.r;
	for (int k = 0; k < 3; k++) {
		double e[3] = {0.0, 0.0, 0.0};
		e[k] = 1.0;
		o.top[k] = top_speed(r, e);
		if (k == 2)
			o.env_w = envelope(r, e);
		else
			o.energy[k] = energy_per_m(r, e, kEnergySpeed);
	}
	for (int h = 0; h < kHeadings; h++) {
		double e[3];
		heading_dir(h * 360.0 / kHeadings, e);
		o.speed.push_back(top_speed(r, e));
		o.env.push_back(envelope(r, e));
		if (o.speed[h].value < o.speed[o.slowest].value)
			o.slowest = h;
		if (o.env[h].value < o.env[o.weakest].value)
			o.weakest = h;
	}
	double e[3];
	heading_dir(o.weakest * 360.0 / kHeadings, e);
	o.worst = at_rest(r, e, o.env[o.weakest].value);
	for (int j = 0; j < r.ph.n; j++)
		o.margin[j] = 1.0 - std::fabs(o.worst.force_n[j]) / (r.mu * o.worst.load_n[j]);
	o.times = move_times(r);
	return o;
}

// Two files of one name (a/robot.ini, b/robot.ini): the later one's column "robot#2".
void unique_name(std::vector<Result> &rs)
{
	const std::string base = rs.back().r.name;
	for (int k = 2;; k++) {
		bool taken = false;
		for (size_t i = 0; i + 1 < rs.size(); i++)
			taken = taken || rs[i].r.name == rs.back().r.name;
		if (!taken)
			return;
		rs.back().r.name = base + "#" + std::to_string(k);
	}
}

std::string fmt(const char *f, double v)
{
	char b[64];
	std::snprintf(b, sizeof(b), f, v);
	return b;
}

std::string layout_text(const Robot &r)
{
	std::string s = std::to_string(r.geom.n) + " at";
	for (int j = 0; j < r.geom.n; j++)
		s += (j ? "/" : " ") + fmt("%g", r.s.layout.angle_deg[j]);
	s += " deg, d";
	for (int j = 0; j < r.geom.n; j++)
		s += (j ? "/" : " ") + fmt("%g", ctl_settings_wheel_distance(&r.s, j));
	return s + " m";
}

std::string bound_text(const Bound &b, const char *f)
{
	return fmt(f, b.value) + " (" + b.kind + ", wheel " + std::to_string(b.wheel) + ")";
}

// One row of the table: label, then one cell per robot.
template <class F>
void row(std::ostringstream &md, const std::string &label, const std::vector<Result> &rs, F cell)
{
	md << "| " << label;
	for (const Result &o : rs)
		md << " | " << cell(o);
	md << " |\n";
}

std::string markdown(const std::vector<Result> &rs)
{
	std::ostringstream md;
	md << "| quantity";
	for (const Result &o : rs)
		md << " | " << o.r.name;
	md << " |\n|---";
	for (size_t i = 0; i < rs.size(); i++)
		md << "|---";
	md << "|\n";
	row(md, "layout", rs, [](const Result &o) { return layout_text(o.r); });
	row(md, "supply [V], floor mu [-]", rs,
	    [](const Result &o) { return fmt("%g", o.r.supply_v) + ", " + fmt("%g", o.r.mu); });
	const char *axes[3] = {"top speed along v [m/s]", "top speed along vn [m/s]",
	                       "top speed about w [rad/s]"};
	for (int k = 0; k < 3; k++)
		row(md, axes[k], rs, [k](const Result &o) { return bound_text(o.top[k], "%.3f"); });
	row(md, "slowest heading [deg]: top speed [m/s]", rs, [](const Result &o) {
		return fmt("%g", o.slowest * 360.0 / kHeadings) + ": " +
		       fmt("%.3f", o.speed[o.slowest].value);
	});
	row(md, "acceleration from rest along v [m/s^2]", rs,
	    [](const Result &o) { return bound_text(o.env[0], "%.3f"); });
	row(md, "acceleration from rest along vn [m/s^2]", rs,
	    [](const Result &o) { return bound_text(o.env[kHeadings / 4], "%.3f"); });
	row(md, "acceleration from rest about w [rad/s^2]", rs,
	    [](const Result &o) { return bound_text(o.env_w, "%.2f"); });
	row(md, "weakest heading [deg]: acceleration [m/s^2]", rs, [](const Result &o) {
		return fmt("%g", o.weakest * 360.0 / kHeadings) + ": " +
		       bound_text(o.env[o.weakest], "%.3f");
	});
	row(md, "energy at 1 m/s along v [J/m]", rs,
	    [](const Result &o) { return fmt("%.3f", o.energy[0]); });
	row(md, "energy at 1 m/s along vn [J/m]", rs,
	    [](const Result &o) { return fmt("%.3f", o.energy[1]); });
	for (size_t m = 0; m < moves().size(); m++)
		row(md, std::string("time: ") + moves()[m].name + " [s]", rs, [m](const Result &o) {
			return std::isnan(o.times[m]) ? std::string("none: no acceleration at rest")
			                              : fmt("%.3f", o.times[m]);
		});
	for (int j = 0; j < 4; j++)
		row(md,
		    "traction margin at the weakest heading, wheel " + std::to_string(j) + " [-]",
		    rs, [j](const Result &o) {
			    const double m = std::fabs(o.margin[j]) < 1e-12 ? 0.0 : o.margin[j];
			    return j < o.r.ph.n ? fmt("%.3f", m) : std::string("-");
		    });
	return md.str();
}

std::string summary_csv(const std::vector<Result> &rs)
{
	std::ostringstream c;
	c << "robot,wheels,supply_v,mu,top_v_m_s,top_vn_m_s,top_w_rad_s,slowest_heading_deg,"
	     "slowest_speed_m_s,acc_w_rad_s2,weakest_heading_deg,weakest_acc_m_s2,energy_v_j_m,"
	     "energy_vn_j_m\n";
	for (const Result &o : rs)
		c << o.r.name << ',' << o.r.ph.n << fmt(",%.12g", o.r.supply_v)
		  << fmt(",%.12g", o.r.mu) << fmt(",%.12g", o.top[0].value)
		  << fmt(",%.12g", o.top[1].value) << fmt(",%.12g", o.top[2].value)
		  << fmt(",%g", o.slowest * 360.0 / kHeadings)
		  << fmt(",%.12g", o.speed[o.slowest].value) << fmt(",%.12g", o.env_w.value)
		  << fmt(",%g", o.weakest * 360.0 / kHeadings)
		  << fmt(",%.12g", o.env[o.weakest].value) << fmt(",%.12g", o.energy[0])
		  << fmt(",%.12g", o.energy[1]) << '\n';
	return c.str();
}

std::string sweep_csv(const std::vector<Result> &rs, bool envelope_sweep)
{
	std::ostringstream c;
	c << "robot,heading_deg," << (envelope_sweep ? "acc_max_m_s2" : "top_speed_m_s")
	  << ",wheel,limit\n";
	for (const Result &o : rs)
		for (int h = 0; h < kHeadings; h++) {
			const Bound &b = envelope_sweep ? o.env[h] : o.speed[h];
			c << o.r.name << fmt(",%g", h * 360.0 / kHeadings) << fmt(",%.12g", b.value)
			  << ',' << b.wheel << ',' << b.kind << '\n';
		}
	return c.str();
}

std::string wheels_csv(const std::vector<Result> &rs)
{
	std::ostringstream c;
	c << "robot,wheel,angle_deg,d_m,force_n,load_n,voltage_v,traction_margin\n";
	for (const Result &o : rs)
		for (int j = 0; j < o.r.ph.n; j++)
			c << o.r.name << ',' << j << fmt(",%.12g", o.r.s.layout.angle_deg[j])
			  << fmt(",%.12g", ctl_settings_wheel_distance(&o.r.s, j))
			  << fmt(",%.12g", o.worst.force_n[j]) << fmt(",%.12g", o.worst.load_n[j])
			  << fmt(",%.12g", o.worst.voltage_v[j]) << fmt(",%.12g", o.margin[j])
			  << '\n';
	return c.str();
}

std::string moves_csv(const std::vector<Result> &rs)
{
	std::ostringstream c;
	c << "robot,move,x_m,y_m,theta_rad,time_s\n";
	for (const Result &o : rs)
		for (size_t m = 0; m < moves().size(); m++)
			c << o.r.name << ',' << moves()[m].name << fmt(",%.12g", moves()[m].x_m)
			  << fmt(",%.12g", moves()[m].y_m) << fmt(",%.12g", moves()[m].theta_rad)
			  << fmt(",%.12g", o.times[m]) << '\n';
	return c.str();
}

// DIR made if missing (and its parents); anything there but a folder refused.
void ensure_dir(const std::string &dir)
{
	for (size_t k = 1; k <= dir.size(); ++k)
		if (k == dir.size() || dir[k] == '/') {
			const std::string part = dir.substr(0, k);
			if (mkdir(part.c_str(), 0777) != 0 && errno != EEXIST)
				throw OutError(part + ": " + std::strerror(errno));
		}
	struct stat st{};
	if (stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
		throw OutError(dir + ": not a folder (--out names a folder)");
}

void write_out(const std::string &dir, const std::vector<Result> &rs)
{
	ensure_dir(dir);
	write_file(dir + "/compare.md", markdown(rs));
	write_file(dir + "/summary.csv", summary_csv(rs));
	write_file(dir + "/speed.csv", sweep_csv(rs, false));
	write_file(dir + "/envelope.csv", sweep_csv(rs, true));
	write_file(dir + "/wheels.csv", wheels_csv(rs));
	write_file(dir + "/moves.csv", moves_csv(rs));
}

} // namespace

int main(int argc, char **argv)
{
	CLI::App app{
	    "Compare robots with different wheel layouts from their INI files: top speeds, "
	    "the acceleration envelope, energy per metre, the planner's move times, "
	    "traction margins (docs/compare.md).\n"
	    "example: omni4-compare docs/examples/paper.ini docs/examples/three.ini "
	    "--out cmp",
	    "omni4-compare"};
	omni4_cli_setup(app);
	std::vector<std::string> files;
	std::string out;
	app.add_option("ROBOT.ini", files, "a robot's INI file (one or more)")->required();
	app.add_option("--out", out,
	               "folder for compare.md and the CSVs (made if missing); without: the "
	               "table on stdout");
	OMNI4_CLI_PARSE(app, argc, argv);
	try {
		std::vector<Result> rs;
		for (const std::string &f : files) {
			rs.push_back(compute(f));
			unique_name(rs);
		}
		if (out.empty())
			std::fputs(markdown(rs).c_str(), stdout);
		else
			write_out(out, rs);
	} catch (const CompareError &e) { // a robot file: configuration
		std::fprintf(stderr, "omni4-compare: %s\n", e.what());
		return 2;
	} catch (const OutError &e) { // nothing replaced
		std::fprintf(stderr, "omni4-compare: %s\n", e.what());
		return 1;
	}
	return 0;
}
