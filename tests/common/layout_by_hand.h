/* layout_by_hand.h - a wheel layout's geometry written out for the tests, sharing no code with
 * model/: eq 2's rows from the angles (row j = [-sin a_j, cos a_j, d_j]: wheel j at angle a_j from
 * the v axis, driving perpendicular to its radius, counter-clockwise) and the inverse of
 * G^T G by cofactors (eqs 3-5 for the layout: (G^T G)^-1 G^T; the least-norm force split:
 * G (G^T G)^-1). */
#ifndef OMNI4_TEST_LAYOUT_BY_HAND_H
#define OMNI4_TEST_LAYOUT_BY_HAND_H

#include <math.h>

struct layout {
	int n;                          /* 3 or 4 */
	double angle_deg[4], dist_m[4]; /* [deg], [m] */
};

/* G's rows (slots j >= n untouched) and (G^T G)^-1. */
static inline void layout_by_hand(const struct layout *L, double G[4][3], double inv[3][3])
{
	const double pi = 3.14159265358979323846;
	double A[3][3] = {{0}};

	for (int j = 0; j < L->n; j++) {
		const double a = L->angle_deg[j] * pi / 180.0;

		G[j][0] = -sin(a);
		G[j][1] = cos(a);
		G[j][2] = L->dist_m[j];
		for (int r = 0; r < 3; r++)
			for (int c = 0; c < 3; c++)
				A[r][c] += G[j][r] * G[j][c];
	}
	const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
	                   A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
	                   A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);

	for (int r = 0; r < 3; r++)
		for (int c = 0; c < 3; c++)
			inv[r][c] = (A[(c + 1) % 3][(r + 1) % 3] * A[(c + 2) % 3][(r + 2) % 3] -
			             A[(c + 1) % 3][(r + 2) % 3] * A[(c + 2) % 3][(r + 1) % 3]) /
			            det;
}

#endif /* OMNI4_TEST_LAYOUT_BY_HAND_H */
