/* consts.c - the angle helpers (consts.h). */
#include "omni4/model/consts.h"

#include <math.h>

double model_wrap_pi(double a)
{
	if (a > MODEL_PI || a <= -MODEL_PI)
		a -= 2.0 * MODEL_PI * floor((a + MODEL_PI) / (2.0 * MODEL_PI));
	if (a <= -MODEL_PI)
		a += 2.0 * MODEL_PI;
	return a;
}

float model_wrap_pi_f32(float a)
{
	const float two_pi = 6.28318530717959f;

	if (a > MODEL_PI_F || a <= -MODEL_PI_F)
		a -= two_pi * floorf((a + MODEL_PI_F) / two_pi);
	if (a <= -MODEL_PI_F)
		a += two_pi;
	return a;
}
