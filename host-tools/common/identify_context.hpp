// identify_context.hpp - what the experiments of identify() share: the segments in use, the
// result being filled, the current-offset epochs. Internal to identify*.cpp.
//
// Every experiment is one function `void NAME(Context &c)` in a file of its own
// (identify_motor.cpp, identify_exp1.cpp, ...): it reads the windows of its segment kind through
// c.windows(), writes its estimates into c.res.table[METHOD] and says what it could not do
// through c.missing(). identify() runs them in kExperiments' order (later ones may read the
// estimates of earlier ones from c.res.table).
#pragma once

#include <string>
#include <vector>

#include "identify.hpp"

namespace omni4::ident
{

inline constexpr const char *kDirs[3] = {"v", "vn", "w"};

inline double sgn(double x)
{
	return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0);
}

// A window together with its segment.
struct SegWindow {
	size_t seg;
	const Segment *s;
	Window w;
};

struct Context {
	const Prepared &P;
	const std::vector<size_t> &use;
	IdentResult &res;

	std::vector<SegWindow> windows(const char *kind, const char *dir,
	                               std::vector<Window> SegmentWindows::*which) const
	{
		std::vector<SegWindow> out;
		for (size_t i : use) {
			const Segment &s = P.segments[i];
			if (s.kind != kind || (dir && s.direction != dir))
				continue;
			for (const Window &w : P.windows[i].*which)
				out.push_back({i, &s, w});
		}
		return out;
	}
	size_t segments_of(const char *kind, const char *dir) const
	{
		size_t n = 0;
		for (size_t i : use)
			n += P.segments[i].kind == kind && (!dir || P.segments[i].direction == dir);
		return n;
	}
	void reject(const SegWindow &w, const std::string &what, const std::string &reason)
	{
		res.windows.push_back({w.seg, w.s->kind, w.s->direction, what,
		                       seg_time(*w.s, w.w.m0), seg_time(*w.s, w.w.m1 - 1), false,
		                       reason});
	}
	void missing(const std::string &line)
	{
		res.missing.push_back(line);
	}

	// Index into P.offset_epochs of the offsets in force at sample k of log (-1: none).
	int epoch_of(const LogData *log, size_t k) const
	{
		for (size_t e = 0; e < P.offset_epochs.size(); ++e) {
			const auto &[l, i] = P.offset_epochs[e];
			if (l == log && k >= l->current_offsets[i].m0 &&
			    k < l->current_offsets[i].m1)
				return static_cast<int>(e);
		}
		return -1;
	}
	// Standard errors of the offsets, 4 per epoch (the inputs of propagate_independent).
	Eigen::VectorXd offset_se() const
	{
		Eigen::VectorXd se(4 * static_cast<Eigen::Index>(P.offset_epochs.size()));
		for (size_t e = 0; e < P.offset_epochs.size(); ++e)
			for (int j = 0; j < 4; ++j)
				se[static_cast<Eigen::Index>(4 * e + j)] =
				    P.offset_epochs[e]
				        .first->current_offsets[P.offset_epochs[e].second]
				        .se_a[j];
		return se;
	}
};

inline bool current_drive(const Context &c)
{
	return c.P.opt.drive == DriveKind::Current;
}

// The motor constant the torque of the measured currents uses: Kt = Kv of the motor test
// (voltage drive), the base model's Kt with no SE of its own (current drive: the drive's).
// Not ok(): the motor test gave none.
inline Estimate torque_constant(Context &c)
{
	if (current_drive(c))
		return {c.P.base.Kt, 0.0};
	const auto kv = c.res.table["motor"].find("Kv");
	return kv == c.res.table["motor"].end() ? Estimate{} : kv->second;
}

// value with its own SE and the borrowed part added in quadrature.
inline Estimate with_borrowed(double value, double se_own, double se_borrowed)
{
	return {value, std::hypot(se_own, se_borrowed), se_borrowed};
}

inline std::string record_hint(const char *kind)
{
	const std::string k = kind;
	if (k == "coast")
		return "record them with 'omni4-ident run --only coast' (motor push) or "
		       "'omni4-ident run "
		       "--hand' (push by hand, bridges off)";
	return "record them with 'omni4-ident run --only " + k + "'";
}

// Mean of motors samples [a, b) of log m.
template <typename F> double mean_over(const std::vector<MotorsSample> &m, size_t a, size_t b, F f)
{
	double s = 0;
	for (size_t k = a; k < b; ++k)
		s += f(m[k]);
	return s / static_cast<double>(b - a);
}

// eqs 12-13 with each wheel's drive (the scalar twin where the shape is uniform).
void wheel_forces(const model_params &p, const WheelShape &s, const double i[4], double f[4]);

// ---- the experiments, in the order identify() runs them ------------------------------------
void motor_test(Context &c);  // identify_motor.cpp: eq 22, method "motor"
void experiment1(Context &c); // identify_exp1.cpp: eq 16, method "exp1"
void experiment2(Context &c); // identify_exp2.cpp: eqs 17-20, method "exp2"
void experiment3(Context &c); // identify_exp3.cpp: eqs 31-35, methods "exp3_ls", "exp3_iv"

using Experiment = void (*)(Context &);
inline constexpr Experiment kExperiments[] = {motor_test, experiment1, experiment2, experiment3};

} // namespace omni4::ident
