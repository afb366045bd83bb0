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

/*
 * The physical range of each parameter, inclusive [MODEL_LO_x, MODEL_HI_x]: from a palm-sized
 * robot to a vehicle of a tonne, a decade or more beyond either on every side. A value outside
 * is a typo or a unit slip (1e300, 1e-300, Kv in rpm/V), never a robot; inside it every gain the
 * controller derives is finite in single precision. The INI key table (ctl_keys.def) and every
 * reader (the controller, the parameter service, the Python package) check these; a wheel's
 * own r_j, Kv_j, Kt_j, R_j has its scalar's range.
 */
#define MODEL_LO_d 0.01 /* m */
#define MODEL_HI_d 10.0
#define MODEL_LO_r 0.001 /* m */
#define MODEL_HI_r 1.0
#define MODEL_LO_l 0.01 /* gear ratio */
#define MODEL_HI_l 1000.0
#define MODEL_LO_Kv 1e-4 /* V/(rad/s) */
#define MODEL_HI_Kv 5.0
#define MODEL_LO_Kt 1e-4 /* N m/A */
#define MODEL_HI_Kt 5.0
#define MODEL_LO_R 1e-3 /* ohm */
#define MODEL_HI_R 1000.0
#define MODEL_LO_M 0.01 /* kg */
#define MODEL_HI_M 10000.0
#define MODEL_LO_J 1e-6 /* kg m^2 */
#define MODEL_HI_J 10000.0
#define MODEL_LO_Bv 0.0 /* N/(m/s) */
#define MODEL_HI_Bv 10000.0
#define MODEL_LO_Bvn 0.0 /* N/(m/s) */
#define MODEL_HI_Bvn 10000.0
#define MODEL_LO_Bw 0.0 /* N m/(rad/s) */
#define MODEL_HI_Bw 1000.0
#define MODEL_LO_Cv 0.0 /* N */
#define MODEL_HI_Cv 100000.0
#define MODEL_LO_Cvn 0.0 /* N */
#define MODEL_HI_Cvn 100000.0
#define MODEL_LO_Cw 0.0 /* N m */
#define MODEL_HI_Cw 10000.0

/* Parameter i's range (model_params_names order) into *lo, *hi. -EINVAL if i is not one. */
int model_params_range(int i, double *lo, double *hi);

/* Field i (0 .. MODEL_PARAMS_COUNT-1) of p, in the order of model_params_names. */
double *model_params_field(struct model_params *p, int i);
double model_params_get(const struct model_params *p, int i);

/*
 * 0 if p describes a physical robot: every value finite and within its range (MODEL_LO_x ..
 * MODEL_HI_x: d, r, l, Kv, Kt, R, M and J > 0, frictions >= 0); -EINVAL otherwise. *bad (may be
 * NULL) gets the index of the first offending field.
 */
int model_params_check(const struct model_params *p, int *bad);

/*
 * The drive constants of each wheel j = 0..3 (docs/model.md): its own wheel radius, back-EMF
 * and torque constants and motor + H-bridge resistance. The rest (d, l, M, J and the body's
 * friction) stays one per robot in struct model_params. Every function taking a struct
 * model_wheels reads r, Kv, Kt and R from it and ignores those fields of struct model_params.
 */
struct model_wheels {
	double r[4];  /* wheel radius [m] */
	double Kv[4]; /* back-EMF constant [V/(rad/s)] */
	double Kt[4]; /* torque constant [N m/A] */
	double R[4];  /* motor + H-bridge resistance [ohm] */
};

/* Four equal wheels with the scalar r, Kv, Kt, R of p: the paper's robot. With these, every
 * _wheels function gives the same bits as its scalar twin. */
void model_wheels_from_params(const struct model_params *p, struct model_wheels *w);

/*
 * 0 if every r, Kv, Kt and R of w is finite and within its scalar's range (MODEL_LO_r ..
 * MODEL_HI_r, ...); -EINVAL otherwise, and *bad (may be NULL) gets 4 * field + wheel of the
 * first offending value (field 0 r, 1 Kv, 2 Kt, 3 R).
 */
int model_wheels_check(const struct model_wheels *w, int *bad);

/*
 * A model is checked once, where it comes in (ctl_settings_check: the INI, a parameter change,
 * the controller's start); the functions behind that door take it as checked. Their
 * precondition, asserted in debug builds only (no NDEBUG: a trap, no libc), free in release.
 */
#ifdef NDEBUG
#define MODEL_ASSERT_CHECKED(p, w) ((void)0)
#else
#define MODEL_ASSERT_CHECKED(p, w)                                                                 \
	((model_params_check((p), NULL) || model_wheels_check((w), NULL)) ? __builtin_trap()       \
	                                                                  : (void)0)
#endif

#endif /* OMNI4_PARAMS_H */
