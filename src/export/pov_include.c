/* envl_pov_include_write: a POV-Ray 3.7 include with the lights, the ambient and the sky of an
 * environment, for povray_include/envlight.inc's macros (docs/methods.md, "POV-Ray").
 *
 * Frames. The canonical frame is Blender's (right-handed, +Z up); POV-Ray's is left-handed,
 * +Y up. A canonical vector (x, y, z) is written as the POV-Ray vector <x, z, y> (a swap of
 * two axes: it turns the right-handed frame into the left-handed one and keeps every angle).
 *
 * Steps: the options resolved into a plan (the scene read, the recipe, the lights' method and
 * count, the ambient, the ground); the computation (lights, ambient as ridge functions in
 * pov_ambient.c, the error of what is emitted, auto exposure); the sky image; the text
 * (pov_text.c), built in memory and written atomically.
 */
#include "pov_include_impl.h"
#include "envmap_impl.h"
#include "clock.h"
#include "escape.h"
#include "options.h"
#include "sh_forms.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* ---- the plan: the options resolved ---- */

/* A warning line, formatted and escaped as the command line prints its messages. */
static void warn(pov_plan *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void warn(pov_plan *p, const char *fmt, ...)
{
    char msg[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    escape_controls(msg, sizeof msg);
    if (p->warn)
        fprintf(p->warn, "%s\n", msg);
}

static envl_result bad_name(void)
{
    return envl__fail(ENVL_ERR_ARGUMENT, "pov: a file name with control characters cannot be "
                      "written into a POV-Ray string");
}

/* The fields one by one: ranges, and defaults for zero. */
static envl_result plan_options(const envl_pov_options *o, const envl_info *info, pov_plan *p)
{
    if (o->recipe < 0 || o->recipe >= ENVL_POV_RECIPE_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: recipe %d out of range", (int)o->recipe);
    if (o->method_is_set && o->method != ENVL_METHOD_FIT && o->method != ENVL_METHOD_MEDIAN &&
        o->method != ENVL_METHOD_VARIANCE)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: method %d: fit, median or variance",
                          (int)o->method);
    if (o->count < 0 || o->count > 1 << 16)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: count %d: 1..65536 lights", (int)o->count);
    if (o->ambient < 0 || o->ambient > ENVL_POV_AMBIENT_NONE)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: ambient %d out of range", (int)o->ambient);
    int32_t order = envl__order(o->order, ENVL_DEFAULT_ORDER);
    if (order < -1 || order > ENVL_POV_MAX_ORDER)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: order %d: 0..%d, ENVL_ORDER_0 or "
                          "ENVL_REMAINDER_NONE", (int)o->order, ENVL_POV_MAX_ORDER);
    if (o->ground_plane && !(o->ground_albedo >= 0 && o->ground_albedo <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: ground albedo %g: within [0, 1]",
                          o->ground_albedo);
    if (o->shadows < 0 || o->shadows > ENVL_POV_SHADOWS_HARD)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: shadows %d out of range", (int)o->shadows);
    if (o->scene_radius != 0 && !(o->scene_radius > 0 && o->scene_radius <= 1e12))
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: scene radius %g: a positive number",
                          o->scene_radius);
    if (o->exposure != 0 && o->exposure != ENVL_POV_EXPOSURE_AUTO &&
        !(o->exposure > 0 && o->exposure <= 1e12))
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: exposure %g: auto or a positive number",
                          o->exposure);
    p->source = o->source                        ? o->source
                : !strcmp(info->format, "sky")    ? "sky"
                : !strcmp(info->format, "memory") ? "memory"
                                                  : info->file;
    p->command = o->command ? o->command : "envl_pov_include_write";
    p->sky_image = o->sky_image && o->sky_image[0] ? o->sky_image : NULL;
    if (!pov_string_ok(p->source) || (p->sky_image && !pov_string_ok(p->sky_image)))
        return bad_name();
    p->lo = (envl_lights_options){.method = o->method_is_set ? o->method : ENVL_METHOD_FIT,
                                  .count = o->count ? o->count : 4};
    p->order_set = o->order != 0;
    p->order = order;
    p->ambient_set = o->ambient != ENVL_POV_AMBIENT_AUTO;
    p->ambient = p->ambient_set ? o->ambient : ENVL_POV_AMBIENT_SH;
    /* auto (-1 until the recipe is known): a dome's lights soft, others hard */
    p->shadows = o->shadows == ENVL_POV_SHADOWS_SOFT   ? SHADOW_SOFT
                 : o->shadows == ENVL_POV_SHADOWS_NONE ? SHADOW_NONE
                 : o->shadows == ENVL_POV_SHADOWS_HARD ? SHADOW_HARD
                                                       : -1;
    p->sky = o->sky || o->sky_residual;
    p->sky_residual = o->sky_residual != 0;
    p->place = !o->no_place;
    p->radius = o->scene_radius ? o->scene_radius : 100;
    p->exposure = o->exposure;
    p->ground = o->ground_plane ? o->ground_albedo : -1;
    p->ground_from = o->ground_plane ? "--ground" : NULL;
    return ENVL_OK;
}

