/* ctl_settings.c - the controller's default settings (expanded from ctl_keys.def) and the checks
 * across them. No I/O: on a microcontroller these defaults are the whole configuration. */
#include "omni4/ctl_settings.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

void ctl_settings_defaults(struct ctl_settings *s)
{
	*s = (struct ctl_settings){0};
#define OMNI4_KEY(kind, section, key, field, def, ...) s->field = (def);
#include "omni4/ctl_keys.def"
#undef OMNI4_KEY
}

int ctl_settings_check(const struct ctl_settings *s, int *bad_key, const char **why)
{
	int bad = 0;

	if (model_params_check(&s->model, &bad)) {
		*bad_key = bad;
		*why = bad < MODEL_PARAMS_POSITIVE ? "must be > 0" : "must be >= 0";
		return -EINVAL;
	}
	*bad_key = -1;
	if (!(s->rate_hz > 0.0) || !isfinite(s->rate_hz)) {
		*why = "[loop] rate_hz must be > 0";
		return -EINVAL;
	}
	if (!(s->limits.supply_min_v < s->limits.supply_v)) {
		*why = "[limits] supply_min_v must be below supply_v";
		return -EINVAL;
	}
	return 0;
}
