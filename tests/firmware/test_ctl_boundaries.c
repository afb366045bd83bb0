/* Fault boundaries of the controller, pinned from the specification (docs/faults.md,
 * docs/design.md), not from the code's constants: every threshold is written here as the
 * documented number, and each case is checked just inside and just outside it, on the default
 * configuration, with exact (noise-free) samples. 1 tick = 1 ms (default loop rate 1 kHz). */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hil_util.h"
#include "omni4/core/ctl.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4_motors_t.h"

/* docs/faults.md */
#define SPEC_CMD_TIMEOUT_MS 200 /* command stream stops: cmd_timeout_ms 200 */
#define SPEC_STOP_RAMP_MS 200   /* voltages ramp to 0 over stop_ramp_s (200 ms) */
#define SPEC_CURRENT_MAX_A 5.0  /* over-current: > current_max_a, 5 A */
#define SPEC_SENSOR_MAX_A 10.2  /* current sensor saturated: reading >= 10.2 A */
#define SPEC_SUPPLY_MIN_V 9.0   /* supply sag: < supply_min_v, 9 V */
#define SPEC_JUMP_RAD_S2                                                                           \
	5000.0                /* encoder jump: step > 5000 rad/s^2 x time since the last reading */
#define SPEC_RESIDUAL_M_S 0.5 /* encoder stuck: v0 - v1 + v2 - v3 > 0.5 m/s ... */
#define SPEC_RESIDUAL_MS 50   /* ... for 50 ms */
/* docs/design.md: supply 12 V; loop 1 kHz */
#define SPEC_SUPPLY_V 12.0
#define SPEC_DT_S 1e-3
#define TICK_US 1000

static struct ctl c;

static void setup_ctl(void)
{
	struct omni4_config cfg;

	config_defaults(&cfg);
	assert_int_equal(ctl_init(&c, &cfg.ctl), 0);
}

static struct motor_sample healthy(void)
{
	struct motor_sample s;

	memset(&s, 0, sizeof(s));
	s.supply_v = (float)SPEC_SUPPLY_V;
	return s;
}

static struct ctl_output step(int64_t t_us, const struct motor_sample *s)
{
	struct ctl_output o;

	ctl_step(&c, t_us, s, 0, false, &o);
	return o;
}

static int command(int8_t mode, const double vel[3], const double volt[4], int64_t t_us)
{
	struct ctl_command cmd = {.utime = t_us, .mode = mode};

	if (vel)
		memcpy(cmd.velocity, vel, sizeof(cmd.velocity));
	if (volt)
		memcpy(cmd.voltage, volt, sizeof(cmd.voltage));
	return ctl_command(&c, &cmd, t_us);
}

static void assert_off(const struct ctl_output *o)
{
	assert_false(o->enable);
	for (int j = 0; j < 4; j++)
		assert_true(o->volts[j] == 0.0f);
}

/* ---- watchdog ------------------------------------------------------------------------- */

/* Last command at t = 0 in a moving mode: no trip while it is at most 200 ms old (the tick at
 * exactly 200 ms included), trip on the next tick (201 ms), then a 200 ms ramp to 0 V and
 * IDLE. */
static void watchdog_boundary(int8_t mode)
{
	const double v[3] = {0.5, 0, 0}, u[4] = {3, 3, 3, 3};
	const struct motor_sample s = healthy();
	struct ctl_output o;

	setup_ctl();
	assert_int_equal(command(mode, v, u, 0), 0);
	for (int ms = 0; ms <= SPEC_CMD_TIMEOUT_MS; ms++) {
		o = step((int64_t)ms * TICK_US, &s);
		if (o.faults & OMNI4_MOTORS_T_FAULT_CMD_TIMEOUT)
			fail_msg("mode %d: watchdog tripped at %d ms, command only %d ms old", mode,
			         ms, ms);
		assert_int_equal(o.mode, mode);
	}
	o = step((int64_t)(SPEC_CMD_TIMEOUT_MS + 1) * TICK_US, &s);
	assert_true(o.faults & OMNI4_MOTORS_T_FAULT_CMD_TIMEOUT);
	assert_int_equal(c.n.watchdog_trips, 1);
	if (mode == CTL_COAST) { /* bridges already off: straight to IDLE */
		assert_int_equal(o.mode, CTL_IDLE);
		return;
	}
	assert_int_equal(o.mode, CTL_VOLTAGE);
	const int trip = SPEC_CMD_TIMEOUT_MS + 1;

	for (int ms = trip + 1; ms < trip + SPEC_STOP_RAMP_MS; ms++) {
		o = step((int64_t)ms * TICK_US, &s);
		assert_int_equal(o.mode, CTL_VOLTAGE);
	}
	o = step((int64_t)(trip + SPEC_STOP_RAMP_MS) * TICK_US, &s);
	assert_int_equal(o.mode, CTL_IDLE);
	assert_off(&o);
}

