/* plant.c - exact per-axis integration of eq 23 with Coulomb friction and stiction, and the
 * floor: traction limit, wheel inertia, radius errors, creep; any three or four wheels
 * (plant.h). */
#include "omni4/model/plant.h"
#include "omni4/model/consts.h"

#include "omni4/model/kinematics.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

static double sgn(double x)
{
	return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0);
}

/* Solution of x' = a x + f from x0 after t (zero-order hold). */
static double lin_solve(double a, double f, double x0, double t)
{
	if (fabs(a) < 1e-12)
		return x0 + f * t;
	const double xss = -f / a;

	return xss + (x0 - xss) * exp(a * t);
}

/* Time for x' = a x + f to go from x0 to 0 (the caller knows it does within the step). */
static double lin_time_to_zero(double a, double f, double x0)
{
	if (fabs(a) < 1e-12)
		return -x0 / f;
	const double xss = -f / a;

	return log(xss / (xss - x0)) / a;
}

/* One axis x' = a x + b - c sgn(x) over dt, with stiction at zero. */
static double axis_step(double a, double b, double c, double x, double dt)
{
	double s = sgn(x);

	if (s == 0.0) {
		if (fabs(b) <= c)
			return 0.0;
		s = sgn(b);
	}
	const double f = b - c * s;
	const double xn = lin_solve(a, f, x, dt);

	if (x == 0.0 || sgn(xn) == s)
		return xn;
	/* Friction stopped the axis inside the step: stop at zero, maybe break away again. */
	double t0 = lin_time_to_zero(a, f, x);

	if (!(t0 >= 0.0) || t0 > dt)
		t0 = dt;
	if (fabs(b) <= c)
		return 0.0;
	return lin_solve(a, b - c * sgn(b), 0.0, dt - t0);
}

int plant_init(struct plant *pl, const struct model_params *p)
{
	if (model_params_check(p, NULL))
		return -EINVAL;
	pl->p = *p;
	dyn_state_space(p, &pl->ss);
	pl->friction_scale = 1.0;
	pl->floor = (struct plant_floor){0};
	pl->has_geom = false;
	pl->coupled = false;
	for (int j = 0; j < 4; j++) {
		pl->r_eff[j] = p->r;
		pl->R_eff[j] = p->R;
		pl->Kv_eff[j] = p->Kv;
		pl->Kt_eff[j] = p->Kt;
	}
	plant_reset(pl);
	return 0;
}

/* Eq 23 for the layout with the nominal drives (the floor's per-wheel errors take the
 * substep path): A = A_coast - m^-1 G^T diag(e) G, B = m^-1 G^T diag(b), m = (M, M, J),
 * e_j = b_j kemf_j; coupled unless A's off-diagonal entries vanish to rounding against its
 * diagonal (then the exact per-axis step drops terms of 1e-12 of the diagonal's or less). */
static void geom_state_space(struct plant *pl)
{
	const struct wheel_phys *ph = &pl->ph;
	const double inertia[3] = {pl->p.M, pl->p.M, pl->p.J};
	double E[3][3] = {{0}}; /* G^T diag(e) G [N/(m/s)], [N/(rad/s)], [N m/(rad/s)] */

	for (int j = 0; j < ph->n; j++)
		for (int k = 0; k < 3; k++)
			for (int m = 0; m < 3; m++)
				E[k][m] += ph->row[j][k] * ph->b[j] * ph->kemf[j] * ph->row[j][m];
	pl->coupled = false;
	for (int k = 0; k < 3; k++) {
		pl->ss.A[k] = pl->ss.A_coast[k] - E[k][k] / inertia[k];
		for (int j = 0; j < 4; j++) /* an absent wheel's row is 0 */
			pl->ss.B[k][j] = ph->row[j][k] * ph->b[j] / inertia[k];
		for (int m = 0; m < 3; m++)
			if (m != k && fabs(E[k][m]) > 1e-12 * sqrt(E[k][k] * E[m][m]))
				pl->coupled = true;
	}
}

