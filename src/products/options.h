/* The one defaults pass (options.c): each public options struct resolved, zero fields replaced
 * by their defaults and ranges checked. Not installed. */
#ifndef ENVL_OPTIONS_H
#define ENVL_OPTIONS_H

#include "envmap_impl.h"

/* An SH order option: 0 -> dflt, ENVL_ORDER_0 -> 0, else the field (a negative one is left for
 * the caller's range check). */
int32_t envl__order(int32_t field, int32_t dflt);
/* The option field that asks for order L (0 -> ENVL_ORDER_0). */
int32_t envl__order_option(int32_t order);

typedef struct resolved_lights {
    int32_t method, count;
    int32_t order;            /* fit: the remainder's order, -1 none */
} resolved_lights;
envl_result envl__lights_resolve(const envl_lights_options *o, resolved_lights *r);

envl_result envl__sh_resolve(const envl_sh_options *o, int32_t *order, int32_t *window);

/* *r: o with its defaults; threads resolved (envl__threads). */
envl_result envl__brdf_resolve(const envl_brdf_options *o, envl_brdf_options *r);

/* Every option of envl_prefilter_options with its default filled in. */
typedef struct resolved {
    int32_t levels, width, min_width, samples, unfiltered;
    int32_t irr_method, irr_width, irr_order, threads, sun_lights;
    int32_t half;             /* measured as half floats (envl_prefilter_options.half) */
    int32_t faces;            /* layout cube or cross: the maps are cube faces of width / 4 */
} resolved;
/* The threads default to the map's (m may be NULL: all cores). */
envl_result envl__prefilter_resolve(const envl_prefilter_options *o, const envl_envmap *m,
                                    resolved *r);
/* k = floor(roughness (levels - 1)): the level of `roughness` is the base width >> k ... */
int32_t envl__level_shift(const resolved *r, double roughness);
/* ... at least the minimum width. */
int32_t envl__level_width(const resolved *r, double roughness);
/* The quadrature density rho of a filtered level w wide (cells.c). */
double envl__level_rho(const resolved *r, int32_t w);

#endif
