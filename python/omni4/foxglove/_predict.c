/*
 * _predict.c - the model's prediction beside the encoders, for omni4-bridge and omni4-mcap.
 *
 * Built by python/setup.py together with model/src/*.c into one shared library that Python
 * loads with ctypes (no Python API here). Everything physical is model/'s: eqs 3-5 are
 * fk_robot_velocity, the prediction is plant_step (eq 23 with Coulomb friction and stiction,
 * bridges off = null traction). This file only decides when the prediction starts, as
 * omni4-ident validate does: the voltage logged at tick k acts until tick k + 1, and the
 * model restarts from the encoder velocity
 *   - at the first sample,
 *   - after lost samples (a seq gap) or a jump in time (utime not increasing, or a step
 *     longer than OMNI4_PRED_MAX_GAP_US),
 *   - when the bridges switch on or off (a mode change between driven and not driven,
 *     mode_drives of core's vocab.h): each drive and each coast-down is predicted from
 *     its start, so the difference shows the model's error over that run, not an old one.
 * The wheels' layout (omni4_predictor_set_layout): the paper's four by default, in the closed
 * forms of eqs 3-5 and 23 with d; any other (three wheels, or four at other angles or
 * distances) is given to the plant (plant_set_geom) and the encoder velocity is the layout's
 * least-squares inverse of eq 2 (wheel_body of its struct wheel_phys).
 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "omni4/model/kinematics.h"
#include "omni4/model/params.h"
#include "omni4/model/plant.h"
#include "omni4/model/wheels.h"
#include "omni4/core/vocab.h"

#define OMNI4_PRED_MAX_GAP_US 50000 /* a step longer than 50 ms is a jump in time */

struct omni4_predictor {
	struct plant pl;
	int have;          /* a previous sample exists */
	int64_t utime;     /* previous sample [us] */
	int64_t seq;       /* previous sample's seq */
	int driven;        /* previous sample's bridges on */
	double u[4];       /* previous sample's voltages [V] */
};

size_t omni4_predictor_size(void)
{
	return sizeof(struct omni4_predictor);
}

/* params: the 14 [model] values in model_params_names order. 0, or -EINVAL (not physical). */
int omni4_predictor_init(struct omni4_predictor *p, const double params[MODEL_PARAMS_COUNT])
{
	struct model_params mp;

	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		*model_params_field(&mp, i) = params[i];
	p->have = 0;
	return plant_init(&p->pl, &mp);
}

/*
 * The same with each wheel's own drive: wheels[16] = r_0..r_3, Kv_0..Kv_3, Kt_0..Kt_3, R_0..R_3
 * (struct model_wheels' order), given to the plant as its per-wheel radii and motors. 0, or
 * -EINVAL (not physical, or a wheel 50 % or more off the scalar: the plant's range).
 */
int omni4_predictor_init_wheels(struct omni4_predictor *p, const double params[MODEL_PARAMS_COUNT],
				const double wheels[16])
{
	struct model_wheels w;
	struct plant_floor f = {0};
	int rc = omni4_predictor_init(p, params);

	for (int j = 0; j < 4; j++) {
		w.r[j] = wheels[j];
		w.Kv[j] = wheels[4 + j];
		w.Kt[j] = wheels[8 + j];
		w.R[j] = wheels[12 + j];
	}
	if (rc || model_wheels_check(&w, NULL))
		return -EINVAL;
	for (int j = 0; j < 4; j++) {
		f.radius_error[j] = w.r[j] / p->pl.p.r - 1.0;
		f.R_error[j] = w.R[j] / p->pl.p.R - 1.0;
		f.Kv_error[j] = w.Kv[j] / p->pl.p.Kv - 1.0;
	}
	if (plant_set_floor(&p->pl, &f))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		p->pl.Kt_eff[j] = w.Kt[j]; /* the plant's floor ties Kt's error to Kv's */
	return 0;
}

/* True when angle a [deg] is k quarter turns (mod 360 deg), to 1e-9 deg. */
static int at_quarter(double a, int k)
{
	return fabs(remainder(a - 90.0 * k, 360.0)) < 1e-9;
}

/* True for the paper's layout: four wheels at 0, 90, 180, 270 deg, all at one distance. */
static int paper_layout(int n, const double angle_deg[4], const double dist_m[4])
{
	int paper = n == 4;

	for (int j = 0; paper && j < 4; j++)
		paper = at_quarter(angle_deg[j], j) && dist_m[j] == dist_m[0];
	return paper;
}