/* What the scene uses: read tolerantly; a scene it cannot read is a warning and the defaults
 * apply. Its plane gives the ground when none was given. */
static void plan_scene(const char *path, pov_plan *p)
{
    if (!path || !*path)
        return;
    if (pov_scene_read(path, &p->scene_uses) == 0) {
        p->scene = &p->scene_uses;
        if (p->scene_uses.note[0])
            warn(p, "pov: warning: scene %s: %s (read as far as it goes)", path,
                 p->scene_uses.note);
    } else {
        warn(p, "pov: warning: %s; the defaults apply", p->scene_uses.note);
    }
    if (p->ground < 0 && p->scene && p->scene->ground) {
        double a = p->scene->ground_albedo;
        if (a > 1)
            warn(p, "pov: warning: scene %s: the ground's colour has luminance %g, more light "
                 "than it receives: albedo 1 used (moved by %g)", path, a, a - 1);
        p->ground = a >= 0 ? fmin(a, 1) : 0.5;
        p->ground_box = p->scene->ground_box;
        static const char *const from[2][2] = {
            {"the scene's plane", "the scene's plane, whose colour is not a literal: 0.5 assumed"},
            {"the scene's floor box",
             "the scene's floor box, whose colour is not a literal: 0.5 assumed"}};
        p->ground_from = from[p->ground_box != 0][a < 0];
    }
}

/* The recipe: given, implied by the low-level options (custom), or picked (auto); then what
 * it implies for the lights, the ambient, the sky and the ground. */
