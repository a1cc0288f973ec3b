/* Which lighting recipe `envlight pov` writes, from what the scene uses (README, "POV-Ray").
 *
 * The scene benchmark (scripts/scene_bench.py --host pov, docs/scene_bench_pov.md) decides:
 * an ambient term (SH, hemispheric) cannot be shadowed, so on maps whose light does not sit in
 * one sun it leaves lower halves too bright and draws no contact shadow; a dome of median-cut
 * lights with hard shadows carries the occlusion, and the ground's bounce (a uniform lower
 * hemisphere, whose irradiance is exactly linear in n . up) stays an ambient. Where nothing is
 * occluded the SH ambient is exact and cheaper; where the scene already renders radiosity,
 * the residual sky under it is the natural partner of a few fitted lights. */
#include "pov_recipe.h"

#include <stdio.h>
#include <string.h>

static const char *const names[POV_RECIPE_COUNT] = {"auto", "custom", "sh", "dome",
                                                    "image-radiosity"};

int pov_recipe_from_name(const char *name)
{
    for (int r = 0; r < POV_RECIPE_COUNT; r++)
        if (r != POV_RECIPE_CUSTOM && !strcmp(name, names[r]))
            return r;
    return -1;
}

const char *pov_recipe_name(int recipe)
{
    return recipe >= 0 && recipe < POV_RECIPE_COUNT ? names[recipe] : "?";
}

int pov_recipe_pick(const pov_scene *scene, int shadows, char *why, size_t size)
{
    if (scene && scene->radiosity) {
        snprintf(why, size, "the scene renders radiosity: 4 fitted lights for the sun and the "
                 "residual sky under the scene's radiosity (occlusion and bounces)");
        return POV_RECIPE_IMAGE_RADIOSITY;
    }
    if (!shadows) {
        snprintf(why, size, "shadowless lights asked for (--shadows none): 4 fitted lights + "
                 "the SH ambient, exact for unoccluded normals");
        return POV_RECIPE_SH;
    }
    int occluded = !scene || (scene->casters > 0 && scene->objects > 1);
    if (!occluded && !scene->glossy) {
        snprintf(why, size, "no object of the scene can shadow another and no finish is "
                 "glossy: 4 fitted lights + the SH ambient, exact for unoccluded normals");
        return POV_RECIPE_SH;
    }
    if (!occluded) {
        snprintf(why, size, "glossy finishes: POV-Ray draws highlights from light sources "
                 "only, so the sky becomes a dome of median-cut lights");
        return POV_RECIPE_DOME;
    }
    snprintf(why, size, "%s: an ambient term cannot be shadowed, so the sky becomes a dome of "
             "median-cut lights with shadows",
             scene ? "objects of the scene shadow others" : "no --scene given, shadows assumed");
    return POV_RECIPE_DOME;
}

/* Filled from docs/scene_bench_pov.md (scripts/scene_bench.py --host pov --docs docs). */
const char *pov_recipe_expected_error(int recipe)
{
    (void)recipe;
    return NULL;
}
