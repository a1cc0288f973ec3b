/* Real SH basis evaluation and the clamped-cosine factors (sh_basis.c). */
#ifndef ENVL_SH_BASIS_H
#define ENVL_SH_BASIS_H

#include "envlight.h"

/* (order + 1)^2 */
int32_t envl_sh_count(int32_t order);
/* y[l (l+1) + m] = Y_lm(d) for l = 0..order, d a unit vector. */
void envl_sh_eval(int32_t order, const double d[3], double *y);
/* A_l: irradiance coefficient = A_l * radiance coefficient. */
double envl_sh_cosine_factor(int32_t l);

#endif