static envl_result plan_recipe(const envl_pov_options *o, pov_plan *p)
{
    int method_set = o->method_is_set != 0, count_set = o->count != 0;
    p->recipe = o->recipe;
    if (p->recipe == POV_RECIPE_AUTO && !o->recipe_is_set &&
        (method_set || count_set || p->ambient_set || p->order_set))
        p->recipe = POV_RECIPE_CUSTOM;
    if (p->recipe == POV_RECIPE_AUTO)
        p->recipe = pov_recipe_pick(p->scene,
                                    p->shadows == SHADOW_NONE ? 0 : p->shadows == SHADOW_HARD ? 1 : 2,
                                    p->why, sizeof p->why);
    else
        snprintf(p->why, sizeof p->why, "%s",
                 p->recipe == POV_RECIPE_CUSTOM ? "the options given" : "--recipe");
    if (p->recipe == POV_RECIPE_SH || p->recipe == POV_RECIPE_IMAGE_RADIOSITY) {
        if (!method_set)
            p->lo.method = ENVL_METHOD_FIT;
        if (!count_set)
            p->lo.count = 4;
    }
    if (p->shadows < 0) /* the sky is no set of points: a dome's shadows are as wide as it */
        p->shadows = p->recipe == POV_RECIPE_DOME ? SHADOW_SOFT : SHADOW_HARD;
    if (p->recipe == POV_RECIPE_DOME) {
        if (!method_set)
            p->lo.method = ENVL_METHOD_VARIANCE;
        p->dome_auto_count = !count_set;
        if (!p->ambient_set) /* the lights take the whole sky, radiosity the bounces */
            p->ambient = ENVL_POV_AMBIENT_NONE;
        p->bounce = pov_recipe_bounces(p->scene);
        /* A box floor is finite: beyond its edges the map's own lower half lights the scene
         * (a room on a 6 m floor box was 39 % dark with that half replaced by a ground). With
         * a bounce pass the lower half stays lights (cut apart: pov_dome.c): the box hides
         * what it covers and radiosity bounces what reaches it. An endless plane, or --ground,
         * hides the whole lower half. */
        if (p->bounce && p->ground_box) {
            p->ground = -1;
            p->ground_from = NULL;
        }
    }
    if (p->recipe == POV_RECIPE_DOME_AMBIENT) {
        if (!method_set)
            p->lo.method = ENVL_METHOD_MEDIAN;
        p->dome_auto_count = !count_set;
        if (!p->ambient_set) /* the cut takes the whole sky: the ambient is the ground's bounce */
            p->ambient = p->ground >= 0 ? ENVL_POV_AMBIENT_SH : ENVL_POV_AMBIENT_NONE;
    }
    if (p->recipe == POV_RECIPE_IMAGE_RADIOSITY) {
        if (!p->ambient_set)
            p->ambient = ENVL_POV_AMBIENT_NONE; /* the residual sky under radiosity carries it */
        p->order_set = 1;   /* the fit keeps its order-2 remainder: its lights stay peaks */
        p->sky = p->sky_residual = 1;
        if (o->ground_plane)
            warn(p, "pov: warning: --ground is not used by image-radiosity: radiosity "
                 "bounces the scene's own plane");
        p->ground = -1;
        p->ground_from = NULL;
    }
    /* A scene with light sources of its own is lit by them: envlight's are declared, not
     * placed (nor the bounce pass), or the scene would be lit twice. A scene that shows its own
     * sky under the dome's bounce pass would have it taken for light: radiosity sees black
     * instead (the dome's lights are the sky). */
    p->place_lights = !(p->scene && p->scene->lights > 0);
    if (!p->place_lights)
        warn(p, "pov: warning: the scene places %d light_source%s of its own: envlight's "
             "lights are declared, not placed (EnvLight_Place_Lights() places them)",
             p->scene->lights, p->scene->lights == 1 ? "" : "s");
    p->shell = p->bounce && p->place_lights && p->scene && p->scene->sky;
    if (p->scene && p->scene->double_highlights && (p->sky || p->scene->sky))
        warn(p, "pov: warning: line %d: a finish reflects and has specular or phong (%d such "
             "finish%s): the reflected sky holds the lights' highlights, which POV-Ray adds "
             "again: set specular 0 and phong 0 in reflective finishes", p->scene->double_line,
             p->scene->double_highlights, p->scene->double_highlights == 1 ? "" : "es");
    /* the library's limit (envlight.h), refused here before any map is computed */
    if (p->lo.method == ENVL_METHOD_FIT && p->lo.count > ENVL_FIT_MAX_LIGHTS)
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: fit takes 1..%d lights, not %d (median and "
                          "variance take more)", ENVL_FIT_MAX_LIGHTS, (int)p->lo.count);
    if (p->lo.method == ENVL_METHOD_FIT)
        p->lo.remainder_order = (p->ambient == ENVL_POV_AMBIENT_NONE && !p->order_set) ||
                                        p->order < 0
                                    ? ENVL_REMAINDER_NONE
                                    : envl__order_option(p->order);
    if (p->order < 0)
        p->order = 2; /* the ambient of a fit without remainder: SH of its residual */
    return ENVL_OK;
}

/* ---- the computation ---- */

static envl_result out_of_memory(void) { return envl__fail(ENVL_ERR_MEMORY, "pov: out of memory"); }

