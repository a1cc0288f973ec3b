/* The POV-Ray include's ambient (pov_ambient.c): an irradiance SH written as ridge functions
 * of the normal, the hemispheric form as one of them, and the error of what is emitted.
 * Not installed. */
#ifndef ENVL_POV_AMBIENT_H
#define ENVL_POV_AMBIENT_H

#include "envlight.h"
#include "pov_light.h"

#define POV_MAX_TERMS (2 * ENVL_POV_MAX_ORDER + 5)

/* E_a(n) = sum_k sum_l coef[k][l] P_l(dir[k] . n), P_l Legendre. */
typedef struct pov_ridge {
    int terms, order;                                  /* K directions, Legendre degree L */
    double dir[POV_MAX_TERMS][3];                      /* canonical frame */
    double coef[POV_MAX_TERMS][ENVL_POV_MAX_ORDER + 1][3];  /* irradiance */
} pov_ridge;

/* Irradiance SH of order 0..ENVL_POV_MAX_ORDER (canonical frame) -> ridge functions. Returns the
 * largest deviation at the 1024 error normals relative to the largest |E|, or -1. */
double pov_ridge_from_sh(int order, const double *sh, pov_ridge *r);

/* The hemispheric form as one term: the axis, C[0][0] = (sky + ground) / 2,
 * C[0][1] = (sky - ground) / 2. */
void pov_ridge_from_hemi(const double axis[3], const double sky[3], const double ground[3],
                         pov_ridge *r);

/* out = E_a(n). */
void pov_ridge_eval(const pov_ridge *r, const double n[3], double out[3]);

/* The least channel of E_a at 4096 Fibonacci normals; *negative: how many of them are
 * negative in some channel. */
double pov_ridge_least(const pov_ridge *r, int *negative);

/* Diffuse error of what is emitted: the lights as placed (their colour max(0, n . l)), + the
 * ambient r (may be NULL), against the exact irradiance ref at docs/design.md's 1024 normals;
 * emit (1024 x RGB) receives the emitted irradiance. */
double pov_emitted_error(const pov_light *lights, int32_t count, const pov_ridge *r,
                         const double *ref, double *emit);

#endif
