/*
 * rng.h - small deterministic random numbers (xoshiro128+ style split-mix seeding) for the
 * simulator's sensor noise and for tests. Not for cryptography.
 */
#ifndef OMNI4_RNG_H
#define OMNI4_RNG_H

#include <stdint.h>

struct rng {
	uint64_t s;
	double spare; /* second Box-Muller sample */
	int has_spare;
};

void rng_seed(struct rng *g, uint64_t seed);
uint64_t rng_u64(struct rng *g);
/* Uniform in [lo, hi). */
double rng_uniform(struct rng *g, double lo, double hi);
/* Normal with mean 0 and the given standard deviation. */
double rng_normal(struct rng *g, double sigma);

#endif /* OMNI4_RNG_H */