static void test_watchdog_trips_one_tick_after_exactly_cmd_timeout(void **state)
{
	(void)state;
	watchdog_boundary(CTL_VELOCITY);
	watchdog_boundary(CTL_VOLTAGE);
	watchdog_boundary(CTL_COAST);
}

/* A command every 200 ms exactly keeps it alive indefinitely. */
static void test_watchdog_commands_exactly_cmd_timeout_apart_never_trip(void **state)
{
	(void)state;
	const double u[4] = {2, 2, 2, 2};
	const struct motor_sample s = healthy();

	setup_ctl();
	for (int ms = 0; ms <= 5000; ms++) {
		if (ms % SPEC_CMD_TIMEOUT_MS == 0)
			assert_int_equal(command(CTL_VOLTAGE, NULL, u, (int64_t)ms * TICK_US), 0);
		const struct ctl_output o = step((int64_t)ms * TICK_US, &s);

		assert_false(o.faults & OMNI4_MOTORS_T_FAULT_CMD_TIMEOUT);
	}
	assert_int_equal(c.n.watchdog_trips, 0);
}

/* ---- sample checks -------------------------------------------------------------------- */

/* Drive at 3 V, then feed one sample; returns the output of that tick. */
static struct ctl_output one_sample(const struct motor_sample *s)
{
	const double u[4] = {3, 3, 3, 3};
	const struct motor_sample ok = healthy();

	setup_ctl();
	assert_int_equal(command(CTL_VOLTAGE, NULL, u, 0), 0);
	const struct ctl_output o = step(0, &ok);

	assert_int_equal(o.mode, CTL_VOLTAGE);
	assert_int_equal(o.faults, 0);
	return step(TICK_US, s);
}

static void expect_fault(const struct motor_sample *s, int32_t bit, const char *what)
{
	const struct ctl_output o = one_sample(s);

	if (!(o.faults & bit) || o.mode != CTL_FAULT)
		fail_msg("%s: want FAULT with bit 0x%x in the same tick, got mode %d faults 0x%x",
		         what, (unsigned)bit, o.mode, (unsigned)o.faults);
	assert_off(&o);
}

static void expect_no_fault(const struct motor_sample *s, int32_t bit, const char *what)
{
	const struct ctl_output o = one_sample(s);

	if (o.faults & bit)
		fail_msg("%s: fault bit 0x%x set inside the limit (mode %d faults 0x%x)", what,
		         (unsigned)bit, o.mode, (unsigned)o.faults);
}

static void test_overcurrent_just_below_and_just_above_the_limit(void **state)
{
	(void)state;
	const int32_t OC = OMNI4_MOTORS_T_FAULT_OVERCURRENT;

	for (int j = 0; j < 4; j++) {
		for (int sign = -1; sign <= 1; sign += 2) {
			struct motor_sample s = healthy();

			s.current_a[j] = (float)(sign * (SPEC_CURRENT_MAX_A - 0.01));
			expect_no_fault(&s, OC, "4.99 A");
			s.current_a[j] = (float)(sign * SPEC_CURRENT_MAX_A);
			expect_no_fault(&s, OC, "exactly 5 A (the limit is '> 5 A')");
			s.current_a[j] = (float)(sign * (SPEC_CURRENT_MAX_A + 0.01));
			expect_fault(&s, OC, "5.01 A");
		}
	}
}

