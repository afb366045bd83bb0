/* params.c - Table III defaults, field access by name index, and the sanity check. */
#include "omni4/model/params.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

const struct model_params model_params_table3 = {
    .d = 0.089,
    .r = 0.0325,
    .l = 5.0,
    .Kv = 0.0259,
    .Kt = 0.0259,
    .R = 4.3111,
    .M = 2.34,
    .J = 0.0228,
    .Bv = 0.4978,
    .Bvn = 0.6763,
    .Bw = 0.0141,
    .Cv = 1.8738,
    .Cvn = 2.2198,
    .Cw = 0.1385,
};

const char *const model_params_names[MODEL_PARAMS_COUNT] = {
    "d", "r", "l", "Kv", "Kt", "R", "M", "J", "Bv", "Bvn", "Bw", "Cv", "Cvn", "Cw",
};

/* The first 8 fields (d .. J) must be strictly positive; frictions may be zero. */

double *model_params_field(struct model_params *p, int i)
{
	double *const f[MODEL_PARAMS_COUNT] = {&p->d,  &p->r,  &p->l,   &p->Kv, &p->Kt,
	                                       &p->R,  &p->M,  &p->J,   &p->Bv, &p->Bvn,
	                                       &p->Bw, &p->Cv, &p->Cvn, &p->Cw};

	return i < 0 || i >= MODEL_PARAMS_COUNT ? NULL : f[i];
}

double model_params_get(const struct model_params *p, int i)
{
	/* model_params_field only takes addresses; nothing is written through p here. */
	const double *f = model_params_field((struct model_params *)p, i);

	return f ? *f : NAN;
}

#define LO_HI(x) {MODEL_LO_##x, MODEL_HI_##x}
static const double range[MODEL_PARAMS_COUNT][2] = {
    LO_HI(d), LO_HI(r),  LO_HI(l),   LO_HI(Kv), LO_HI(Kt), LO_HI(R),   LO_HI(M),
    LO_HI(J), LO_HI(Bv), LO_HI(Bvn), LO_HI(Bw), LO_HI(Cv), LO_HI(Cvn), LO_HI(Cw),
};

int model_params_range(int i, double *lo, double *hi)
{
	if (i < 0 || i >= MODEL_PARAMS_COUNT)
		return -EINVAL;
	*lo = range[i][0];
	*hi = range[i][1];
	return 0;
}

/* v within parameter i's range (NaN is not). */
static bool in_range(int i, double v)
{
	return v >= range[i][0] && v <= range[i][1];
}

int model_params_check(const struct model_params *p, int *bad)
{
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++) {
		const double v = model_params_get(p, i);
		const bool ok = in_range(i, v); /* finite, and > 0 or >= 0 as its range says */

		if (!ok) {
			if (bad)
				*bad = i;
			return -EINVAL;
		}
	}
	return 0;
}

void model_wheels_from_params(const struct model_params *p, struct model_wheels *w)
{
	for (int j = 0; j < 4; j++) {
		w->r[j] = p->r;
		w->Kv[j] = p->Kv;
		w->Kt[j] = p->Kt;
		w->R[j] = p->R;
	}
}

int model_wheels_check(const struct model_wheels *w, int *bad)
{
	const double *const f[4] = {w->r, w->Kv, w->Kt, w->R};
	static const int scalar[4] = {1, 3, 4, 5}; /* r, Kv, Kt, R in model_params_names */

	for (int i = 0; i < 16; i++) {
		const double v = f[i / 4][i % 4];

		if (!in_range(scalar[i / 4], v)) { /* finite, > 0: r, Kv, Kt, R's ranges */
			if (bad)
				*bad = i;
			return -EINVAL;
		}
	}
	return 0;
}