/* The layout's rows, drives and loads (the floor's com_height); ph untouched on -EINVAL. */
static int geom_prepare(struct plant *pl, const struct wheel_geom *g)
{
	struct model_wheels w;

	model_wheels_from_params(&pl->p, &w);
	return wheel_phys_init(&pl->ph, g, &pl->p, &w, pl->floor.com_height);
}

int plant_set_geom(struct plant *pl, const struct wheel_geom *g)
{
	if (g && geom_prepare(pl, g))
		return -EINVAL;
	pl->has_geom = g != NULL;
	pl->coupled = false;
	if (g)
		pl->geom = *g;
	plant_set_friction_scale(pl, pl->friction_scale); /* eq 23: the paper's or the layout's */
	plant_reset(pl);
	return 0;
}

int plant_set_floor(struct plant *pl, const struct plant_floor *f)
{
	if (!(f->traction_mu >= 0.0 && isfinite(f->traction_mu)) || !isfinite(f->wheel_inertia) ||
	    (f->traction_mu > 0.0 && !(f->wheel_inertia > 0.0)) ||
	    !(f->slip_noise >= 0.0 && isfinite(f->slip_noise)) ||
	    !(f->com_height >= 0.0 && isfinite(f->com_height)))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		if (!(fabs(f->radius_error[j]) < 0.5) || !(fabs(f->R_error[j]) < 0.5) ||
		    !(fabs(f->Kv_error[j]) < 0.5))
			return -EINVAL;
	pl->floor = *f;
	for (int j = 0; j < 4; j++) {
		pl->r_eff[j] = pl->p.r * (1.0 + f->radius_error[j]);
		pl->R_eff[j] = pl->p.R * (1.0 + f->R_error[j]);
		pl->Kv_eff[j] = pl->p.Kv * (1.0 + f->Kv_error[j]);
		pl->Kt_eff[j] = pl->p.Kt * (1.0 + f->Kv_error[j]);
	}
	if (pl->has_geom)
		(void)geom_prepare(pl, &pl->geom); /* the loads' com_height; the layout was taken */
	plant_reset(pl);
	return 0;
}

void plant_reset(struct plant *pl)
{
	for (int k = 0; k < 3; k++) {
		pl->x[k] = 0.0;
		pl->pose[k] = 0.0;
		pl->acc[k] = 0.0;
	}
	for (int j = 0; j < 4; j++) {
		pl->current_a[j] = 0.0;
		pl->voltage_v[j] = 0.0;
		pl->rim[j] = 0.0;
		pl->creep[j] = 0.0;
		pl->slipping[j] = false;
		pl->slip_dir[j] = 0;
	}
	for (int k = 0; k < 3; k++)
		pl->ext_force[k] = 0.0;
	pl->blocked = false;
	pl->driven = false;
	rng_seed(&pl->rng, pl->floor.seed);
}

void plant_set_resistance(struct plant *pl, const double R_ohm[4])
{
	for (int j = 0; j < 4; j++)
		pl->R_eff[j] = R_ohm[j];
}

void plant_set_friction_scale(struct plant *pl, double scale)
{
	struct model_params p = pl->p;

	p.Bv *= scale;
	p.Bvn *= scale;
	p.Bw *= scale;
	p.Cv *= scale;
	p.Cvn *= scale;
	p.Cw *= scale;
	pl->friction_scale = scale;
	dyn_state_space(&p, &pl->ss);
	if (pl->has_geom)
		geom_state_space(pl);
}

/* Eq 2: the ground speed at each wheel [m/s] of robot velocity x (an absent wheel's 0). */
static void rims_of(const struct plant *pl, const double x[3], double vg[4])
{
	if (pl->has_geom)
		wheel_rims(&pl->ph, x, vg);
	else
		ik_wheel_speeds(pl->p.d, x, vg);
}

/* The paper's plant: every wheel grips (the whole step exact per axis). */
/* What exact_step changes (kept to undo it: a copy of the whole plant costs more than the step). */
struct exact_state {
	double x[3], pose[3], acc[3], current_a[4], voltage_v[4], rim[4];
	bool driven;
};

