/*
 * q16.h - the one fixed-point format of omni4.
 *
 * q16_t is Q16.16 in an int32_t: 16 integer bits (sign included), 16 fraction bits.
 * Range [-32768, 32767.99998], resolution 2^-16 = 1.53e-5. Products and sums are formed in
 * int64_t and saturated to the int32_t range: results never wrap. Products round to nearest,
 * ties upwards (add half an LSB, then an arithmetic shift: branch-free).
 *
 * The helpers are static inline, integer-only: the fixed-point path needs no libc and no
 * floating-point support routine. Conversions to/from double are for set-up and tests only.
 */
#ifndef OMNI4_Q16_H
#define OMNI4_Q16_H

#include <stdint.h>

typedef int32_t q16_t;

#define Q16_FRAC_BITS 16
#define Q16_ONE ((q16_t)1 << Q16_FRAC_BITS)
#define Q16_MAX INT32_MAX
#define Q16_MIN INT32_MIN

/* Saturate a 64-bit intermediate to the q16_t range. */
static inline q16_t q16_sat(int64_t x)
{
	if (x > (int64_t)Q16_MAX)
		return Q16_MAX;
	if (x < (int64_t)Q16_MIN)
		return Q16_MIN;
	return (q16_t)x;
}

static inline q16_t q16_add(q16_t a, q16_t b)
{
	return q16_sat((int64_t)a + b);
}

static inline q16_t q16_sub(q16_t a, q16_t b)
{
	return q16_sat((int64_t)a - b);
}

static inline q16_t q16_neg(q16_t a)
{
	return q16_sat(-(int64_t)a);
}

/*
 * Q16.16 x Q16.16, rounded to nearest (ties upwards) but not saturated: the Q16.16 result
 * stays in int64_t with |result| <= 2^46, so a handful of them can be summed without overflow
 * and saturated once at the end.
 */
static inline int64_t q16_mul_wide(q16_t a, q16_t b)
{
	/* Right shift of a negative int64_t is arithmetic on every compiler omni4 targets (gcc,
	 * clang: documented implementation-defined behaviour). */
	return ((int64_t)a * b + ((int64_t)1 << (Q16_FRAC_BITS - 1))) >> Q16_FRAC_BITS;
}

/*
 * Scaling and overflow: Q16.16 x Q16.16 -> Q32.32 in int64_t (exact, |a*b| < 2^62), rounded
 * back to Q16.16 and saturated.
 */
static inline q16_t q16_mul(q16_t a, q16_t b)
{
	return q16_sat(q16_mul_wide(a, b));
}

/* Set-up and test helpers (double; not part of the per-tick fixed-point path). */
static inline q16_t q16_from_double(double x)
{
	double s = x * (double)Q16_ONE;

	if (!(s == s))
		return 0;
	if (s >= (double)Q16_MAX)
		return Q16_MAX;
	if (s <= (double)Q16_MIN)
		return Q16_MIN;
	return (q16_t)(s >= 0 ? s + 0.5 : s - 0.5);
}

static inline double q16_to_double(q16_t x)
{
	return (double)x / (double)Q16_ONE;
}

/* Per-tick conversions at the controller's precision (single precision: the Cortex-M4F's FPU
 * does these in hardware). Rounded to nearest, saturated, NaN -> 0. */
static inline q16_t q16_from_float(float x)
{
	const float s = x * (float)Q16_ONE;

	if (!(s == s))
		return 0;
	if (s >= 2147483520.0f) /* the largest float below 2^31 */
		return Q16_MAX;
	if (s <= (float)Q16_MIN)
		return Q16_MIN;
	return (q16_t)(s >= 0 ? s + 0.5f : s - 0.5f);
}

static inline float q16_to_float(q16_t x)
{
	return (float)x * (1.0f / (float)Q16_ONE);
}

#endif /* OMNI4_Q16_H */
