/* battery.c - the supply of a battery under the bridges' power (battery.h). */
#include "omni4/model/battery.h"

#include <errno.h>
#include <math.h>

int battery_init(struct battery *b, double v_full, double capacity_ah, double r_int_ohm)
{
	if (!(v_full > 0.0 && isfinite(v_full)) || !(capacity_ah > 0.0 && isfinite(capacity_ah)) ||
	    !(r_int_ohm >= 0.0 && isfinite(r_int_ohm)))
		return -EINVAL;
	b->v_full = v_full;
	b->capacity_c = capacity_ah * 3600.0;
	b->r_int_ohm = r_int_ohm;
	b->drawn_c = 0.0;
	b->v_supply = v_full;
	return 0;
}

double battery_open_circuit_v(const struct battery *b)
{
	return b->v_full * (1.0 - (1.0 - BATTERY_EMPTY_SHARE) * b->drawn_c / b->capacity_c);
}

void battery_step(struct battery *b, double power_w, double dt)
{
	const double voc = battery_open_circuit_v(b);
	const double disc = voc * voc - 4.0 * b->r_int_ohm * power_w;

	b->v_supply = 0.5 * (voc + sqrt(fmax(0.0, disc)));
	b->drawn_c = fmin(b->capacity_c, fmax(0.0, b->drawn_c + power_w / b->v_supply * dt));
}