static void test_current_sensor_rail_at_10_2_A(void **state)
{
	(void)state;
	const int32_t CS = OMNI4_MOTORS_T_FAULT_CURRENT_SENSOR;
	struct motor_sample s = healthy();

	s.current_a[2] = (float)(SPEC_SENSOR_MAX_A - 0.01);
	expect_no_fault(&s, CS, "10.19 A");
	expect_fault(&s, OMNI4_MOTORS_T_FAULT_OVERCURRENT, "10.19 A is still an over-current");
	s.current_a[2] = (float)SPEC_SENSOR_MAX_A; /* the float nearest 10.2 A is the rail */
	expect_fault(&s, CS, "10.2 A");
	s.current_a[2] = -(float)SPEC_SENSOR_MAX_A;
	expect_fault(&s, CS, "-10.2 A");
	s.current_a[2] = NAN;
	expect_fault(&s, CS, "no current reading (NaN)");
}

/* Each driver-side fault the HAL reports (hal.h) latches its own controller fault (motors_t
 * numbering, docs/faults.md), in the same tick, and nothing else. */
static void test_hal_driver_faults_latch_their_own_fault(void **state)
{
	(void)state;
	const struct {
		uint32_t hal;
		int32_t want;
		const char *what;
	} map[] = {
	    {HAL_FAULT_DRIVER_TIMEOUT, OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT, "driver timeout"},
	    {HAL_FAULT_DRIVER, OMNI4_MOTORS_T_FAULT_DRIVER, "driver fault"},
	    {HAL_FAULT_BUS, OMNI4_MOTORS_T_FAULT_BUS, "bus off"},
	};

	for (size_t k = 0; k < sizeof(map) / sizeof(map[0]); k++) {
		struct motor_sample s = healthy();

		s.faults = map[k].hal;
		const struct ctl_output o = one_sample(&s);

		if (o.mode != CTL_FAULT || o.faults != map[k].want)
			fail_msg("%s: want FAULT with 0x%x only, got mode %d faults 0x%x",
			         map[k].what, (unsigned)map[k].want, o.mode, (unsigned)o.faults);
		assert_off(&o);
	}
}

static void test_supply_sag_below_9_V(void **state)
{
	(void)state;
	const int32_t SU = OMNI4_MOTORS_T_FAULT_SUPPLY;
	struct motor_sample s = healthy();

	s.supply_v = (float)SPEC_SUPPLY_MIN_V;
	expect_no_fault(&s, SU, "exactly 9 V (the limit is '< 9 V')");
	s.supply_v = (float)(SPEC_SUPPLY_MIN_V + 0.01);
	expect_no_fault(&s, SU, "9.01 V");
	s.supply_v = (float)(SPEC_SUPPLY_MIN_V - 0.01);
	expect_fault(&s, SU, "8.99 V");
}

/* Every wheel steps by the same amount (the rigid-body residual stays 0). */
static void test_encoder_jump_just_below_and_just_above_5000_rad_s2(void **state)
{
	(void)state;
	const int32_t EN = OMNI4_MOTORS_T_FAULT_ENCODER;
	const double max_step = SPEC_JUMP_RAD_S2 * SPEC_DT_S; /* 5 rad/s per tick */

	for (int sign = -1; sign <= 1; sign += 2) {
		struct motor_sample s = healthy();

		for (int j = 0; j < 4; j++)
			s.wheel_rad_s[j] = (float)(sign * (max_step - 0.01));
		expect_no_fault(&s, EN, "wheel speed step 4.99 rad/s in 1 ms");
		for (int j = 0; j < 4; j++)
			s.wheel_rad_s[j] = (float)(sign * (max_step + 0.01));
		expect_fault(&s, EN, "wheel speed step 5.01 rad/s in 1 ms");
	}
}

/* The bound is over the time since the previous reading: after a stall of 20 ms (the loop
 * or the bus late, or 19 ticks without a reading) a wheel may really have changed by up to
 * 5000 rad/s^2 x 20 ms = 100 rad/s. Just below passes, just above trips, both ways of the gap. */
