/*
 * The sim backend's robot that changes as it runs ([sim] thermal, battery, floor_change_s;
 * docs/configuration.md) against computations of the test's own: a stalled motor's winding
 * against its heat ODE integrated here (RK4), the supply under a constant load against the
 * closed form of a linear open-circuit curve, Ohm's law at the battery, the floor's friction
 * against eq 23's steady speed before and after the change; and OMNI4_SIM_PLANT from the
 * lockstep simulator at 10 Hz. Each case simulates a few seconds at most.
 */
#include "omni4_test.h"

#include <lcm/eventlog.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "config_ini.h"
#include "omni4/config/config.h"
#include "omni4/drivers/sim_motor.h"
#include "omni4/lcmtypes/channels.h"
#include "omni4/sil/simrun.h"
#include "omni4_sim_plant_t.h"

/* Exact sensors, the plant stepped every period_s. */
static void start(struct sim_motor *s, const struct omni4_config *cfg, double period_s)
{
	const struct sim_motor_config sc = sim_motor_config_from(
	    &cfg->sim, false, &cfg->ctl.model, period_s, cfg->ctl.limits.supply_v);

	assert_int_equal(sim_motor_init(s, &sc), 0);
}

/* n reads with the bridges on at u (the last sample in *m). */
static void run(struct sim_motor *s, const float u[4], int n, struct motor_sample *m)
{
	assert_int_equal(sim_motor_ops.enable(s, true), 0);
	assert_int_equal(sim_motor_ops.write(s, u), 0);
	for (int k = 0; k < n; k++)
		assert_int_equal(sim_motor_ops.read(s, m), 0);
}

static void test_keys_are_off_by_default_and_report_constants(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;
	struct sim_motor s;
	struct motor_sample m;
	struct sim_plant_state ps;
	static const float u[4] = {4, -3, 2, 5};

	config_defaults(&cfg);
	assert_false(cfg.sim.thermal || cfg.sim.battery);
	assert_true(cfg.sim.floor_change_s == 0.0 && cfg.sim.floor_friction_scale == 1.0);
	assert_true(cfg.sim.ambient == 25.0);
	const char *bad[] = {"[sim]\nthermal_resistance = 0\n", "[sim]\nbattery_capacity = 0\n",
	                     "[sim]\nfloor_change_s = -1\n", "[sim]\nfloor_friction_scale = -0.1\n",
	                     "[sim]\nbattery_resistance = -0.1\n"};

	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		config_defaults(&cfg);
		assert_int_not_equal(config_load_string(bad[i], "bad.ini", &cfg, &err), 0);
	}
	cfg = config_ini("[sim]\nmotor_R_error_2 = 0.1\n");
	start(&s, &cfg, 1e-3);
	run(&s, u, 500, &m);
	sim_motor_plant_state(&s, &ps);
	for (int j = 0; j < 4; j++) {
		assert_true(ps.R_ohm[j] == cfg.ctl.model.R * (j == 2 ? 1.1 : 1.0));
		assert_true(ps.winding_c[j] == 25.0);
	}
	assert_true(ps.supply_v == 12.0 && m.supply_v == 12.0f && ps.friction_scale == 1.0);
}

/* ---- warm windings ------------------------------------------------------------------------- */

#define ALPHA_CU 0.00393

/* The rise x = T - ambient of a winding stalled at u volts: x' = (u^2 / R(x) - x / R_th) / C_th,
 * R(x) = R0 (1 + alpha x); one RK4 step of h. */
static double stall_rise_rate(double x, double u, double R0, double r_th, double c_th)
{
	return (u * u / (R0 * (1.0 + ALPHA_CU * x)) - x / r_th) / c_th;
}

static double stall_rk4(double x, double h, double u, double R0, double r_th, double c_th)
{
	const double k1 = stall_rise_rate(x, u, R0, r_th, c_th);
	const double k2 = stall_rise_rate(x + 0.5 * h * k1, u, R0, r_th, c_th);
	const double k3 = stall_rise_rate(x + 0.5 * h * k2, u, R0, r_th, c_th);
	const double k4 = stall_rise_rate(x + h * k3, u, R0, r_th, c_th);

	return x + h * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0;
}

/* A held body (the motors stall: i = u / R(T)) with a 5 s thermal time constant: after 1, 2
 * and 4 s each winding's temperature, resistance and current are those of the ODE. */
