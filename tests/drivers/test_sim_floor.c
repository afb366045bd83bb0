/*
 * The sim backend's floor and camera timing ([sim] traction_mu, wheel_inertia,
 * wheel_radius_error_0..3, slip_noise, camera_latency_ms; docs/ini-keys.md) and the
 * world faults (sim_motor_faults.ext_force, blocked, camera_off): the keys, the camera's
 * latency and dropout, wheel odometry with a radius error, the readings of slipping wheels and
 * the truth (read_pose, read_truth: the HAL's optional ops), against the plant and closed forms.
 */
#include "omni4_test.h"

#include <errno.h>
#include <string.h>

#include "config_ini.h"
#include "omni4/config/config.h"
#include "omni4/model/kinematics.h"
#include "omni4/drivers/sim_motor.h"

static void start(struct sim_motor *s, const struct omni4_config *cfg, bool noise)
{
	const struct sim_motor_config sc = sim_motor_config_from(
	    &cfg->sim, noise, &cfg->ctl.model, 1.0 / cfg->ctl.rate_hz, cfg->ctl.limits.supply_v);

	assert_int_equal(sim_motor_init(s, &sc), 0);
}

static void test_keys_defaults_and_ranges(void **state)
{
	(void)state;
	struct omni4_config cfg;
	struct config_error err;

	config_defaults(&cfg);
	assert_true(cfg.sim.traction_mu == 0.0 && cfg.sim.wheel_inertia == 1e-4);
	for (int j = 0; j < 4; j++)
		assert_true(cfg.sim.wheel_radius_error[j] == 0.0);
	assert_true(cfg.sim.slip_noise == 0.0 && cfg.sim.camera_latency_ms == 40.0);
	cfg = config_ini("[sim]\ntraction_mu = 0.4\nwheel_inertia = 2e-4\nwheel_radius_error_0 = "
	                 "0.01\nwheel_radius_error_3 = -0.02\nslip_noise = 0.003\n"
	                 "camera_latency_ms = 40\n");
	assert_true(cfg.sim.traction_mu == 0.4 && cfg.sim.wheel_inertia == 2e-4);
	assert_true(cfg.sim.wheel_radius_error[0] == 0.01 &&
	            cfg.sim.wheel_radius_error[3] == -0.02);
	assert_true(cfg.sim.slip_noise == 0.003 && cfg.sim.camera_latency_ms == 40.0);
	const char *bad[] = {"[sim]\ntraction_mu = 2.1\n", "[sim]\nwheel_radius_error_2 = 0.11\n",
	                     "[sim]\ncamera_latency_ms = 501\n", "[sim]\nslip_noise = -0.001\n",
	                     "[sim]\nwheel_inertia = 0\n"};

	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		config_defaults(&cfg);
		assert_int_not_equal(config_load_string(bad[i], "bad.ini", &cfg, &err), 0);
	}
}

/* ---- the camera ---------------------------------------------------------------------------- */

#define MAX_FRAMES 200
#define TICKS 3000

struct frames {
	int n;
	int64_t capture[MAX_FRAMES]; /* stamp given */
	int64_t arrival[MAX_FRAMES]; /* s->t_us when it came */
	double pose[MAX_FRAMES][3];
	const struct sim_motor *s;
};

/* The poses that fell due at the last read, as the loop polls them. */
static void take_poses(struct frames *f)
{
	struct hal_pose p;

	while (sim_motor_ops.read_pose((void *)f->s, &p) == 0) {
		assert_true(f->n < MAX_FRAMES);
		f->capture[f->n] = p.utime;
		f->arrival[f->n] = f->s->t_us;
		memcpy(f->pose[f->n], p.pose, sizeof(f->pose[0]));
		f->n++;
	}
}

/* The robot driven (it turns and translates) for 3 s; the plant's pose at every tick kept. */
static void drive(struct sim_motor *s, struct frames *f, double plant_pose[TICKS + 1][3],
                  int off_from, int off_to)
{
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static const float u[4] = {3, -2, 1, 4};
	struct motor_sample m;

	memset(f, 0, sizeof(*f));
	f->s = s;
	ops->enable(s, true);
	ops->write(s, u);
	for (int k = 1; k <= TICKS; k++) {
		s->inject.camera_off = k >= off_from && k < off_to;
		const int before = f->n;

		assert_int_equal(ops->read(s, &m), 0);
		take_poses(f);
		if (s->inject.camera_off)
			assert_int_equal(f->n, before); /* nothing while the camera is off */
		memcpy(plant_pose[k], s->plant.pose, sizeof(plant_pose[k]));
	}
}

/* 40 ms latency at 25 Hz: every frame arrives exactly 40 ms after its capture, stamped with the
 * capture time, with the plant's pose at that time (exact sensors); with noise the frames are
 * those of the camera without latency (same stamps, same values), each 40 ms later. */
