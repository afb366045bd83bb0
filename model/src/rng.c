/* rng.c - splitmix64 generator and Box-Muller normals. */
#include "omni4/model/rng.h"

#include <math.h>

#define TWO_PI 6.283185307179586477

void rng_seed(struct rng *g, uint64_t seed)
{
	g->s = seed;
	g->has_spare = 0;
	g->spare = 0.0;
}

uint64_t rng_u64(struct rng *g)
{
	uint64_t z = (g->s += 0x9E3779B97F4A7C15ull);

	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}

double rng_uniform(struct rng *g, double lo, double hi)
{
	return lo + (hi - lo) * ((double)(rng_u64(g) >> 11) * 0x1.0p-53);
}

double rng_normal(struct rng *g, double sigma)
{
	if (g->has_spare) {
		g->has_spare = 0;
		return sigma * g->spare;
	}
	double u1 = rng_uniform(g, 0.0, 1.0), u2 = rng_uniform(g, 0.0, 1.0);

	if (u1 < 1e-300)
		u1 = 1e-300;
	const double m = sqrt(-2.0 * log(u1));

	g->spare = m * sin(TWO_PI * u2);
	g->has_spare = 1;
	return sigma * m * cos(TWO_PI * u2);
}
