/* envl_compute: a request computes only the products a scene calls for (levels without
 * repeats, one SH projection shared with an SH irradiance map, one pyramid, one split of the
 * bright pixels), measures them when asked, and hands them out. */
#include "prefilter_impl.h"

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
    free(p->irr_px);
    envl_sh_free(p->sh);
    envl_lights_free(p->lights);
    free(p->sun);
    free(p->brdf);
    free(p);
}

envl_result envl_compute(envl_envmap *m, const envl_request *q, envl_products **out)
{
    if (!m || !q || !out || q->n_roughness < 0 || (q->n_roughness && !q->roughness))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_compute: bad arguments");
    *out = NULL;
    double t0 = envl__seconds();
    envl_products *p = calloc(1, sizeof *p);
    if (!p)
        return envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
    envl_result rc = envl__prefilter_resolve(&q->prefilter, m, &p->opt);
    if (rc)
        goto fail;
    snprintf(p->file, sizeof p->file, "%s", m->info.file);
    for (int32_t i = 0; i < q->n_roughness; i++)
        if (!(q->roughness[i] >= 0 && q->roughness[i] <= 1)) {
            rc = envl__fail(ENVL_ERR_ARGUMENT, "request: roughness %g is not in [0, 1]",
                            q->roughness[i]);
            goto fail;
        }
    int32_t sh_order = envl__order(q->sh_order, ENVL_DEFAULT_ORDER);
    if (sh_order < 0 || sh_order > 32) {
        rc = envl__fail(ENVL_ERR_ARGUMENT, "request: SH order %d (0..32)", (int)sh_order);
        goto fail;
    }
    envl_products_summary *s = &p->summary;
    double t;

    /* The list of levels: (roughness, width), without repeats. */
    int32_t cap = 1 + p->opt.levels + q->n_roughness;
    double *want = malloc(sizeof(double) * cap);
    p->levels = calloc((size_t)cap, sizeof(envl_level));
    p->level_px = calloc((size_t)cap, sizeof(float *));
    if (!want || !p->levels || !p->level_px) {
        free(want);
        rc = envl__fail(ENVL_ERR_MEMORY, "envl_compute: out of memory");
        goto fail;
    }
    int32_t nw = 0;
#define WANT(r)                                                                                \
    do {                                                                                       \
        double r_ = (r);                                                                       \
        int dup_ = 0;                                                                          \
        for (int32_t k_ = 0; k_ < nw; k_++)                                                    \
            dup_ |= want[k_] == r_;                                                            \
        if (!dup_)                                                                             \
            want[nw++] = r_;                                                                   \
    } while (0)
    int32_t K = p->opt.levels;
    if (q->mirror && !q->specular_chain)
        WANT(0.0);
    if (q->specular_chain)
        for (int32_t k = 0; k < K; k++)
            WANT(K > 1 ? (double)k / (K - 1) : 0.0);
    for (int32_t i = 0; i < q->n_roughness; i++)
        WANT(q->roughness[i]);
#undef WANT

    /* Diffuse: one SH projection, shared with an SH irradiance map of the same order. */
    int irr_sh = q->irradiance_map && p->opt.irr_method == ENVL_IRRADIANCE_SH;
    if (q->diffuse) {
        t = envl__seconds();
        envl_sh_options so = {.order = envl__order_option(sh_order), .window = ENVL_WINDOW_AUTO};
        if ((rc = envl_sh_compute(m, &so, &p->sh))) {
            free(want);
            goto fail;
        }
        s->sh_projections++;
        s->seconds_sh += envl__seconds() - t;
    }
    /* The bright pixels split off once for every filtered level (see make_split), and for
     * the irradiance map when they become lights. */
    int need_mips = 0;
    for (int32_t i = 0; i < nw; i++)
        need_mips |= want[i] > 0 && !p->opt.unfiltered;
    split sp = {0};
    if ((need_mips || (p->opt.sun_lights && q->irradiance_map)) && (rc = envl__split_make(m, &sp))) {
        free(want);
        goto fail;
    }
    if (p->opt.sun_lights && (rc = envl__sun_split_lights(m, &sp.sun, &p->sun, &p->n_sun))) {
        envl__split_free(&sp);
        free(want);
        goto fail;
    }
    if (q->irradiance_map) {
        t = envl__seconds();
        int projected = 0;
        const envl_sh *shared = p->sh && irr_sh && p->opt.irr_order == sh_order ? p->sh : NULL;
        envl_envmap *residual = NULL;
        if (p->n_sun) { /* the map without what the lights took */
            size_t npx = (size_t)m->width * m->height;
            float *px = malloc(sizeof(float) * 3 * npx);
            if (!px) {
                rc = envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
            } else {
                memcpy(px, m->px, sizeof(float) * 3 * npx);
                for (int32_t i = 0; i < sp.sun.n; i++)
                    if (sp.sun.lobes[i].taken) {
                        const envl_sun_lobe *b = sp.sun.lobes + i;
                        size_t at = 3 * ((size_t)b->r * m->width + b->c);
                        memcpy(px + at, sp.sun.res + at, sizeof(float) * 3);
                    }
                envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = p->opt.threads};
                rc = envl_envmap_from_pixels(px, m->width, m->height, 3, &lo, &residual);
                free(px);
            }
            shared = NULL;
        }
        if (!rc)
            rc = envl__irradiance_map(residual ? residual : m, &p->opt, shared, &p->irr_px, &p->irr,
                                &projected);
        envl_envmap_free(residual);
        if (rc) {
            envl__split_free(&sp);
            free(want);
            goto fail;
        }
        p->irr.rgb = p->irr_px;
        p->has_irradiance = 1;
        s->sh_projections += projected;
        s->irradiance_maps++;
        s->seconds_irradiance += envl__seconds() - t;
    }
    if (q->shadows) {
        t = envl__seconds();
        if ((rc = envl_lights_compute(m, &q->lights, &p->lights))) {
            envl__split_free(&sp);
            free(want);
            goto fail;
        }
        s->lights_computed = 1;
        s->seconds_lights += envl__seconds() - t;
    }
    /* One pyramid for every filtered specular level of non-zero roughness. */
    if (need_mips) {
        t = envl__seconds();
        int built = m->mip_levels == 0;
        if ((rc = envl_envmap_mips(m, &s->pyramid_levels))) {
            envl__split_free(&sp);
            free(want);
            goto fail;
        }
        s->pyramids_built += built;
        s->seconds_pyramid += envl__seconds() - t;
    }
    for (int32_t i = 0; i < nw; i++) {
        t = envl__seconds();
        rc = envl__specular_level(m, &p->opt, want[i], 0, &sp, &p->level_px[i], &p->levels[i]);
        if (!rc && !envl__floats_finite(p->level_px[i], 3 * (size_t)p->levels[i].width *
                                                      p->levels[i].height))
            rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the specular level of roughness %g "
                            "overflows the float range", m->info.file, want[i]);
        if (rc) {
            envl__split_free(&sp);
            free(want);
            goto fail;
        }
        p->levels[i].rgb = p->level_px[i];
        p->n_levels++;
        s->specular_levels++;
        s->seconds_specular += envl__seconds() - t;
    }
    envl__split_free(&sp);
    free(want);
    if (q->brdf_lut) {
        t = envl__seconds();
        envl_brdf_options bo = q->brdf;
        if (!bo.threads)
            bo.threads = p->opt.threads;
        if ((rc = envl__brdf_resolve(&bo, &bo)) || (rc = envl_brdf_lut(&bo, &p->brdf, &p->brdf_size)))
            goto fail;
        p->brdf_multiscatter = bo.multiscatter;
        p->brdf_samples = bo.samples;
        s->brdf_tables = 1;
        s->seconds_brdf += envl__seconds() - t;
    }
    s->seconds = envl__seconds() - t0;

    if (q->measure) {
        double *dirs = envl__fibonacci_dirs();
        double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        if (!dirs || !ref)
            rc = envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
        for (int32_t i = 0; !rc && i < p->n_levels; i++) {
            envl_level *l = &p->levels[i];
            rc = envl_prefilter_reference(m, l->roughness, ENVL_ERROR_NORMALS, dirs, ref);
            if (!rc)
                rc = envl__sampled_error(dirs, ref, l->rgb, l->width, l->height, p->sun,
                                   l->roughness > 0 ? p->n_sun : 0, l->roughness,
                                   &l->glossy_error);
        }
        if (!rc && p->has_irradiance) {
            const double *eref;
            rc = envl_envmap_reference_irradiance(m, &eref);
            if (!rc)
                rc = envl__sampled_error(dirs, eref, p->irr_px, p->irr.width, p->irr.height, p->sun,
                                   p->n_sun, -1, &p->irr.diffuse_error);
        }
        free(dirs);
        free(ref);
        if (rc)
            goto fail;
    }
    *out = p;
    return ENVL_OK;
fail:
    envl_products_free(p);
    return rc;
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