/* The maps: the lit one (over a ground plane), the one cut into lights, the reference. */
static envl_result compute_maps(const pov_plan *p, int32_t threads, pov_work *w)
{
    w->lit = w->map;
    int dome = p->recipe == POV_RECIPE_DOME || p->recipe == POV_RECIPE_DOME_AMBIENT;
    /* A dome with its bounce pass over a ground reads only the sky half (its lights, their
     * reference; the ground's light is radiosity's): on a map of even height that half is a
     * window of the map's own rows, and the map with its ground (`grounded`) is not made, two
     * copies of the map fewer (a 16K map's 1.5 GiB each). */
    int window = dome && p->bounce && p->ground >= 0 && w->map->height % 2 == 0 &&
                 envl__points_fine(w->map);
    if (p->ground >= 0) {
        envl_result r = window ? envl__ground_radiance(w->map, p->ground, w->ground_radiance,
                                                       w->e_up)
                               : envl_ground_plane_map(w->map, p->ground, threads, &w->grounded,
                                                       w->ground_radiance);
        w->e_up_known = window && !r; /* lit is the map itself: its E_up, computed once */
        if (r)
            return r == ENVL_ERR_MEMORY ? out_of_memory() : r;
        if (w->grounded)
            w->lit = w->grounded;
    }
    /* A dome over a ground takes its lights from the sky half: the plane would shadow any
     * light below the horizon. The dome (pov_dome.c) always cuts the sky half apart, and
     * without a ground the lower half too: from the map's own rows when the horizon lies
     * between two (an even height), else from copies. */
    w->cut_map = w->lit;
    if (window) {
        envl_result r = envl__envmap_window(w->map, 0, w->map->height / 2, &w->sky_half);
        if (r)
            return r == ENVL_ERR_MEMORY ? out_of_memory() : r;
        w->cut_map = w->sky_half;
    } else if ((dome && w->grounded) || (p->recipe == POV_RECIPE_DOME && w->map->height % 2)) {
        envl_result r = envl_sky_hemisphere_map(w->map, threads, &w->sky_half);
        if (r)
            return r;
        if (w->grounded)
            w->cut_map = w->sky_half;
    }
    w->emit = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!w->emit)
        return out_of_memory();
    /* Under radiosity the bounce is not the include's: its error is the lights' against the
     * sky they stand for (the sky half over a ground). */
    return envl_envmap_reference_irradiance(p->bounce ? w->cut_map : w->lit, &w->ref);
}

/* The ambient's SH: the ground's bounce under a dome, the fit's remainder, else the SH of the
 * residual (zero for a full cut). */
static envl_result ambient_sh(const pov_plan *p, int32_t threads, pov_work *w)
{
    if (w->cut_map == w->sky_half) {
        /* Uniform radiance L_g below the horizon gives E(n) = pi L_g (1 - n_z) / 2 (the
         * isotropic-sky formula turned over): bands 0 and 1 exactly. */
        const double y00 = 0.28209479177387814, y1 = 0.4886025119029199;
        for (int ch = 0; ch < 3; ch++) {
            double a = ENVL_PI * w->ground_radiance[ch] / 2;
            w->ground_sh[ch] = a / y00;
            w->ground_sh[3 * 2 + ch] = -a / y1;
        }
        w->amb_order = 1;
        w->amb_sh = w->ground_sh;
        return ENVL_OK;
    }
    if (w->rem) {
        w->amb_order = w->rem_order;
        w->amb_sh = w->rem;
        return ENVL_OK;
    }
    if (!w->ls) { /* the dome's lights take the whole sky: nothing is left */
        memset(w->ground_sh, 0, sizeof w->ground_sh);
        w->amb_order = 1;
        w->amb_sh = w->ground_sh;
        return ENVL_OK;
    }
    envl_load_options rl = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    /* window auto: the least windowing that keeps it non-negative */
    envl_sh_options so = {.order = envl__order_option(p->order), .window = ENVL_WINDOW_AUTO};
    envl_result r = envl_envmap_from_pixels(envl_lights_residual(w->ls), w->info.width,
                                            w->info.height, 3, &rl, &w->residual);
    if (!r)
        r = envl_sh_compute(w->residual, &so, &w->sh);
    if (r)
        return r;
    w->amb_order = p->order;
    w->amb_sh = envl_sh_irradiance(w->sh);
    return ENVL_OK;
}

/* The ambient as written: ridge functions of the SH (checked against it to 1e-9), or the
 * hemispheric form (sh.c's) as one term. */
static envl_result ambient_form(const pov_plan *p, pov_work *w)
{
    if (p->ambient == ENVL_POV_AMBIENT_SH) {
        double dev = pov_ridge_from_sh(w->amb_order, w->amb_sh, &w->rd);
        if (!(dev >= 0 && dev <= 1e-9)) /* NaN too */
            return envl__fail(ENVL_ERR_NONFINITE, "pov: internal error: the slope-pattern form "
                              "of the SH ambient deviates by %g", dev);
    } else {
        envl__sh_artist_forms(w->amb_order, w->amb_sh, NULL, NULL, w->hemi_axis, w->hemi_sky,
                              w->hemi_ground);
        pov_ridge_from_hemi(w->hemi_axis, w->hemi_sky, w->hemi_ground, &w->rd);
    }
    return ENVL_OK;
}

