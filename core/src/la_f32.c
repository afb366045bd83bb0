/* la_f32.c - the core's small single-precision mathematics (la_f32.h). */
#include "omni4/core/la_f32.h"

#include <errno.h>
#include <math.h>

void la_sin_cos_f32(float theta, float *sin_out, float *cos_out)
{
	const float q = floorf(theta * 0.636619772f + 0.5f); /* nearest multiple of pi/2 */
	const float r = (theta - q * 1.57079625f) - q * 7.54978995e-8f;
	const float r2 = r * r;
	const float sr = r * (1.0f + r2 * (-1.0f / 6 + r2 * (1.0f / 120 + r2 * (-1.0f / 5040))));
	const float cr =
	    1.0f + r2 * (-0.5f + r2 * (1.0f / 24 + r2 * (-1.0f / 720 + r2 * (1.0f / 40320))));

	switch ((int)q & 3) {
	case 0:
		*sin_out = sr;
		*cos_out = cr;
		break;
	case 1:
		*sin_out = cr;
		*cos_out = -sr;
		break;
	case 2:
		*sin_out = -sr;
		*cos_out = -cr;
		break;
	default:
		*sin_out = -cr;
		*cos_out = sr;
		break;
	}
}

/* Index of (i, j), j <= i, in a packed lower triangle; of (j, i) in a packed upper one. */
static int lo(int i, int j)
{
	return i * (i + 1) / 2 + j;
}

static int up(int i, int j)
{
	static const int idx[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};

	return idx[i][j];
}

int la_chol3_f32(const float A[6], float ridge, float L[6])
{
	for (int i = 0; i < 3; i++) {
		for (int j = 0; j <= i; j++) {
			float sum = A[up(i, j)] + (i == j ? ridge : 0.0f);

			for (int l = 0; l < j; l++)
				sum -= L[lo(i, l)] * L[lo(j, l)];
			if (i == j) {
				if (!(sum > 0.0f))
					return -EDOM;
				L[lo(i, i)] = sqrtf(sum);
			} else {
				L[lo(i, j)] = sum / L[lo(j, j)];
			}
		}
	}
	return 0;
}

/* y = L^-1 b */
static void forward(const float L[6], const float b[3], float y[3])
{
	for (int i = 0; i < 3; i++) {
		float sum = b[i];

		for (int l = 0; l < i; l++)
			sum -= L[lo(i, l)] * y[l];
		y[i] = sum / L[lo(i, i)];
	}
}

void la_chol3_solve_f32(const float L[6], const float b[3], float x[3])
{
	float y[3];

	forward(L, b, y);
	for (int i = 2; i >= 0; i--) {
		float sum = y[i];

		for (int l = i + 1; l < 3; l++)
			sum -= L[lo(l, i)] * x[l];
		x[i] = sum / L[lo(i, i)];
	}
}

float la_chol3_norm2_f32(const float L[6], const float v[3])
{
	float y[3];

	forward(L, v, y);
	return y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
}
