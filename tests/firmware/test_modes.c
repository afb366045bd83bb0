/* The controller's mode transition matrix (docs/modes.md): every mode before the switch
 * (7 rows, the watchdog's stop ramp counted as one) x every trigger (5 commands, a latched
 * fault, the e-stop line, the watchdog, and the keep-alive / "cause persists" variants), each
 * at rest and with the robot moving, checked against the doc's rule for the cell: outputs
 * (volts, enable), reference (shaper), PI integrators and voltage ramp at the switch and after
 * it. Expected values come from the documented settings (SPEC_* below), the kinematics
 * (eq 2) and the model's double feedforward, or from a twin controller that did not see the
 * trigger (rejected / no-op cells) or was just started (the bumpless VELOCITY start).
 * 1 tick = 1 ms (default loop rate 1 kHz). */
#include "omni4_test.h"

#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "omni4/core/ctl.h"
#include "omni4/model/feedforward.h"
#include "omni4/model/params.h"

/* docs/ini-keys.md defaults, docs/design.md (Table III robot), docs/faults.md */
#define SPEC_DT_S 1e-3
#define TICK_US 1000
#define SPEC_KP 20.0      /* V/(m/s) */
#define SPEC_KI 200.0     /* V/m */
#define SPEC_ACC_LIN 3.0  /* m/s^2 */
#define SPEC_ACC_ROT 30.0 /* rad/s^2 */
#define SPEC_CMD_TIMEOUT_US 200000
#define SPEC_STOP_RAMP_TICKS 200 /* stop_ramp_s 0.2 */
#define SPEC_SUPPLY_V 12.0
#define SPEC_SUPPLY_LOW_V 8.0 /* below supply_min_v 9 V: FAULT SUPPLY */
#define SPEC_D 0.089          /* m */
#define SPEC_R 0.0325         /* m */

/* ---- the only places that know how a controller is built and what is inside it ---------- */

static void make_ctl(struct ctl *c)
{
	struct ctl_settings cfg;

	ctl_settings_defaults(&cfg);
	assert_int_equal(ctl_init(c, &cfg), 0);
}

/* The state the matrix is about: the shaped reference and its derivative, the integrals. */
static void ctl_state(const struct ctl *c, double ref[3], double acc[3], double integ[4])
{
	for (int k = 0; k < 3; k++) {
		ref[k] = c->shaper.ref[k];
		acc[k] = c->shaper.acc[k];
	}
	for (int j = 0; j < 4; j++)
		integ[j] = c->pi[j].integ;
}

/* ---- kinematics (eq 2, docs/design.md) -------------------------------------------------- */

static double ik(int j, const double x[3])
{
	static const double row[4][2] = {{0, 1}, {-1, 0}, {0, -1}, {1, 0}};

	return row[j][0] * x[0] + row[j][1] * x[1] + SPEC_D * x[2];
}

static double clampd(double x, double lim)
{
	return x > lim ? lim : (x < -lim ? -lim : x);
}

/* ---- the rig: one controller, its clock, its reading, its line --------------------------- */

enum from { F_IDLE, F_VELOCITY, F_VOLTAGE, F_STOP, F_COAST, F_FAULT, F_ESTOP, N_FROM };
enum trig {
	T_IDLE,
	T_VELOCITY,
	T_VOLTAGE,
	T_COAST,
	T_CLEAR,
	T_FAULT,
	T_ESTOP,
	T_WATCHDOG,
	T_VELOCITY_SAME, /* the target in force again (keep-alive) */
	T_VOLTAGE_SAME,  /* (the stop ramp's: 0 V) */
	T_CLEAR_BUSY,    /* CLEAR_FAULT while the cause persists */
	N_TRIG
};
static const char *const from_name[N_FROM] = {"IDLE",  "VELOCITY", "VOLTAGE", "VOLTAGE(stop)",
                                              "COAST", "FAULT",    "ESTOP"};
static const char *const trig_name[N_TRIG] = {"cmd IDLE",
                                              "cmd VELOCITY",
                                              "cmd VOLTAGE",
                                              "cmd COAST",
                                              "cmd CLEAR_FAULT",
                                              "latched fault",
                                              "e-stop",
                                              "watchdog",
                                              "cmd VELOCITY (same target)",
                                              "cmd VOLTAGE (same target)",
                                              "cmd CLEAR_FAULT (cause present)"};

