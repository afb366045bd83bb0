/* The estimator with each wheel's own drive (est_set_model_wheels) against a computation by
 * hand for a robot with one odd wheel: its forces from eqs 12, 13, 21 and 2 written out here
 * (f_j = b_j u_j - e_j v_j), eqs 9-11 and the friction of eq 23, integrated by RK4 in double;
 * each reading's rim speed with its own radius. Figures printed; tolerances 2-3x measured. */
#include "omni4_test.h"

#include <stdio.h>
#include <string.h>

#include "omni4/core/est.h"
#include "omni4/model/params.h"

#define TICK_US 1000
#define VEL_TOL 2.5e-4 /* model-only prediction vs RK4 over 0.5 s [m/s]: measured 8.7e-5 */

static struct est E;

/* Table III with wheel 1 odd: radius +4 %, Kv and Kt +5 %, R -5 %. */
static void odd_robot(struct model_params *p, struct model_wheels *w)
{
	*p = model_params_table3;
	for (int j = 0; j < 4; j++) {
		w->r[j] = p->r;
		w->Kv[j] = p->Kv;
		w->Kt[j] = p->Kt;
		w->R[j] = p->R;
	}
	w->r[1] *= 1.04;
	w->Kv[1] *= 1.05;
	w->Kt[1] *= 1.05;
	w->R[1] *= 0.95;
}

/* Rim speeds of eq 2: v0 = vn + d w, v1 = -v + d w, v2 = -vn + d w, v3 = v + d w. */
static void rims(double d, const double x[3], double v[4])
{
	v[0] = x[1] + d * x[2];
	v[1] = -x[0] + d * x[2];
	v[2] = -x[1] + d * x[2];
	v[3] = x[0] + d * x[2];
}

static double sgn(double a, double dflt)
{
	return a > 0.0 ? 1.0 : (a < 0.0 ? -1.0 : dflt);
}

/* dx/dt by hand: wheel forces (gearbox l, motor j's own constants), body forces (eqs 9-11),
 * viscous and Coulomb friction, mass and inertia. */
static void xdot(const struct model_params *p, const struct model_wheels *w, const double u[4],
                 const double x[3], double dx[3])
{
	double v[4], f[4];

	rims(p->d, x, v);
	for (int j = 0; j < 4; j++) {
		const double wm = p->l * v[j] / w->r[j];           /* motor speed */
		const double i = (u[j] - w->Kv[j] * wm) / w->R[j]; /* eq 21, L neglected */

		f[j] = p->l * w->Kt[j] * i / w->r[j]; /* eqs 12-13 */
	}
	const double F[3] = {f[3] - f[1], f[0] - f[2], p->d * (f[0] + f[1] + f[2] + f[3])};
	const double B[3] = {p->Bv, p->Bvn, p->Bw}, C[3] = {p->Cv, p->Cvn, p->Cw};
	const double m[3] = {p->M, p->M, p->J};

	for (int k = 0; k < 3; k++)
		dx[k] = (F[k] - B[k] * x[k] - C[k] * sgn(x[k], sgn(F[k], 0.0))) / m[k];
}

