/*
 * consts.h - the physical constants and the angle helpers every part of omni4 uses, once.
 */
#ifndef OMNI4_CONSTS_H
#define OMNI4_CONSTS_H

#define MODEL_PI 3.14159265358979323846 /* pi */
#define MODEL_PI_F 3.14159265358979f    /* pi, nearest float */
#define MODEL_G_M_S2 9.80665            /* standard gravity [m/s^2]: a wheel's load N = M g */
#define MODEL_G_M_S2_F 9.80665f

/* a [rad] into (-pi, pi]; a non-finite a is returned as it is. */
double model_wrap_pi(double a);
float model_wrap_pi_f32(float a);

#endif /* OMNI4_CONSTS_H */
