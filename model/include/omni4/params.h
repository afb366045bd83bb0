/*
 * params.h - the robot's physical parameters (SI units) and their sanity check.
 * Default robot: the paper's Table III.
 */
#ifndef OMNI4_PARAMS_H
#define OMNI4_PARAMS_H

struct model_params {
	double d;   /* wheel distance from the robot centre [m] */
	double r;   /* wheel radius [m] */
	double l;   /* gearbox reduction [-] */
	double Kv;  /* back-EMF constant [V/(rad/s)] */
	double Kt;  /* torque constant [N m/A] */
	double R;   /* motor + H-bridge resistance [ohm] */
	double M;   /* mass [kg] */
	double J;   /* moment of inertia [kg m^2] */
	double Bv;  /* viscous friction along v [N/(m/s)] */
	double Bvn; /* viscous friction along vn [N/(m/s)] */
	double Bw;  /* viscous friction about w [N m/(rad/s)] */
	double Cv;  /* Coulomb friction along v [N] */
	double Cvn; /* Coulomb friction along vn [N] */
	double Cw;  /* Coulomb friction about w [N m] */
};

/* Table III of the paper. */
extern const struct model_params model_params_table3;

/* Names of the fields in declaration order, as used by the INI [model] section. */
#define MODEL_PARAMS_COUNT 14
/* The first MODEL_PARAMS_POSITIVE parameters (d r l Kv Kt R M J) must be > 0, the friction
 * ones >= 0. */
#define MODEL_PARAMS_POSITIVE 8
extern const char *const model_params_names[MODEL_PARAMS_COUNT];

/* Field i (0 .. MODEL_PARAMS_COUNT-1) of p, in the order of model_params_names. */
double *model_params_field(struct model_params *p, int i);
double model_params_get(const struct model_params *p, int i);

/*
 * 0 if p describes a physical robot; -EINVAL if any value is NaN/inf, d, r, l, Kv, Kt, R, M or J
 * is not positive, or a friction coefficient is negative. *bad (may be NULL) gets the index of
 * the first offending field.
 */
int model_params_check(const struct model_params *p, int *bad);

#endif /* OMNI4_PARAMS_H */
