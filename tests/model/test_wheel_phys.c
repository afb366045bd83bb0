/*
 * Tests for the wheels' physics (wheels.h) against computations that share none of its code:
 * the paper's equations written out (eqs 2-5, 9-13, 21) for its layout; the closed forms of a
 * three-wheel robot at 120 deg; and, for layouts with no closed form (a RoboCup-style four at
 * 60/135/225/300 deg, unequal distances), the defining properties: the split's forces give back
 * the body force and are orthogonal to the null space (least norm), the loads balance the
 * weight and the tipping moment, eqs 3-5 invert eq 2.
 */
#include "omni4_test.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "omni4/model/consts.h"
#include "omni4/model/dynamics.h"
#include "omni4/model/params.h"
#include "omni4/model/rng.h"
#include "omni4/model/wheels.h"

#define H_COM 0.08 /* centre of mass height [m] */
#define G0 9.80665 /* standard gravity, written here again: the test's own */
#define PI_T 3.14159265358979323846

static void near(double got, double want, double tol, const char *what)
{
	if (!(fabs(got - want) <= tol * (1.0 + fabs(want))))
		fail_msg("%s: got %.17g, want %.17g", what, got, want);
}

static void wheels_of(const struct model_params *p, struct model_wheels *w)
{
	model_wheels_from_params(p, w);
}

static void random_vec(struct rng *g, double *v, int n, double scale)
{
	for (int k = 0; k < n; k++)
		v[k] = rng_uniform(g, -scale, scale);
}

/* The paper's layout, eq by eq. */
static void test_paper_layout_is_the_papers_equations(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct model_wheels w;
	struct wheel_geom g;
	struct wheel_phys ph;
	struct rng r;
	const double d = p->d;

	wheels_of(p, &w);
	w.R[2] *= 1.1; /* one odd drive */
	w.r[1] *= 0.99;
	wheel_geom_paper(d, &g);
	assert_int_equal(wheel_phys_init(&ph, &g, p, &w, H_COM), 0);
	rng_seed(&r, 7);
	for (int n = 0; n < 200; n++) {
		double x[3], v[4], xb[3], F[3], f[4], Fb[3], ac[2], N[4];

		random_vec(&r, x, 3, 3.0);
		wheel_rims(&ph, x, v);
		/* eq 2 */
		near(v[0], x[1] + d * x[2], 1e-15, "eq 2 wheel 0");
		near(v[1], -x[0] + d * x[2], 1e-15, "eq 2 wheel 1");
		near(v[2], -x[1] + d * x[2], 1e-15, "eq 2 wheel 2");
		near(v[3], x[0] + d * x[2], 1e-15, "eq 2 wheel 3");
		/* eqs 3-5 on any four readings */
		random_vec(&r, v, 4, 2.0);
		wheel_body(&ph, v, xb);
		near(xb[0], (v[3] - v[1]) / 2.0, 1e-15, "eq 3");
		near(xb[1], (v[0] - v[2]) / 2.0, 1e-15, "eq 4");
		near(xb[2], (v[0] + v[1] + v[2] + v[3]) / (4.0 * d), 1e-14, "eq 5");
		/* eqs 9-11 and their least-norm inverse */
		random_vec(&r, F, 3, 20.0);
		wheel_split(&ph, F, f);
		for (int j = 0; j < 4; j++) {
			const double gx[4] = {0, -1, 0, 1}, gy[4] = {1, 0, -1, 0};

			near(f[j], gx[j] * F[0] / 2 + gy[j] * F[1] / 2 + F[2] / (4 * d), 1e-14,
			     "split");
		}
		wheel_body_force(&ph, f, Fb);
		near(Fb[0], f[3] - f[1], 1e-14, "eq 9");
		near(Fb[1], f[0] - f[2], 1e-14, "eq 10");
		near(Fb[2], d * (f[0] + f[1] + f[2] + f[3]), 1e-14, "eq 11");
		/* loads: a quarter of the weight, less the tipping moment's share toward the wheel
		 */
		random_vec(&r, ac, 2, 3.0);
		wheel_loads(&ph, ac, N);
		const double k = p->M * H_COM / (2 * d);

		near(N[0], fmax(0, p->M * G0 / 4 - k * ac[0]), 1e-14, "load 0");
		near(N[1], fmax(0, p->M * G0 / 4 - k * ac[1]), 1e-14, "load 1");
		near(N[2], fmax(0, p->M * G0 / 4 + k * ac[0]), 1e-14, "load 2");
		near(N[3], fmax(0, p->M * G0 / 4 + k * ac[1]), 1e-14, "load 3");
	}
	/* eqs 12, 13, 21: f = l Kt (u - Kv l v / r) / (R r) */
	for (int j = 0; j < 4; j++) {
		const double u = 7.0, v = 0.8;
		const double f =
		    p->l * w.Kt[j] * (u - w.Kv[j] * p->l * v / w.r[j]) / (w.R[j] * w.r[j]);

		near(ph.b[j] * (u - ph.kemf[j] * v), f, 1e-14, "eqs 12, 13, 21");
	}
	/* the state space's B is the same drive gains on the same rows */
	struct model_ss_wheels ss;

	dyn_state_space_wheels(p, &w, &ss);
	for (int j = 0; j < 4; j++) {
		near(ss.B[0][j] * p->M, ph.row[j][0] * ph.b[j], 1e-13, "B row v");
		near(ss.B[1][j] * p->M, ph.row[j][1] * ph.b[j], 1e-13, "B row vn");
		near(ss.B[2][j] * p->J, ph.row[j][2] * ph.b[j], 1e-13, "B row w");
	}
}