/* The lights of one cut as placed: their colour their rgb, points. */
static envl_result lights_as_placed(pov_work *w)
{
    int32_t n = envl_lights_count(w->ls);
    w->lights = calloc(n > 0 ? (size_t)n : 1, sizeof *w->lights);
    if (!w->lights)
        return out_of_memory();
    for (int32_t j = 0; j < n; j++) {
        pov_light *q = w->lights + j;
        envl_lights_get(w->ls, j, &q->l);
        memcpy(q->colour, q->l.rgb, sizeof q->colour);
        q->samples = 1;
    }
    w->nlights = n;
    return ENVL_OK;
}

/* The dome's lights (pov_dome.c) and a summary of them as one set. */
static envl_result dome_lights(const pov_plan *p, int32_t count, int32_t threads, pov_work *w)
{
    envl_result r = pov_dome_lights(w->sky_half, p->ground >= 0 ? NULL : w->map, count, threads,
                                    &w->lights, &w->nlights, &w->suns, &w->below);
    if (r)
        return r;
    if (p->shadows != SHADOW_SOFT) /* points: the lights as the cut gave them */
        for (int32_t j = 0; j < w->nlights; j++) {
            pov_light *q = w->lights + j;
            q->samples = 1;
            memset(q->axis, 0, sizeof q->axis);
            memcpy(q->colour, q->l.rgb, sizeof q->colour);
        }
    memset(&w->s, 0, sizeof w->s);
    w->s.method = p->lo.method;
    w->s.count = w->nlights;
    w->s.remainder_order = -1;
    memcpy(w->s.power, w->info.power, sizeof w->s.power);
    for (int32_t j = 0; j < w->nlights; j++)
        for (int ch = 0; ch < 3; ch++)
            w->s.lights_power[ch] += w->lights[j].l.rgb[ch];
    w->s.no_light = !(envl_luminance(w->info.power[0], w->info.power[1], w->info.power[2]) > 0);
    return ENVL_OK;
}

/* One light set of `count` and its ambient; w->error the diffuse error of what is emitted. */
static envl_result compute_try(const pov_plan *p, int32_t count, int32_t threads, pov_work *w)
{
    envl_lights_options lo = p->lo;
    lo.count = count;
    envl_lights_free(w->ls);
    envl_sh_free(w->sh);
    envl_envmap_free(w->residual);
    free(w->lights);
    w->ls = NULL;
    w->sh = NULL;
    w->residual = NULL;
    w->lights = NULL;
    w->nlights = w->suns = w->below = 0;
    w->rem = NULL;
    envl_result r;
    if (p->recipe == POV_RECIPE_DOME && p->lo.method == ENVL_METHOD_VARIANCE) {
        if ((r = dome_lights(p, count, threads, w)))
            return r;
    } else {
        if ((r = envl_lights_compute(w->cut_map, &lo, &w->ls)) || (r = lights_as_placed(w)))
            return r;
        envl_lights_get_summary(w->ls, &w->s);
        w->rem = envl_lights_remainder(w->ls, &w->rem_order);
    }
    w->amb_order = -1;
    w->amb_sh = NULL;
    if (p->ambient != ENVL_POV_AMBIENT_NONE) {
        if ((r = ambient_sh(p, threads, w)) || (r = ambient_form(p, w)))
            return r;
    }
    w->error = pov_emitted_error(w->lights, w->nlights,
                                 p->ambient != ENVL_POV_AMBIENT_NONE ? &w->rd : NULL, w->ref,
                                 w->emit);
    return ENVL_OK;
}

/* The suns' light on the best-lit vertical wall over the ground's irradiance e_up (luminance):
 * the wall's normal (cos a, sin a, 0) at 64 azimuths a, each sun's rgb x max(0, n . d); then
 * the bounce pass's reuse for a low sun (POV_LOW_SUN_RATIO). */