static int jump_after_gap(double step_rad_s, bool missing_readings)
{
	const double u[4] = {3, 3, 3, 3};
	const struct motor_sample ok = healthy();
	struct motor_sample s = healthy();
	struct ctl_output o;

	setup_ctl();
	assert_int_equal(command(CTL_VOLTAGE, NULL, u, 0), 0);
	o = step(0, &ok);
	assert_int_equal(o.faults, 0);
	if (missing_readings)
		for (int t = 1; t < 20; t++)
			ctl_step(&c, (int64_t)t * TICK_US, NULL, -EAGAIN, false, &o);
	for (int j = 0; j < 4; j++)
		s.wheel_rad_s[j] = (float)step_rad_s;
	o = step(20 * TICK_US, &s);
	return (o.faults & OMNI4_MOTORS_T_FAULT_ENCODER) != 0;
}

static void test_encoder_jump_bound_grows_with_the_time_since_the_last_reading(void **state)
{
	(void)state;
	const double max_step = SPEC_JUMP_RAD_S2 * 20 * SPEC_DT_S; /* 100 rad/s in 20 ms */

	for (int missing = 0; missing <= 1; missing++) {
		for (int sign = -1; sign <= 1; sign += 2) {
			if (jump_after_gap(sign * (max_step - 0.05), missing))
				fail_msg("step %.2f rad/s after 20 ms (%s) tripped ENCODER",
				         sign * (max_step - 0.05),
				         missing ? "no readings" : "late tick");
			if (!jump_after_gap(sign * (max_step + 0.05), missing))
				fail_msg("step %.2f rad/s after 20 ms (%s) did not trip ENCODER",
				         sign * (max_step + 0.05),
				         missing ? "no readings" : "late tick");
		}
	}
}

/* Residual from wheel 0 alone (r from the default robot, Table III: 0.0325 m), constant
 * from the first sample (no jump). Returns the tick of the first ENCODER fault, -1 if none
 * within 1 s. */
static int residual_fault_tick(double residual_m_s)
{
	struct motor_sample s = healthy();

	s.wheel_rad_s[0] = (float)(residual_m_s / 0.0325);
	setup_ctl();
	for (int t = 1; t <= 1000; t++) {
		const struct ctl_output o = step((int64_t)t * TICK_US, &s);

		if (o.faults & OMNI4_MOTORS_T_FAULT_ENCODER)
			return t;
	}
	return -1;
}

static void test_encoder_residual_over_0_5_m_s_for_50_ms(void **state)
{
	(void)state;
	const int below = residual_fault_tick(SPEC_RESIDUAL_M_S - 0.01);
	const int above = residual_fault_tick(SPEC_RESIDUAL_M_S + 0.01);
	const int neg = residual_fault_tick(-(SPEC_RESIDUAL_M_S + 0.01));

	print_message("residual 0.49 m/s: fault at %d (none = -1); 0.51 m/s: at tick %d; "
	              "-0.51 m/s: at tick %d\n",
	              below, above, neg);
	assert_int_equal(below, -1);
	/* over the limit from tick 1: the 50 ms are complete at tick 50 */
	assert_int_equal(above, SPEC_RESIDUAL_MS);
	assert_int_equal(neg, SPEC_RESIDUAL_MS);
}

/* A fresh controller driving 3 V on every channel at t = 0, with a healthy reading. */
static struct ctl_output driving_3_v(void)
{
	const double u[4] = {3, 3, 3, 3};
	const struct motor_sample ok = healthy();

	setup_ctl();
	assert_int_equal(command(CTL_VOLTAGE, NULL, u, 0), 0);
	return step(0, &ok);
}

static void test_driver_silent_faults_in_the_same_tick(void **state)
{
	(void)state;
	struct ctl_output o = driving_3_v();

	ctl_step(&c, TICK_US, NULL, -EAGAIN, false, &o); /* no new reading: not a fault */
	assert_int_equal(o.mode, CTL_VOLTAGE);
	ctl_step(&c, 2 * TICK_US, NULL, -ETIMEDOUT, false, &o);
	assert_int_equal(o.mode, CTL_FAULT);
	assert_true(o.faults & OMNI4_MOTORS_T_FAULT_DRIVER_TIMEOUT);
	assert_off(&o);
}

