/*
 * wheels.h - the wheels' physics, in one place (docs/model.md, "The wheels' physics").
 *
 * From the layout (eq 2's rows taken as data: another layout changes only the rows) and each
 * wheel's drive (struct model_wheels), prepared once with no trigonometry per call:
 *   - each wheel's rim speed, eq 2: v_j = g_j . (v, vn, w), g_j = [gx_j, gy_j, d_j];
 *   - the least-squares inverse of eq 2 (eqs 3-5) and the least-norm split of a body force
 *     (Fv, Fvn, T) onto the wheels (eqs 9-11 solved for the wheel forces): f = G (G^T G)^-1 F
 *     with G the n x 3 matrix of the rows (for the paper's layout f_j = gx_j Fv / 2 +
 *     gy_j Fvn / 2 + T / (4 d));
 *   - each wheel's drive gain b_j = l Kt_j / (R_j r_j) [N/V] and back-EMF constant
 *     kemf_j = Kv_j l / r_j [V/(m/s)]: its force f_j = b_j (u_j - kemf_j v_j) (eqs 12, 13, 21);
 *   - each wheel's load with the load transfer: the least-norm N with sum N_j = M g and
 *     sum N_j p_j = -M h a_c (p_j the wheel's contact point from the centre, h the centre of
 *     mass's height, a_c its acceleration (a_v - w vn, a_vn + w v)), for the paper's layout
 *     N_j = M g / 4 - M h (a_c . p_j) / (2 d^2);
 *   - the traction bound: |f_j| <= mu max(0, N_j).
 * Double and float (the controller's arithmetic) twins; no I/O.
 */
#ifndef OMNI4_WHEELS_H
#define OMNI4_WHEELS_H

#include "omni4/model/params.h"

#define WHEELS_MAX 4

/* The layout, prepared once (the least-squares and least-norm maps solved here, so a model
 * change behind it costs a few products: wheel_phys_init). */
struct wheel_geom {
	int n;              /* 3 or 4 */
	double row[4][3];   /* eq 2: wheel j's rim speed = row[j] . (v, vn, w) [m/s] */
	double pos[4][2];   /* wheel j's contact point from the centre, (v, vn) axes [m] */
	double split[4][3]; /* least norm: f = split (Fv, Fvn, T); its transpose is eqs 3-5 */
	double lmap[4][3];  /* least norm: N = lmap (sum N, sum N p_v, sum N p_vn) */
};

/* The paper's layout: wheel j at j 90 deg from the v axis, all at distance d [m]: rows [0 1 d],
 * [-1 0 d], [0 -1 d], [1 0 d] exactly, the maps in closed form (eqs 3-5; loads
 * 1/4 + p_j . (., .) / (2 d^2)). d > 0 (checked at the door). */
void wheel_geom_paper(double d, struct wheel_geom *g);

/* n (3 or 4) wheels at angle_deg[j] from the v axis, counter-clockwise, at dist_m[j] [m], each
 * driving perpendicular to its radius, counter-clockwise positive (as eq 2): row
 * [-sin a, cos a, dist], contact point dist (cos a, sin a); multiples of 90 deg exact (the
 * paper's layout gives wheel_geom_paper's rows). -EINVAL unless n is 3 or 4, every value
 * finite, every distance > 0 and the rows of full rank (the body's three motions driven). */
int wheel_geom_angles(int n, const double angle_deg[4], const double dist_m[4],
                      struct wheel_geom *g);

/* Everything the callers need, prepared once (double). */
struct wheel_phys {
	int n;
	double row[4][3];    /* eq 2 */
	double fk[3][4];     /* eqs 3-5: (v, vn, w) = fk . rims [m/s] */
	double split[4][3];  /* least-norm force split: f_j = split[j] . (Fv, Fvn, T) */
	double b[4];         /* drive gain l Kt_j / (R_j r_j) [N/V] */
	double vpn[4];       /* 1 / b_j [V/N] */
	double kemf[4];      /* back-EMF Kv_j l / r_j [V/(m/s)] at the rim */
	double load0[4];     /* load at rest [N] */
	double load_a[4][2]; /* load per centre-of-mass acceleration (a_v, a_vn) [N/(m/s^2)] */
};

/* The float twin (struct wheel_phys rounded once). */
struct wheel_phys_f32 {
	int n;
	float row[4][3];
	float fk[3][4];
	float split[4][3];
	float b[4];
	float vpn[4];
	float kemf[4];
	float load0[4];
	float load_a[4][2];
};

/* From the layout, the model (M, l; w's per-wheel drives: both checked before, as everything
 * behind the door takes them: params.h) and the centre of mass's height com_height_m [m] (>= 0;
 * 0: no load transfer). -EINVAL for an invalid layout or height; ph untouched then. */
int wheel_phys_init(struct wheel_phys *ph, const struct wheel_geom *g, const struct model_params *p,
                    const struct model_wheels *w, double com_height_m);
/* The layout's part alone (n, rows, split, eqs 3-5; no drive, no load: those stay 0), for a
 * caller with a model it has not checked (identification's fits). -EINVAL for an invalid
 * layout. */
int wheel_phys_layout(struct wheel_phys *ph, const struct wheel_geom *g);
void wheel_phys_to_f32(const struct wheel_phys *ph, struct wheel_phys_f32 *out);

/* Rim speeds [m/s] of a body velocity x (v, vn [m/s], w [rad/s]): eq 2. */
void wheel_rims(const struct wheel_phys *ph, const double x[3], double rim_m_s[4]);
/* Body velocity from the rims: eqs 3-5. */
void wheel_body(const struct wheel_phys *ph, const double rim_m_s[4], double x[3]);
/* Wheel forces [N] of a body force F (Fv, Fvn [N], T [N m]), least norm. */
void wheel_split(const struct wheel_phys *ph, const double F[3], double f_n[4]);
/* Body force of wheel forces: eqs 9-11, F = G^T f. */
void wheel_body_force(const struct wheel_phys *ph, const double f_n[4], double F[3]);
/* The centre of mass's acceleration (a_v - w vn, a_vn + w v) at velocity x, body-frame
 * acceleration a. */
void wheel_com_accel(const double x[3], const double a[3], double ac[2]);
/* Each wheel's load [N] at the centre of mass's acceleration ac, never below 0. */
void wheel_loads(const struct wheel_phys *ph, const double ac[2], double load_n[4]);
/*
 * The rigid-body check of four wheels: the vector spanning the null space of G^T (the rims of
 * every body motion are orthogonal to it), n_j = (-1)^j det(G without row j), scaled so its
 * largest entry is 1 and n_0 > 0: the paper's layout gives (1, -1, 1, -1) exactly (eqs 2-5's
 * v0 - v1 + v2 - v3 = 0). Three wheels have none: 0 and null_m = 0 [0, 0, 0, 0].
 */
int wheel_null(const struct wheel_phys *ph, double null_m[4]);

/* The float twins. */
void wheel_rims_f32(const struct wheel_phys_f32 *ph, const float x[3], float rim_m_s[4]);
void wheel_body_f32(const struct wheel_phys_f32 *ph, const float rim_m_s[4], float x[3]);
void wheel_split_f32(const struct wheel_phys_f32 *ph, const float F[3], float f_n[4]);
void wheel_com_accel_f32(const float x[3], const float a[3], float ac[2]);
void wheel_loads_f32(const struct wheel_phys_f32 *ph, const float ac[2], float load_n[4]);

#endif /* OMNI4_WHEELS_H */