static void rk4(const struct model_params *p, const struct model_wheels *w, const double u[4],
                double x[3], double h)
{
	double k1[3], k2[3], k3[3], k4[3], y[3];

	xdot(p, w, u, x, k1);
	for (int k = 0; k < 3; k++)
		y[k] = x[k] + 0.5 * h * k1[k];
	xdot(p, w, u, y, k2);
	for (int k = 0; k < 3; k++)
		y[k] = x[k] + 0.5 * h * k2[k];
	xdot(p, w, u, y, k3);
	for (int k = 0; k < 3; k++)
		y[k] = x[k] + h * k3[k];
	xdot(p, w, u, y, k4);
	for (int k = 0; k < 3; k++)
		x[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
}

/* Largest velocity error over 0.5 s of a drive from rest, model only (no readings); w in m/s
 * at the wheels (d w). */
static double drive_error(const struct model_params *p, const struct model_wheels *w)
{
	const double u[4] = {4.0, -5.0, 2.0, 6.0};
	double x[3] = {0.0, 0.0, 0.0}, worst = 0.0;

	for (int n = 0; n < 500; n++) {
		struct est_input in = {.utime = (int64_t)n * TICK_US, .driven = true};

		for (int j = 0; j < 4; j++)
			in.volts[j] = (float)u[j];
		est_step(&E, &in);
		for (int s = 0; s < 10; s++)
			rk4(p, w, u, x, 1e-4);
		const float *v = est_get(&E)->vel;

		worst = fmax(worst, fmax(fabs(v[0] - x[0]), fabs(v[1] - x[1])));
		worst = fmax(worst, p->d * fabs(v[2] - x[2]));
	}
	printf("  at 0.5 s: truth v %.4f vn %.4f w %.4f, estimate %.4f %.4f %.4f\n", x[0], x[1],
	       x[2], est_get(&E)->vel[0], est_get(&E)->vel[1], est_get(&E)->vel[2]);
	return worst;
}

static void test_prediction_follows_each_wheels_drive(void **state)
{
	(void)state;
	struct model_params p;
	struct model_wheels w;

	odd_robot(&p, &w);
	assert_int_equal(est_init(&E, NULL, &p, 1000.0), 0);
	est_set_model_wheels(&E, &p, &w, NULL);
	const double per_wheel = drive_error(&p, &w);

	assert_int_equal(est_init(&E, NULL, &p, 1000.0), 0); /* the paper's averaged model */
	const double scalar = drive_error(&p, &w);

	printf("model-only drive, one odd wheel: worst velocity error %.2e m/s per wheel, %.2e "
	       "m/s with four equal wheels\n",
	       per_wheel, scalar);
	assert_true(per_wheel <= VEL_TOL);
	assert_true(scalar > 5.0 * VEL_TOL); /* the test can tell the two apart */
}

/* A rigid body's readings, each wheel's rim speed over its own radius: the estimator's rim
 * speeds fit a rigid body (null-space residual 0) and give back the body's velocity. */
static void test_readings_use_each_wheels_radius(void **state)
{
	(void)state;
	struct model_params p;
	struct model_wheels w;
	struct est_settings set;
	const double x[3] = {0.8, -0.3, 1.5};
	double v[4];

	odd_robot(&p, &w);
	est_settings_defaults(&set);
	set.calibrate = false;
	assert_int_equal(est_init(&E, &set, &p, 1000.0), 0);
	est_set_model_wheels(&E, &p, &w, NULL);
	rims(p.d, x, v);
	double worst_nr = 0.0;

	for (int n = 0; n < 2000; n++) {
		struct est_input in = {.utime = (int64_t)n * TICK_US, .have_wheels = true};

		for (int j = 0; j < 4; j++)
			in.wheel_rad_s[j] = (float)(v[j] / w.r[j]);
		est_step(&E, &in);
		worst_nr = fmax(worst_nr, fabs(est_get(&E)->null_residual));
	}
	const float *e = est_get(&E)->vel;

	printf("readings with one odd radius: null-space residual at most %.2e m/s (a 4 %% radius "
	       "left out: %.2e); velocity %.4f %.4f %.4f, body %.4f %.4f %.4f\n",
	       worst_nr, 0.04 * fabs(v[1]), e[0], e[1], e[2], x[0], x[1], x[2]);
	assert_true(worst_nr <= 1e-5);
	assert_near(e[0], x[0], 0.01); /* measured 0.004: the coasting model pulls */
	assert_near(e[1], x[1], 0.01);
	assert_near(e[2], x[2], 0.01 / p.d);
	assert_true(!(est_get(&E)->flags & EST_FLAG_SLIP));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_prediction_follows_each_wheels_drive),
	    cmocka_unit_test(test_readings_use_each_wheels_radius),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
