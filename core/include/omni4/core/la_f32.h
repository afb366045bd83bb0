/*
 * la_f32.h - the core's small single-precision mathematics, written once (the angle wrap:
 * model/consts.h): sin and cos together (the shape of CMSIS-DSP's arm_sin_cos_f32, radians), and a
 * 3 x 3 symmetric positive definite solve by Cholesky (arm_mat_cholesky_f32 then the two triangular
 * solves, fixed size). Portable C11, no allocation, no OS; fast-loop safe (no loops beyond 3 x 3).
 *
 * Packed symmetric 3 x 3: the upper triangle row by row, {a00, a01, a02, a11, a12, a22}.
 * Packed lower triangle (a Cholesky factor L): row by row, {l00, l10, l11, l20, l21, l22}.
 */
#ifndef OMNI4_LA_F32_H
#define OMNI4_LA_F32_H

/* sin and cos of theta [rad], |theta| <= pi + a little: a quadrant and Taylor polynomials on
 * [-pi/4, pi/4] (errors below 4e-7 against libm, float level), a tenth of libm's cost on the M4. */
void la_sin_cos_f32(float theta, float *sin_out, float *cos_out);

/* L L^T = A + ridge I (A packed symmetric, L packed lower). 0, or -EDOM if a pivot is not > 0
 * (A + ridge I not positive definite, or NaN): L is then not usable. */
int la_chol3_f32(const float A[6], float ridge, float L[6]);

/* x = (L L^T)^-1 b: the forward then the backward substitution. */
void la_chol3_solve_f32(const float L[6], const float b[3], float x[3]);

/* v^T (L L^T)^-1 v = |L^-1 v|^2: the squared Mahalanobis length of v. */
float la_chol3_norm2_f32(const float L[6], const float v[3]);

#endif /* OMNI4_LA_F32_H */
