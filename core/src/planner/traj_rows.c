/*
 * traj_rows.c - the drive envelope of the trajectory generator (docs/trajectory.md): each wheel's
 * voltage, traction and rim speed as linear rows in the world frame at a heading (the brake
 * prelude's and the turn in place's), the acceleration they leave at rest, and traj_envelope
 * along a direction.
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdbool.h>

#include "traj_int.h"

/* Largest A with every row met (velocity half widths wx, wy); -1 if a velocity-only row fails. */
float traj_rows_acc(const struct row *r, int n, float ca, float sa, float wx, float wy)
{
	const float speed = sqrtf(wx * wx + wy * wy); /* |v| over the box */
	float best = INFINITY;

	for (int k = 0; k < n; k++) {
		const float room = r[k].c - r[k].kv[0] * wx - r[k].kv[1] * wy - r[k].kc * speed;
		const float per = r[k].ka[0] * ca + r[k].ka[1] * sa;
		if (per > 0.0f)
			best = minf(best, room / per);
		else if (room < 0.0f)
			return -1.0f;
	}
	return best;
}

/* Wheel j's load floor at heading (cos cp, sin sp): the load an acceleration takes off it (the
 * traction rows' sl, either sign) within lift_max, so the wheel keeps the traction margin's share
 * of its static load (a wheel that pushes nothing would otherwise be unloaded to 0: a tall
 * robot's braking on a grippy floor lifting it). No velocity terms. */
static struct row load_row(const struct traj_coef *c, int j, float cp, float sp, float cos_h)
{
	const float lx = c->f_load[j][0], ly = c->f_load[j][1];
	struct row r = {.sl = {cp * lx - sp * ly, sp * lx + cp * ly},
	                .c = c->lift_max[j] * cos_h,
	                .c0 = c->lift_max[j] * cos_h,
	                .credit = true,
	                .ph = {cp, sp}};

	r.ka[0] = fabsf(r.sl[0]);
	r.ka[1] = fabsf(r.sl[1]);
	return r;
}

/*
 * Translation rows at heading phi: wheel j's force, voltage and rim speed in the world frame
 * (k_w = R(phi) k_robot), a share `share` of the budgets, Coulomb friction with its worst
 * sign, the room scaled by cos_h (the headings between two samples: docs/trajectory.md).
 */
int traj_rows_translation(const struct traj_coef *c, float phi, float share, float cos_h,
                          float w_max, struct row *r)
{
	const float cp = cosf(phi), sp = cosf(phi - 0.5f * PI_F);
	int n = 0;

	for (int j = 0; j < c->wh.n; j++) {
		/* wheel j's rim (eq 2) and its share of the body's force (wheels.h) */
		const float *row = c->wh.row[j], *sh = c->wh.split[j];
		const float fa[2] = {c->M * sh[0], c->M * sh[1]};
		const float fv[2] = {sh[0] * c->B[0], sh[1] * c->B[1]};
		const float coul = fabsf(sh[0]) * c->C[0] + fabsf(sh[1]) * c->C[1];
		const float uv[2] = {(fv[0] + c->e[j] * row[0]) / c->wh.b[j],
		                     (fv[1] + c->e[j] * row[1]) / c->wh.b[j]};
		const float *ka[3] = {fa, fa, NULL}, *kv[3] = {fv, uv, row};
		const float kscale[3] = {1.0f, 1.0f / c->wh.b[j], 0.0f};
		/* wheel j's share of M w x v: M w |sh_j x v| <= M w_max |sh_j| |v| */
		const float turn = c->M * w_max * c->turn[j];
		const float room[3] = {share * c->f_max_n[j] - coul,
		                       share * c->u_max_v - coul / c->wh.b[j],
		                       share * c->rim_max[j]};
		const float room0[3] = {share * c->f_max_n[j], share * c->u_max_v,
		                        share * c->rim_max[j]};
		const bool one_axis =
		    fabsf(sh[0] * sh[1]) <= 1e-6f * (sh[0] * sh[0] + sh[1] * sh[1]);
		for (int q = 0; q < 3; q++, n++) {
			const float ax = ka[q] ? ka[q][0] * kscale[q] : 0.0f;
			const float ay = ka[q] ? ka[q][1] * kscale[q] : 0.0f;
			r[n].sa[0] = cp * ax - sp * ay;
			r[n].sa[1] = sp * ax + cp * ay;
			r[n].sv[0] = cp * kv[q][0] - sp * kv[q][1];
			r[n].sv[1] = sp * kv[q][0] + cp * kv[q][1];
			/* traction: the load an acceleration takes off wheel j (wheels.h) */
			const float lx = q ? 0.0f : c->f_load[j][0],
			            ly = q ? 0.0f : c->f_load[j][1];
			r[n].sl[0] = cp * lx - sp * ly;
			r[n].sl[1] = sp * lx + cp * ly;
			for (int i = 0; i < 2; i++) {
				r[n].ka[i] = fabsf(r[n].sa[i]) + fabsf(r[n].sl[i]);
				r[n].kv[i] = fabsf(r[n].sv[i]);
			}
			r[n].kc = turn * kscale[q];
			r[n].c = room[q] * cos_h;
			r[n].c0 = room0[q] * cos_h;
			r[n].credit = one_axis;
			r[n].cs[0] = sh[0] * c->C[0] * kscale[q];
			r[n].cs[1] = sh[1] * c->C[1] * kscale[q];
			r[n].ph[0] = cp;
			r[n].ph[1] = sp;
			r[n].fixed = w_max == 0.0f && cos_h == 1.0f;
		}
		if (c->f_load[j][0] != 0.0f || c->f_load[j][1] != 0.0f)
			r[n++] = load_row(c, j, cp, sp, cos_h);
	}
	return n;
}

