/* envl_compute: a request computes only the products a scene calls for (levels without
 * repeats, one SH projection shared with an SH irradiance map, one pyramid, one split of the
 * bright pixels), measures them when asked, and hands them out. */
#include "prefilter_impl.h"
#include "ktx2.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- requests and products ---- */

void envl_products_free(envl_products *p)
{
    if (!p)
        return;
    for (int32_t i = 0; i < p->n_levels; i++)
        free(p->level_px[i]);
    free(p->level_px);
    free(p->levels);
    free(p->widths);
    free(p->irr_px);
    envl_sh_free(p->sh);
    envl_lights_free(p->lights);
    free(p->sun);
    free(p->brdf);
    free(p->source_path);
    free(p);
}

/* The work a request shares between its stages. */
typedef struct plan {
    double *want;             /* the roughness of each level, without repeats */
    int32_t n_want;
    int32_t sh_order;         /* of the diffuse SH */
    int need_mips;            /* a filtered level of roughness > 0 (needs the cell pyramid) */
    split sp;                 /* with sun lights: the bright pixels, split once, and the cells
                                 of the map less the lights (bright_lobes.c) */
    int32_t done, steps;      /* progress: steps taken, of all (envl__progress) */
} plan;

/* The next step begins: progress done / steps, and the callback's cancel. */
static envl_result step(plan *pl, const char *stage)
{
    return envl__progress((double)pl->done++ / (pl->steps > 0 ? pl->steps : 1), stage);
}

/* Adds a level of roughness r unless the plan has it. */
static void add_level(plan *pl, const resolved *o, double r)
{
    for (int32_t k = 0; k < pl->n_want; k++)
        if (pl->want[k] == r)
            return;
    pl->want[pl->n_want++] = r;
    pl->need_mips |= r > 0 && !o->unfiltered;
}

/* Checks the request and lists its levels: the mirror, the chain's K, then the requested
 * roughness values not already there, in that order. */
static envl_result plan_levels(const envl_request *q, envl_products *p, plan *pl)
{
    for (int32_t i = 0; i < q->n_roughness; i++)
        if (!(q->roughness[i] >= 0 && q->roughness[i] <= 1))
            return envl__fail(ENVL_ERR_ARGUMENT, "request: roughness %g is not in [0, 1]",
                              q->roughness[i]);
    pl->sh_order = envl__order(q->sh_order, ENVL_DEFAULT_ORDER);
    if (pl->sh_order < 0 || pl->sh_order > 32)
        return envl__fail(ENVL_ERR_ARGUMENT, "request: SH order %d (0..32)", (int)pl->sh_order);
    int32_t K = p->opt.levels, cap = 1 + K + q->n_roughness;
    pl->want = malloc(sizeof(double) * cap);
    p->levels = calloc((size_t)cap, sizeof(envl_level));
    p->level_px = calloc((size_t)cap, sizeof(float *));
    p->widths = calloc((size_t)cap, sizeof(envl_width_estimate));
    if (!pl->want || !p->levels || !p->level_px || !p->widths)
        return envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
    if (q->mirror && !q->specular_chain)
        add_level(pl, &p->opt, 0.0);
    for (int32_t k = 0; q->specular_chain && k < K; k++)
        add_level(pl, &p->opt, K > 1 ? (double)k / (K - 1) : 0.0);
    for (int32_t i = 0; i < q->n_roughness; i++)
        add_level(pl, &p->opt, q->roughness[i]);
    return ENVL_OK;
}

/* Diffuse: one SH projection (window auto), shared with an SH irradiance map of its order. */
static envl_result compute_diffuse(envl_envmap *m, envl_products *p, const plan *pl)
{
    double t = envl__seconds();
    envl_sh_options so = {.order = envl__order_option(pl->sh_order), .window = ENVL_WINDOW_AUTO};
    envl_result rc = envl_sh_compute(m, &so, &p->sh);
    p->summary.sh_projections += !rc;
    p->summary.seconds_sh += envl__seconds() - t;
    return rc;
}

/* The pixels of the map less what the sun lights took (their pixels at the split's
 * threshold). */
