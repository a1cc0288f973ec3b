/* The lights' insides, shared by their files (not installed):
 *   lights.c      the call (envl_lights_compute), evaluation, the error, the accessors
 *   lights_cut.c  median cut and variance cut: regions of the map, one light each
 *   lights_fit.c  K fitted lights + an SH remainder, and the fit's residual (cones)
 *   lights_sun.c  the map's suns split off exactly (sun_split.c), the rest a residual map
 * Energy of a pixel = luminance x its solid angle. */
#ifndef ENVL_LIGHTS_IMPL_H
#define ENVL_LIGHTS_IMPL_H

#include "clock.h"
#include "envmap_impl.h"

struct envl_lights {
    envl_lights_summary summary;
    envl_light *lights;
    double *remainder;      /* irradiance SH, (order+1)^2 x 3, or NULL */
    int32_t width, height;
    float *residual;        /* width x height x 3 (fit: what the cones left; sun: the map
                               less the suns' excess); for the cuts (which take everything)
                               made, all zero, only when asked for */
    int32_t residual_skipped; /* fit or sun with options.skip_residual: there is none */
    envl_pixel_patch *patch;  /* sun: the pixels where the residual differs from the map (the
                                 kept suns' pixels at the split's threshold), row-major */
    int32_t npatch;
};

/* A pixel rectangle of the canonical lat-long map, [x0, x1) x [y0, y1); x1 may exceed the width:
 * the region then wraps across the seam. */
typedef struct region {
    int32_t x0, x1, y0, y1;
    double energy;
    double priority;        /* which region to split next */
} region;

/* max(a.b, 0) */
static inline double envl__clamped_dot(const double a[3], const double b[3])
{
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return d > 0 ? d : 0;
}

/* ---- cuts (lights_cut.c) ---- */
/* Cuts the map into n regions (median or variance cut); *out malloc'd, *count of them. The
 * first region starts at the darkest column, so a sun on the seam is never cut in two. */
envl_result envl__cut_regions(envl_envmap *m, int32_t method, int32_t n, region **out,
                              int32_t *count);
/* One light per region: rgb = sum of L dw, at the energy-weighted centroid of its directions. */
void envl__region_lights(const envl_envmap *m, const region *rs, int32_t k, envl_light *out);

/* ---- fit (lights_fit.c) ---- */
/* At most K lights + an SH remainder of `order` (-1: none) into ls (ls->residual holds a copy
 * of the map). */
envl_result envl__fit_lights(envl_envmap *m, int32_t K, int32_t order, envl_lights *ls);
/* The fit's residual: each light takes its rgb from the smallest cone around it that holds
 * that much light. coarse (may be NULL): a copy of m area-resampled smaller, whose rings
 * point the search at each cone (the result is the same: the cones are decided on m).
 * ls->residual: a copy of m's pixels, made the residual; or NULL: none is kept (the lights
 * are the same). */
envl_result envl__take_cones(const envl_envmap *m, const envl_envmap *coarse, envl_lights *ls);

/* ---- sun (lights_sun.c) ---- */
/* The map's n brightest suns as lights and the patches that make the map their residual;
 * the residual map itself (ls->residual) only with keep_residual. */
envl_result envl__sun_lights(const envl_envmap *m, int32_t n, int32_t keep_residual,
                             envl_lights *ls);
/* Adds the exact irradiance of the sun method's residual at the error normals to approx. */
envl_result envl__add_residual_irradiance(const envl_envmap *m, const envl_lights *ls,
                                          const double *ref, double *approx);

#endif