static void test_camera_latency_delivers_the_captured_pose_later(void **state)
{
	(void)state;
	static struct sim_motor s;
	static struct frames f, f0;
	static double pose[TICKS + 1][3];
	const struct omni4_config cfg = config_ini("[sim]\ncamera_latency_ms = 40\n");
	const struct omni4_config cfg0 = config_ini("[sim]\ncamera_latency_ms = 0\n");

	start(&s, &cfg, false);
	drive(&s, &f, pose, -1, -1);
	print_message("%d frames, first captured at %lld us, arrived at %lld us\n", f.n,
	              (long long)f.capture[0], (long long)f.arrival[0]);
	/* captured at the first read (1 ms), then every 40 ms: 0.04 .. 2.96 s */
	assert_int_equal(f.n, 75);
	for (int i = 0; i < f.n; i++) {
		assert_int_equal(f.arrival[i] - f.capture[i], 40000);
		assert_int_equal(f.capture[i], i == 0 ? 1000 : 40000 * i);
		const int k = (int)(f.capture[i] / 1000);

		for (int a = 0; a < 3; a++)
			assert_true(f.pose[i][a] == pose[k][a]);
	}
	assert_true(pose[TICKS][2] > 1.0); /* it moved */

	/* With noise: the same frames as without latency, later. */
	start(&s, &cfg, true);
	drive(&s, &f, pose, -1, -1);
	start(&s, &cfg0, true);
	drive(&s, &f0, pose, -1, -1);
	assert_int_equal(f0.n, f.n + 1);
	for (int i = 0; i < f.n; i++) {
		assert_int_equal(f.capture[i], f0.capture[i]);
		assert_int_equal(f0.arrival[i], f0.capture[i]);
		assert_memory_equal(f.pose[i], f0.pose[i], sizeof(f.pose[i]));
	}
}

/* The queue is fixed: latency x rate must leave room (SIM_CAM_QUEUE frames). */
static void test_camera_latency_beyond_the_queue_is_refused(void **state)
{
	(void)state;
	static struct sim_motor s;
	struct omni4_config cfg = config_ini("[sim]\ncamera_rate_hz = 100\n");
	struct sim_motor_config sc = sim_motor_config_from(
	    &cfg.sim, true, &cfg.ctl.model, 1.0 / cfg.ctl.rate_hz, cfg.ctl.limits.supply_v);

	sc.camera_latency_s = (SIM_CAM_QUEUE - 1) / 100.0;
	assert_int_equal(sim_motor_init(&s, &sc), -EINVAL);
	sc.camera_latency_s = (SIM_CAM_QUEUE - 2) / 100.0;
	assert_int_equal(sim_motor_init(&s, &sc), 0);
}

/* A dropout from 1.0 s to 1.5 s: nothing captured or delivered meanwhile (the 40 ms in flight
 * at its start are lost too), the camera's instants unchanged before and after. */
static void test_camera_dropout(void **state)
{
	(void)state;
	static struct sim_motor s;
	static struct frames f;
	static double pose[TICKS + 1][3];
	const struct omni4_config cfg = config_ini("[sim]\ncamera_latency_ms = 40\n");

	start(&s, &cfg, false);
	drive(&s, &f, pose, 1000, 1500);
	int before = 0, after = 0;

	for (int i = 0; i < f.n; i++) {
		assert_false(f.arrival[i] >= 1000000 && f.arrival[i] < 1500000);
		assert_false(f.capture[i] >= 960000 && f.capture[i] < 1500000);
		before += f.arrival[i] < 1000000;
		after += f.capture[i] >= 1500000;
	}
	print_message("dropout: %d frames before, %d after, %d in all\n", before, after, f.n);
	assert_int_equal(before, 24); /* captured at 0.001 s, 0.04 .. 0.92 s */
	assert_int_equal(after, 37);  /* captured at 1.52 .. 2.96 s */
	assert_int_equal(f.n, before + after);
}

/* No latency, 25 Hz: the frame captured at a read is offered after that read only; one not
 * taken then is gone at the next read (a pose on a bus nobody reads), the next capture 40 ms
 * later comes as usual. A backend without a camera offers none. */
