/* Prefiltering's insides, shared by its files (not installed):
 *   options.c            the defaults resolved in one pass, each level's width and samples
 *   mips.c               the map's cached mip pyramid and cell pyramid, the energy of a
 *                        lat-long image
 *   specular.c           a GGX specular level (the cells' quadrature, or plain importance
 *                        sampling for the unfiltered baseline)
 *   cells.c              the cell pyramid and its quadrature of P(R)
 *   bright_lobes.c       bright pixels as point lobes, sun lights added to P(R) or E(n)
 *   glossy_reference.c   the brute-force reference and the error of a product against it
 *   irradiance_map.c     irradiance maps
 *   request.c            envl_compute: only what a request asks for, measured when asked
 *   export/prefilter_files.c  the products as files with prefilter.json */
#ifndef ENVL_PREFILTER_IMPL_H
#define ENVL_PREFILTER_IMPL_H

#include "clock.h"
#include "options.h"
#include "envmap_impl.h"
#include "sun_split.h"
#include "error_measure.h"
#include "cells.h"

/* ---- the mip pyramid (mips.c) ---- */
/* The area-averaged pyramid of a W x H image: the sizes of levels 0 .. *n - 1 in mw, mh; the
 * levels kept (from *first, the first no wider than 4096) in *buf at off[k]. */
envl_result envl__build_pyramid(const float *px, int32_t w, int32_t h, float **buf_out,
                                int32_t *n_out, int32_t *first, int32_t mw[40], int32_t mh[40],
                                size_t off[40]);
/* The coarsest level of the map's mip pyramid (built and cached here; level 0 the map) whose
 * pixels are at most `pixel` radians tall, as an image (its pixels stay the map's). Each is
 * the exact area mean of the map over its pixels, so a footprint mean over a texel several
 * of its pixels wide is the map's, for a fraction of the lookups. A level not kept (wider
 * than 4096) gives the map. The pyramid is built on the first request past level 0. */
envl_result envl__mip_level_for(envl_envmap *m, double pixel, envl_image *out);
/* Integral of L dw of a w x h product image (ENVL_LAYOUT_LATLONG or _STRIP_H), per channel. */
void envl__image_energy(const float *px, int32_t layout, int32_t w, int32_t h, double e[3]);

/* ---- bright pixels (bright_lobes.c) ---- */
/* The map's split (sun_split.c) and, with sun lights, the cells of the map less the lights. */
typedef struct split {
    envl_sun_split sun;       /* the split-off pixels and the residual (sun_split.c) */
    envl_cells *cells;        /* the map less what the sun lights took; NULL: the map's own */
    float *cells_px;          /* ... and that image (the cells read it) */
} split;
envl_result envl__split_make(const envl_envmap *m, split *s);
void envl__split_free(split *s);
/* Adds what n lights give to P(R) at roughness > 0, or to E(n) for roughness < 0, in `count`
 * directions (out: count x 3). */
void envl__sun_lights_add(const envl_light *l, int32_t n, double roughness, int32_t count,
                          const double *dirs, double *out);

/* ---- a specular level (specular.c) ---- */
/* The level of `roughness`, `width` wide (0: its resolved width); sp: the map's split (NULL:
 * made here when needed). *out: malloc'd RGB. */
envl_result envl__specular_level(envl_envmap *m, const resolved *o, double roughness,
                                 int32_t width, const split *sp, float **out, envl_level *st);

/* ENVL_OK when every value of a level is finite; else frees *px (sets it NULL) and fails with
 * ENVL_ERR_NONFINITE naming the map's file and the roughness. */
envl_result envl__level_finite(const envl_envmap *m, const envl_level *st, float **px);

/* ---- what a level's width costs (level_width.c) ---- */
/* The width at which level l (measured: glossy_error >= 0) would meet ENVL_GLOSSY_TARGET: C the
 * cells it was computed from, sun / n_sun the sun lights added to it, ref the glossy reference
 * at the error directions dirs. */
envl_result envl__level_width_estimate(const envl_cells *C, const resolved *o,
                                       const envl_level *l, const envl_light *sun,
                                       int32_t n_sun, const double *dirs, const double *ref,
                                       envl_width_estimate *out);

/* ---- irradiance maps (irradiance_map.c) ---- */
/* `sh` may be given (an SH object of the right order, shared with the diffuse product);
 * *projected is set when an SH projection was made here. */
envl_result envl__irradiance_map(envl_envmap *m, const resolved *o, const envl_sh *sh,
                                 float **out, envl_irradiance_map *st, int *projected);
/* Every value of a float product is finite (checked before anything is written). */
int envl__floats_finite(const float *v, size_t n);

/* ---- the products of a request (request.c) ---- */
struct envl_products {
    envl_products_summary summary;
    resolved opt;
    int32_t n_levels;
    envl_level *levels;
    envl_width_estimate *widths; /* per level: the width for ENVL_GLOSSY_TARGET (measured) */
    float **level_px;
    int32_t has_irradiance;
    int32_t measured;         /* request.measure: the errors were measured */
    envl_irradiance_map irr;
    float *irr_px;
    envl_sh *sh;
    envl_lights *lights;
    envl_light *sun;          /* options.sun_lights: the split-off pixels as lights */
    int32_t n_sun;
    float *brdf;
    int32_t brdf_size, brdf_multiscatter, brdf_samples;
    char file[1024];
    envl_info source_info;    /* the map's, as loaded (what the loader repaired) */
    char *source_path;        /* the map's file in full (envl__envmap_source), or NULL */
};

#endif