/* The angles 0/90/180/270 deg give the paper's rows to the bit. */
static void test_paper_angles_give_the_papers_rows(void **state)
{
	(void)state;
	const double a[4] = {0, 90, 180, 270}, a2[4] = {360, -270, 540, -90};
	const double dist[4] = {0.24, 0.24, 0.24, 0.24};
	struct wheel_geom g, gp, g2;

	assert_int_equal(wheel_geom_angles(4, a, dist, &g), 0);
	assert_int_equal(wheel_geom_angles(4, a2, dist, &g2), 0);
	wheel_geom_paper(0.24, &gp);
	assert_memory_equal(g.row, gp.row, sizeof(g.row));
	assert_memory_equal(g.pos, gp.pos, sizeof(g.pos));
	assert_memory_equal(g2.row, gp.row, sizeof(g.row));
	/* the general least-squares / least-norm solve agrees with the paper's closed forms */
	for (int j = 0; j < 4; j++)
		for (int k = 0; k < 3; k++) {
			near(g.split[j][k], gp.split[j][k], 1e-15, "split, solved and closed form");
			near(g.lmap[j][k], gp.lmap[j][k], 1e-15,
			     "load map, solved and closed form");
		}
}

/* Three wheels at 0/120/240 deg, distance d: G^T G = diag(3/2, 3/2, 3 d^2), so
 * f_j = 2/3 (g_j . F_xy) + T / (3 d); A A^T = diag(3, 3 d^2 / 2, 3 d^2 / 2), so
 * N_j = M g / 3 - 2 M h (a . p_j) / (3 d^2). */