static void test_a_pose_not_taken_before_the_next_read_is_lost(void **state)
{
	(void)state;
	static struct sim_motor s;
	struct motor_sample m;
	struct hal_pose p;
	const struct omni4_config cfg = config_ini("[sim]\ncamera_latency_ms = 0\n");

	start(&s, &cfg, false);
	assert_int_equal(sim_motor_ops.read(&s, &m), 0); /* captures at 1 ms */
	assert_int_equal(sim_motor_ops.read(&s, &m), 0); /* the frame not taken: lost */
	assert_int_equal(sim_motor_ops.read_pose(&s, &p), -EAGAIN);
	for (int k = 3; k <= 40; k++) {
		assert_int_equal(sim_motor_ops.read(&s, &m), 0);
		assert_int_equal(sim_motor_ops.read_pose(&s, &p), k == 40 ? 0 : -EAGAIN);
	}
	assert_int_equal(p.utime, 40000);
	assert_int_equal(sim_motor_ops.read_pose(&s, &p), -EAGAIN); /* once */

	struct sim_motor_config sc = s.cfg;

	sc.camera = false;
	assert_int_equal(sim_motor_init(&s, &sc), 0);
	for (int k = 1; k <= 100; k++) {
		assert_int_equal(sim_motor_ops.read(&s, &m), 0);
		assert_int_equal(sim_motor_ops.read_pose(&s, &p), -EAGAIN);
	}
}

/* ---- the floor ----------------------------------------------------------------------------- */

/* Straight along v (u3 = +6, u1 = -6 V) for 1.5 s, then coasting to rest: the odometry from
 * the wheel readings (eqs 3-5 with the model's r, readings integrated over each period) over
 * the true distance is 1 / (1 + e) with every wheel's radius r (1 + e); 1 with e = 0. */
static double odometry_ratio(double e)
{
	static struct sim_motor s;
	char ini[256];
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static const float u[4] = {0, -6, 0, 6};
	struct motor_sample m;
	double dist = 0;

	snprintf(ini, sizeof(ini),
	         "[sim]\nwheel_radius_error_0 = %g\nwheel_radius_error_1 = %g\n"
	         "wheel_radius_error_2 = %g\nwheel_radius_error_3 = %g\n",
	         e, e, e, e);
	const struct omni4_config cfg = config_ini(ini);

	start(&s, &cfg, false); /* exact sensors: encoder_cpr 0 */
	ops->enable(&s, true);
	ops->write(&s, u);
	for (int k = 0; k < 4000; k++) {
		if (k == 1500)
			ops->enable(&s, false);
		assert_int_equal(ops->read(&s, &m), 0);
		double v[4], x[3];

		for (int j = 0; j < 4; j++)
			v[j] = m.wheel_rad_s[j] * cfg.ctl.model.r;
		fk_robot_velocity(cfg.ctl.model.d, v, x);
		dist += x[0] * 1e-3;
	}
	assert_true(s.plant.x[0] == 0.0 && s.plant.pose[0] > 0.5);
	print_message("e = %+.3f: odometry %.6f m, true %.6f m, ratio %.9f (1/(1+e) = %.9f)\n", e,
	              dist, s.plant.pose[0], dist / s.plant.pose[0], 1 / (1 + e));
	return dist / s.plant.pose[0];
}

static void test_radius_error_makes_odometry_drift_by_it(void **state)
{
	(void)state;
	/* measured within 1.1e-7 (float readings, substepped pose) */
	assert_near(odometry_ratio(0.0), 1.0, 3e-7);
	assert_near(odometry_ratio(0.01), 1 / 1.01, 3e-7);
	assert_near(odometry_ratio(-0.02), 1 / 0.98, 3e-7);
}

struct truths {
	int n;
	int64_t utime[8];
	struct hal_truth t[8];
};

/* One read, then the truths it offers, as the loop polls them. */
static int read_and_take_truth(struct sim_motor *s, struct motor_sample *m, struct truths *tr)
{
	const int rc = sim_motor_ops.read(s, m);
	struct hal_truth t;

	while (sim_motor_ops.read_truth(s, &t) == 0) {
		if (tr->n < 8) {
			tr->utime[tr->n] = t.utime;
			tr->t[tr->n] = t;
		}
		tr->n++;
	}
	return rc;
}

/* Blocked with a traction limit, 6 V on every wheel: the body stays, the wheels break loose
 * and the readings follow their own speeds (to r u / (l Kv) - r^2 R F / (l^2 Kt Kv) with
 * tau_w), the currents eq 21 at those speeds; the truth says so (slip flags, blocked, slip =
 * rim speed). Released, the robot turns; a push moves it with the bridges off. */
