/* est_settings.c - the estimator's noise figures and thresholds: the defaults and their check
 * (est.h; docs/estimator.md, "Noise figures and thresholds"). */
#include <errno.h>

#include "omni4/est.h"

void est_settings_defaults(struct est_settings *s)
{
	/* docs/estimator.md, "Noise figures and thresholds" */
	s->accel_noise_lin = 1.0f;
	s->accel_noise_rot = 10.0f;
	s->wheel_noise = 0.0065f; /* 10240 cpr at 1 kHz: 0.18 rad/s quantisation x r */
	s->cam_pos_noise = 0.01f;
	s->cam_theta_noise = 0.0524f; /* 3 deg */
	s->gate_sigmas = 5.0f;
	s->slip_threshold = 0.08f;
	s->slip_ticks = 3;
	s->collision_threshold = 0.02f;
	s->collision_ticks = 5;
	s->calibrate = true;
	s->replay = true;
}

int est_settings_check(const struct est_settings *s)
{
	const float pos[] = {s->accel_noise_lin, s->accel_noise_rot,    s->wheel_noise,
	                     s->cam_pos_noise,   s->cam_theta_noise,    s->gate_sigmas,
	                     s->slip_threshold,  s->collision_threshold};

	for (unsigned k = 0; k < sizeof(pos) / sizeof(pos[0]); k++)
		if (!(pos[k] > 0.0f && pos[k] < 1e6f))
			return -EINVAL;
	return s->slip_ticks >= 1 && s->collision_ticks >= 1 ? 0 : -EINVAL;
}