static void exact_save(const struct plant *pl, struct exact_state *st)
{
	memcpy(st->x, pl->x, sizeof(st->x));
	memcpy(st->pose, pl->pose, sizeof(st->pose));
	memcpy(st->acc, pl->acc, sizeof(st->acc));
	memcpy(st->current_a, pl->current_a, sizeof(st->current_a));
	memcpy(st->voltage_v, pl->voltage_v, sizeof(st->voltage_v));
	memcpy(st->rim, pl->rim, sizeof(st->rim));
	st->driven = pl->driven;
}

static void exact_restore(struct plant *pl, const struct exact_state *st)
{
	memcpy(pl->x, st->x, sizeof(st->x));
	memcpy(pl->pose, st->pose, sizeof(st->pose));
	memcpy(pl->acc, st->acc, sizeof(st->acc));
	memcpy(pl->current_a, st->current_a, sizeof(st->current_a));
	memcpy(pl->voltage_v, st->voltage_v, sizeof(st->voltage_v));
	memcpy(pl->rim, st->rim, sizeof(st->rim));
	pl->driven = st->driven;
}

static void exact_step(struct plant *pl, const double u[4], bool driven, double dt)
{
	const struct model_ss *ss = &pl->ss;
	const double x_old[3] = {pl->x[0], pl->x[1], pl->x[2]};
	const double inertia[3] = {pl->p.M, pl->p.M, pl->p.J};

	for (int k = 0; k < 3; k++) {
		double b = 0.0;

		if (driven)
			for (int j = 0; j < 4; j++)
				b += ss->B[k][j] * u[j];
		if (pl->ext_force[k] != 0.0)
			b += pl->ext_force[k] / inertia[k];
		pl->x[k] =
		    axis_step(driven ? ss->A[k] : ss->A_coast[k], b, -ss->K[k], pl->x[k], dt);
	}

	/* World pose: eq 1 inverted with the mid-step heading and mean velocity. */
	const double x_mid[3] = {0.5 * (x_old[0] + pl->x[0]), 0.5 * (x_old[1] + pl->x[1]),
	                         0.5 * (x_old[2] + pl->x[2])};
	double xw[3];

	frame_robot_to_world(pl->pose[2] + 0.5 * dt * x_mid[2], x_mid, xw);
	for (int k = 0; k < 3; k++) {
		pl->pose[k] += dt * xw[k];
		pl->acc[k] = (pl->x[k] - x_old[k]) / dt;
	}

	double vw[4];

	rims_of(pl, pl->x, vw);
	for (int j = 0; j < 4; j++) {
		pl->voltage_v[j] = driven ? u[j] : 0.0;
		pl->current_a[j] =
		    driven ? motor_current(&pl->p, u[j], motor_speed_rad_s(&pl->p, vw[j])) : 0.0;
		pl->rim[j] = vw[j];
	}
	pl->driven = driven;
}

/* The traction limit of a wheel carrying a quarter of the weight, mu M g / 4 [N]. */
static double traction_limit(const struct plant *pl)
{
	return pl->floor.traction_mu * pl->p.M * MODEL_G_M_S2 / 4.0;
}

/* Normal loads N_j with the load transfer of acceleration acc at velocity x (plant.h), and the
 * drive-direction force each holds, mu N_j. */
static void loads_at(const struct plant *pl, const double x[3], const double acc[3],
                     double normal[4], double hold[4])
{
	const struct model_params *p = &pl->p;

	if (pl->has_geom) { /* the layout's least-norm loads (wheels.h) */
		double ac[2];

		wheel_com_accel(x, acc, ac);
		wheel_loads(&pl->ph, ac, normal);
		for (int j = 0; j < 4; j++)
			hold[j] = pl->floor.traction_mu * normal[j];
		return;
	}
	const double quarter = p->M * MODEL_G_M_S2 / 4.0;
	const double av = acc[0] - x[2] * x[1], avn = acc[1] + x[2] * x[0]; /* centre of mass */
	const double ap[4] = {av, avn, -av, -avn};                          /* a . p_j / d */
	const double k = p->M * pl->floor.com_height / (2.0 * p->d);

	for (int j = 0; j < 4; j++) {
		normal[j] = fmax(0.0, quarter - k * ap[j]);
		hold[j] = traction_limit(pl) * normal[j] / quarter;
	}
}

