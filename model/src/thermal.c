/* thermal.c - the windings' single-node thermal model, integrated exactly per step (thermal.h). */
#include "omni4/model/thermal.h"

#include <errno.h>
#include <math.h>

int thermal_init(struct thermal *th, double r_th_k_w, double c_th_j_k, double ambient_c,
                 const double R_cold[4])
{
	if (!(r_th_k_w > 0.0 && isfinite(r_th_k_w)) || !(c_th_j_k > 0.0 && isfinite(c_th_j_k)) ||
	    !isfinite(ambient_c))
		return -EINVAL;
	for (int j = 0; j < 4; j++)
		if (!(R_cold[j] > 0.0 && isfinite(R_cold[j])))
			return -EINVAL;
	th->r_th_k_w = r_th_k_w;
	th->c_th_j_k = c_th_j_k;
	th->ambient_c = ambient_c;
	for (int j = 0; j < 4; j++)
		th->R_cold[j] = R_cold[j];
	thermal_reset(th);
	return 0;
}

void thermal_reset(struct thermal *th)
{
	for (int j = 0; j < 4; j++)
		th->temp_c[j] = th->ambient_c;
}

/*
 * The rise over ambient, x = T - ambient, follows x' = a x + f with
 * a = (i^2 R_cold alpha - 1 / R_th) / C_th and f = i^2 R_cold / C_th: exact over dt.
 */
void thermal_step(struct thermal *th, const double current_a[4], double dt)
{
	for (int j = 0; j < 4; j++) {
		const double i2r = current_a[j] * current_a[j] * th->R_cold[j];
		const double a = (i2r * THERMAL_ALPHA_CU - 1.0 / th->r_th_k_w) / th->c_th_j_k;
		const double f = i2r / th->c_th_j_k;
		const double x = th->temp_c[j] - th->ambient_c;
		const double xn =
		    fabs(a * dt) < 1e-12 ? x + f * dt : (x + f / a) * exp(a * dt) - f / a;

		th->temp_c[j] = th->ambient_c + xn;
	}
}

void thermal_resistance(const struct thermal *th, double R_ohm[4])
{
	for (int j = 0; j < 4; j++)
		R_ohm[j] =
		    th->R_cold[j] * (1.0 + THERMAL_ALPHA_CU * (th->temp_c[j] - th->ambient_c));
}