static void test_estop_disables_outputs_in_the_same_tick(void **state)
{
	(void)state;
	const struct motor_sample ok = healthy();
	struct ctl_output o = driving_3_v();

	assert_true(o.enable);
	ctl_step(&c, TICK_US, &ok, 0, true, &o);
	assert_int_equal(o.mode, CTL_ESTOP);
	assert_off(&o);
	/* released, but a clear is needed; a clear while pressed is refused */
	ctl_step(&c, 2 * TICK_US, &ok, 0, true, &o);
	assert_int_equal(command(CTL_CLEAR_FAULT, NULL, NULL, 2 * TICK_US), -EBUSY);
	ctl_step(&c, 3 * TICK_US, &ok, 0, false, &o);
	assert_int_equal(o.mode, CTL_ESTOP);
	assert_int_equal(command(CTL_CLEAR_FAULT, NULL, NULL, 3 * TICK_US), 0);
	ctl_step(&c, 4 * TICK_US, &ok, 0, false, &o);
	assert_int_equal(o.mode, CTL_IDLE);
}

/* Voltage commands within +-12 V (the supply) are applied, beyond it rejected. */
static void test_voltage_command_at_and_beyond_the_supply(void **state)
{
	(void)state;
	const double at[4] = {SPEC_SUPPLY_V, -SPEC_SUPPLY_V, 0, 0};
	const double beyond[4] = {0, 0, SPEC_SUPPLY_V + 0.01, 0};
	const struct motor_sample ok = healthy();

	setup_ctl();
	assert_int_equal(command(CTL_VOLTAGE, NULL, at, 0), 0);
	assert_int_equal(command(CTL_VOLTAGE, NULL, beyond, 0), -EINVAL);
	const struct ctl_output o = step(0, &ok);

	assert_int_equal(c.n.cmd_rejected, 1);
	assert_true(o.volts[0] == (float)SPEC_SUPPLY_V && o.volts[2] == 0.0f);
}

/* End to end through the sim HAL with noise off: an idle robot (bridges off, true current 0)
 * with a current-sensor offset just below / just above 5 A. Below it, no over-current; once
 * the start-up offset calibration is done (bridges off 50 ms + 400 readings: 0.45 s) the
 * 4.99 A offset is subtracted (still no over-current) and, being beyond 0.25 A, latches
 * CURRENT_SENSOR. */
static void test_overcurrent_through_the_sim_hal_without_noise(void **state)
{
	(void)state;
	struct omni4_config cfg;
	char err[256];

	config_defaults(&cfg);
	for (int above = 0; above <= 1; above++) {
		struct simrun *sr =
		    simrun_create(&cfg, &cfg.ctl.model, false, NULL, err, sizeof(err));
		struct simrun_stats st;

		assert_non_null(sr);
		simrun_faults(sr)->current_offset_a = SPEC_CURRENT_MAX_A + (above ? 0.01 : -0.01);
		simrun_tick(sr);
		simrun_get_stats(sr, &st);
		if (above) {
			assert_int_equal(st.mode, CTL_FAULT);
			assert_true(st.faults & OMNI4_MOTORS_T_FAULT_OVERCURRENT);
		} else {
			hil_run(sr, 0.4);
			simrun_get_stats(sr, &st);
			assert_int_equal(st.mode, CTL_IDLE);
			assert_int_equal(st.faults, 0);
			hil_run(sr, 0.1);
			simrun_get_stats(sr, &st);
			assert_int_equal(st.mode, CTL_FAULT);
			assert_int_equal(st.faults, OMNI4_MOTORS_T_FAULT_CURRENT_SENSOR);
		}
		simrun_destroy(sr);
	}
}

/* ---- PI anti-windup -------------------------------------------------------------------- */

/* A robot held against a wall: VELOCITY 0.3 m/s along v, the wheels stay at 0. The error on
 * wheels 1 and 3 is 0.3 m/s, kp e = 6 V, so feed-forward + kp e + integral reaches the 12 V
 * supply once the integral is below 6 V; from then on the integrator must stop (it would only
 * push further into saturation), not wind up to the supply (measured 3.75 V). */
