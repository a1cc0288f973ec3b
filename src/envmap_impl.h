/* The envmap's insides, shared by the files that compute products from it. */
#ifndef ENVL_ENVMAP_IMPL_H
#define ENVL_ENVMAP_IMPL_H

#include "internal.h"

struct envl_envmap {
    int32_t width, height;
    float *px;            /* RGB, row 0 = top (canonical lat-long) */
    double *row_omega;    /* solid angle of a pixel of each row (exact) */
    double *row_cos;      /* cos(theta) at each row's centre */
    double *row_sin;      /* sin(theta) = z at each row's centre */
    double *col_cos;      /* cos(phi) at each column's centre */
    double *col_sin;      /* sin(phi) */
    envl_info info;
    int32_t threads;
    double *reference;    /* cached exact irradiance at the ENVL_ERROR_NORMALS Fibonacci normals */
    double *energy_sat;   /* cached summed-area table of luminance x solid angle, (W+1)(H+1) */
    /* prefilter.c: the cached area-averaged mip pyramid. Level 0 is px itself; levels 1 ..
     * mip_levels - 1 live in mip_px at mip_offset[level] (floats). mip_levels 0: not built. */
    float *mip_px;
    int32_t mip_levels;
    int32_t mip_w[40], mip_h[40];
    size_t mip_offset[40];
};

/* The map's summed-area table of luminance x solid angle (double), built once and cached:
 * sat[r (W+1) + c] = sum over rows < r and columns < c. */
envl_result envl__energy_sat(envl_envmap *m, const double **out);

/* Number of worker threads for `requested` (0 = all cores). */
int32_t envl__threads(int32_t requested);

#endif