static void test_stalled_windings_heat_as_their_ode_says(void **state)
{
	(void)state;
	struct omni4_config cfg = config_ini("[sim]\nthermal = true\nthermal_resistance = 10\n"
	                                     "thermal_capacity = 0.5\nambient = 20\n");
	struct sim_motor s;
	struct motor_sample m;
	struct sim_plant_state ps;
	static const float u[4] = {6, -6, 5, -4};
	const double R0 = cfg.ctl.model.R, dt = 0.01;
	double x[4] = {0};
	int done = 0;

	start(&s, &cfg, dt);
	s.inject.blocked = true;
	for (int t_ms = 1000; t_ms <= 4000; t_ms *= 2) {
		run(&s, u, (t_ms - done) / 10, &m);
		for (int j = 0; j < 4; j++)
			for (int k = done; k < t_ms; k++) /* 1 ms steps */
				x[j] = stall_rk4(x[j], 1e-3, u[j], R0, 10.0, 0.5);
		done = t_ms;
		sim_motor_plant_state(&s, &ps);
		for (int j = 0; j < 4; j++) {
			const double R = R0 * (1.0 + ALPHA_CU * x[j]);

			assert_near(ps.winding_c[j], 20.0 + x[j], 0.005 * x[j]);
			assert_near(ps.R_ohm[j], R, 0.005 * (R - R0));
			assert_near(m.current_a[j], u[j] / R, 2e-3 * fabs(u[j]) / R);
		}
	}
	assert_true(x[0] > 30.0); /* R up 12 %: the heating is no rounding */
}

/* ---- the battery --------------------------------------------------------------------------- */

/* A stalled load of constant power P = sum u_j^2 / R on a battery without resistance: the
 * supply V solves V dV/dt = -k P (k = 0.25 V_full / Q), V(t) = sqrt(V_full^2 - 2 k P t). */
static void test_supply_sags_under_constant_power_as_the_closed_form(void **state)
{
	(void)state;
	struct omni4_config cfg =
	    config_ini("[sim]\nbattery = true\nbattery_capacity = 0.001\nbattery_resistance = 0\n");
	struct sim_motor s;
	struct motor_sample m;
	static const float u[4] = {3, -3, 3, -3};
	const double v0 = 12.0, q = 0.001 * 3600.0, k = 0.25 * v0 / q;
	const double p = 4.0 * 9.0 / cfg.ctl.model.R;

	start(&s, &cfg, 1e-3);
	s.inject.blocked = true;
	for (int t_ms = 500; t_ms <= 2000; t_ms += 500) {
		run(&s, u, 500, &m);
		const double want = sqrt(v0 * v0 - 2.0 * k * p * t_ms * 1e-3);

		assert_near(m.supply_v, want, 2e-3);
	}
	assert_true(m.supply_v < 11.0f); /* 8 % down */
	/* The bridges cannot exceed the supply they have now. */
	static const float high[4] = {20, -20, 20, -20};
	struct sim_plant_state ps;

	run(&s, high, 1, &m);
	sim_motor_plant_state(&s, &ps);
	assert_true(fabs(s.plant.voltage_v[0]) < 11.0 && fabs(s.plant.voltage_v[0]) > 10.0);
	assert_near(s.plant.voltage_v[1], -s.plant.voltage_v[0], 0.0);
}

/* Ohm's law at the battery: with 0.5 ohm inside, the supply of the first step is its full
 * voltage less 0.5 ohm x the current drawn, the motors' power (from the readings) over it. */
static void test_supply_drops_by_the_internal_resistance_times_the_current(void **state)
{
	(void)state;
	struct omni4_config cfg = config_ini("[sim]\nbattery = true\nbattery_resistance = 0.5\n");
	struct sim_motor s;
	struct motor_sample m;
	static const float u[4] = {8, -6, 4, -2};
	double p = 0.0;

	start(&s, &cfg, 1e-3);
	s.inject.blocked = true;
	run(&s, u, 1, &m);
	for (int j = 0; j < 4; j++)
		p += u[j] * (double)m.current_a[j];
	assert_near(m.supply_v, 12.0 - 0.5 * p / m.supply_v, 1e-4);
	assert_true(m.supply_v < 11.5f);
}

/* ---- a new floor --------------------------------------------------------------------------- */

/* Eq 23's steady v under u on wheels 1 and 3 (-U, +U) with the body's friction times scale:
 * 2 b U = (2 e + Bv s) v + Cv s, b = l Kt / (R r), e = l^2 Kt Kv / (R r^2). */