static void test_three_wheels_closed_form(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	const double d = 0.2, a[4] = {0, 120, 240, 0}, dist[4] = {d, d, d, 0};
	struct model_wheels w;
	struct wheel_geom g;
	struct wheel_phys ph;
	struct rng r;

	wheels_of(p, &w);
	assert_int_equal(wheel_geom_angles(3, a, dist, &g), 0);
	assert_int_equal(wheel_phys_init(&ph, &g, p, &w, H_COM), 0);
	rng_seed(&r, 11);
	for (int n = 0; n < 200; n++) {
		double F[3], f[4], ac[2], N[4], x[3], v[4], xb[3];

		random_vec(&r, F, 3, 20.0);
		random_vec(&r, ac, 2, 2.0);
		random_vec(&r, x, 3, 2.0);
		wheel_split(&ph, F, f);
		wheel_loads(&ph, ac, N);
		for (int j = 0; j < 3; j++) {
			const double t = a[j] * (PI_T / 180.0);
			const double gx = -sin(t), gy = cos(t), px = d * cos(t), py = d * sin(t);

			near(f[j], 2.0 / 3.0 * (gx * F[0] + gy * F[1]) + F[2] / (3 * d), 1e-13,
			     "3-wheel split");
			near(N[j],
			     fmax(0, p->M * G0 / 3 - 2 * p->M * H_COM * (ac[0] * px + ac[1] * py) /
			                                 (3 * d * d)),
			     1e-13, "3-wheel load");
		}
		assert_true(f[3] == 0.0 && N[3] == 0.0);
		/* no null space: eq 2 then eqs 3-5 is the identity */
		wheel_rims(&ph, x, v);
		wheel_body(&ph, v, xb);
		for (int k = 0; k < 3; k++)
			near(xb[k], x[k], 1e-13, "3-wheel eqs 3-5 invert eq 2");
	}
}

/* The null vector z of the 4 x 3 rows (G^T z = 0): the signed 3 x 3 minors. */
static void null_vector(const double row[4][3], double z[4])
{
	for (int j = 0; j < 4; j++) {
		double m[3][3];
		int q = 0;

		for (int i = 0; i < 4; i++)
			if (i != j)
				memcpy(m[q++], row[i], sizeof(m[0]));
		const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
		                   m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
		                   m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);

		z[j] = (j % 2 ? -1.0 : 1.0) * det;
	}
}

/* A RoboCup-style four: 60/135/225/300 deg, the front pair nearer, Table III's drives. */
static void robocup_four(struct wheel_geom *g, struct wheel_phys *ph)
{
	const double a[4] = {60, 135, 225, 300}, dist[4] = {0.078, 0.081, 0.081, 0.078};
	struct model_wheels w;

	wheels_of(&model_params_table3, &w);
	assert_int_equal(wheel_geom_angles(4, a, dist, g), 0);
	assert_int_equal(wheel_phys_init(ph, g, &model_params_table3, &w, H_COM), 0);
}

/* A RoboCup-style four (60/135/225/300 deg, the front pair nearer): the split gives back the
 * body force with no share in the null space; the loads carry the weight and the tipping
 * moment with no share in their null space; eqs 3-5 invert eq 2. */
static void test_unequal_layout_properties(void **state)
{
	(void)state;
	const struct model_params *p = &model_params_table3;
	struct wheel_geom g;
	struct wheel_phys ph;
	struct rng r;
	double z[4], zl[4], arow[4][3];

	robocup_four(&g, &ph);
	null_vector(g.row, z);
	for (int j = 0; j < 4; j++) {
		arow[j][0] = 1.0;
		arow[j][1] = g.pos[j][0];
		arow[j][2] = g.pos[j][1];
	}
	null_vector(arow, zl);
	rng_seed(&r, 13);
	for (int n = 0; n < 200; n++) {
		double F[3], f[4], Fb[3] = {0, 0, 0}, ac[2], N[4], x[3], v[4], xb[3];
		double fz = 0, nz = 0, sum = 0, mv = 0, mvn = 0;

		random_vec(&r, F, 3, 20.0);
		random_vec(&r, ac, 2, 1.0); /* small enough that no wheel lifts */
		random_vec(&r, x, 3, 2.0);
		wheel_split(&ph, F, f);
		wheel_loads(&ph, ac, N);
		for (int j = 0; j < 4; j++) {
			for (int k = 0; k < 3; k++)
				Fb[k] += g.row[j][k] * f[j];
			fz += f[j] * z[j];
			nz += N[j] * zl[j];
			sum += N[j];
			mv += N[j] * g.pos[j][0];
			mvn += N[j] * g.pos[j][1];
		}
		for (int k = 0; k < 3; k++)
			near(Fb[k], F[k], 1e-12, "split gives back the body force");
		near(fz, 0.0, 1e-12, "split orthogonal to the null space");
		near(sum, p->M * G0, 1e-12, "loads carry the weight");
		near(mv, -p->M * H_COM * ac[0], 1e-12, "loads carry the tipping moment (v)");
		near(mvn, -p->M * H_COM * ac[1], 1e-12, "loads carry the tipping moment (vn)");
		near(nz, 0.0, 1e-12, "loads orthogonal to their null space");
		wheel_rims(&ph, x, v);
		wheel_body(&ph, v, xb);
		for (int k = 0; k < 3; k++)
			near(xb[k], x[k], 1e-12, "eqs 3-5 invert eq 2");
	}
}

