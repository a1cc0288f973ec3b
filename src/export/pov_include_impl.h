/* What the POV-Ray include's call (pov_include.c) and its text (pov_text.c) share: the plan
 * (the options resolved) and the work (what was computed). Not installed. */
#ifndef ENVL_POV_INCLUDE_IMPL_H
#define ENVL_POV_INCLUDE_IMPL_H

#include "internal.h"
#include "pov_ambient.h"
#include "pov_light.h"
#include "pov_recipe.h"

#include <stdio.h>

/* The dome's own (unoccluded) diffuse error it grows until it meets: its lights are a
 * quadrature of the sky, and this keeps that part well below the in-scene errors. */
#define POV_DOME_ERROR 0.005
/* The dome under radiosity: its lights are also what each radiosity sample gathers, so their
 * number sets the cost. Variance cut (whose regions follow the sky's spread, not its energy:
 * 0.75-1.3 % unoccluded error with 32 lights where median cut has 2.1-3.9 %), 48 lights, or 64
 * where 48 leave more than POV_DOME_BOUNCE_ERROR: the scene benchmark's choice
 * (docs/pov_scenes.md: scene (b)'s object in a corner on four maps 2.1-3.4 % with 32, 2.1-3.0 %
 * with 48, the plane and the banding down, at 1.2-1.5x the light sources; 64 at 1.5-1.8x). */
#define POV_DOME_BOUNCE_ERROR 0.01
/* The dome's sizes tried in turn when -n is not given (compute, pov_include.c; the header says
 * which, pov_text.c): under radiosity, and with an ambient for the bounces. */
#define POV_DOME_COUNTS_BOUNCE {48, 64}
#define POV_DOME_COUNTS_AMBIENT {64, 128, 256}
/* A low sun under the bounce pass: where the suns light the best-lit vertical wall more than
 * POV_LOW_SUN_RATIO x the ground's whole irradiance E_up (so the objects' sunlit sides bounce
 * much light onto the floor beside them), the bounce pass reuses its samples over
 * POV_LOW_SUN_REUSE of the scene's size instead of POV-Ray's 0.2, which spread that light
 * thin: the planes of scenes (a), (b) 2.1-2.8 % off -> 1.4-2.2 % at 1.2-2.5x the POV-Ray CPU
 * (the 3 of 26 maps where it applies, ratios 2.9-3.1; the next 1.4; docs/pov_scenes.md, "A low
 * sun"). Elsewhere the denser samples would darken (a)'s spheres by 0.3-0.7 % for nothing. */
#define POV_LOW_SUN_RATIO 2.0
#define POV_LOW_SUN_REUSE 0.05
/* ENVL_POV_EXPOSURE_AUTO: the value a white surface facing up shows (sRGB ~0.8 in an 8-bit
 * image). */
#define POV_AUTO_WHITE 0.6
/* The include's EnvLight_Shadows: 0 none, 1 hard, 2 soft (a dome's lights shaped as their
 * region, pov_area.c; others a disc of their angular diameter). */
enum { SHADOW_NONE, SHADOW_HARD, SHADOW_SOFT };

/* The plan: the options resolved (the scene read, the recipe, the lights, the ambient). */
typedef struct pov_plan {
    int recipe;
    char why[320];
    pov_scene scene_uses;
    const pov_scene *scene;   /* NULL: none given or unreadable */
    envl_lights_options lo;
    int order, order_set, ambient, ambient_set, shadows;
    int sky, sky_residual, place, dome_auto_count, bounce;
    int place_lights;         /* 0: the scene has light sources of its own: declared only */
    int shell;                /* 1: EnvLight_Radiosity_Shell() hides the scene's own sky from
                                 the bounce pass */
    double ground;            /* < 0: no ground plane */
    const char *ground_from;  /* where the ground came from, for the header; NULL: none */
    int ground_box;           /* the scene's ground is a box (finite): a dome with a bounce
                                 pass keeps the map's lower half as lights (plan_recipe) */
    double radius, exposure;
    const char *source, *command, *sky_image;
    const char *out;          /* the include's path (NULL: handed back) */
    FILE *warn;               /* the warnings, a line each */
} pov_plan;

/* The work: what was computed for the plan. */
typedef struct pov_work {
    envl_envmap *map;         /* the environment as read (info, the sky image) */
    envl_envmap *lit;         /* what the objects see: map, or with a ground the map over it */
    envl_envmap *cut_map;     /* where the lights come from (a dome over a ground: the sky half) */
    envl_envmap *grounded, *sky_half, *residual; /* owned (sky_half may be a window of map's
                                                    rows: compute_maps) */
    envl_info info;
    envl_lights *ls;          /* the lights computed by one cut (NULL for the dome: lights) */
    envl_lights_summary s;    /* their summary (the dome's: method variance, its count) */
    pov_light *lights;        /* the lights as placed: colour, area light */
    int32_t nlights, suns, below; /* the dome's suns and lights below the horizon */
    envl_sh *sh;              /* the residual's SH, when that is the ambient */
    const double *ref;        /* exact irradiance at the 1024 normals of what is measured */
    double *emit;             /* 1024 x RGB */
    const double *rem;        /* the fit's remainder, or NULL */
    int32_t rem_order;        /* its order */
    int amb_order;            /* the ambient's SH order, -1: none */
    const double *amb_sh;     /* its irradiance SH: ground_sh, rem or the residual's */
    double ground_sh[4 * 3];
    double ground_radiance[3];
    double e_up[3];           /* lit's exact irradiance at +Z (once: compute_maps or exposure) */
    int e_up_known;
    pov_ridge rd;
    double hemi_axis[3], hemi_sky[3], hemi_ground[3];
    double error, amb_least, exposure_auto, seconds;
    double low_sun;           /* the suns on the best-lit vertical wall / E_up (luminance) */
    double bounce_reuse;      /* the bounce pass's maximum_reuse; 0: envlight.inc's default */
    int amb_negative;
    char *sky_path;           /* the sky image, NULL without a sky */
    char *sky_pov;            /* its name in the include, as POV-Ray 3.7 can open it */
    int sky_relative;         /* 1: sky_pov is relative to the include's folder (render there) */
    int sky_use_input;        /* 1: the map's own .hdr file is the sky image */
    double sky_rotate;
} pov_work;

/* A POV-Ray string literal cannot hold control characters. */
static inline int pov_string_ok(const char *s)
{
    for (const unsigned char *q = (const unsigned char *)s; *q; q++)
        if (*q < 0x20 || *q == 0x7f)
            return 0;
    return 1;
}

/* The whole include, in memory (*text, *size; NUL-terminated): ENVL_OK or ENVL_ERR_MEMORY. */
envl_result pov_text_build(const pov_plan *p, const pov_work *w, char **text, size_t *size);

#endif