void plant_wheel_loads(const struct plant *pl, double normal_n[4], double hold_n[4])
{
	loads_at(pl, pl->x, pl->acc, normal_n, hold_n);
}

/* Traction force [N] a gripping wheel j needs at ground speed v [m/s] (massless wheel,
 * eqs 12-13 with eq 21 at radius r_eff_j). */
static double grip_force(const struct plant *pl, int j, double u, bool driven, double v)
{
	const struct model_params *p = &pl->p;
	const double rj = pl->r_eff[j];

	if (!driven)
		return 0.0;
	return p->l * pl->Kt_eff[j] * (u - pl->Kv_eff[j] * p->l * v / rj) / (pl->R_eff[j] * rj);
}

/* Does a gripping wheel need more than it holds at robot velocity x and acceleration acc? */
static bool beyond_limit(const struct plant *pl, const double u[4], bool driven, const double x[3],
                         const double acc[3])
{
	double vg[4], normal[4], lim[4];

	if (!(pl->floor.traction_mu > 0.0))
		return false;
	loads_at(pl, x, acc, normal, lim);
	rims_of(pl, x, vg);
	for (int j = 0; j < 4; j++)
		if (fabs(grip_force(pl, j, u[j], driven, vg[j])) > lim[j])
			return true;
	return false;
}

/* Wheel j's share of the robot forces (eqs 9-11): robot_f[k] = sum_j G(k, j) f_j. */
static double g_coef(const struct plant *pl, int k, int j)
{
	static const double G[3][4] = {{0, -1, 0, 1}, {1, 0, -1, 0}, {1, 1, 1, 1}};

	if (pl->has_geom)
		return pl->ph.row[j][k]; /* G^T of the layout's rows */
	return k == 2 ? pl->p.d * G[2][j] : G[k][j];
}

/* Eq 2's row j: v_j = IK(j, :) x. */
static double ik_coef(const struct plant *pl, int j, int k)
{
	static const double IK[4][3] = {{0, 1, 1}, {-1, 0, 1}, {0, -1, 1}, {1, 0, 1}};

	if (pl->has_geom)
		return pl->ph.row[j][k];
	return k == 2 ? pl->p.d * IK[j][2] : IK[j][k];
}

/* The body's per-axis x' = a x + b - c sgn(x) for a substep: viscous friction and the external
 * force, each slipping wheel's kinetic force F dir_j (wheels breaking loose now start slipping
 * along their force), each gripping wheel's motor force with its own axis's back-EMF in a and
 * the other axes' held from the substep's start (eqs 9-13, 21). */
