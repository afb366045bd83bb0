/*
 * The controller on layouts other than the paper's ([model] wheels, wheel_angle_j, d_j;
 * docs/model.md "Layouts"): a three-wheel robot and a RoboCup-style four at unequal angles and
 * distances. Its feedforward is the layout's model written out here by hand (each wheel's row
 * from its angle, the least-norm split of the body force solved here, eqs 12-13, 21); with the
 * plant of the same layout it reaches the commanded velocity; slot 3 of a three-wheel robot is
 * never driven; the rigid-body encoder check follows the layout's null space (none for three
 * wheels); the loop reads slot 3 of a three-wheel robot as 0, whatever its channel reports.
 */
#include "omni4_test.h"

#include <math.h>
#include <string.h>

#include "omni4/core/adapt.h"
#include "omni4/core/ctl.h"
#include "omni4/core/fw.h"
#include "omni4/model/params.h"
#include "omni4/model/plant.h"

#define TICK_US 1000
#define DT_S 1e-3
#define SIGN_BAND_LIN 0.01 /* [m/s], feedforward.h's dead band */
#define SIGN_BAND_ROT 0.1  /* [rad/s] */
#define PI 3.14159265358979323846

struct layout {
	int n;
	double angle_deg[4], d[4];
};

/* Three wheels at 0/120/240 deg at unequal distances; RoboCup-style four (front pair apart). */
static const struct layout three = {3, {0, 120, 240, 0}, {0.09, 0.085, 0.095, 0}};
static const struct layout robocup = {4, {60, 135, 225, 300}, {0.078, 0.081, 0.081, 0.078}};

static void settings_of(const struct layout *L, struct ctl_settings *s, bool feedback)
{
	ctl_settings_defaults(s);
	s->layout.wheels = L->n;
	for (int j = 0; j < 4; j++) {
		s->layout.angle_deg[j] = L->angle_deg[j];
		s->layout.d[j] = L->d[j];
	}
	s->layout_keys = (uint8_t)((1u << L->n) - 1u);
	s->control.feedback = feedback;
}

/* Eq 2's row of wheel j: it drives perpendicular to its radius, counter-clockwise positive. */
static void row_of(const struct layout *L, int j, double g[3])
{
	const double a = L->angle_deg[j] * PI / 180.0;

	g[0] = -sin(a);
	g[1] = cos(a);
	g[2] = L->d[j];
}

/* The least-norm wheel forces of body force F: f = G (G^T G)^-1 F, the 3 x 3 system solved by
 * Cramer's rule. */
static void split_by_hand(const struct layout *L, const double F[3], double f[4])
{
	double G[4][3], A[3][3] = {{0}}, y[3];

	for (int j = 0; j < L->n; j++) {
		row_of(L, j, G[j]);
		for (int a = 0; a < 3; a++)
			for (int b = 0; b < 3; b++)
				A[a][b] += G[j][a] * G[j][b];
	}
	const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
	                   A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
	                   A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);

	for (int k = 0; k < 3; k++) {
		double M[3][3];

		memcpy(M, A, sizeof(M));
		for (int a = 0; a < 3; a++)
			M[a][k] = F[a];
		y[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
		        M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
		        M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
		       det;
	}
	for (int j = 0; j < 4; j++)
		f[j] = j < L->n ? G[j][0] * y[0] + G[j][1] * y[1] + G[j][2] * y[2] : 0.0;
}

static double band_sign(double x, double band)
{
	const double s = x / band;

	return s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s);
}

/* Wheel j's feedforward voltage at steady velocity x (no acceleration): the body's friction
 * split least norm, then the motor: u = R r / (l Kt) f + Kv l / r (g . x). */
