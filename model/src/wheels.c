/* wheels.c - the wheels' physics (wheels.h). */
#include "omni4/model/wheels.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "omni4/model/consts.h"

void wheel_geom_paper(double d, struct wheel_geom *g)
{
	static const double gxy[4][2] = {{0.0, 1.0}, {-1.0, 0.0}, {0.0, -1.0}, {1.0, 0.0}};
	const double q = 1.0 / (4.0 * d), k = 1.0 / (2.0 * d * d);

	memset(g, 0, sizeof(*g));
	g->n = 4;
	for (int j = 0; j < 4; j++) {
		g->row[j][0] = gxy[j][0];
		g->row[j][1] = gxy[j][1];
		g->row[j][2] = d;
		g->pos[j][0] = d * gxy[j][1] + 0.0; /* the drive direction turned back 90 deg */
		g->pos[j][1] = 0.0 - d * gxy[j][0];
		/* G^T G = diag(2, 2, 4 d^2); A A^T = diag(4, 2 d^2, 2 d^2) (wheels.h) */
		g->split[j][0] = 0.5 * gxy[j][0];
		g->split[j][1] = 0.5 * gxy[j][1];
		g->split[j][2] = q;
		g->lmap[j][0] = 0.25;
		g->lmap[j][1] = g->pos[j][0] * k;
		g->lmap[j][2] = g->pos[j][1] * k;
	}
}

/* sin and cos of a [deg], exact at the multiples of 90 deg. */
static void sin_cos_deg(double a, double *s, double *c)
{
	const double k = round(a / 90.0), r = (a - 90.0 * k) * (MODEL_PI / 180.0);
	const double sr = r == 0.0 ? 0.0 : sin(r), cr = r == 0.0 ? 1.0 : cos(r);
	const long q = ((long)fmod(k, 4.0) + 4) % 4;

	*s = q == 0 ? sr : q == 1 ? cr : q == 2 ? -sr : -cr;
	*c = q == 0 ? cr : q == 1 ? -sr : q == 2 ? -cr : sr;
}

/* The inverse of a symmetric 3 x 3 m (cofactors); -EINVAL when m is singular against its
 * scale. */
static int inv3(const double m[3][3], double out[3][3])
{
	double adj[3][3];

	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++) {
			const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3,
			          j2 = (j + 2) % 3;

			adj[j][i] = m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1];
		}
	const double det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
	const double scale = fabs(m[0][0] * m[1][1] * m[2][2]);

	if (!isfinite(det) || !(fabs(det) > 1e-9 * scale))
		return -EINVAL;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			out[i][j] = adj[i][j] / det;
	return 0;
}

/* Least norm for the n x 3 columns a (a^T x = rhs): x = a (a^T a)^-1 rhs, as the n x 3 map
 * a (a^T a)^-1. */
static int least_norm(int n, const double a[4][3], double map[4][3])
{
	double m[3][3] = {{0}}, inv[3][3];

	for (int i = 0; i < 3; i++)
		for (int k = 0; k < 3; k++)
			for (int j = 0; j < n; j++)
				m[i][k] += a[j][i] * a[j][k];
	if (inv3(m, inv))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		for (int k = 0; k < 3; k++) {
			map[j][k] = 0.0;
			if (j < n) /* an absent wheel: no share */
				for (int i = 0; i < 3; i++)
					map[j][k] += a[j][i] * inv[i][k];
		}
	return 0;
}

/* The rows valid and of full rank; their maps solved into g. */
static bool prepare(struct wheel_geom *g)
{
	double a[4][3] = {{0}};

	if (g->n != 3 && g->n != 4)
		return false;
	for (int j = 0; j < g->n; j++) {
		if (!isfinite(g->row[j][0]) || !isfinite(g->row[j][1]) || !(g->row[j][2] > 0.0) ||
		    !isfinite(g->row[j][2]) || !isfinite(g->pos[j][0]) || !isfinite(g->pos[j][1]))
			return false;
		a[j][0] = 1.0;
		a[j][1] = g->pos[j][0];
		a[j][2] = g->pos[j][1];
	}
	return least_norm(g->n, g->row, g->split) == 0 && least_norm(g->n, a, g->lmap) == 0;
}