/* One rotation row: ka a + kv w <= c, one axis, every coefficient >= 0 (signed = box), the
 * velocity terms opposing a braking acceleration; c0 the room braking (the stop), where the
 * Coulomb term, which opposes the turn, helps: without it a stop at a small share of the
 * budget braked slower than the friction alone and the wheels pushed against it beyond their
 * share (1.086 of a wheel's traction braking a turning start). */
static struct row rotation_row(float ka, float kv, float c, float c0)
{
	return (struct row){.ka = {ka, 0.0f},
	                    .kv = {kv, 0.0f},
	                    .c = c,
	                    .c0 = c0,
	                    .sa = {ka, 0.0f},
	                    .sv = {kv, 0.0f},
	                    .credit = true};
}

/* Rotation rows: T = J a + Bw w + Cw sgn w, wheel j's share q_j T (wheels.h: 1 / (4 d) for the
 * paper's layout), plus back-EMF e_j d_j w. */
int traj_rows_rotation(const struct traj_coef *c, float share, struct row *r)
{
	for (int j = 0; j < c->wh.n; j++) {
		const float ib = 1.0f / c->wh.b[j], q = c->wh.split[j][2], dj = c->wh.row[j][2];
		const float f = share * c->f_max_n[j], u = share * c->u_max_v;
		r[3 * j] = rotation_row(c->J * q, c->B[2] * q, f - c->C[2] * q, f + c->C[2] * q);
		r[3 * j + 1] = rotation_row(c->J * q * ib, (c->B[2] * q + c->e[j] * dj) * ib,
		                            u - c->C[2] * q * ib, u + c->C[2] * q * ib);
		r[3 * j + 2] = rotation_row(0.0f, dj, share * c->rim_max[j], share * c->rim_max[j]);
	}
	return 3 * c->wh.n;
}

/* Largest a >= 0 with k a <= b. */
static float room_up(float k, float b)
{
	if (k > 0.0f)
		return b / k;
	return b >= 0.0f ? INFINITY : -INFINITY;
}

/* Wheel j's limit on a >= 0 along dir: p a + q within +-(bound - lift a). */
static float acc_room(float p, float q, float bound, float lift)
{
	return minf(room_up(p + lift, bound - q), room_up(lift - p, bound + q));
}