static double ff_by_hand(const struct layout *L, const struct model_params *p, int j,
                         const double x[3])
{
	const double F[3] = {p->Bv * x[0] + p->Cv * band_sign(x[0], SIGN_BAND_LIN),
	                     p->Bvn * x[1] + p->Cvn * band_sign(x[1], SIGN_BAND_LIN),
	                     p->Bw * x[2] + p->Cw * band_sign(x[2], SIGN_BAND_ROT)};
	double f[4], g[3];

	if (j >= L->n)
		return 0.0;
	split_by_hand(L, F, f);
	row_of(L, j, g);
	return p->R * p->r / (p->l * p->Kt) * f[j] +
	       p->Kv * p->l / p->r * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]);
}

static const struct ctl_command g_cmd = {
    .utime = 1, .seq = 1, .mode = CTL_VELOCITY, .velocity = {0.5, -0.3, 2.0}};

/* Tick n (1 ms each) with the wheels' speeds [rad/s]; command: the command repeated every
 * 100 ms. */
static void tick_with(struct ctl *c, int n, const double wheel_rad_s[4], bool command,
                      struct ctl_output *out)
{
	struct motor_sample s = {.supply_v = 12.0f};

	if (command && n % 100 == 0)
		assert_int_equal(ctl_command(c, &g_cmd, (int64_t)(n + 1) * TICK_US), 0);
	for (int j = 0; j < 4; j++)
		s.wheel_rad_s[j] = wheel_rad_s ? (float)wheel_rad_s[j] : 0.0f;
	ctl_step(c, (int64_t)(n + 1) * TICK_US, &s, 0, false, out);
}

static void tick(struct ctl *c, int n, const double wheel_rad_s[4], struct ctl_output *out)
{
	tick_with(c, n, wheel_rad_s, true, out);
}

/* Feedforward alone, once the reference has reached the command: every wheel's output within
 * 5 mV of the layout's model by hand (Q16.16 gains and float outputs: a few mV). */
static void check_feedforward(const struct layout *L)
{
	struct ctl_settings s;
	struct ctl c;
	struct ctl_output out;
	const double x[3] = {g_cmd.velocity[0], g_cmd.velocity[1], g_cmd.velocity[2]};

	settings_of(L, &s, false);
	assert_int_equal(ctl_init(&c, &s), 0);
	assert_int_equal(ctl_command(&c, &g_cmd, TICK_US), 0);
	for (int n = 1; n <= 2000; n++)
		tick(&c, n, NULL, &out);
	assert_true(out.enable);
	for (int j = 0; j < 4; j++) {
		const double want = ff_by_hand(L, &s.model, j, x);

		print_message("%d wheels, wheel %d: %.4f V (by hand %.4f V)\n", L->n, j,
		              out.volts[j], want);
		assert_true(fabs(out.volts[j] - want) < 0.005);
		assert_true(j < L->n || out.volts[j] == 0.0f);
	}
}

static void test_feedforward_is_the_layouts_model(void **state)
{
	(void)state;
	check_feedforward(&three);
	check_feedforward(&robocup);
}

/* Closed loop on the plant of the same layout: the body's velocity within 0.25 mm/s and
 * 0.25 mrad/s of the command after 1.5 s (measured: 0.09), every output inside the supply, slot 3
 * of three wheels at 0 V on every tick. */
static void check_closed_loop(const struct layout *L)
{
	struct ctl_settings s;
	struct ctl c;
	struct ctl_output out;
	struct plant pl;
	struct wheel_geom g;
	double ws[4] = {0, 0, 0, 0};

	settings_of(L, &s, true);
	assert_int_equal(ctl_settings_geom(&s, &g), 0);
	assert_int_equal(plant_init(&pl, &s.model), 0);
	assert_int_equal(plant_set_geom(&pl, &g), 0);
	assert_int_equal(ctl_init(&c, &s), 0);
	assert_int_equal(ctl_command(&c, &g_cmd, TICK_US), 0);
	for (int n = 1; n <= 1500; n++) {
		double u[4];

		tick(&c, n, ws, &out);
		for (int j = 0; j < 4; j++) {
			u[j] = out.volts[j];
			assert_true(fabs(u[j]) <= s.limits.supply_v);
		}
		assert_true(L->n == 4 || out.volts[3] == 0.0f);
		plant_step(&pl, u, out.enable, DT_S);
		plant_wheel_speeds(&pl, ws);
	}
	for (int k = 0; k < 3; k++) {
		print_message("%d wheels, axis %d: %.6f (command %.4f)\n", L->n, k, pl.x[k],
		              g_cmd.velocity[k]);
		assert_true(fabs(pl.x[k] - g_cmd.velocity[k]) < 2.5e-4);
	}
	assert_int_equal(out.faults & ~CTL_FAULT_CMD_TIMEOUT, 0);
}