static void low_sun(const pov_plan *p, pov_work *w, double e_up)
{
    w->low_sun = 0;
    w->bounce_reuse = 0;
    for (int k = 0; k < 64; k++) {
        double a = 2 * ENVL_PI * k / 64, n[3] = {cos(a), sin(a), 0}, wall = 0;
        for (int32_t i = 0; i < w->nlights; i++) {
            const envl_light *l = &w->lights[i].l;
            double c = n[0] * l->direction[0] + n[1] * l->direction[1];
            if (w->lights[i].sun && c > 0)
                wall += c * envl_luminance(l->rgb[0], l->rgb[1], l->rgb[2]);
        }
        if (e_up > 0 && wall / e_up > w->low_sun)
            w->low_sun = wall / e_up;
    }
    if (p->bounce && w->low_sun > POV_LOW_SUN_RATIO)
        w->bounce_reuse = POV_LOW_SUN_REUSE;
}

/* Lights and ambient; the dome's size, when not given: the smallest of its counts whose
 * diffuse error (lights + ambient against the exact integrator, unoccluded) is within the
 * recipe's bound. Then the ambient's least value, the warnings and the auto exposure. */
static envl_result compute(pov_plan *p, int32_t threads, pov_work *w)
{
    double t0 = envl__seconds();
    envl_result r = compute_maps(p, threads, w);
    if (r)
        return r;
    static const int ambient_counts[] = POV_DOME_COUNTS_AMBIENT,
                     bounce_counts[] = POV_DOME_COUNTS_BOUNCE;
    const int *counts = p->bounce ? bounce_counts : ambient_counts;
    double bound = p->bounce ? POV_DOME_BOUNCE_ERROR : POV_DOME_ERROR;
    int tries = !p->dome_auto_count ? 1
                : p->bounce        ? (int)(sizeof bounce_counts / sizeof *bounce_counts)
                                   : (int)(sizeof ambient_counts / sizeof *ambient_counts);
    for (int t = 0; t < tries; t++) {
        if ((r = compute_try(p, p->dome_auto_count ? counts[t] : p->lo.count, threads, w)))
            return r;
        if (w->error <= bound)
            break;
    }
    /* Negative ambient light is never usable: the hemispheric form and the residual's SH
     * (window auto) cannot go negative; the fit's remainder is what the fit chose, so the
     * include and the warnings say where it dips below 0. */
    w->amb_least = p->ambient != ENVL_POV_AMBIENT_NONE ? pov_ridge_least(&w->rd, &w->amb_negative)
                                                       : 0;
    if (w->amb_negative)
        warn(p, "%s: warning: the ambient irradiance is negative at %d of 4096 normals "
             "(least %.6g in a channel)", p->source, w->amb_negative, w->amb_least);
    if (w->s.no_light)
        warn(p, "%s: no light: the environment is black", p->source);
    /* Auto exposure: a white Lambertian surface facing up, unshadowed, reads POV_AUTO_WHITE:
     * its radiance is E_up / pi. */
    const double up[3] = {0, 0, 1};
    if (!w->e_up_known && envl_irradiance_exact(w->lit, 1, up, w->e_up) != ENVL_OK)
        w->e_up[0] = w->e_up[1] = w->e_up[2] = 0; /* no exposure, no low sun */
    double e_up = envl_luminance(w->e_up[0], w->e_up[1], w->e_up[2]);
    w->exposure_auto = e_up > 0 ? POV_AUTO_WHITE * ENVL_PI / e_up : 1;
    low_sun(p, w, e_up);
    w->seconds = envl__seconds() - t0;
    return ENVL_OK;
}

/* ---- the sky image ---- */

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

static int ascii(const char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s >= 0x80)
            return 0;
    return 1;
}

/* POV-Ray 3.7 opens no file name with a byte outside ASCII (tried with Debian's 3.7.0.10: an
 * image or #include named by an absolute or a relative path, or found through +L, fails; an
 * ASCII name relative to a working folder with such bytes opens). The name of `file` as the
 * include can give it: absolute when that is ASCII, else relative to the include's folder
 * (*relative set: the scene is rendered from there) when that is; NULL when neither is. */