int traj_envelope(const struct traj *tr, const float dir[2], float speed_m_s, float *acc_m_s2,
                  float *speed_max_m_s)
{
	if (!isfinite(dir[0]) || !isfinite(dir[1]) || !isfinite(speed_m_s) || speed_m_s < 0.0f ||
	    fabsf(dir[0] * dir[0] + dir[1] * dir[1] - 1.0f) > 1e-3f)
		return -EINVAL;
	const struct traj_coef *c = &tr->c;
	const float sg[2] = {dir[0] > 0.0f   ? 1.0f
	                     : dir[0] < 0.0f ? -1.0f
	                                     : 0.0f,
	                     dir[1] > 0.0f   ? 1.0f
	                     : dir[1] < 0.0f ? -1.0f
	                                     : 0.0f};
	float acc = INFINITY, top = c->speed_cap_m_s;

	for (int j = 0; j < c->wh.n; j++) {
		const float *row = c->wh.row[j], *sp = c->wh.split[j], *fl = c->f_load[j];
		const float ge = row[0] * dir[0] + row[1] * dir[1]; /* rim speed per unit speed */
		/* f_j = p a + q0 + q1 s (the force split, wheels.h), u_j = (f_j + e_j ge s)/b_j */
		const float p = c->M * (sp[0] * dir[0] + sp[1] * dir[1]);
		const float q0 = sp[0] * c->C[0] * sg[0] + sp[1] * c->C[1] * sg[1];
		const float q1 = sp[0] * c->B[0] * dir[0] + sp[1] * c->B[1] * dir[1];
		const float s = speed_m_s;
		const float lift = fl[0] * dir[0] + fl[1] * dir[1]; /* the load it takes off */
		acc = minf(acc, acc_room(p, q0 + q1 * s, c->f_max_n[j], lift));
		acc = minf(acc, room_up(lift, c->lift_max[j])); /* the load's floor */
		acc = minf(
		    acc, acc_room(p, q0 + (q1 + c->e[j] * ge) * s, c->u_max_v * c->wh.b[j], 0.0f));
		/* top speed: where the room reaches 0 (room falls linearly with s) */
		const float k_u = p >= 0.0f ? q1 + c->e[j] * ge : -(q1 + c->e[j] * ge);
		const float r_u = c->u_max_v * c->wh.b[j] - (p >= 0.0f ? q0 : -q0);
		const float k_f = p >= 0.0f ? q1 : -q1,
		            r_f = c->f_max_n[j] - (p >= 0.0f ? q0 : -q0);
		if (ge == 0.0f)
			continue;
		top = minf(top, k_u > 0.0f ? r_u / k_u : r_u < 0.0f ? 0.0f : INFINITY);
		top = minf(top, k_f > 0.0f ? r_f / k_f : r_f < 0.0f ? 0.0f : INFINITY);
		top = minf(top, c->rim_max[j] / fabsf(ge));
	}
	*acc_m_s2 = acc;
	*speed_max_m_s = maxf(top, 0.0f);
	return 0;
}

/* Headings sampled over a turn: one per this step at most (cos(step/2) = 0.98 of the budget),
 * TRAJ_HEADINGS_MAX at most (a turn of 2 pi: cos(pi/8) = 0.92). */
#define HEADING_STEP_RAD (PI_F / 8.0f)

/* Headings sampled over [lo, hi] (a whole turn at most) and cos of half their spacing. */
int traj_heading_samples(float lo, float hi, float phi[TRAJ_HEADINGS_MAX], float *cos_h)
{
	const float span = minf(hi - lo, 2.0f * PI_F);
	int n = 1;

	*cos_h = 1.0f;
	phi[0] = lo;
	if (span > 1e-4f) {
		n = 1 + (int)ceilf(span / HEADING_STEP_RAD);
		n = n > TRAJ_HEADINGS_MAX ? TRAJ_HEADINGS_MAX : n;
		const float step = span / (float)(n - 1);
		for (int k = 0; k < n; k++)
			phi[k] = lo + step * (float)k;
		*cos_h = cosf(0.5f * step);
	}
	return n;
}