/* The moving robot (docs/modes.md), and the targets. */
static const double X_MOVING[3] = {0.4, -0.2, 1.5};
static const double X_TARGET_A[3] = {0.7, 0.0, -0.5}; /* the from-state's (moving) */
static const double X_TARGET_B[3] = {0.1, 0.5, 2.5};  /* the trigger's (moving) */
static const double X_GO[3] = {0.3, -0.1, 1.0};       /* the trigger's (at rest) */
static const double U_A[4] = {2.0, -1.5, 1.0, -2.5};  /* the from-state's (moving) */
static const double U_B[4] = {-1.0, 3.0, 1.5, -0.5};  /* the trigger's */
#define RAMP_A_S 0.05
#define RAMP_B_S 0.1
#define RAMP_B_TICKS 100

struct rig {
	struct ctl c;
	int64_t t; /* time of the next tick [us] */
	struct motor_sample s;
	bool estop;
	struct ctl_output o; /* the last tick's output */
	int64_t last_cmd_t;  /* the last accepted motion command */
	double x[3];         /* the velocity the readings' wheel speeds encode */
	double vel_target[3];
	double volt_target[4]; /* F_VOLTAGE: its target; F_STOP: the stop ramp's, 0 V */
	int64_t trip_t;        /* F_STOP: the watchdog's trip tick */
	float trip_from[4];    /* F_STOP: the output before it */
};

static char cell[160];
static int cells_asserted;

