/* est_settings.c - the estimator's noise figures and thresholds: the defaults (est_keys.def),
 * the INI's doubles as the filter's floats, and their check (est.h; docs/estimator.md, "Noise
 * figures and thresholds"). */
#include <errno.h>

#include "omni4/core/est.h"
#include "omni4/core/est_keys.h"

void est_keys_defaults(struct est_keys *k)
{
#define OMNI4_KEY(kind, section, key, field, def, ...) k->field = (def);
#include "omni4/core/est_keys.def"
#undef OMNI4_KEY
}

/* A key's value as the filter's member: doubles to float, the rest as they are. */
#define EST_FROM_KEY_DBL(v) ((float)(v))
#define EST_FROM_KEY_INT(v) (v)
#define EST_FROM_KEY_BOOL(v) (v)

void est_settings_from_keys(const struct est_keys *k, struct est_settings *s)
{
#define OMNI4_KEY(kind, section, key, field, ...) s->field = EST_FROM_KEY_##kind(k->field);
#include "omni4/core/est_keys.def"
#undef OMNI4_KEY
}

void est_settings_defaults(struct est_settings *s)
{
	struct est_keys k;

	est_keys_defaults(&k);
	est_settings_from_keys(&k, s);
}

int est_settings_check(const struct est_settings *s)
{
	const float pos[] = {s->accel_noise_lin,   s->accel_noise_rot,     s->wheel_noise,
	                     s->cam_pos_noise,     s->cam_theta_noise,     s->gate_sigmas,
	                     s->slip_threshold,    s->collision_threshold, s->slip_model_threshold,
	                     s->slip_camera_sigmas};

	for (unsigned k = 0; k < sizeof(pos) / sizeof(pos[0]); k++)
		if (!(pos[k] > 0.0f && pos[k] < 1e6f))
			return -EINVAL;
	return s->slip_ticks >= 1 && s->collision_ticks >= 1 ? 0 : -EINVAL;
}
