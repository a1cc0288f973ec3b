/* Real SH basis evaluation and the clamped-cosine factors (sh_basis.c). */
#ifndef ENVL_SH_BASIS_H
#define ENVL_SH_BASIS_H

#include "envlight.h"

/* (order + 1)^2 */
int32_t envl_sh_count(int32_t order);
/* y[l (l+1) + m] = Y_lm(d) for l = 0..order, d a unit vector. */
void envl_sh_eval(int32_t order, const double d[3], double *y);
/* The factor of each basis function (K_l^0, or sqrt2 K_l^m), computed once for many directions
 * (scratch: (order + 1)^2 doubles); envl_sh_eval_normed with them gives envl_sh_eval's values
 * bit for bit, without the square roots per direction. */
void envl_sh_norms(int32_t order, double *norm, double *scratch);
void envl_sh_eval_normed(int32_t order, const double *norm, const double d[3], double *y);
/* A_l: irradiance coefficient = A_l * radiance coefficient. */
double envl_sh_cosine_factor(int32_t l);

#endif