/* The rigid-body check's vector: every body motion's rims are orthogonal to it, its largest
 * entry is 1 and its first positive; the paper's is (1, -1, 1, -1) to the bit; three wheels
 * have none. */
static void test_null_vector_of_the_rims(void **state)
{
	(void)state;
	static const double paper[4] = {1.0, -1.0, 1.0, -1.0};
	const double a3[4] = {0, 120, 240, 0}, d3[4] = {0.09, 0.08, 0.1, 0};
	struct wheel_geom g;
	struct wheel_phys ph;
	double nv[4];
	struct rng r;

	wheel_geom_paper(0.2, &g);
	assert_int_equal(wheel_phys_layout(&ph, &g), 0);
	assert_int_equal(wheel_null(&ph, nv), 4);
	assert_memory_equal(nv, paper, sizeof(paper));
	robocup_four(&g, &ph);
	assert_int_equal(wheel_null(&ph, nv), 4);
	double big = 0.0;

	for (int j = 0; j < 4; j++)
		big = fmax(big, fabs(nv[j]));
	near(big, 1.0, 1e-15, "largest entry 1");
	assert_true(nv[0] > 0.0);
	rng_seed(&r, 7);
	for (int n = 0; n < 100; n++) {
		double x[3], v[4], dot = 0.0;

		random_vec(&r, x, 3, 3.0);
		wheel_rims(&ph, x, v);
		for (int j = 0; j < 4; j++)
			dot += nv[j] * v[j];
		near(dot, 0.0, 1e-13, "rims of a body motion orthogonal to the null vector");
	}
	assert_int_equal(wheel_geom_angles(3, a3, d3, &g), 0);
	assert_int_equal(wheel_phys_layout(&ph, &g), 0);
	assert_int_equal(wheel_null(&ph, nv), 0);
	for (int j = 0; j < 4; j++)
		assert_true(nv[j] == 0.0);
}

/* The layout's part alone is the full one's, with no drive and no load. */
static void test_layout_part_alone(void **state)
{
	(void)state;
	struct wheel_geom g;
	struct wheel_phys full, part;

	robocup_four(&g, &full);
	assert_int_equal(wheel_phys_layout(&part, &g), 0);
	assert_int_equal(part.n, full.n);
	assert_memory_equal(part.row, full.row, sizeof(part.row));
	assert_memory_equal(part.split, full.split, sizeof(part.split));
	assert_memory_equal(part.fk, full.fk, sizeof(part.fk));
	for (int j = 0; j < 4; j++)
		assert_true(part.b[j] == 0.0 && part.kemf[j] == 0.0 && part.load0[j] == 0.0);
	g.n = 2;
	assert_int_equal(wheel_phys_layout(&part, &g), -EINVAL);
}

