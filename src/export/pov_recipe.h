/* Which lighting recipe the POV-Ray include uses for a scene, and why (pov_recipe.c).
 * Not installed. */
#ifndef ENVL_POV_RECIPE_H
#define ENVL_POV_RECIPE_H

#include "envlight.h"
#include "pov_scene.h"

#include <stddef.h>

/* The public ENVL_POV_RECIPE_* values. */
enum {
    POV_RECIPE_AUTO = ENVL_POV_RECIPE_AUTO,       /* pick one of the three below from the scene */
    POV_RECIPE_CUSTOM = ENVL_POV_RECIPE_CUSTOM,   /* method / count / ambient / order given
                                                     without a recipe */
    POV_RECIPE_SH = ENVL_POV_RECIPE_SH,           /* fit 4 + SH ambient: exact for unoccluded
                                                     normals */
    POV_RECIPE_DOME = ENVL_POV_RECIPE_DOME,       /* cut lights of the sky with shadows +
                                                     radiosity for the bounces between surfaces
                                                     (no sky in it) */
    POV_RECIPE_DOME_AMBIENT = ENVL_POV_RECIPE_DOME_AMBIENT, /* the same lights, the ground's
                                                     bounce as an ambient instead of radiosity
                                                     (unshadowed) */
    POV_RECIPE_IMAGE_RADIOSITY = ENVL_POV_RECIPE_IMAGE_RADIOSITY, /* fit 4 + the residual sky
                                                     under radiosity */
    POV_RECIPE_COUNT = ENVL_POV_RECIPE_COUNT
};

/* "auto", "custom", "sh", "dome", "dome-ambient", "image-radiosity"; "?" for anything else
 * (envl_pov_recipe_name and envl_pov_recipe_from_name are the public forms). */
const char *pov_recipe_name(int recipe);

/* The recipe for a scene (NULL: none given) and the shadows asked for (0: shadowless lights,
 * 1: hard, 2: soft or not asked); `why` receives one sentence. */
int pov_recipe_pick(const pov_scene *scene, int shadows, char *why, size_t size);

/* Whether a dome's lights need radiosity for the bounces: the scene has more than one object
 * (or is unknown: none read). */
int pov_recipe_bounces(const pov_scene *scene);

/* The in-scene error to expect, measured by scripts/scene_bench.py --host pov (a sentence
 * for the include's header), or NULL when the recipe was not measured. */
const char *pov_recipe_expected_error(int recipe);

/* The default dome's figure against Cycles path tracing (pov_figures.h, from
 * docs/pov_path_traced.json), NULL for another recipe: not measured there. */
const char *pov_recipe_path_traced(int recipe);

#endif
