/*
 * est_keys.h - the state estimator's settings as the INI holds them ([estimator] keys,
 * est_keys.def): doubles, ints and bools, one member per row. The filter works on a float copy
 * (struct est_settings, est.h: est_settings_from_keys).
 */
#ifndef OMNI4_EST_KEYS_H
#define OMNI4_EST_KEYS_H

#include <stdbool.h>

#define EST_KEY_TYPE_DBL double
#define EST_KEY_TYPE_INT int
#define EST_KEY_TYPE_BOOL bool

struct est_keys {
#define OMNI4_KEY(kind, section, key, field, ...) EST_KEY_TYPE_##kind field;
#include "omni4/core/est_keys.def"
#undef OMNI4_KEY
};

/* The defaults of est_keys.def. */
void est_keys_defaults(struct est_keys *k);

#endif /* OMNI4_EST_KEYS_H */