static void test_closed_loop_reaches_the_command_on_the_layouts_plant(void **state)
{
	(void)state;
	check_closed_loop(&three);
	check_closed_loop(&robocup);
}

/* A three-wheel robot has no motor in slot 3: a voltage there is refused, 0 V accepted, and
 * whatever slot 3 reads, it is never driven. */
static void test_three_wheels_refuse_a_voltage_on_slot_3(void **state)
{
	(void)state;
	struct ctl_settings s;
	struct ctl c;
	struct ctl_command v = {.utime = 1, .seq = 1, .mode = CTL_VOLTAGE, .voltage = {1, 1, 1, 1}};

	settings_of(&three, &s, true);
	assert_int_equal(ctl_init(&c, &s), 0);
	assert_int_equal(ctl_command(&c, &v, TICK_US), -EINVAL);
	v.voltage[3] = 0.0;
	assert_int_equal(ctl_command(&c, &v, TICK_US), 0);
	const double ws[4] = {0, 0, 0, 5.0};
	struct ctl_output out;

	assert_int_equal(ctl_init(&c, &s), 0);
	assert_int_equal(ctl_command(&c, &g_cmd, TICK_US), 0);
	for (int n = 1; n <= 300; n++) {
		tick(&c, n, ws, &out);
		assert_true(out.enable);
		assert_true(out.volts[3] == 0.0f);
	}
}

/* Readings of a rigid body's motion (eq 2 by hand) pass; one wheel off by 1 m/s for 100 ms
 * latches ENCODER on the four (its null space sees it), never on three wheels (none). */
static int32_t run_readings(const struct layout *L, double off_m_s)
{
	struct ctl_settings s;
	struct ctl c;
	struct ctl_output out;
	const double x[3] = {0.3, 0.2, 1.0};
	double ws[4] = {0, 0, 0, 0};

	settings_of(L, &s, true);
	assert_int_equal(ctl_init(&c, &s), 0);
	for (int j = 0; j < L->n; j++) {
		double g[3];

		row_of(L, j, g);
		ws[j] = (g[0] * x[0] + g[1] * x[1] + g[2] * x[2] + (j == 1 ? off_m_s : 0.0)) /
		        s.model.r;
	}
	for (int n = 1; n <= 100; n++)
		tick_with(&c, n, ws, false, &out);
	return out.faults & CTL_FAULT_ENCODER;
}

static void test_the_encoder_check_follows_the_null_space(void **state)
{
	(void)state;
	assert_int_equal(run_readings(&robocup, 0.0), 0);
	assert_int_equal(run_readings(&three, 0.0), 0);
	assert_int_not_equal(run_readings(&robocup, 1.0), 0);
	assert_int_equal(run_readings(&three, 1.0), 0);
}

/* The online estimator's maps from wheel currents to body force and wheel speeds to body
 * velocity, for three equal-distance wheels at 0/120/240 deg by hand: G^T G = diag(3/2, 3/2,
 * 3 d^2), so force column j = g_j l Kt / r and velocity column j = r g_jk / diag_k. */