#define CHECK(cond, ...)                                                                           \
	do {                                                                                       \
		if (!(cond)) {                                                                     \
			print_error("%s: ", cell);                                                 \
			print_error(__VA_ARGS__);                                                  \
			print_error("\n");                                                         \
			fail_msg("%s:%d: %s", __FILE__, __LINE__, #cond);                          \
		}                                                                                  \
	} while (0)

static void near(double got, double want, double tol, const char *what, int j)
{
	CHECK(fabs(got - want) <= tol, "%s[%d] = %.9g, want %.9g +- %.2g", what, j, got, want, tol);
}

static void set_velocity(struct rig *r, const double x[3])
{
	memcpy(r->x, x, sizeof(r->x));
	for (int j = 0; j < 4; j++)
		r->s.wheel_rad_s[j] = (float)(ik(j, x) / SPEC_R);
}

static void tick(struct rig *r)
{
	ctl_step(&r->c, r->t, &r->s, 0, r->estop, &r->o);
	r->t += TICK_US;
}

static int cmd(struct rig *r, int8_t mode, const double vel[3], const double volt[4], double ramp_s)
{
	struct ctl_command k = {.utime = r->t, .mode = mode, .ramp_s = ramp_s};

	if (vel)
		memcpy(k.velocity, vel, sizeof(k.velocity));
	if (volt)
		memcpy(k.voltage, volt, sizeof(k.voltage));
	const int rc = ctl_command(&r->c, &k, r->t);

	if (rc == 0 && mode != CTL_CLEAR_FAULT)
		r->last_cmd_t = r->t;
	return rc;
}

static bool off(const struct ctl_output *o)
{
	return !o->enable && o->volts[0] == 0.0f && o->volts[1] == 0.0f && o->volts[2] == 0.0f &&
	       o->volts[3] == 0.0f;
}

/* The mode before the switch (docs/modes.md, "At rest" / "Moving"). */
static void enter(struct rig *r, enum from f, bool moving)
{
	static const double zero3[3] = {0, 0, 0};
	static const double zero4[4] = {0, 0, 0, 0};

	memset(r, 0, sizeof(*r));
	make_ctl(&r->c);
	r->s.supply_v = (float)SPEC_SUPPLY_V;
	set_velocity(r, moving ? X_MOVING : zero3);
	for (int k = 0; k < 5; k++)
		tick(r);
	CHECK(r->o.mode == CTL_IDLE && r->o.faults == 0, "start: mode %d faults 0x%x", r->o.mode,
	      (unsigned)r->o.faults);
	if (f == F_IDLE)
		return;
	memcpy(r->vel_target, moving ? X_TARGET_A : zero3, sizeof(r->vel_target));
	CHECK(cmd(r, CTL_VELOCITY, r->vel_target, NULL, 0) == 0, "VELOCITY refused");
	for (int k = 0; k < 20; k++)
		tick(r);
	CHECK(r->o.mode == CTL_VELOCITY && r->o.enable, "VELOCITY: mode %d", r->o.mode);
	switch (f) {
	case F_VOLTAGE:
		memcpy(r->volt_target, moving ? U_A : zero4, sizeof(r->volt_target));
		CHECK(cmd(r, CTL_VOLTAGE, NULL, r->volt_target, RAMP_A_S) == 0, "VOLTAGE refused");
		for (int k = 0; k < 10; k++)
			tick(r);
		CHECK(r->o.mode == CTL_VOLTAGE, "VOLTAGE: mode %d", r->o.mode);
		break;
	case F_STOP:
		while (!(r->o.faults & CTL_FAULT_CMD_TIMEOUT)) {
			memcpy(r->trip_from, r->o.volts, sizeof(r->trip_from));
			r->trip_t = r->t;
			tick(r);
			CHECK(r->t < 10 * SPEC_CMD_TIMEOUT_US, "the watchdog never tripped");
		}
		for (int k = 0; k < 50; k++)
			tick(r);
		CHECK(r->o.mode == CTL_VOLTAGE, "stop ramp: mode %d", r->o.mode);
		break;
	case F_COAST:
		CHECK(cmd(r, CTL_COAST, NULL, NULL, 0) == 0, "COAST refused");
		for (int k = 0; k < 10; k++)
			tick(r);
		CHECK(r->o.mode == CTL_COAST, "COAST: mode %d", r->o.mode);
		break;
	case F_FAULT:
		r->s.supply_v = (float)SPEC_SUPPLY_LOW_V;
		tick(r);
		r->s.supply_v = (float)SPEC_SUPPLY_V; /* the cause is gone */
		for (int k = 0; k < 3; k++)
			tick(r);
		CHECK(r->o.mode == CTL_FAULT, "FAULT: mode %d", r->o.mode);
		break;
	case F_ESTOP:
		r->estop = true;
		tick(r);
		r->estop = false; /* released */
		for (int k = 0; k < 3; k++)
			tick(r);
		CHECK(r->o.mode == CTL_ESTOP, "ESTOP: mode %d", r->o.mode);
		break;
	default:
		break;
	}
	if (moving && (f == F_VELOCITY || f == F_VOLTAGE || f == F_STOP)) {
		/* the state a switch could leak: a reference off the measured velocity, integrals
		 * away from 0, volts applied */
		double ref[3], acc[3], integ[4], most_i = 0, most_u = 0, most_off = 0;

		ctl_state(&r->c, ref, acc, integ);
		/* plain comparisons, not fmax: see test_ctl_boundaries (aarch64 GCC 12's
		 * vectoriser) */
		for (int j = 0; j < 4; j++) {
			if (fabs(integ[j]) > most_i)
				most_i = fabs(integ[j]);
			if (fabs(r->o.volts[j]) > most_u)
				most_u = fabs(r->o.volts[j]);
		}
		for (int k = 0; k < 3; k++)
			if (fabs(ref[k] - r->x[k]) > most_off)
				most_off = fabs(ref[k] - r->x[k]);
		CHECK(most_i > 0.01 && most_u > 0.5 && most_off > 0.05,
		      "moving from-state too tame: integral %g V, volts %g V, reference off by %g",
		      most_i, most_u, most_off);
	}
}

/* ---- the rules (docs/modes.md, "The rules") -------------------------------------------- */

enum rule {
	R_NA,
	R_SAME,
	R_OFF,
	R_VEL_START,
	R_VEL_RETARGET,
	R_RAMP,
	R_KEEP,
	R_STOP,
	R_STOP_GOES_ON,
	R_COAST_TIMEOUT,
	R_NOT_WATCHED,
	R_REJECT,
	R_CLEAR,
};

struct rule_of_cell {
	enum rule rule;
	int8_t mode; /* after the switch */
	int rc;      /* of the command */
};

#define SAME(m) {R_SAME, m, 0}
#define OFF(m) {R_OFF, m, 0}
#define REJ(m, e) {R_REJECT, m, -(e)}
#define NA {R_NA, 0, 0}

/* The matrix of docs/modes.md. */
static const struct rule_of_cell MATRIX[N_FROM][N_TRIG] = {
    [F_IDLE] = {SAME(CTL_IDLE),
                {R_VEL_START, CTL_VELOCITY, 0},
                {R_RAMP, CTL_VOLTAGE, 0},
                OFF(CTL_COAST),
                SAME(CTL_IDLE),
                OFF(CTL_FAULT),
                OFF(CTL_ESTOP),
                {R_NOT_WATCHED, CTL_IDLE, 0},
                NA,
                NA,
                NA},
    [F_VELOCITY] = {OFF(CTL_IDLE),
                    {R_VEL_RETARGET, CTL_VELOCITY, 0},
                    {R_RAMP, CTL_VOLTAGE, 0},
                    OFF(CTL_COAST),
                    SAME(CTL_VELOCITY),
                    OFF(CTL_FAULT),
                    OFF(CTL_ESTOP),
                    {R_STOP, CTL_VOLTAGE, 0},
                    SAME(CTL_VELOCITY),
                    NA,
                    NA},
    [F_VOLTAGE] = {OFF(CTL_IDLE),
                   {R_VEL_START, CTL_VELOCITY, 0},
                   {R_RAMP, CTL_VOLTAGE, 0},
                   OFF(CTL_COAST),
                   SAME(CTL_VOLTAGE),
                   OFF(CTL_FAULT),
                   OFF(CTL_ESTOP),
                   {R_STOP, CTL_VOLTAGE, 0},
                   NA,
                   {R_KEEP, CTL_VOLTAGE, 0},
                   NA},
    [F_STOP] = {OFF(CTL_IDLE),
                {R_VEL_START, CTL_VELOCITY, 0},
                {R_RAMP, CTL_VOLTAGE, 0},
                OFF(CTL_COAST),
                SAME(CTL_VOLTAGE),
                OFF(CTL_FAULT),
                OFF(CTL_ESTOP),
                {R_STOP_GOES_ON, CTL_VOLTAGE, 0},
                NA,
                {R_RAMP, CTL_VOLTAGE, 0},
                NA},
    [F_COAST] = {OFF(CTL_IDLE),
                 {R_VEL_START, CTL_VELOCITY, 0},
                 {R_RAMP, CTL_VOLTAGE, 0},
                 SAME(CTL_COAST),
                 SAME(CTL_COAST),
                 OFF(CTL_FAULT),
                 OFF(CTL_ESTOP),
                 {R_COAST_TIMEOUT, CTL_IDLE, 0},
                 NA,
                 NA,
                 NA},
    [F_FAULT] = {REJ(CTL_FAULT, EPERM),
                 REJ(CTL_FAULT, EPERM),
                 REJ(CTL_FAULT, EPERM),
                 REJ(CTL_FAULT, EPERM),
                 {R_CLEAR, CTL_IDLE, 0},
                 OFF(CTL_FAULT),
                 OFF(CTL_ESTOP),
                 {R_NOT_WATCHED, CTL_FAULT, 0},
                 NA,
                 NA,
                 REJ(CTL_FAULT, EBUSY)},
    [F_ESTOP] = {REJ(CTL_ESTOP, EPERM),
                 REJ(CTL_ESTOP, EPERM),
                 REJ(CTL_ESTOP, EPERM),
                 REJ(CTL_ESTOP, EPERM),
                 {R_CLEAR, CTL_IDLE, 0},
                 OFF(CTL_ESTOP),
                 OFF(CTL_ESTOP),
                 {R_NOT_WATCHED, CTL_ESTOP, 0},
                 NA,
                 NA,
                 REJ(CTL_ESTOP, EBUSY)},
};

/* The switch tick of rule OFF: bridges off, 0 V, integrals 0. */
static void check_off(const struct rig *r)
{
	double ref[3], acc[3], integ[4];

	CHECK(off(&r->o), "outputs not off: enable %d volts %g %g %g %g", r->o.enable,
	      r->o.volts[0], r->o.volts[1], r->o.volts[2], r->o.volts[3]);
	ctl_state(&r->c, ref, acc, integ);
	for (int j = 0; j < 4; j++)
		CHECK(integ[j] == 0.0, "integral %d = %g, want 0", j, integ[j]);
}

/* a (saw the trigger) against b (the same controller without it), n ticks: nothing but the
 * reported bits in `ignore` may differ. */
static void check_twin(struct rig *a, struct rig *b, int n, int32_t ignore)
{
	for (int k = 0; k < n; k++) {
		double ra[3], aa[3], ia[4], rb[3], ab[3], ib[4];

		if (k > 0) {
			tick(a);
			tick(b);
		}
		CHECK(a->o.mode == b->o.mode, "tick %d: mode %d, without the trigger %d", k,
		      a->o.mode, b->o.mode);
		CHECK(a->o.enable == b->o.enable, "tick %d: enable differs", k);
		CHECK((a->o.faults & ~ignore) == (b->o.faults & ~ignore),
		      "tick %d: faults 0x%x, without the trigger 0x%x", k, (unsigned)a->o.faults,
		      (unsigned)b->o.faults);
		for (int j = 0; j < 4; j++)
			CHECK(a->o.volts[j] == b->o.volts[j],
			      "tick %d: volts[%d] %.9g, without %.9g", k, j, a->o.volts[j],
			      b->o.volts[j]);
		ctl_state(&a->c, ra, aa, ia);
		ctl_state(&b->c, rb, ab, ib);
		for (int i = 0; i < 3; i++)
			CHECK(ra[i] == rb[i] && aa[i] == ab[i],
			      "tick %d: reference[%d] %.9g, without %.9g", k, i, ra[i], rb[i]);
		for (int j = 0; j < 4; j++)
			CHECK(ia[j] == ib[j], "tick %d: integral[%d] %.9g, without %.9g", k, j,
			      ia[j], ib[j]);
	}
}

/* VEL-START at the switch tick (a has just ticked with the new target): reference, its
 * derivative, integrals and volts from the documented settings; then the same outputs as a
 * controller started fresh at that instant with the same reading and command. */
static void check_vel_start(struct rig *a, const struct rig *before, const double target[3])
{
	const double max_step[3] = {SPEC_ACC_LIN * SPEC_DT_S, SPEC_ACC_LIN * SPEC_DT_S,
	                            SPEC_ACC_ROT * SPEC_DT_S};
	double ref[3], acc[3], integ[4], want_ref[3], want_acc[3], step[3], u_ff[4];

	ctl_state(&a->c, ref, acc, integ);
	for (int k = 0; k < 3; k++) {
		step[k] = clampd(target[k] - a->x[k], max_step[k]);
		want_ref[k] = a->x[k] + step[k];
		want_acc[k] = step[k] / SPEC_DT_S;
		near(ref[k], want_ref[k], 2e-4, "reference (starts at the measured velocity)", k);
		near(acc[k], want_acc[k], 1e-3, "reference derivative", k);
	}
	ff_voltages(&model_params_table3, want_ref, want_acc, SPEC_SUPPLY_V, u_ff);
	for (int j = 0; j < 4; j++) {
		const double e = ik(j, step); /* IK(ref) - r w = IK(x + step) - IK(x) */

		near(integ[j], SPEC_KI * SPEC_DT_S * e, 1e-4, "integral (from 0)", j);
		near(a->o.volts[j], u_ff[j] + SPEC_KP * e + SPEC_KI * SPEC_DT_S * e, 0.02, "volts",
		     j);
	}
	CHECK(a->o.enable, "bridges off in VELOCITY");

	/* The fresh controller: started 5 ticks before the switch with the same reading. */
	struct rig f;

	memset(&f, 0, sizeof(f));
	make_ctl(&f.c);
	f.s = before->s;
	f.t = before->t - 5 * TICK_US;
	for (int k = 0; k < 5; k++)
		tick(&f);
	CHECK(cmd(&f, CTL_VELOCITY, target, NULL, 0) == 0, "fresh: VELOCITY refused");
	tick(&f);
	for (int k = 0; k < 30; k++) {
		if (k > 0) {
			tick(a);
			tick(&f);
		}
		CHECK(a->o.mode == CTL_VELOCITY, "tick %d: mode %d", k, a->o.mode);
		for (int j = 0; j < 4; j++)
			CHECK(fabsf(a->o.volts[j] - f.o.volts[j]) <= 1e-6f,
			      "tick %d: volts[%d] %.9g, a fresh controller %.9g (history leaks in)",
			      k, j, a->o.volts[j], f.o.volts[j]);
	}
}

/* VEL-RETARGET at the switch tick: the reference goes on from where it was, the integrals go
 * on integrating. */
static void check_vel_retarget(const struct rig *a, const double ref0[3], const double integ0[4],
                               const double target[3])
{
	const double max_step[3] = {SPEC_ACC_LIN * SPEC_DT_S, SPEC_ACC_LIN * SPEC_DT_S,
	                            SPEC_ACC_ROT * SPEC_DT_S};
	double ref[3], acc[3], integ[4], want_ref[3];

	ctl_state(&a->c, ref, acc, integ);
	for (int k = 0; k < 3; k++) {
		want_ref[k] = ref0[k] + clampd(target[k] - ref0[k], max_step[k]);
		near(ref[k], want_ref[k], 1e-5, "reference (goes on from where it was)", k);
	}
	for (int j = 0; j < 4; j++) {
		const double e = ik(j, want_ref) - ik(j, a->x);

		near(integ[j], integ0[j] + SPEC_KI * SPEC_DT_S * e, 1e-4, "integral (goes on)", j);
	}
	CHECK(a->o.mode == CTL_VELOCITY && a->o.enable, "mode %d enable %d", a->o.mode,
	      a->o.enable);
}

/* RAMP: the command at the switch tick's time from u0 (the output in force) to u1 over
 * RAMP_B_S: u0 at the switch, u0 + (u1 - u0) k dt / ramp at tick k, then u1. */
static void check_ramp(struct rig *a, const float u0[4], const double u1[4])
{
	for (int k = 0; k <= RAMP_B_TICKS + 5; k++) {
		if (k > 0)
			tick(a);
		CHECK(a->o.mode == CTL_VOLTAGE && a->o.enable, "ramp tick %d: mode %d enable %d", k,
		      a->o.mode, a->o.enable);
		for (int j = 0; j < 4; j++) {
			const double frac = k >= RAMP_B_TICKS ? 1.0 : (double)k / RAMP_B_TICKS;

			near(a->o.volts[j], u0[j] + (u1[j] - u0[j]) * frac, 1e-5, "ramp volts", j);
		}
	}
}

/* From the trip tick (a has just ticked it): u0 down to 0 over stop_ramp_s, IDLE at its end. */
static void check_stop_ramp(struct rig *a, int64_t trip_t, const float u0[4])
{
	for (;;) {
		const int k = (int)((a->t - TICK_US - trip_t) / TICK_US);

		CHECK(a->o.faults & CTL_FAULT_CMD_TIMEOUT, "stop ramp tick %d: no CMD_TIMEOUT", k);
		if (k >= SPEC_STOP_RAMP_TICKS) {
			CHECK(a->o.mode == CTL_IDLE, "stop ramp over: mode %d, want IDLE",
			      a->o.mode);
			check_off(a);
			return;
		}
		CHECK(a->o.mode == CTL_VOLTAGE && a->o.enable, "stop ramp tick %d: mode %d", k,
		      a->o.mode);
		for (int j = 0; j < 4; j++)
			near(a->o.volts[j], u0[j] * (1.0 - (double)k / SPEC_STOP_RAMP_TICKS), 1e-5,
			     "stop ramp volts", j);
		tick(a);
	}
}

/* Tick without commands up to the watchdog's limit: nothing may change before it. */
static void run_to_trip(struct rig *a, float prev[4])
{
	const int8_t mode = a->o.mode;

	while (a->t <= a->last_cmd_t + SPEC_CMD_TIMEOUT_US) {
		memcpy(prev, a->o.volts, 4 * sizeof(float));
		tick(a);
		CHECK(a->o.mode == mode && !(a->o.faults & CTL_FAULT_CMD_TIMEOUT),
		      "watchdog at %lld us after the last command (limit 200 ms): mode %d",
		      (long long)(a->t - TICK_US - a->last_cmd_t), a->o.mode);
	}
	memcpy(prev, a->o.volts, 4 * sizeof(float));
	tick(a); /* the first tick more than 200 ms after the command */
	CHECK(a->t - TICK_US - a->last_cmd_t == SPEC_CMD_TIMEOUT_US + TICK_US, "trip tick time");
	CHECK(a->o.faults & CTL_FAULT_CMD_TIMEOUT, "no trip 201 ms after the last command");
}

static void run_cell(enum from f, enum trig tr, bool moving)
{
	const struct rule_of_cell want = MATRIX[f][tr];
	static struct rig a, b, before;
	double ref0[3], acc0[3], integ0[4];
	const double *vel = moving ? X_TARGET_B : X_GO;
	int rc = 0;

	if (want.rule == R_NA)
		return;
	snprintf(cell, sizeof(cell), "%s -> %s (%s)", from_name[f], trig_name[tr],
	         moving ? "moving" : "at rest");
	enter(&a, f, moving);
	b = a;
	before = a;
	ctl_state(&a.c, ref0, acc0, integ0);
	if (tr == T_CLEAR_BUSY) { /* the cause present in both, at the last reading */
		if (f == F_FAULT)
			a.s.supply_v = b.s.supply_v = (float)SPEC_SUPPLY_LOW_V;
		else
			a.estop = b.estop = true;
		tick(&a);
		tick(&b);
		before = a;
	}

	switch (tr) {
	case T_IDLE:
		rc = cmd(&a, CTL_IDLE, NULL, NULL, 0);
		break;
	case T_VELOCITY:
		rc = cmd(&a, CTL_VELOCITY, vel, NULL, 0);
		break;
	case T_VOLTAGE:
		rc = cmd(&a, CTL_VOLTAGE, NULL, U_B, RAMP_B_S);
		break;
	case T_COAST:
		rc = cmd(&a, CTL_COAST, NULL, NULL, 0);
		break;
	case T_CLEAR:
	case T_CLEAR_BUSY:
		rc = cmd(&a, CTL_CLEAR_FAULT, NULL, NULL, 0);
		break;
	case T_FAULT:
		a.s.supply_v = (float)SPEC_SUPPLY_LOW_V;
		break;
	case T_ESTOP:
		a.estop = true;
		break;
	case T_VELOCITY_SAME:
		rc = cmd(&a, CTL_VELOCITY, a.vel_target, NULL, 0);
		break;
	case T_VOLTAGE_SAME:
		rc = cmd(&a, CTL_VOLTAGE, NULL, a.volt_target, RAMP_B_S); /* another ramp_s */
		break;
	case T_WATCHDOG:
	case N_TRIG:
		break;
	}
	CHECK(rc == want.rc, "command returned %d, want %d", rc, want.rc);

	if (tr == T_WATCHDOG) {
		float prev[4];

		switch (want.rule) {
		case R_STOP:
			run_to_trip(&a, prev);
			CHECK(a.o.mode == CTL_VOLTAGE, "trip: mode %d, want VOLTAGE", a.o.mode);
			check_stop_ramp(&a, a.t - TICK_US, prev);
			break;
		case R_COAST_TIMEOUT:
			run_to_trip(&a, prev);
			CHECK(a.o.mode == CTL_IDLE, "trip: mode %d, want IDLE", a.o.mode);
			check_off(&a);
			break;
		case R_STOP_GOES_ON:
			tick(&a);
			check_stop_ramp(&a, a.trip_t, a.trip_from);
			break;
		default: /* R_NOT_WATCHED: a second without commands changes nothing */
			for (int k = 0; k < 1000; k++) {
				tick(&a);
				CHECK(a.o.mode == want.mode && off(&a.o) &&
				          !(a.o.faults & CTL_FAULT_CMD_TIMEOUT),
				      "%d ms without commands: mode %d faults 0x%x", k + 1,
				      a.o.mode, (unsigned)a.o.faults);
			}
			break;
		}
		cells_asserted++;
		return;
	}

	tick(&a); /* the switch tick */
	tick(&b);
	CHECK(a.o.mode == want.mode, "mode %d after the switch, want %d", a.o.mode, want.mode);
	switch (want.rule) {
	case R_SAME:
		check_twin(&a, &b, 5, CTL_FAULT_CMD_TIMEOUT | CTL_FAULT_CMD_REJECTED);
		break;
	case R_KEEP:
		check_twin(&a, &b, RAMP_B_TICKS, 0);
		break;
	case R_REJECT:
		CHECK(a.o.faults & CTL_FAULT_CMD_REJECTED, "CMD_REJECTED not flagged");
		check_twin(&a, &b, 5, CTL_FAULT_CMD_REJECTED);
		break;
	case R_OFF:
		check_off(&a);
		if (tr == T_FAULT)
			CHECK(a.o.faults & CTL_FAULT_SUPPLY, "SUPPLY not reported");
		if (tr == T_ESTOP)
			CHECK(a.o.faults & CTL_FAULT_ESTOP, "ESTOP not reported");
		for (int k = 0; k < 5; k++) {
			tick(&a);
			CHECK(a.o.mode == want.mode, "%d ticks later: mode %d", k + 1, a.o.mode);
			check_off(&a);
		}
		break;
	case R_CLEAR:
		check_off(&a);
		CHECK(a.o.faults == 0, "faults 0x%x after the clear, want 0", (unsigned)a.o.faults);
		break;
	case R_VEL_START:
		check_vel_start(&a, &before, vel);
		break;
	case R_VEL_RETARGET:
		check_vel_retarget(&a, ref0, integ0, vel);
		break;
	case R_RAMP:
		check_ramp(&a, before.o.volts, tr == T_VOLTAGE_SAME ? before.volt_target : U_B);
		break;
	default:
		fail_msg("%s: no check for rule %d", cell, want.rule);
	}
	cells_asserted++;
}

static void run_row(enum from f)
{
	for (int moving = 0; moving <= 1; moving++)
		for (int tr = 0; tr < N_TRIG; tr++)
			run_cell(f, (enum trig)tr, moving);
}

static void test_from_idle(void **state)
{
	(void)state;
	run_row(F_IDLE);
}

static void test_from_velocity(void **state)
{
	(void)state;
	run_row(F_VELOCITY);
}

static void test_from_voltage(void **state)
{
	(void)state;
	run_row(F_VOLTAGE);
}

static void test_from_the_watchdog_stop_ramp(void **state)
{
	(void)state;
	run_row(F_STOP);
}

static void test_from_coast(void **state)
{
	(void)state;
	run_row(F_COAST);
}

static void test_from_fault(void **state)
{
	(void)state;
	run_row(F_FAULT);
}

static void test_from_estop(void **state)
{
	(void)state;
	run_row(F_ESTOP);
}

/* A cause seen in the last reading still stands over ticks without a reading (read -EAGAIN,
 * "none available yet"): CLEAR_FAULT is refused until a reading shows it gone, and nothing
 * drives meanwhile (docs/modes.md, "Cause persists"). */
static void test_a_tick_without_a_reading_keeps_the_cause(void **state)
{
	static const double v[3] = {0.5, 0, 0};
	static struct rig r;

	(void)state;
	enter(&r, F_IDLE, false);
	r.s.supply_v = (float)SPEC_SUPPLY_LOW_V;
	tick(&r);
	assert_int_equal(r.o.mode, CTL_FAULT);
	for (int k = 0; k < 3; k++) {
		ctl_step(&r.c, r.t, NULL, -EAGAIN, false, &r.o);
		r.t += TICK_US;
		assert_int_equal(cmd(&r, CTL_CLEAR_FAULT, NULL, NULL, 0), -EBUSY);
		assert_int_equal(cmd(&r, CTL_VELOCITY, v, NULL, 0), -EPERM);
		assert_true(off(&r.o));
		assert_int_equal(r.o.mode, CTL_FAULT);
	}
	r.s.supply_v = (float)SPEC_SUPPLY_V; /* the next reading shows the cause gone */
	tick(&r);
	assert_int_equal(cmd(&r, CTL_CLEAR_FAULT, NULL, NULL, 0), 0);
	tick(&r);
	assert_int_equal(r.o.mode, CTL_IDLE);
}

/* Every cell of the matrix was asserted: 7 rows x 8 triggers, 3 same-target commands, 2
 * "cause present", each at rest and moving. */
static void test_every_cell_was_asserted(void **state)
{
	(void)state;
	print_message("%d cells asserted\n", cells_asserted);
	assert_int_equal(cells_asserted, 2 * (N_FROM * 8 + 3 + 2));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_from_idle),
	    cmocka_unit_test(test_from_velocity),
	    cmocka_unit_test(test_from_voltage),
	    cmocka_unit_test(test_from_the_watchdog_stop_ramp),
	    cmocka_unit_test(test_from_coast),
	    cmocka_unit_test(test_from_fault),
	    cmocka_unit_test(test_from_estop),
	    cmocka_unit_test(test_every_cell_was_asserted),
	    cmocka_unit_test(test_a_tick_without_a_reading_keeps_the_cause),
	};

	return cmocka_run_group_tests_name("modes", tests, NULL, NULL);
}