static char *pov_name(const char *file, const char *include_path, int *relative)
{
    *relative = 0;
    char *abs = envl__normalised_path(file);
    if (!abs || ascii(abs))
        return abs;
    char *dir = envl__normalised_path(include_path ? include_path : ".");
    if (dir && include_path) {
        char *slash = strrchr(dir, '/');
        slash[slash == dir ? 1 : 0] = '\0'; /* the include's folder */
    }
    char *rel = dir ? envl__relative_path(dir, abs) : NULL;
    free(dir);
    free(abs);
    if (rel && ascii(rel)) {
        *relative = 1;
        return rel;
    }
    free(rel);
    return NULL;
}

/* Where the sky image goes: the lat-long .hdr the map was read from, as it is, else the
 * name given, else next to the include; and its name in the include. Decided before the
 * computation. */
static envl_result sky_name(pov_plan *p, const char *path, pov_work *w)
{
    if (!p->sky)
        return ENVL_OK;
    const envl_info *in = &w->info;
    w->sky_use_input = !p->sky_residual && !p->sky_image && !strcmp(in->format, "hdr") &&
                       in->layout == ENVL_LAYOUT_LATLONG && !w->map->apply_exposure &&
                       strlen(in->file) + 1 < sizeof in->file; /* not truncated */
    if (w->sky_use_input && path && !(w->sky_pov = pov_name(in->file, path, &w->sky_relative)))
        w->sky_use_input = 0; /* a name POV-Ray cannot open: a copy next to the include */
    if (w->sky_use_input) {
        w->sky_path = strdup(in->file);
        w->sky_rotate = in->rotate_degrees;
    } else if (p->sky_image) {
        w->sky_path = strdup(p->sky_image);
    } else if (path) {
        size_t n = strlen(path);
        size_t stem = ends_with(path, ".inc") ? n - 4 : n;
        w->sky_path = malloc(stem + 16);
        if (w->sky_path)
            snprintf(w->sky_path, stem + 16, "%.*s_sky.hdr", (int)stem, path);
    } else {
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: the sky image needs a name (a sky image "
                          "file, or the include's path to put it next to): the map is not a "
                          "lat-long .hdr file to use as it is");
    }
    if (!w->sky_path)
        return out_of_memory();
    if (!pov_string_ok(w->sky_path))
        return bad_name();
    if (!w->sky_pov && !(w->sky_pov = pov_name(w->sky_path, path, &w->sky_relative)))
        return envl__fail(ENVL_ERR_ARGUMENT, "pov: the sky image %s: POV-Ray 3.7 cannot open a "
                          "file name with bytes outside ASCII, and this one has them both as an "
                          "absolute path and relative to the include's folder (sky_image, "
                          "--sky-image: give it an ASCII name)", w->sky_path);
    if (w->sky_relative)
        warn(p, "pov: warning: POV-Ray 3.7 cannot open a file name with bytes outside ASCII: "
             "the include names the sky image %s relative to its own folder, as \"%s\": render "
             "from that folder", w->sky_path, w->sky_pov);
    return ENVL_OK;
}

/* Writes the canonical map (rotation applied) or the residual, unless the input is used as
 * it is; the include names it by its absolute path (the scene may be rendered from another
 * folder). */
static envl_result sky_write(const pov_plan *p, pov_work *w)
{
    if (!p->sky)
        return ENVL_OK;
    if (!w->sky_use_input) {
        envl_save_options so = {.format = "hdr"};
        /* the dome's lights take the whole sky: its residual is black */
        float *black = p->sky_residual && !w->ls
                           ? calloc((size_t)3 * w->info.width * w->info.height, sizeof(float))
                           : NULL;
        if (p->sky_residual && !w->ls && !black)
            return out_of_memory();
        envl_result r = p->sky_residual
                            ? envl_image_save(w->sky_path, w->ls ? envl_lights_residual(w->ls)
                                                                 : black,
                                              w->info.width, w->info.height, &so)
                            : envl_envmap_save(w->map, w->sky_path, &so);
        free(black);
        if (r)
            return r;
    }
    char *absolute = realpath(w->sky_path, NULL);
    if (absolute && pov_string_ok(absolute)) {
        free(w->sky_path);
        w->sky_path = absolute;
    } else {
        free(absolute);
    }
    return ENVL_OK;
}

/* No output replaces the map's file, the scene or the other output (envl_outputs_check); a
 * sky image named after the include says so. */
