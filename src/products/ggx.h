/* The GGX lobe of the split-sum prefiltered radiance (N = V = R), shared by the specular levels,
 * the bright lobes, the glossy reference and the preview. Header-only: the per-sample loops
 * inline it. */
#ifndef ENVL_GGX_H
#define ENVL_GGX_H

#include "envlight.h"

/* D(h) = alpha^2 / (pi ((N.h)^2 (alpha^2 - 1) + 1)^2), a2 = alpha^2. */
static inline double ggx_d(double noh2, double a2)
{
    double q = noh2 * (a2 - 1.0) + 1.0;
    return a2 / (ENVL_PI * q * q);
}

/* w(u) = D(h) R.l up to a constant, u = R.l > 0 (N = V = R, h = normalize(R + l), so
 * (N.h)^2 = (1 + u) / 2): u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1. */
static inline double ggx_w(double u, double a2)
{
    double q = 0.5 * (1 + u) * (a2 - 1) + 1;
    return u / (q * q);
}

#endif