int wheel_geom_angles(int n, const double angle_deg[4], const double dist_m[4],
                      struct wheel_geom *g)
{
	struct wheel_geom t;

	memset(&t, 0, sizeof(t));
	if (n != 3 && n != 4)
		return -EINVAL;
	t.n = n;
	for (int j = 0; j < n; j++) {
		double s, c;

		if (!isfinite(angle_deg[j]) || !(dist_m[j] > 0.0) || !isfinite(dist_m[j]))
			return -EINVAL;
		sin_cos_deg(angle_deg[j], &s, &c);
		t.row[j][0] = 0.0 - s; /* (+ 0.0: no negative zeros, the paper's rows' bits) */
		t.row[j][1] = c + 0.0;
		t.row[j][2] = dist_m[j];
		t.pos[j][0] = dist_m[j] * c + 0.0;
		t.pos[j][1] = dist_m[j] * s + 0.0;
	}
	if (!prepare(&t))
		return -EINVAL;
	*g = t;
	return 0;
}

/* A layout's shape as wheel_geom_paper or wheel_geom_angles leave it (cheap: no solve). */
static bool geom_ok(const struct wheel_geom *g)
{
	if (g->n != 3 && g->n != 4)
		return false;
	for (int j = 0; j < g->n; j++)
		if (!(g->row[j][2] > 0.0) || !isfinite(g->row[j][2]) || !isfinite(g->split[j][2]))
			return false;
	return true;
}

int wheel_phys_layout(struct wheel_phys *ph, const struct wheel_geom *g)
{
	if (!ph || !g || !geom_ok(g))
		return -EINVAL;
	memset(ph, 0, sizeof(*ph));
	ph->n = g->n;
	memcpy(ph->row, g->row, sizeof(ph->row));
	memcpy(ph->split, g->split, sizeof(ph->split));
	for (int j = 0; j < g->n; j++)
		for (int k = 0; k < 3; k++)
			ph->fk[k][j] = g->split[j][k]; /* (G^T G)^-1 G^T: the split's transpose */
	return 0;
}

int wheel_phys_init(struct wheel_phys *ph, const struct wheel_geom *g, const struct model_params *p,
                    const struct model_wheels *w, double com_height_m)
{
	struct wheel_phys t;
	const double h = com_height_m;

	if (!g || !p || !w || wheel_phys_layout(&t, g) || !(h >= 0.0) || !isfinite(h))
		return -EINVAL;
	MODEL_ASSERT_CHECKED(p, w); /* checked at the door (params.h) */
	for (int j = 0; j < g->n; j++) {
		t.b[j] = p->l * w->Kt[j] / (w->R[j] * w->r[j]);
		t.vpn[j] = w->R[j] * w->r[j] / (p->l * w->Kt[j]);
		t.kemf[j] = w->Kv[j] * p->l / w->r[j];
		t.load0[j] = g->lmap[j][0] * p->M * MODEL_G_M_S2;
		t.load_a[j][0] = -g->lmap[j][1] * p->M * h;
		t.load_a[j][1] = -g->lmap[j][2] * p->M * h;
	}
	*ph = t;
	return 0;
}

void wheel_phys_to_f32(const struct wheel_phys *ph, struct wheel_phys_f32 *out)
{
	out->n = ph->n;
	for (int j = 0; j < 4; j++) {
		for (int k = 0; k < 3; k++) {
			out->row[j][k] = (float)ph->row[j][k];
			out->fk[k][j] = (float)ph->fk[k][j];
			out->split[j][k] = (float)ph->split[j][k];
		}
		out->b[j] = (float)ph->b[j];
		out->vpn[j] = (float)ph->vpn[j];
		out->kemf[j] = (float)ph->kemf[j];
		out->load0[j] = (float)ph->load0[j];
		out->load_a[j][0] = (float)ph->load_a[j][0];
		out->load_a[j][1] = (float)ph->load_a[j][1];
	}
}