/*
 * The wheels' layout from now on (after omni4_predictor_init or _init_wheels, which leave the
 * paper's): n (3 or 4) wheels at angle_deg[j] [deg] from the v axis, counter-clockwise, at
 * dist_m[j] [m] from the centre (docs/model.md "Layouts"). The paper's layout (four at 0, 90,
 * 180, 270 deg to 1e-9 deg, all at the model's d) keeps the closed forms, to the last bit as
 * without a layout; the paper's angles at another common distance are another layout. The
 * prediction restarts at the next sample. 0, or -EINVAL (not a layout that drives v, vn and
 * w; nothing changed).
 */
int omni4_predictor_set_layout(struct omni4_predictor *p, int n, const double angle_deg[4],
			       const double dist_m[4])
{
	struct wheel_geom g;
	const int paper = paper_layout(n, angle_deg, dist_m) && dist_m[0] == p->pl.p.d;

	if (!paper && wheel_geom_angles(n, angle_deg, dist_m, &g))
		return -EINVAL;
	if (plant_set_geom(&p->pl, paper ? NULL : &g))
		return -EINVAL;
	p->have = 0;
	return 0;
}

/*
 * The controller's door for a model (model_params_check, model_wheels_check): params the 14
 * values, wheels NULL or r_0..r_3, Kv_0..Kv_3, Kt_0..Kt_3, R_0..R_3. -1 if the model is
 * physical, else the offending value's index: i < 14 a scalar, 14 + 4 q + j a wheel's own.
 */
int omni4_model_check(const double params[MODEL_PARAMS_COUNT], const double *wheels)
{
	struct model_params mp;
	struct model_wheels w;
	int bad = -1;

	for (int i = 0; i < MODEL_PARAMS_COUNT; i++)
		*model_params_field(&mp, i) = params[i];
	if (model_params_check(&mp, &bad))
		return bad;
	if (!wheels)
		return -1;
	for (int j = 0; j < 4; j++) {
		w.r[j] = wheels[j];
		w.Kv[j] = wheels[4 + j];
		w.Kt[j] = wheels[8 + j];
		w.R[j] = wheels[12 + j];
	}
	return model_wheels_check(&w, &bad) ? MODEL_PARAMS_COUNT + bad : -1;
}

/* Parameter i's physical range (model_params_range). 0, or -EINVAL. */
int omni4_model_range(int i, double *lo, double *hi)
{
	return model_params_range(i, lo, hi);
}

const char *omni4_predictor_param_name(int i)
{
	return (i >= 0 && i < MODEL_PARAMS_COUNT) ? model_params_names[i] : NULL;
}

/*
 * One motors_t sample: measured[3] gets the encoder velocity (eqs 3-5 of the layout, wheel
 * speeds [rad/s] times each wheel's r_j; a three-wheel robot's slot 3 unused), predicted[3]
 * the model's velocity at this sample's time. Returns 1 if the model restarted from the
 * encoders at this sample, 0 otherwise.
 */
int omni4_predictor_step(struct omni4_predictor *p, int64_t utime, int64_t seq, int mode,
			 const float voltage[4], const float wheel_speed[4], double measured[3],
			 double predicted[3])
{
	double vw[4];
	const int driven = mode_drives(mode);
	int restart;

	for (int j = 0; j < 4; j++)
		vw[j] = (double)wheel_speed[j] * p->pl.r_eff[j]; /* each wheel's own radius */
	if (p->pl.has_geom) /* the layout's rows (the plant's struct wheel_phys) */
		wheel_body(&p->pl.ph, vw, measured);
	else
		fk_robot_velocity(p->pl.p.d, vw, measured);

	restart = !p->have || seq != p->seq + 1 || utime <= p->utime ||
		  utime - p->utime > OMNI4_PRED_MAX_GAP_US || driven != p->driven;
	if (restart) {
		for (int k = 0; k < 3; k++)
			p->pl.x[k] = measured[k];
	} else {
		plant_step(&p->pl, p->u, p->driven, (double)(utime - p->utime) * 1e-6);
	}
	for (int k = 0; k < 3; k++)
		predicted[k] = p->pl.x[k];
	p->have = 1;
	p->utime = utime;
	p->seq = seq;
	p->driven = driven;
	for (int j = 0; j < 4; j++)
		p->u[j] = voltage[j];
	return restart;
}

/* n samples at once (arrays of n, n*4, n*3): omni4_predictor_step on each, in order. */
void omni4_predictor_run(struct omni4_predictor *p, size_t n, const int64_t *utime,
			 const int64_t *seq, const int8_t *mode, const float *voltage,
			 const float *wheel_speed, double *measured, double *predicted,
			 int8_t *restarted)
{
	for (size_t k = 0; k < n; k++)
		restarted[k] = (int8_t)omni4_predictor_step(p, utime[k], seq[k], mode[k],
							     voltage + 4 * k, wheel_speed + 4 * k,
							     measured + 3 * k, predicted + 3 * k);
}