static float *pixels_without_sun_lights(const envl_envmap *m, const envl_sun_split *sun)
{
    size_t npx = (size_t)m->width * m->height;
    float *px = malloc(sizeof(float) * 3 * npx);
    if (!px)
        return NULL;
    memcpy(px, m->px, sizeof(float) * 3 * npx);
    for (int32_t i = 0; i < sun->n; i++)
        if (sun->lobes[i].taken)
            memcpy(px + 3 * ((size_t)sun->lobes[i].r * m->width + sun->lobes[i].c),
                   sun->lobes[i].keep, sizeof sun->lobes[i].keep);
    return px;
}

/* The map less what the sun lights took, as a map (that owns the pixels: one copy). */
static envl_result without_sun_lights(const envl_envmap *m, const envl_sun_split *sun,
                                      int32_t threads, envl_envmap **out)
{
    float *px = pixels_without_sun_lights(m, sun);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    return envl__envmap_adopt(px, m->width, m->height, &lo, "", out);
}

static envl_result compute_irradiance(envl_envmap *m, envl_products *p, const plan *pl)
{
    double t = envl__seconds();
    int projected = 0;
    const envl_sh *shared = p->sh && p->opt.irr_method == ENVL_IRRADIANCE_SH &&
                                    p->opt.irr_order == pl->sh_order
                                ? p->sh
                                : NULL;
    envl_envmap *residual = NULL;
    envl_result rc = ENVL_OK;
    if (p->n_sun) {
        rc = without_sun_lights(m, &pl->sp.sun, p->opt.threads, &residual);
        shared = NULL;
    }
    if (!rc)
        rc = envl__irradiance_map(residual ? residual : m, &p->opt, shared, &p->irr_px, &p->irr,
                                  &projected);
    envl_envmap_free(residual);
    if (rc)
        return rc;
    p->irr.rgb = p->irr_px;
    p->has_irradiance = 1;
    p->summary.sh_projections += projected;
    p->summary.irradiance_maps++;
    p->summary.seconds_irradiance += envl__seconds() - t;
    return ENVL_OK;
}

static envl_result compute_shadows(envl_envmap *m, const envl_request *q, envl_products *p)
{
    double t = envl__seconds();
    envl_result rc = envl_lights_compute(m, &q->lights, &p->lights);
    p->summary.lights_computed = !rc;
    p->summary.seconds_lights += envl__seconds() - t;
    return rc;
}

/* One cell pyramid for every filtered level of non-zero roughness (the map's, cached in it,
 * or with sun lights that of the map less the lights), then the levels. */
static envl_result compute_levels(envl_envmap *m, envl_products *p, plan *pl)
{
    envl_products_summary *s = &p->summary;
    if (pl->need_mips) {
        double t = envl__seconds();
        envl_result rc = ENVL_OK;
        int built = 0;
        const envl_cells *C = NULL;
        /* the finest level any of the levels needs: the cells below it are never built */
        int32_t base = 1 << 30;
        for (int32_t i = 0; i < pl->n_want; i++)
            if (pl->want[i] > 0) {
                int32_t b = envl__cells_base(NULL, pl->want[i] * pl->want[i], m->height);
                base = b < base ? b : base;
            }
        if (p->n_sun) {
            float *px = pl->sp.cells_px = pixels_without_sun_lights(m, &pl->sp.sun);
            rc = px ? envl__cells_build(px, m->width, m->height, base, m->threads,
                                      &pl->sp.cells)
                    : envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
            C = pl->sp.cells;
            built = 1;
        } else {
            rc = envl__map_cells(m, base, &C, &built);
        }
        if (rc)
            return rc;
        s->pyramid_levels = envl__cells_levels(C);
        s->pyramids_built += built;
        s->seconds_pyramid += envl__seconds() - t;
    }
    for (int32_t i = 0; i < pl->n_want; i++) {
        char stage[64];
        snprintf(stage, sizeof stage, "specular level %d of %d", (int)i + 1, (int)pl->n_want);
        envl_result rc = step(pl, stage);
        if (rc)
            return rc;
        double t = envl__seconds();
        envl_level *l = &p->levels[i];
        rc = envl__specular_level(m, &p->opt, pl->want[i], 0, &pl->sp, &p->level_px[i], l);
        if (!rc)
            rc = envl__level_finite(m, l, &p->level_px[i]);
        if (rc)
            return rc;
        l->rgb = p->level_px[i];
        p->n_levels++;
        s->specular_levels++;
        s->seconds_specular += envl__seconds() - t;
    }
    return ENVL_OK;
}

