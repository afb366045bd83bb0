/* ctl_settings.c - the controller's default settings (expanded from ctl_keys.def) and the checks
 * across them. No I/O: on a microcontroller these defaults are the whole configuration. */
#include "omni4/core/ctl_settings.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

void ctl_settings_defaults(struct ctl_settings *s)
{
	*s = (struct ctl_settings){0};
#define OMNI4_KEY(kind, section, key, field, def, ...) s->field = (def);
#include "omni4/core/ctl_keys.def"
#undef OMNI4_KEY
	est_keys_defaults(&s->est);
}

void ctl_settings_wheels(const struct ctl_settings *s, struct model_wheels *w)
{
	model_wheels_from_params(&s->model, w);
	for (int j = 0; j < 4; j++) {
		if (s->wheel_keys & CTL_WHEEL_KEY(0, j))
			w->r[j] = s->wheels.r[j];
		if (s->wheel_keys & CTL_WHEEL_KEY(1, j))
			w->Kv[j] = s->wheels.Kv[j];
		if (s->wheel_keys & CTL_WHEEL_KEY(2, j))
			w->Kt[j] = s->wheels.Kt[j];
		if (s->wheel_keys & CTL_WHEEL_KEY(3, j))
			w->R[j] = s->wheels.R[j];
	}
}

void ctl_settings_wheels_follow(struct ctl_settings *s)
{
	struct model_wheels w;

	ctl_settings_wheels(s, &w);
	s->wheels = w;
	for (int j = 0; j < 4; j++)
		if (!(s->layout_keys & (1u << j)))
			s->layout.d[j] = s->model.d;
}

/* The paper's layout: four wheels at 0, 90, 180, 270 deg, each at d. */
bool ctl_settings_paper_layout(const struct ctl_settings *s)
{
	bool paper = s->layout.wheels == 4;

	for (int j = 0; j < 4; j++)
		paper = paper && s->layout.angle_deg[j] == 90.0 * j &&
		        ctl_settings_wheel_distance(s, j) == s->model.d;
	return paper;
}

int ctl_settings_geom(const struct ctl_settings *s, struct wheel_geom *g)
{
	double d[4];

	if (ctl_settings_paper_layout(s) && s->model.d > 0.0) {
		wheel_geom_paper(s->model.d, g);
		return 0;
	}
	for (int j = 0; j < 4; j++)
		d[j] = ctl_settings_wheel_distance(s, j);
	return wheel_geom_angles(s->layout.wheels, s->layout.angle_deg, d, g);
}

int ctl_settings_layout(const struct ctl_settings *s, struct wheel_geom *g,
                        const struct wheel_geom **use)
{
	*use = NULL;
	if (ctl_settings_paper_layout(s))
		return s->model.d > 0.0 ? 0 : -EINVAL;
	if (ctl_settings_geom(s, g))
		return -EINVAL;
	*use = g;
	return 0;
}

int ctl_settings_check(const struct ctl_settings *s, int *bad_key, const char **why)
{
	int bad = 0;

	if (model_params_check(&s->model, &bad)) {
		*bad_key = bad;
		*why = "not finite or outside its physical range (docs/ini-keys.md)";
		return -EINVAL;
	}
	struct model_wheels w;

	ctl_settings_wheels(s, &w);
	if (model_wheels_check(&w, &bad)) {
		*bad_key = MODEL_PARAMS_COUNT + bad;
		*why = "not finite or outside its scalar's physical range (docs/ini-keys.md)";
		return -EINVAL;
	}
	struct wheel_geom g;

	*bad_key = CTL_KEY_WHEELS;
	if (ctl_settings_geom(s, &g)) {
		*why = "[model] wheels, wheel_angle_j, d_j: 3 or 4 wheels whose rows drive v, vn "
		       "and w "
		       "(no two wheels along one line)";
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