static void test_online_maps_follow_the_layout(void **state)
{
	(void)state;
	const struct layout sym = {3, {0, 120, 240, 0}, {0.1, 0.1, 0.1, 0}};
	static struct adapt a;
	struct ctl_settings s;

	settings_of(&sym, &s, true);
	adapt_init(&a, &s);
	const struct model_params *p = &s.model;
	const double diag[3] = {1.5, 1.5, 3.0 * 0.1 * 0.1};

	for (int j = 0; j < 4; j++) {
		double g[3] = {0, 0, 0};

		if (j < 3)
			row_of(&sym, j, g);
		for (int k = 0; k < 3; k++) {
			assert_true(fabs(a.Gi[k][j] - g[k] * p->l * p->Kt / p->r) < 1e-5);
			assert_true(fabs(a.Gw[k][j] - p->r * g[k] / diag[k]) < 1e-6);
		}
	}
}

/* A motor backend of three wheels whose fourth channel reports what an unconnected one may:
 * a current offset beyond the calibration's 0.25 A limit (docs/faults.md) with +-20 mA of
 * noise, a wheel speed, and every 7th reading NaN in both. Slots 0-2 read 0 A at rest. */
struct slot3_motor {
	int reads;
};

static int slot3_enable(void *ctx, bool on)
{
	(void)ctx;
	(void)on;
	return 0;
}

static int slot3_write(void *ctx, const float volts[4])
{
	(void)ctx;
	(void)volts;
	return 0;
}

static int slot3_read(void *ctx, struct motor_sample *out)
{
	struct slot3_motor *m = ctx;
	const int k = m->reads++;

	memset(out, 0, sizeof(*out));
	out->supply_v = 12.0f;
	out->current_a[3] = k % 7 == 6 ? NAN : 0.3f + (k % 2 ? 0.02f : -0.02f);
	out->wheel_rad_s[3] = k % 7 == 6 ? NAN : 5.0f;
	return 0;
}

static const struct motor_hal_ops slot3_ops = {
    .enable = slot3_enable, .write = slot3_write, .read = slot3_read};

/* Every motors_t sample of the loop (idle through the current calibration, then VELOCITY)
 * holds 0 in slot 3: voltage, current and wheel speed (robot_t: "a three-wheel robot's fourth
 * slot holds 0, as in every per-wheel array"); the fourth channel's offset latches no
 * CURRENT_SENSOR fault (no motor there) and the robot drives. */
static void test_the_loop_reads_slot_3_of_three_wheels_as_0(void **state)
{
	(void)state;
	static struct fw fw;
	struct slot3_motor m = {0};
	struct ctl_settings s;
	struct log_entry e;
	int samples = 0;
	float driven = 0.0f;

	settings_of(&three, &s, true);
	assert_int_equal(fw_init(&fw, &s, (struct motor_hal){.ops = &slot3_ops, .ctx = &m},
	                         (struct line_hal){.ops = &line_none_ops}),
	                 0);
	for (int n = 0; n < 1500; n++) {
		if (n >= 1000 && n % 100 == 0)
			assert_true(fw_post_command(&fw, &g_cmd));
		fw_tick(&fw, (int64_t)(n + 1) * TICK_US);
		while (fw_pop_log(&fw, &e)) {
			if (e.kind != LOG_MOTORS)
				continue;
			samples++;
			assert_true(e.sample.voltage[3] == 0.0f);
			assert_true(e.sample.current[3] == 0.0f);
			assert_true(e.sample.wheel_speed[3] == 0.0f);
			assert_int_equal(e.sample.faults & CTL_FAULTS_LATCHING, 0);
			driven = fmaxf(driven, fabsf(e.sample.voltage[0]));
		}
	}
	assert_int_equal(samples, 1500);
	assert_int_equal(fw.last_out.mode, CTL_VELOCITY);
	assert_true(driven > 1.0f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_feedforward_is_the_layouts_model),
	    cmocka_unit_test(test_closed_loop_reaches_the_command_on_the_layouts_plant),
	    cmocka_unit_test(test_three_wheels_refuse_a_voltage_on_slot_3),
	    cmocka_unit_test(test_the_encoder_check_follows_the_null_space),
	    cmocka_unit_test(test_online_maps_follow_the_layout),
	    cmocka_unit_test(test_the_loop_reads_slot_3_of_three_wheels_as_0),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