static void test_pi_integrator_stops_while_the_output_saturates(void **state)
{
	(void)state;
	const double vel[3] = {0.3, 0.0, 0.0};
	struct ctl_output o;
	struct motor_sample s = healthy();
	int64_t t = 0;

	setup_ctl();
	for (int k = 0; k < 1000; k++, t += TICK_US) {
		if (k % 100 == 0)
			assert_int_equal(command(OMNI4_MOTORS_T_MODE_VELOCITY, vel, NULL, t), 0);
		o = step(t, &s);
	}
	assert_true(o.enable);
	assert_true(fabs(o.volts[3]) >= SPEC_SUPPLY_V - 1e-6); /* saturated against the wall */
	double worst = 0.0;

	/* A plain comparison, not fmax: aarch64 GCC 12's vectoriser crashes (internal compiler
	 * error in vect_transform_reduction) on that fmax reduction over struct ctl's floats. */
	for (int j = 0; j < 4; j++) {
		const double a = fabs(c.pi[j].integ);

		if (a > worst)
			worst = a;
	}
	printf("stalled 1 s at 0.3 m/s: output %.2f V, largest integral %.3f V\n", o.volts[3],
	       worst);
	assert_true(worst < 6.0);
}

/* A sagging supply: the drives measure 9.5 V of the 12 V configured. Held against a wall
 * (VELOCITY 0.3 m/s, wheels at 0) the outputs saturate at what the bridges can give, 9.5 V, and
 * the integrals stay within it; a supply that is not measured (NaN) leaves the configured 12 V. */
static void test_outputs_stay_within_the_measured_supply(void **state)
{
	(void)state;
	const double vel[3] = {0.3, 0.0, 0.0};
	const float measured[2] = {9.5f, NAN};
	const double bound[2] = {9.5, SPEC_SUPPLY_V};

	for (int m = 0; m < 2; m++) {
		struct ctl_output o;
		struct motor_sample s = healthy();
		int64_t t = 0;
		double top = 0.0, integ = 0.0;

		s.supply_v = measured[m];
		setup_ctl();
		for (int k = 0; k < 1000; k++, t += TICK_US) {
			if (k % 100 == 0)
				assert_int_equal(
				    command(OMNI4_MOTORS_T_MODE_VELOCITY, vel, NULL, t), 0);
			o = step(t, &s);
			for (int j = 0; j < 4; j++) {
				const double u = fabs(o.volts[j]), i = fabs(c.pi[j].integ);

				top = u > top ? u : top;
				integ = i > integ ? i : integ;
			}
		}
		printf("supply measured %.1f V: largest output %.3f V, largest integral %.3f V\n",
		       (double)measured[m], top, integ);
		assert_true(o.enable);
		assert_true(top <= bound[m] + 1e-6 && top >= bound[m] - 1e-6);
		assert_true(integ <= bound[m] + 1e-6);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_watchdog_trips_one_tick_after_exactly_cmd_timeout),
	    cmocka_unit_test(test_watchdog_commands_exactly_cmd_timeout_apart_never_trip),
	    cmocka_unit_test(test_overcurrent_just_below_and_just_above_the_limit),
	    cmocka_unit_test(test_current_sensor_rail_at_10_2_A),
	    cmocka_unit_test(test_hal_driver_faults_latch_their_own_fault),
	    cmocka_unit_test(test_supply_sag_below_9_V),
	    cmocka_unit_test(test_outputs_stay_within_the_measured_supply),
	    cmocka_unit_test(test_encoder_jump_just_below_and_just_above_5000_rad_s2),
	    cmocka_unit_test(test_encoder_jump_bound_grows_with_the_time_since_the_last_reading),
	    cmocka_unit_test(test_encoder_residual_over_0_5_m_s_for_50_ms),
	    cmocka_unit_test(test_driver_silent_faults_in_the_same_tick),
	    cmocka_unit_test(test_estop_disables_outputs_in_the_same_tick),
	    cmocka_unit_test(test_voltage_command_at_and_beyond_the_supply),
	    cmocka_unit_test(test_overcurrent_through_the_sim_hal_without_noise),
	    cmocka_unit_test(test_pi_integrator_stops_while_the_output_saturates),
	};

	return cmocka_run_group_tests_name("ctl_boundaries", tests, NULL, NULL);
}