static void test_blocked_wheels_spin_and_the_readings_follow_them(void **state)
{
	(void)state;
	static struct sim_motor s;
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static const float u[4] = {6, 6, 6, 6};
	struct motor_sample m;
	struct truths tr = {0};
	const struct omni4_config cfg = config_ini("[sim]\ntraction_mu = 0.3\n");
	const struct model_params *p = &cfg.ctl.model;
	const double F = 0.3 * p->M * 9.80665 / 4;
	const double s_ss =
	    p->r * 6 / (p->l * p->Kv) - p->r * p->r * p->R * F / (p->l * p->l * p->Kt * p->Kv);

	start(&s, &cfg, false);
	sim_motor_set_clock(&s, 1000000);
	s.inject.blocked = true;
	ops->enable(&s, true);
	ops->write(&s, u);
	for (int k = 0; k < 500; k++)
		assert_int_equal(read_and_take_truth(&s, &m, &tr), 0);
	assert_int_equal(tr.n, 500);
	assert_int_equal(tr.utime[0], 1000000 + 1000);
	for (int j = 0; j < 4; j++) {
		print_message("wheel %d: %.4f rad/s (steady %.4f), %.4f A\n", j, m.wheel_rad_s[j],
		              s_ss / p->r, m.current_a[j]);
		assert_near(m.wheel_rad_s[j], s_ss / p->r, 1e-4 * s_ss / p->r); /* 19 tau_w */
		assert_near(m.current_a[j], (6 - p->Kv * p->l * m.wheel_rad_s[j]) / p->R, 1e-5);
	}
	struct hal_truth t;

	sim_motor_truth(&s, &t);
	assert_int_equal(t.flags, 0xf | SIM_TRUTH_BLOCKED);
	for (int j = 0; j < 4; j++)
		assert_near(t.wheel_slip[j], s_ss, 1e-4);
	for (int k = 0; k < 3; k++)
		assert_true(t.pose[k] == 0.0 && t.vel[k] == 0.0);

	s.inject.blocked = false;
	for (int k = 0; k < 500; k++)
		ops->read(&s, &m);
	assert_true(s.plant.x[2] > 1.0);

	/* Bridges off, pushed along vn. */
	start(&s, &cfg, false);
	s.inject.ext_force[1] = 6.0;
	for (int k = 0; k < 500; k++)
		ops->read(&s, &m);
	sim_motor_truth(&s, &t);
	assert_true(t.flags == SIM_TRUTH_PUSHED && t.vel[1] > 0.3 && t.pose[1] > 0.05);
}

/* The truth op: once per read (also when the driver is silent), the plant's state; nothing
 * from a backend set up without it ([sim] truth = false). */
static void test_truth_once_per_read_equal_to_the_plant(void **state)
{
	(void)state;
	static struct sim_motor s;
	const struct motor_hal_ops *ops = &sim_motor_ops;
	static const float u[4] = {2, -1, 3, 4};
	struct motor_sample m;
	struct truths tr = {0};
	const struct omni4_config on = config_ini("[sim]\nslip_noise = 0.01\n");

	start(&s, &on, true);
	ops->enable(&s, true);
	ops->write(&s, u);
	for (int k = 0; k < 300; k++) {
		s.inject.silent = k == 299;
		const int n = tr.n;

		read_and_take_truth(&s, &m, &tr);
		assert_int_equal(tr.n, n + 1);
		assert_int_equal(tr.utime[n < 8 ? n : 7], n < 8 ? 1000 * (n + 1) : tr.utime[7]);
	}
	assert_int_equal(tr.n, 300);
	struct hal_truth t;
	double vg[4];

	sim_motor_truth(&s, &t);
	ik_wheel_speeds(s.plant.p.d, s.plant.x, vg);
	assert_memory_equal(t.pose, s.plant.pose, sizeof(t.pose));
	assert_memory_equal(t.vel, s.plant.x, sizeof(t.vel));
	for (int j = 0; j < 4; j++) {
		assert_true(t.wheel_slip[j] ==
		            s.plant.rim[j] + s.plant.creep[j] * fabs(vg[j]) - vg[j]);
		assert_true(t.wheel_slip[j] != 0.0); /* the creep */
	}
	assert_int_equal(t.flags, 0);

	tr.n = 0;
	const struct omni4_config off = config_ini("[sim]\ntruth = false\n");

	start(&s, &off, true);
	for (int k = 0; k < 10; k++)
		read_and_take_truth(&s, &m, &tr);
	assert_int_equal(tr.n, 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_keys_defaults_and_ranges),
	    cmocka_unit_test(test_camera_latency_delivers_the_captured_pose_later),
	    cmocka_unit_test(test_camera_latency_beyond_the_queue_is_refused),
	    cmocka_unit_test(test_camera_dropout),
	    cmocka_unit_test(test_radius_error_makes_odometry_drift_by_it),
	    cmocka_unit_test(test_blocked_wheels_spin_and_the_readings_follow_them),
	    cmocka_unit_test(test_truth_once_per_read_equal_to_the_plant),
	    cmocka_unit_test(test_a_pose_not_taken_before_the_next_read_is_lost),
	};

	return cmocka_run_group_tests_name("sim_floor", tests, NULL, NULL);
}