/* The float twin within float's rounding of the double. */
static void test_float_twin(void **state)
{
	(void)state;
	struct wheel_geom g;
	struct wheel_phys ph;
	struct wheel_phys_f32 pf;
	struct rng r;

	robocup_four(&g, &ph);
	wheel_phys_to_f32(&ph, &pf);
	rng_seed(&r, 17);
	for (int n = 0; n < 200; n++) {
		double x[3], F[3], ac[2], v[4], f[4], N[4], xb[3];
		float xf[3], Ff[3], acf[2], vf[4], ff[4], Nf[4], xbf[3];

		random_vec(&r, x, 3, 2.0);
		random_vec(&r, F, 3, 20.0);
		random_vec(&r, ac, 2, 3.0);
		for (int k = 0; k < 3; k++) {
			xf[k] = (float)x[k];
			Ff[k] = (float)F[k];
		}
		acf[0] = (float)ac[0];
		acf[1] = (float)ac[1];
		wheel_rims(&ph, x, v);
		wheel_rims_f32(&pf, xf, vf);
		wheel_split(&ph, F, f);
		wheel_split_f32(&pf, Ff, ff);
		wheel_loads(&ph, ac, N);
		wheel_loads_f32(&pf, acf, Nf);
		wheel_body(&ph, v, xb);
		wheel_body_f32(&pf, vf, xbf);
		for (int j = 0; j < 4; j++) {
			assert_true(fabs(vf[j] - v[j]) <= 1e-6 * (1 + fabs(v[j])));
			assert_true(fabs(ff[j] - f[j]) <= 1e-5 * (1 + fabs(f[j])));
			assert_true(fabs(Nf[j] - N[j]) <= 1e-5 * (1 + fabs(N[j])));
		}
		for (int k = 0; k < 3; k++)
			assert_true(fabs(xbf[k] - xb[k]) <= 1e-5 * (1 + fabs(xb[k])));
	}
}

/* Layouts that drive less than the body's three motions, and bad values, are refused. */
static void test_bad_layouts_refused(void **state)
{
	(void)state;
	const double one[4] = {0.2, 0.2, 0.2, 0.2};
	struct wheel_geom g;
	struct wheel_phys ph;
	struct model_wheels w;
	const double same[4] = {30, 30, 30, 30}, opposite[4] = {0, 180, 0, 180};
	const double good[4] = {0, 120, 240, 0}, nan4[4] = {0, NAN, 240, 0};
	const double zero[4] = {0.2, 0.0, 0.2, 0.2};

	memset(&g, 0x5a, sizeof(g));
	const struct wheel_geom before = g;

	assert_int_equal(wheel_geom_angles(2, good, one, &g), -EINVAL);
	assert_int_equal(wheel_geom_angles(5, good, one, &g), -EINVAL);
	assert_int_equal(wheel_geom_angles(4, same, one, &g), -EINVAL);
	assert_int_equal(wheel_geom_angles(4, opposite, one, &g), -EINVAL);
	assert_int_equal(wheel_geom_angles(3, nan4, one, &g), -EINVAL);
	assert_int_equal(wheel_geom_angles(3, good, zero, &g), -EINVAL);
	assert_memory_equal(&g, &before, sizeof(g));
	wheels_of(&model_params_table3, &w);
	wheel_geom_paper(0.2, &g);
	assert_int_equal(wheel_phys_init(&ph, &g, &model_params_table3, &w, -0.1), -EINVAL);
	assert_int_equal(wheel_phys_init(&ph, &g, &model_params_table3, &w, NAN), -EINVAL);
	/* the helpers once: wrap into (-pi, pi] */
	near(model_wrap_pi(3.0 * PI_T), PI_T, 1e-12, "wrap 3 pi");
	near(model_wrap_pi(-7.0), -7.0 + 2 * PI_T, 1e-12, "wrap -7");
	near(model_wrap_pi_f32(-3.14159265f), 3.14159265f, 1e-6, "wrap -pi (f32)");
	assert_true(model_wrap_pi_f32(3.2f) < 0.0f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_paper_layout_is_the_papers_equations),
	    cmocka_unit_test(test_paper_angles_give_the_papers_rows),
	    cmocka_unit_test(test_three_wheels_closed_form),
	    cmocka_unit_test(test_unequal_layout_properties),
	    cmocka_unit_test(test_null_vector_of_the_rims),
	    cmocka_unit_test(test_layout_part_alone),
	    cmocka_unit_test(test_float_twin),
	    cmocka_unit_test(test_bad_layouts_refused),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
