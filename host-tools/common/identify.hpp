// identify.hpp - the paper's identification procedure on segmented logs.
//   motor test  (eq 22): Kv, R per motor and combined (Kt = Kv)
//   experiment 1 (eq 16): Bw, Cw from steady rotation
//   experiment 2 (eqs 17-20): Bv, Cv, Bvn, Cvn from null-traction coast-downs; J from eq 20
//   experiment 3 (eqs 31-35): LS and IV on the ramped steps for the state-space model
//   per wheel (identify_wheels.cpp): each motor's R_j, Kv_j and an F-test of whether the motors
//   differ; each wheel's radius relative to the others from the rigid-body consistency of the
//   four wheel speeds, their common scale from the camera. Where the wheels differ, experiments
//   1 and 3 and every back-EMF term use each wheel's own values (WheelShape).
// Every method works on windows found in the data (windows.hpp), not on positions inside a
// segment. Missing data drops only what needs it. Final values: see combine_methods().
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "layout.hpp"
#include "logdata.hpp"
#include "regression.hpp"
#include "signals.hpp"
#include "windows.hpp"

extern "C" {
#include "omni4/model/params.h"
}

namespace omni4
{

enum class VelocitySource { Encoder, Camera };

// What drove the motors. Voltage: H-bridges, the logged voltages reached the windings (eq 23 in
// voltage form). Current: a drive with its own current loop (ODrive torque, VESC current); the
// logged voltages are the controller's model voltages, so R and Kv are the drive's (the base
// model's, not fitted) and experiment 3 fits eq 23 in force form on the measured currents,
// which also gives M.
enum class DriveKind { Voltage, Current };

struct IdentOptions {
	VelocitySource source = VelocitySource::Encoder;
	DriveKind drive = DriveKind::Voltage;
	WindowOptions windows;
	// Methods agree on a parameter when the chi-square of their estimates about the weighted
	// mean has a p-value of at least agree_p.
	double agree_p = 0.01;
	// Relative standard-error floor of every method (model error: the residual SE of a long,
	// clean window can be far smaller than what the method's assumptions support).
	double method_floor = 0.005;
	// A method whose SE exceeds this fraction of its value is shown but not combined.
	double max_rel_se = 0.1;
	// The wheel layout (layout.hpp): the paper's keeps today's closed forms to the bit; any
	// other fits the coupled model (identify_exp3.cpp) with one drive for every wheel.
	Layout layout;
};

// The wheels' drives relative to their mean (each array's mean is 1): Kv_j = Kv kv[j] (and
// Kt_j = Kt kv[j]), R_j = R R[j], r_j = r r[j], with Kv, R, r the scalar (mean) values. All ones:
// the paper's robot, and every formula takes the scalar path (the same bits as without it).
struct WheelShape {
	std::array<double, 4> kv{1, 1, 1, 1}, R{1, 1, 1, 1}, r{1, 1, 1, 1};
	// The layout the experiments fit (IdentOptions::layout; not the paper's: kept uniform).
	Layout layout;
	bool uniform() const;
	// b_j / mean b: beta_j = kv_j / (R_j r_j); e_j / mean e: eps_j = kv_j^2 / (R_j r_j^2) (b_j,
	// e_j: dynamics.h, per-wheel drives; "mean": of the scalar model).
	double beta(int j) const;
	double eps(int j) const;
	// The wheels of p's scalars with this shape.
	model_wheels wheels(const model_params &p) const;
};

// The per-wheel part of the identification.
struct WheelResult {
	// Motors: F-test of one (Kv, R) for all motors against one per motor (eq 22).
	bool motors_tested = false, motors_differ = false;
	double motors_F = 0, motors_p = 1;
	int motors_df1 = 0, motors_df2 = 0;
	// Radii relative to their mean (ok() where estimated) from sum_j n_j r_j w_j = 0,
	// n = (1, -1, 1, -1) (the left null space of eq 2): chi-square of rho - 1 (3 dof).
	std::array<Estimate, 4> rho{};
	bool radii_tested = false, radii_differ = false;
	double radii_chi2 = 0, radii_p = 1;
	size_t radii_rows = 0;
	// The mean radius from the camera (not ok(): unobservable, see r_scale_note).
	Estimate r_scale;
	std::string r_scale_note;
	WheelShape shape;                // what experiments 1 and 3 used
	bool per_wheel() const;          // the motors or the radii differ
	std::array<Estimate, 4> r_wheel; // r_j = r rho_j (the measured mean r: SE of rho only)
};

// Points kept for plots and CSV export.
// epoch: index into Prepared::offset_epochs of the current offsets in force (-1: none known).
struct MotorPoint {
	int motor;
	double u, i, wm;
	int epoch = -1;
}; // [V, A, rad/s]
struct RotationPoint {
	double level, omega_cam, omega_enc, torque; // [V, rad/s, rad/s, N m]
	std::array<double, 4> imean{};              // mean currents of the window [A]
	int epoch = -1;
};
struct CurvePoint {
	size_t segment;
	double t, measured, fitted;
};

// A window used or rejected, for the report.
struct WindowRecord {
	size_t segment = 0;
	std::string kind, direction; // of the segment
	std::string what;            // "steady window", "coast-down", "step", "segment", ...
	double t0_s = 0, t1_s = 0;   // from the segment's mark
	bool used = false;
	std::string reason; // why it was rejected
};

struct Agreement {
	int methods = 0;       // estimates combined
	int too_uncertain = 0; // estimates left out: SE above max_rel_se of the value
	double chi2 = 0;
	int dof = 0;
	double p = 1;
	bool agree = true;
	// When they disagree: the estimate kept (index into the estimates given, the method's name
	// in identify()'s agreement) and the Birge ratio sqrt(chi2 / dof) its SE was scaled by.
	int kept = -1;
	std::string kept_method;
	double birge = 1;
	std::string rule; // how the final value was formed
};

struct IdentResult {
	// Per method: parameter name -> estimate. Method names: "motor", "exp1", "exp2",
	// "exp3_ls", "exp3_iv", "final"; with a current drive also "drive" (Kv, R: the base
	// model's, no SE) and M from "exp3_ls", "exp3_iv" into "final".
	std::map<std::string, std::map<std::string, Estimate>> table;
	std::array<Estimate, 4> R_motor{}, Kv_motor{}; // not ok() for a motor without data
	model_params final{};                   // base with the identified values (see identified)
	std::map<std::string, bool> identified; // by kIdentParams name
	bool complete() const;
	std::map<std::string, Agreement> agreement; // by parameter
	std::vector<MotorPoint> motor_points;
	std::vector<RotationPoint> rotation_points;
	std::map<std::string, std::vector<CurvePoint>> coast_curves; // by direction
	std::map<std::string, size_t> segments_used;                 // by kind
	std::vector<WindowRecord> windows;                           // used and rejected
	std::vector<std::string> missing; // one line per thing that could not be identified
	WheelResult wheels;
	model_wheels final_wheels{}; // each wheel's drive (final's scalars where uniform)
};

// The estimate of param by method (not ok() when the method gave none).
Estimate find_estimate(const IdentResult &r, const char *method, const char *param);

// Encoder and camera tracks and windows of every segment, computed once (identify and the
// bootstrap replicates share them).
struct Prepared {
	model_params base{};
	IdentOptions opt;
	std::vector<Segment> segments;
	std::vector<SegmentWindows> windows; // per segment
	std::map<const LogData *, EncoderTrack> enc;
	std::map<const LogData *, CameraTrack> cam;
	// The current-offset epochs of the logs (LogData::current_offsets, filled by
	// calibrate_currents) whose offsets were estimated: their standard errors are borrowed by
	// the motor test and experiment 1.
	std::vector<std::pair<const LogData *, size_t>> offset_epochs;
	// The wheels' radii relative to their mean (identify_wheels.cpp): the encoder tracks use
	// base.r * rho_j when the radii differ.
	WheelResult radii;
};

// Tasks to run at once when each log is one task: the cores, or up to twice as many when there
// are that many logs (the OS shares the cores evenly among them).
size_t log_workers(size_t n_logs);

// base: the measured d, r, l, M (other fields ignored).
Prepared prepare(const std::vector<Segment> &segments, const model_params &base,
                 const IdentOptions &opt = {});

// Identifies what the segments (all, or the indices in `use`, repeats allowed) support.
// Throws IdentError only when no parameter at all can be identified (the message lists why).
IdentResult identify(const Prepared &prep, const std::vector<size_t> *use = nullptr);
IdentResult identify(const std::vector<Segment> &segments, const model_params &base,
                     const IdentOptions &opt = {});

// Final value of one parameter from the methods' estimates. An estimate with an SE above
// opt.max_rel_se of its value is left out (shown in the table only). Each SE is first raised to the
// floor (opt.method_floor * |value|). If the estimates agree (chi-square p >= opt.agree_p):
// inverse-variance weighted mean. If they do not, at least one is biased beyond its SE: the
// better-determined estimate (smallest raised SE) is kept, its SE scaled by the Birge ratio
// sqrt(chi2 / dof) to cover the disagreement; agreement->kept says which, and the disagreement
// is reported. (A plain mean would carry a poorly determined method's bias halfway in.)
Estimate combine_methods(const std::vector<Estimate> &estimates, const IdentOptions &opt,
                         Agreement *agreement = nullptr);

// Experiment 3 along one axis (eqs 31-35): rows of dx/dt = theta1 x + theta2 u + theta3 sign(x),
// filtered velocity x, filtered input u and the filtered derivative y, per run of contiguous
// rows. LS regresses y on [x, u, sign(x)]; IV uses as instruments the noise-free response of
// the current estimate to the logged input (from each run's first measured x), three times.
// Measurement noise in x biases LS towards zero (errors in variables), not IV.
struct StateSpaceData {
	Eigen::MatrixXd X;         // [x, input, sign(x)]
	Eigen::VectorXd y;         // dx/dt
	std::vector<double> t;     // [s] of each row
	std::vector<size_t> start; // first row of each run
	int half = 20;             // filter half-window [samples]: rows within 2 half + 1 correlate
};
struct StateSpaceFits {
	Fit ls, iv;
};
// Throws IdentError("what (LS|IV): ...") when the rows cannot give the three parameters.
StateSpaceFits fit_state_space(const StateSpaceData &d, const std::string &what);

// Experiment 3's axis model x' = theta1 x + theta2 u_axis + theta3 sign(x) is model/'s state
// space (dyn_state_space, eqs 23-27) along one axis: theta1 = A[axis], theta3 = K[axis], and
// theta2 the B coefficient of the axis input u_axis = axis_input(u, axis) (u3 - u1 along v,
// u0 - u2 along vn, the sum along w), so that sum_j B[axis][j] u_j = theta2 u_axis.
double axis_input(const double u_v[4], int axis);
// The inverses, given p's geometry (d, r, l), M, Kt and Kv; J_from_theta2 and B_from_theta1
// also need p.R, and along w B_from_theta1 and C_from_theta3 need p.J.
// With a shape s that is not uniform, the axis input is sum_j IK(d)^T[axis][j] beta_j u_j /
// beta_axis (beta_axis: the mean beta of the axis's wheels; along v and vn less the back-EMF
// coupling of the other axes, axis_input_wheels), so theta2 carries beta_axis and the back-EMF
// term of theta1 the axis's eps sum (dynamics.h: e1 + e3 along v, e0 + e2 along vn, d^2 sum e).
double R_from_theta2(const model_params &p, int axis, double theta2,
                     const WheelShape &s = {}); // axis 0 or 1 [ohm], mean R
double J_from_theta2(const model_params &p, double theta2, const WheelShape &s = {}); // [kg m^2]
double B_from_theta1(const model_params &p, int axis, double theta1,
                     const WheelShape &s = {});                       // Bv, Bvn, Bw
double C_from_theta3(const model_params &p, int axis, double theta3); // Cv, Cvn, Cw
// The input of axis with a non-uniform shape: sum_j IK^T[axis][j] beta_j u_j / beta_axis minus
// the back-EMF that the other axes' velocities x (robot frame) put on this one, in volts of
// that input: the coupling A[axis][other] x_other / theta2 (dynamics.h, per-wheel drives).
double axis_input_wheels(const model_params &p, const WheelShape &s, const double u_v[4],
                         const double x[3], int axis);
double axis_beta(const WheelShape &s, int axis);
// The F distribution's upper tail: P(F(df1, df2) > f).
double f_sf(double f, int df1, int df2);

// Upper tail of the chi-square distribution with dof degrees of freedom.
double chi2_sf(double x, int dof);

extern const char *const kIdentParams[9];  // Kv R J Bv Bvn Bw Cv Cvn Cw
extern const char *const kIdentMethods[6]; // motor exp1 exp2 exp3_ls exp3_iv final

} // namespace omni4