static envl_result compute_brdf(const envl_request *q, envl_products *p)
{
    double t = envl__seconds();
    envl_brdf_options bo = q->brdf;
    if (!bo.threads)
        bo.threads = p->opt.threads;
    envl_result rc = envl__brdf_resolve(&bo, &bo);
    if (!rc)
        rc = envl_brdf_lut(&bo, &p->brdf, &p->brdf_size);
    if (rc)
        return rc;
    p->brdf_multiscatter = bo.multiscatter;
    p->brdf_samples = bo.samples;
    p->summary.brdf_tables = 1;
    p->summary.seconds_brdf += envl__seconds() - t;
    return ENVL_OK;
}

/* The error of a map (`layout`, w x h) as written, against ref at the error directions and per
 * texel (m's exact values; C its cells for roughness > 0): with half floats (options.half) the
 * map rounded to half first, values above ENVL_HALF_MAX as it. */
static envl_result written_error(envl_envmap *m, const envl_cells *C, const envl_products *p,
                                 const double *dirs, const double *ref, const float *px,
                                 int32_t layout, int32_t w, int32_t h, int32_t n_sun,
                                 double roughness, double *error, envl_texel_error *texel)
{
    float *half = p->opt.half ? envl__half_rounded(px, 3 * (size_t)w * h) : NULL;
    if (p->opt.half && !half)
        return envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
    const float *as_written = half ? half : px;
    envl_result rc = envl__sampled_error(dirs, ref, as_written, layout, w, h, p->sun, n_sun,
                                         roughness, error);
    if (!rc)
        rc = envl__texel_error(m, C, as_written, layout, w, h, p->sun, n_sun, roughness, texel);
    free(half);
    return rc;
}

/* The glossy error of every level and the diffuse error of the irradiance map (the sun lights
 * added as the renderer adds them), and the per-texel error of each, as written; for a level
 * over ENVL_GLOSSY_TARGET the width that would meet it (sp: the split whose cells the levels
 * were computed from, with sun lights). */
static envl_result measure(envl_envmap *m, envl_products *p, const split *sp)
{
    double *dirs = envl__fibonacci_dirs();
    double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    envl_result rc = dirs && ref ? ENVL_OK
                                 : envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
    /* the glossy references cut the map's own pyramid (the levels' when no sun light took
     * from it), built once at the finest base they need */
    const envl_cells *C = NULL;
    int32_t base = 1 << 30;
    for (int32_t i = 0; i < p->n_levels; i++)
        if (p->levels[i].roughness > 0) {
            int32_t b = envl__glossy_reference_base(p->levels[i].roughness, m->height);
            base = b < base ? b : base;
        }
    if (!rc && base < (1 << 30))
        rc = envl__map_cells(m, base, &C, NULL);
    for (int32_t i = 0; !rc && i < p->n_levels; i++) {
        envl_level *l = &p->levels[i];
        int32_t n_sun = l->roughness > 0 ? p->n_sun : 0;
        rc = envl__glossy_reference(m, C, l->roughness, ENVL_ERROR_NORMALS, dirs, ref);
        if (!rc)
            rc = written_error(m, C, p, dirs, ref, l->rgb, l->layout, l->width, l->height, n_sun,
                               l->roughness, &l->glossy_error, &l->texel_error);
        if (!rc)
            rc = envl__level_width_estimate(sp->cells ? sp->cells : C, &p->opt, l, p->sun, n_sun,
                                            dirs, ref, &p->widths[i]);
    }
    if (!rc && p->sh)
        rc = envl__sh_measure(m, p->sh);
    if (!rc && p->lights)
        rc = envl__lights_measure(m, p->lights);
    if (!rc && p->has_irradiance) {
        const double *eref;
        envl_irradiance_map *im = &p->irr;
        rc = envl_envmap_reference_irradiance(m, &eref);
        if (!rc)
            rc = written_error(m, NULL, p, dirs, eref, p->irr_px, im->layout, im->width,
                               im->height, p->n_sun, -1, &im->diffuse_error, &im->texel_error);
    }
    free(dirs);
    free(ref);
    return rc;
}