static envl_result outputs_check(const envl_envmap *map, const envl_pov_options *o,
                                 const pov_plan *p, const char *path, const pov_work *w)
{
    const char *outputs[2] = {path, w->sky_use_input ? NULL : w->sky_path};
    envl_result r = envl__outputs_of_map(map, o->scene_path, outputs, 1);
    if (!r && (r = envl__outputs_of_map(map, o->scene_path, outputs, 2)) && !p->sky_image)
        envl__fail_prefix(r, "pov: the sky image, named after the include (sky_image, "
                          "--sky-image, names it)");
    return r;
}

/* ---- the call ---- */

/* What the plan says, before anything is computed. */
static void fill_plan(const pov_plan *p, envl_pov_result *res)
{
    res->recipe = p->recipe;
    snprintf(res->reason, sizeof res->reason, "%s", p->why);
    res->method = p->lo.method;
    res->count = p->lo.count;
    res->ambient = p->ambient;
    res->bounce = p->bounce;
}

static void fill_result(const pov_plan *p, pov_work *w, envl_pov_result *res)
{
    fill_plan(p, res);
    res->method = w->s.method;
    res->count = w->s.count;
    res->ambient_order = p->ambient != ENVL_POV_AMBIENT_NONE ? w->amb_order : -1;
    res->ambient_terms = p->ambient != ENVL_POV_AMBIENT_NONE ? w->rd.terms : 0;
    res->ambient_least = w->amb_least;
    res->ambient_negative = w->amb_negative;
    res->ground_plane = p->ground >= 0;
    res->ground_albedo = p->ground >= 0 ? p->ground : 0;
    memcpy(res->ground_radiance, w->ground_radiance, sizeof res->ground_radiance);
    res->diffuse_error = w->error;
    res->exposure_auto = w->exposure_auto;
    res->seconds = w->seconds;
    res->no_light = w->s.no_light;
    res->sky_file = w->sky_path; /* handed over */
    w->sky_path = NULL;
}

/* Plan, compute, sky image, text; the include written or handed back. */
static envl_result pov_run(envl_envmap *map, const envl_pov_options *o, const char *path,
                           pov_plan *p, pov_work *w, envl_pov_result *res)
{
    envl_result r;
    w->map = map;
    if ((r = envl_envmap_info(map, &w->info)) || (r = plan_options(o, &w->info, p)))
        return r;
    p->out = path;
    plan_scene(o->scene_path, p);
    r = plan_recipe(o, p);
    if (res)
        fill_plan(p, res);
    if (r || (r = sky_name(p, path, w)))
        return r;
    if ((r = outputs_check(map, o, p, path, w)) || (r = compute(p, o->threads, w)) ||
        (r = sky_write(p, w)))
        return r;
    char *text = NULL;
    size_t size = 0;
    if ((r = pov_text_build(p, w, &text, &size)))
        return r;
    if (path) {
        r = envl_file_write_atomic(path, text, size);
        free(text);
        text = NULL;
        if (r)
            return r;
    }
    if (res) {
        fill_result(p, w, res);
        res->text = text;
    } else {
        free(text);
    }
    return ENVL_OK;
}

envl_result envl_pov_include_write(envl_envmap *map, const envl_pov_options *options,
                                   const char *path, envl_pov_result *result)
{
    static const envl_pov_options defaults;
    const envl_pov_options *o = options ? options : &defaults;
    if (result)
        memset(result, 0, sizeof *result);
    if (!map)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_pov_include_write: NULL map");
    pov_plan p = {0};
    pov_work w = {0};
    char *warnings = NULL;
    size_t warnings_size = 0;
    p.warn = open_memstream(&warnings, &warnings_size);
    if (!p.warn)
        return out_of_memory();
    envl_result r = pov_run(map, o, path, &p, &w, result);
    fclose(p.warn);
    if (result && warnings_size)
        result->warnings = warnings;
    else
        free(warnings);
    free(w.emit);
    free(w.sky_path);
    free(w.sky_pov);
    envl_sh_free(w.sh);
    envl_envmap_free(w.residual);
    envl_envmap_free(w.grounded);
    envl_envmap_free(w.sky_half);
    envl_lights_free(w.ls);
    free(w.lights);
    return r;
}

void envl_pov_result_free(envl_pov_result *result)
{
    if (!result)
        return;
    free(result->sky_file);
    free(result->text);
    free(result->warnings);
    result->sky_file = result->text = result->warnings = NULL;
}
