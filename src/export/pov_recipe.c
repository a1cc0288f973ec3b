/* Which lighting recipe the POV-Ray include uses, from what the scene uses (docs/methods.md, "POV-Ray").
 *
 * The scene benchmark (scripts/scene_bench.py --host pov, docs/scene_bench_pov.md) decides:
 * an ambient term (SH, hemispheric, or the ground's bounce as one) cannot be shadowed, so on
 * maps whose light does not sit in one sun it leaves lower halves and corners too bright and
 * draws no contact shadow; a dome of median-cut lights with hard shadows carries the sky's
 * occlusion, and a cheap radiosity pass with no sky in it (the lights' light only) carries the
 * bounces, occluded too. Where nothing is occluded the SH ambient is exact and cheaper. A scene
 * the reader sees no object in (they are in #include files or macros) gets the dome: it holds
 * for any scene. */
#include "pov_recipe.h"
#include "pov_figures.h"

#include <stdio.h>
#include <string.h>

static const char *const names[POV_RECIPE_COUNT] = {"auto",         "custom",
                                                    "sh",           "dome",
                                                    "dome-ambient", "image-radiosity"};

int32_t envl_pov_recipe_from_name(const char *name)
{
    for (int r = 0; name && r < POV_RECIPE_COUNT; r++)
        if (!strcmp(name, names[r]))
            return r;
    return -1;
}

const char *envl_pov_recipe_name(int32_t recipe)
{
    return recipe >= 0 && recipe < POV_RECIPE_COUNT ? names[recipe] : NULL;
}

const char *pov_recipe_name(int recipe)
{
    return recipe >= 0 && recipe < POV_RECIPE_COUNT ? names[recipe] : "?";
}

int pov_recipe_pick(const pov_scene *scene, int shadows, char *why, size_t size)
{
    if (!shadows) {
        snprintf(why, size, "shadowless lights asked for (--shadows none): 4 fitted lights + "
                 "the SH ambient, exact for unoccluded normals");
        return POV_RECIPE_SH;
    }
    if (scene && scene->objects == 0) {
        snprintf(why, size, "no object statement found in the scene (objects in #include "
                 "files or macros are not read): the dome, which holds for any scene");
        return POV_RECIPE_DOME;
    }
    int occluded = !scene || (scene->casters > 0 && scene->objects > 1);
    if (!occluded && !scene->glossy) {
        snprintf(why, size, "no object of the scene can shadow another and no finish is "
                 "glossy: 4 fitted lights + the SH ambient, exact for unoccluded normals");
        return POV_RECIPE_SH;
    }
    if (!occluded) {
        snprintf(why, size, "glossy finishes: POV-Ray draws highlights from light sources "
                 "only, so the sky becomes a dome of lights (its suns, the rest by variance)");
        return POV_RECIPE_DOME;
    }
    snprintf(why, size, "%s: an ambient term cannot be shadowed, so the sky becomes a dome of "
             "lights with %s shadows (its suns, the rest by variance), and radiosity carries "
             "the bounces between surfaces%s",
             scene ? "objects of the scene shadow others" : "no --scene given, shadows assumed",
             shadows == 1 ? "hard (--shadows hard)" : "soft",
             scene && scene->radiosity ? " (the scene's radiosity block, if later, wins)" : "");
    return POV_RECIPE_DOME;
}

int pov_recipe_bounces(const pov_scene *scene)
{
    return !scene || scene->objects != 1;
}

/* The scene benchmark's figures (pov_figures.h, written by scripts/figures.py from
 * docs/scene_bench_pov.json: the objects and plane of scenes (a) and (b), the banding scene, the
 * user scenes, on every map; relative RMS of luminance against a validated reference). */
const char *pov_recipe_expected_error(int recipe)
{
    switch (recipe) {
    case POV_RECIPE_DOME:
        return POV_FIGURE_DOME;
    case POV_RECIPE_DOME_AMBIENT:
        return POV_FIGURE_DOME_AMBIENT;
    case POV_RECIPE_SH:
        return POV_FIGURE_SH;
    case POV_RECIPE_IMAGE_RADIOSITY:
        return POV_FIGURE_IMAGE_RADIOSITY;
    default:
        return NULL;
    }
}

const char *pov_recipe_path_traced(int recipe)
{
    return recipe == POV_RECIPE_DOME ? POV_FIGURE_DOME_PATH_TRACED : NULL;
}