envl_result envl_compute(envl_envmap *map, const envl_request *q, envl_products **out)
{
    if (!map || !q || !out || q->n_roughness < 0 || (q->n_roughness && !q->roughness))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_compute: bad arguments");
    *out = NULL;
    double t0 = envl__seconds();
    envl_products *p = calloc(1, sizeof *p);
    if (!p)
        return envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
    snprintf(p->file, sizeof p->file, "%s", map->info.file);
    p->source_info = map->info;
    plan pl = {0};
    envl_result rc = ENVL_OK;
    if (map->source_path && !(p->source_path = strdup(map->source_path)))
        rc = envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
    /* every product from the map the GGX sums can take (a too coarse one split first) */
    envl_envmap *m = map;
    if (!rc)
        rc = envl__points_map(map, &m);
    p->summary.prefiltered_width = m->width;
    p->summary.prefiltered_height = m->height;
    if (!rc)
        rc = envl__prefilter_resolve(&q->prefilter, m, &p->opt);
    if (!rc)
        rc = plan_levels(q, p, &pl);
    pl.steps = (q->diffuse != 0) + (q->irradiance_map != 0) + (q->shadows != 0) + pl.n_want +
               (q->brdf_lut != 0) + (q->measure != 0);
    if (!rc && q->diffuse && !(rc = step(&pl, "SH and lights")))
        rc = compute_diffuse(m, p, &pl);
    /* the bright pixels split once when they become lights (for the filtered levels and the
     * irradiance map) */
    if (!rc && p->opt.sun_lights && (pl.need_mips || q->irradiance_map))
        rc = envl__split_make(m, &pl.sp);
    if (!rc && p->opt.sun_lights)
        rc = envl__sun_split_lights(m, &pl.sp.sun, &p->sun, &p->n_sun);
    if (!rc && q->irradiance_map && !(rc = step(&pl, "irradiance map")))
        rc = compute_irradiance(m, p, &pl);
    if (!rc && q->shadows && !(rc = step(&pl, "shadow lights")))
        rc = compute_shadows(m, q, p);
    if (!rc)
        rc = compute_levels(m, p, &pl);
    free(pl.want);
    if (!rc && q->brdf_lut && !(rc = step(&pl, "BRDF table")))
        rc = compute_brdf(q, p);
    p->summary.seconds = envl__seconds() - t0;
    if (!rc && q->measure && !(rc = step(&pl, "error measures")))
        rc = measure(m, p, &pl.sp); /* the split kept for the levels' width estimates */
    envl__split_free(&pl.sp);
    p->measured = q->measure != 0;
    if (!rc)
        rc = envl__progress(1.0, "done");
    if (rc) {
        envl_products_free(p);
        return rc;
    }
    *out = p;
    return ENVL_OK;
}

envl_result envl_products_get_summary(const envl_products *p, envl_products_summary *out)
{
    if (!p || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_get_summary: NULL argument");
    *out = p->summary;
    return ENVL_OK;
}

int32_t envl_products_level_count(const envl_products *p) { return p ? p->n_levels : 0; }

envl_result envl_products_level(const envl_products *p, int32_t i, envl_level *out)
{
    if (!p || !out || i < 0 || i >= p->n_levels)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_level: no level %d", (int)i);
    *out = p->levels[i];
    return ENVL_OK;
}

int32_t envl_products_find_level(const envl_products *p, double roughness)
{
    for (int32_t i = 0; p && i < p->n_levels; i++)
        if (p->levels[i].roughness == roughness)
            return i;
    return -1;
}

envl_result envl_products_level_width(const envl_products *p, int32_t i, envl_width_estimate *out)
{
    if (!p || !out || i < 0 || i >= p->n_levels)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_level_width: no level %d", (int)i);
    *out = p->widths[i];
    return ENVL_OK;
}

envl_result envl_products_irradiance(const envl_products *p, envl_irradiance_map *out)
{
    if (!p || !out || !p->has_irradiance)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_products_irradiance: no irradiance map was "
                          "requested");
    *out = p->irr;
    return ENVL_OK;
}

const envl_sh *envl_products_sh(const envl_products *p) { return p ? p->sh : NULL; }
const envl_lights *envl_products_lights(const envl_products *p) { return p ? p->lights : NULL; }

const envl_light *envl_products_sun_lights(const envl_products *p, int32_t *count)
{
    if (count)
        *count = p ? p->n_sun : 0;
    return p && p->n_sun ? p->sun : NULL;
}

const float *envl_products_brdf(const envl_products *p, int32_t *size, int32_t *multiscatter)
{
    if (size)
        *size = p && p->brdf ? p->brdf_size : 0;
    if (multiscatter)
        *multiscatter = p && p->brdf ? p->brdf_multiscatter : 0;
    return p ? p->brdf : NULL;
}