static double steady_v(const struct model_params *p, double U, double scale)
{
	const double b = p->l * p->Kt / (p->R * p->r);
	const double e = p->l * p->l * p->Kt * p->Kv / (p->R * p->r * p->r);

	return (2.0 * b * U - p->Cv * scale) / (2.0 * e + p->Bv * scale);
}

static void test_floor_change_scales_the_friction_from_its_time_on(void **state)
{
	(void)state;
	struct omni4_config cfg =
	    config_ini("[sim]\nfloor_change_s = 4\nfloor_friction_scale = 3\n");
	struct omni4_config same = config_ini("");
	struct sim_motor s, ref;
	struct motor_sample m;
	struct hal_truth t, tr;
	static const float u[4] = {0, -6, 0, 6};

	start(&s, &cfg, 1e-3);
	start(&ref, &same, 1e-3);
	run(&s, u, 4000, &m);
	run(&ref, u, 4000, &m);
	sim_motor_truth(&s, &t);
	sim_motor_truth(&ref, &tr);
	assert_memory_equal(t.vel, tr.vel, sizeof(t.vel)); /* the first floor until then */
	assert_near(t.vel[0], steady_v(&cfg.ctl.model, 6.0, 1.0), 1e-4);
	run(&s, u, 1, &m);
	run(&ref, u, 1, &m);
	sim_motor_truth(&s, &t);
	sim_motor_truth(&ref, &tr);
	assert_true(t.vel[0] < tr.vel[0]); /* the step from 4 s on: the new floor */
	run(&s, u, 4000, &m);
	sim_motor_truth(&s, &t);
	assert_near(t.vel[0], steady_v(&cfg.ctl.model, 6.0, 3.0), 1e-4);
	struct sim_plant_state ps;

	sim_motor_plant_state(&s, &ps);
	assert_true(ps.friction_scale == 3.0);
}

/* ---- OMNI4_SIM_PLANT ---------------------------------------------------------------------- */

/* The lockstep simulator logs sim_plant_t every 100 ms of simulated time (ticks 0, 100, ...,
 * 1000 at 1 kHz), stamped with its tick's time, with the plant's state. */
static void test_simulator_logs_the_plant_at_10_hz(void **state)
{
	(void)state;
	struct omni4_config cfg = config_ini("[sim]\nthermal = true\nbattery = true\n");
	char path[] = "/tmp/omni4_sim_plant_XXXXXX", err[256];
	const int fd = mkstemp(path);

	assert_true(fd >= 0);
	close(fd);
	struct simrun *sr = simrun_create(&cfg, &cfg.ctl.model, false, path, err, sizeof(err));
	int64_t t[16];
	int n = 0;

	assert_non_null(sr);
	const int64_t t0 = simrun_now_us(sr);

	for (int k = 0; k <= 1000; k++)
		simrun_tick(sr);
	struct simrun_stats st;

	simrun_get_stats(sr, &st);
	assert_int_equal(st.plant, 11);
	assert_int_equal(simrun_flush_log(sr), 0);
	simrun_destroy(sr);
	lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
	lcm_eventlog_event_t *ev;

	assert_non_null(log);
	while ((ev = lcm_eventlog_read_next_event(log))) {
		if (!strcmp(ev->channel, OMNI4_CHANNEL_SIM_PLANT)) {
			omni4_sim_plant_t p;

			assert_int_equal(
			    omni4_sim_plant_t_decode(ev->data, 0, (int)ev->datalen, &p),
			    (int)ev->datalen);
			assert_true(n < 16 && p.utime == ev->timestamp);
			assert_true(p.supply_v == 12.0 && p.friction_scale == 1.0);
			assert_true(p.R[0] == cfg.ctl.model.R && p.winding_temp[3] == 25.0);
			t[n++] = p.utime - t0;
		}
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
	unlink(path);
	assert_int_equal(n, 11);
	for (int k = 0; k < n; k++)
		assert_int_equal(t[k], 100000 * k);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_keys_are_off_by_default_and_report_constants),
	    cmocka_unit_test(test_stalled_windings_heat_as_their_ode_says),
	    cmocka_unit_test(test_supply_sags_under_constant_power_as_the_closed_form),
	    cmocka_unit_test(test_supply_drops_by_the_internal_resistance_times_the_current),
	    cmocka_unit_test(test_floor_change_scales_the_friction_from_its_time_on),
	    cmocka_unit_test(test_simulator_logs_the_plant_at_10_hz),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