static void substep_forces(struct plant *pl, const double u[4], bool driven, const double lim[4],
                           double a[3], double b[3], int dir[4])
{
	const struct model_params *p = &pl->p;
	const double inertia[3] = {p->M, p->M, p->J};
	double vg[4];

	rims_of(pl, pl->x, vg);
	for (int k = 0; k < 3; k++) {
		a[k] = pl->ss.A_coast[k]; /* viscous friction only: the motors come in per wheel */
		b[k] = pl->ext_force[k] / inertia[k];
	}
	for (int j = 0; j < 4; j++) {
		if (!pl->slipping[j] && pl->floor.traction_mu > 0.0) {
			const double fg = grip_force(pl, j, u[j], driven, vg[j]);

			if (fabs(fg) >
			    lim[j]) { /* breaks loose: slip velocity 0, growing along fg */
				pl->slipping[j] = true;
				pl->slip_dir[j] = (int8_t)(fg > 0 ? 1 : -1);
				pl->rim[j] = vg[j];
			}
		}
		dir[j] = 0;
		if (pl->slipping[j]) {
			const double sig = pl->rim[j] - vg[j];

			dir[j] = sig > 0 ? 1 : (sig < 0 ? -1 : pl->slip_dir[j]);
			for (int k = 0; k < 3; k++)
				b[k] += g_coef(pl, k, j) * lim[j] * dir[j] / inertia[k];
		} else if (driven) {
			/* f_j = c1 u_j - c2 v_j: the own axis's back-EMF exact, the others held. */
			const double rj = pl->r_eff[j];
			const double Kt = pl->Kt_eff[j], R = pl->R_eff[j];
			const double c1 = p->l * Kt / (R * rj);
			const double c2 = p->l * p->l * Kt * pl->Kv_eff[j] / (R * rj * rj);

			for (int k = 0; k < 3; k++) {
				const double g = g_coef(pl, k, j);
				double other = 0.0;

				if (g == 0.0)
					continue;
				for (int m = 0; m < 3; m++)
					if (m != k)
						other += ik_coef(pl, j, m) * pl->x[m];
				a[k] -= g * c2 * ik_coef(pl, j, k) / inertia[k];
				b[k] += g * (c1 * u[j] - c2 * other) / inertia[k];
			}
		}
	}
}

/* The wheels after a substep: a slipping one on its own inertia, J_w w' = l Kt i - r F dir_j,
 * until its slip velocity returns to 0; a gripping one at its ground speed. */
static void substep_wheels(struct plant *pl, const double u[4], bool driven, const double lim[4],
                           const int dir[4], double h)
{
	const struct model_params *p = &pl->p;
	const double Jw = pl->floor.wheel_inertia;
	double vg[4];

	rims_of(pl, pl->x, vg);
	for (int j = 0; j < 4; j++) {
		if (!pl->slipping[j]) {
			pl->rim[j] = vg[j];
			continue;
		}
		const double rj = pl->r_eff[j], Kt = pl->Kt_eff[j], R = pl->R_eff[j];
		const double aw = driven ? -p->l * p->l * Kt * pl->Kv_eff[j] / (Jw * R) : 0.0;
		const double bw = (driven ? rj * p->l * Kt * u[j] / (Jw * R) : 0.0) -
		                  rj * rj * lim[j] * dir[j] / Jw;
		const double rim = lin_solve(aw, bw, pl->rim[j], h);
		const double sig = rim - vg[j];

		if (sig * dir[j] > 0) {
			pl->rim[j] = rim;
		} else { /* the slip velocity came back to 0: grips again */
			pl->slipping[j] = false;
			pl->slip_dir[j] = 0;
			pl->rim[j] = vg[j];
		}
	}
}

/* One substep of h with some wheel slipping, or with the body blocked, radius or motor errors. */
static void floor_substep(struct plant *pl, const double u[4], bool driven, double h)
{
	const double x_old[3] = {pl->x[0], pl->x[1], pl->x[2]};
	double a[3], b[3], normal[4], lim[4];
	int dir[4];

	loads_at(pl, pl->x, pl->acc, normal, lim);
	substep_forces(pl, u, driven, lim, a, b, dir);
	if (pl->blocked) {
		for (int k = 0; k < 3; k++) {
			pl->x[k] = 0.0;
			pl->acc[k] = 0.0;
		}
	} else {
		for (int k = 0; k < 3; k++)
			pl->x[k] = axis_step(a[k], b[k], -pl->ss.K[k], pl->x[k], h);
		const double x_mid[3] = {0.5 * (x_old[0] + pl->x[0]), 0.5 * (x_old[1] + pl->x[1]),
		                         0.5 * (x_old[2] + pl->x[2])};
		double xw[3];

		frame_robot_to_world(pl->pose[2] + 0.5 * h * x_mid[2], x_mid, xw);
		for (int k = 0; k < 3; k++) {
			pl->pose[k] += h * xw[k];
			pl->acc[k] = (pl->x[k] - x_old[k]) / h;
		}
	}
	substep_wheels(pl, u, driven, lim, dir, h);
}

