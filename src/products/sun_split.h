/* The bright pixels of a map split off (sun_split.c): shared by the prefiltered maps, which
 * filter the residual and add the split-off pixels as point lobes or sun lights (prefilter.c),
 * and the lights method "sun" (lights.c). Not installed. */
#ifndef ENVL_SUN_SPLIT_H
#define ENVL_SUN_SPLIT_H

#include "envmap_impl.h"

/* One split-off pixel: its excess E = L (1 - T / Y) omega (per channel) at its centre
 * direction. */
typedef struct envl_sun_lobe {
    double d[3], e[3];
    float keep[3];            /* the pixel in the residual: the map's, scaled to luminance T */
    int32_t r, c;
    int32_t taken;            /* 1 + the index of the sun light that took it
                                 (envl__sun_split_lights), else 0 (prefilter: baked as a lobe) */
} envl_sun_lobe;

typedef struct envl_sun_split {
    int32_t n;                /* lobes; 0: nothing was split (use the map itself) */
    envl_sun_lobe *lobes;     /* row-major order */
    double threshold;         /* T */
} envl_sun_split;

/* Splits off the pixels brighter than the threshold (sun_split.c): *s is zeroed first; n = 0
 * when no pixel is above it or the map is black. No residual copy of the map is made: a caller
 * that needs the residual (every split pixel at luminance T) puts each lobe's `keep` at its
 * pixel in a copy of its own, or resamples the map with them (envl__sun_split_patches,
 * envl__latlong_resample_patched), so the split costs no second map. */
envl_result envl__sun_split_lobes(const envl_envmap *m, envl_sun_split *s);
/* Every lobe's pixel with its `keep` value (s->n patches, row-major, malloc'd; NULL when out of
 * memory): the patches that make the map the split's residual (envl__latlong_resample_patched,
 * envl__envmap_resampled_patched). */
envl_pixel_patch *envl__sun_split_patches(const envl_sun_split *s);
/* The 8-connected groups of the split pixels that are suns, one light each (*out: *count
 * lights, malloc'd, NULL when none), in the order of the groups' first pixel (row-major);
 * marks each lobe's `taken`. */
envl_result envl__sun_split_lights(const envl_envmap *m, envl_sun_split *s, envl_light **out,
                                   int32_t *count);
void envl__sun_split_free(envl_sun_split *s);

#endif