void wheel_rims(const struct wheel_phys *ph, const double x[3], double rim_m_s[4])
{
	for (int j = 0; j < 4; j++)
		rim_m_s[j] = ph->row[j][0] * x[0] + ph->row[j][1] * x[1] +
		             ph->row[j][2] * x[2]; /* (an absent wheel's row is 0) */
}

void wheel_body(const struct wheel_phys *ph, const double rim_m_s[4], double x[3])
{
	for (int k = 0; k < 3; k++) {
		x[k] = 0.0;
		for (int j = 0; j < ph->n; j++)
			x[k] += ph->fk[k][j] * rim_m_s[j];
	}
}

void wheel_split(const struct wheel_phys *ph, const double F[3], double f_n[4])
{
	for (int j = 0; j < 4; j++)
		f_n[j] = ph->split[j][0] * F[0] + ph->split[j][1] * F[1] + ph->split[j][2] * F[2];
}

void wheel_body_force(const struct wheel_phys *ph, const double f_n[4], double F[3])
{
	for (int k = 0; k < 3; k++) {
		F[k] = 0.0;
		for (int j = 0; j < ph->n; j++)
			F[k] += ph->row[j][k] * f_n[j];
	}
}

void wheel_com_accel(const double x[3], const double a[3], double ac[2])
{
	ac[0] = a[0] - x[2] * x[1];
	ac[1] = a[1] + x[2] * x[0];
}

void wheel_loads(const struct wheel_phys *ph, const double ac[2], double load_n[4])
{
	for (int j = 0; j < 4; j++)
		load_n[j] =
		    fmax(0.0, ph->load0[j] + ph->load_a[j][0] * ac[0] + ph->load_a[j][1] * ac[1]);
}

void wheel_rims_f32(const struct wheel_phys_f32 *ph, const float x[3], float rim_m_s[4])
{
	for (int j = 0; j < 4; j++)
		rim_m_s[j] = ph->row[j][0] * x[0] + ph->row[j][1] * x[1] + ph->row[j][2] * x[2];
}

void wheel_body_f32(const struct wheel_phys_f32 *ph, const float rim_m_s[4], float x[3])
{
	for (int k = 0; k < 3; k++)
		x[k] = ph->fk[k][0] * rim_m_s[0] + ph->fk[k][1] * rim_m_s[1] +
		       ph->fk[k][2] * rim_m_s[2] + ph->fk[k][3] * rim_m_s[3];
}

void wheel_split_f32(const struct wheel_phys_f32 *ph, const float F[3], float f_n[4])
{
	for (int j = 0; j < 4; j++)
		f_n[j] = ph->split[j][0] * F[0] + ph->split[j][1] * F[1] + ph->split[j][2] * F[2];
}

void wheel_com_accel_f32(const float x[3], const float a[3], float ac[2])
{
	ac[0] = a[0] - x[2] * x[1];
	ac[1] = a[1] + x[2] * x[0];
}

void wheel_loads_f32(const struct wheel_phys_f32 *ph, const float ac[2], float load_n[4])
{
	for (int j = 0; j < 4; j++)
		load_n[j] =
		    fmaxf(0.0f, ph->load0[j] + ph->load_a[j][0] * ac[0] + ph->load_a[j][1] * ac[1]);
}

/* 3 x 3 determinant of G's rows other than skip. */
static double det_without(const struct wheel_phys *ph, int skip)
{
	const double *r[3];
	int k = 0;

	for (int j = 0; j < 4; j++)
		if (j != skip)
			r[k++] = ph->row[j];
	return r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) -
	       r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
	       r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
}

int wheel_null(const struct wheel_phys *ph, double null_m[4])
{
	double big = 0.0;

	for (int j = 0; j < 4; j++)
		null_m[j] = 0.0;
	if (ph->n != 4)
		return 0;
	for (int j = 0; j < 4; j++) {
		null_m[j] = (j & 1 ? -1.0 : 1.0) * det_without(ph, j);
		big = fmax(big, fabs(null_m[j])); /* rank 3: some determinant is not 0 */
	}
	const double scale = null_m[0] < 0.0 ? -big : big;

	for (int j = 0; j < 4; j++)
		null_m[j] /= scale;
	return 4;
}