static void floor_step(struct plant *pl, const double u[4], bool driven, double dt)
{
	const struct model_params *p = &pl->p;
	int n = (int)ceil(dt / PLANT_SUBSTEP_S - 1e-9);

	if (n < 1)
		n = 1;
	if (pl->blocked)
		for (int k = 0; k < 3; k++)
			pl->x[k] = 0.0;
	for (int i = 0; i < n; i++)
		floor_substep(pl, u, driven, dt / n);
	for (int j = 0; j < 4; j++) {
		pl->voltage_v[j] = driven ? u[j] : 0.0;
		pl->current_a[j] =
		    driven
		        ? (u[j] - pl->Kv_eff[j] * p->l * pl->rim[j] / pl->r_eff[j]) / pl->R_eff[j]
		        : 0.0;
	}
	pl->driven = driven;
}

/* The creep process over dt (Gauss-Markov, stationary std dev slip_noise, per m/s). */
static void creep_step(struct plant *pl, double dt)
{
	const double phi = exp(-dt / PLANT_CREEP_TAU_S);
	const double q = pl->floor.slip_noise * sqrt(1.0 - phi * phi);

	for (int j = 0; j < 4; j++)
		pl->creep[j] = phi * pl->creep[j] + rng_normal(&pl->rng, q);
}

void plant_step(struct plant *pl, const double u_v[4], bool driven, double dt)
{
	const int n = pl->has_geom ? pl->ph.n : 4;
	/* A three-wheel robot has no motor in slot 3: 0 V there (its row and load are 0 too). */
	const double u[4] = {u_v[0], u_v[1], u_v[2], n > 3 ? u_v[3] : 0.0};
	bool general = pl->blocked || (pl->coupled && driven); /* coupled: substeps (plant.h) */

	for (int j = 0; j < 4; j++)
		general = general || pl->slipping[j] || pl->floor.radius_error[j] != 0.0 ||
		          pl->R_eff[j] != pl->p.R || pl->floor.Kv_error[j] != 0.0;
	if (!general && beyond_limit(pl, u, driven, pl->x, pl->acc))
		general = true;
	if (!general) {
		struct exact_state before;

		exact_save(pl, &before);
		exact_step(pl, u, driven, dt);
		if (beyond_limit(pl, u, driven, pl->x, pl->acc)) { /* broke loose inside the step */
			exact_restore(pl, &before);
			general = true;
		}
	}
	if (general)
		floor_step(pl, u, driven, dt);
	if (pl->floor.slip_noise > 0.0)
		creep_step(pl, dt);
}

/* The creep's part of each rim speed [m/s]: the process times the ground speed. */
static void creep_m_s(const struct plant *pl, const double vg[4], double c[4])
{
	for (int j = 0; j < 4; j++)
		c[j] = pl->creep[j] * fabs(vg[j]);
}

void plant_wheel_speeds(const struct plant *pl, double wheel_rad_s[4])
{
	double vg[4], c[4];

	if (!(pl->floor.slip_noise > 0.0)) {
		for (int j = 0; j < 4; j++)
			wheel_rad_s[j] = pl->rim[j] / pl->r_eff[j];
		return;
	}
	rims_of(pl, pl->x, vg);
	creep_m_s(pl, vg, c);
	for (int j = 0; j < 4; j++)
		wheel_rad_s[j] = (pl->rim[j] + c[j]) / pl->r_eff[j];
}

void plant_wheel_slip(const struct plant *pl, double slip_m_s[4])
{
	double vg[4], c[4];

	rims_of(pl, pl->x, vg);
	creep_m_s(pl, vg, c);
	for (int j = 0; j < 4; j++)
		slip_m_s[j] = pl->rim[j] + c[j] - vg[j];
}

uint32_t plant_slip_flags(const struct plant *pl)
{
	uint32_t f = 0;

	for (int j = 0; j < 4; j++)
		if (pl->slipping[j])
			f |= 1u << j;
	return f;
}
