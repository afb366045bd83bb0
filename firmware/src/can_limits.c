/* can_limits.c - the CAN plausibility limits from the controller's settings (can_limits.h). */
#include "omni4/firmware/can_limits.h"

#include <math.h>

struct sc_limits can_limits_for(const struct ctl_settings *s)
{
	const struct model_params *p = &s->model;
	struct model_wheels w; /* each drive's own R, Kt, r: the worst wheel sets each limit */
	double i_step = 0.0, f_max = 0.0, r_min = INFINITY;

	ctl_settings_wheels(s, &w);
	for (int j = 0; j < 4; j++) {
		const double i_j = 2.0 * s->limits.supply_v / w.R[j];

		i_step = fmax(i_step, i_j);
		f_max = fmax(f_max, p->l * w.Kt[j] * i_j / w.r[j]);
		r_min = fmin(r_min, w.r[j]);
	}
	const double a_max = f_max * (2.0 / p->M + 4.0 * p->d * p->d / p->J);

	return (struct sc_limits){
	    .current_step_a = (float)(i_step + SC_CURRENT_NOISE_MARGIN_A + CAN_CURR_LSB),
	    .speed_step_rad_s = (float)(a_max / s->rate_hz / r_min + 2.0 * CAN_SPEED_LSB),
	    .current_limit_a = (float)s->limits.current_max_a,
	    .confirm_frames = 3,
	};
}

struct sc_limits can_limits_default(void)
{
	struct ctl_settings s;

	ctl_settings_defaults(&s);
	return can_limits_for(&s);
}
