/* Lights that stand in for the environment: the call (envl_lights_compute) picks the method
 * (lights_cut.c, lights_fit.c, lights_sun.c), measures the diffuse error of what it made, and
 * hands the lights, the SH remainder and the residual map out. */
#include "lights_impl.h"
#include "error_measure.h"
#include "options.h"
#include "nnls.h"
#include "sh_basis.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *method_names[ENVL_METHOD_COUNT] = {
    [ENVL_METHOD_FIT] = "fit", [ENVL_METHOD_MEDIAN] = "median",
    [ENVL_METHOD_VARIANCE] = "variance", [ENVL_METHOD_SUN] = "sun"};

const char *envl_method_name(int32_t method)
{
    return method >= 0 && method < ENVL_METHOD_COUNT ? method_names[method] : NULL;
}

int32_t envl_method_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_METHOD_COUNT; i++)
        if (!strcmp(name, method_names[i]))
            return i;
    return -1;
}

/* ---- evaluation ---- */

envl_result envl_lights_irradiance(const envl_lights *ls, int32_t count, const double *normals,
                                   double *out)
{
    if (!ls || count < 0 || (count && (!normals || !out)))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_irradiance: bad arguments");
    int32_t order = ls->summary.remainder_order;
    double y[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < count; i++) {
        const double *n = normals + 3 * i;
        double e[3] = {0, 0, 0};
        for (int32_t j = 0; j < ls->summary.count; j++) {
            double c = envl__clamped_dot(n, ls->lights[j].direction);
            for (int k = 0; k < 3; k++)
                e[k] += ls->lights[j].rgb[k] * c;
        }
        if (order >= 0) {
            envl_sh_eval(order, n, y);
            for (int32_t j = 0; j < envl_sh_count(order); j++)
                for (int k = 0; k < 3; k++)
                    e[k] += ls->remainder[3 * j + k] * y[j];
        }
        memcpy(out + 3 * i, e, sizeof e);
    }
    return ENVL_OK;
}

/* ---- the call ---- */

void envl_light_over_residual(const envl_light *l, double direction[3], double rgb[3])
{
    /* |V| = rgb (1 - w / 4 pi) along V (lights_take.c, envl__light_size) */
    double keep = 1.0 - l->take_solid_angle / (4.0 * ENVL_PI);
    for (int k = 0; k < 3; k++) {
        direction[k] = l->take_direction[k];
        rgb[k] = l->rgb[k] * keep;
    }
}

/* Every number the lights carry is finite: their directions, colours and sizes, the SH
 * remainder, the residual map (float) and the summary (a map near FLT_MAX could overflow). */
static int lights_finite(const envl_lights *ls)
{
    const envl_lights_summary *s = &ls->summary;
    int ok = isfinite(s->diffuse_error);
    for (int k = 0; k < 3; k++)
        ok &= isfinite(s->power[k]) && isfinite(s->lights_power[k]) &&
              isfinite(s->residual_power[k]);
    for (int32_t i = 0; ok && i < s->count; i++) {
        const envl_light *l = ls->lights + i;
        for (int k = 0; k < 3; k++)
            ok &= isfinite(l->direction[k]) && isfinite(l->rgb[k]) &&
                  isfinite(l->take_direction[k]);
        ok &= isfinite(l->solid_angle) && isfinite(l->angle) && isfinite(l->take_solid_angle) &&
              isfinite(l->take_angle);
    }
    int32_t nsh = s->remainder_order >= 0 ? (s->remainder_order + 1) * (s->remainder_order + 1)
                                          : 0;
    for (int32_t j = 0; ok && ls->remainder && j < 3 * nsh; j++)
        ok &= isfinite(ls->remainder[j]);
    size_t npx = (size_t)ls->width * ls->height * 3;
    for (size_t i = 0; ok && ls->residual && i < npx; i++)
        ok &= isfinite(ls->residual[i]);
    return ok;
}

/* The diffuse error of the lights (+ remainder; sun: + the residual's exact irradiance). */
envl_result envl__lights_measure(envl_envmap *m, envl_lights *ls)
{
    int32_t method = ls->summary.method;
    const double *ref;
    envl_result rc = envl_envmap_reference_irradiance(m, &ref);
    if (rc)
        return rc;
    double *normals = envl__fibonacci_dirs();
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!normals || !approx)
        rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    if (!rc)
        envl_lights_irradiance(ls, ENVL_ERROR_NORMALS, normals, approx);
    if (!rc && method == ENVL_METHOD_SUN)
        rc = envl__add_residual_irradiance(m, ls, ref, normals, approx);
    if (!rc)
        ls->summary.diffuse_error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, approx, ref);
    free(normals);
    free(approx);
    return rc;
}

envl_result envl_lights_compute(envl_envmap *m, const envl_lights_options *options,
                                envl_lights **out)
{
    if (!m || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_compute: NULL argument");
    *out = NULL;
    resolved_lights ro;
    envl_result rc = envl__lights_resolve(options, &ro);
    if (rc)
        return rc;
    const resolved_lights *o = &ro;
    int32_t n = ro.count, order = ro.order;
    envl_lights *ls = calloc(1, sizeof *ls);
    if (!ls)
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    ls->width = m->width;
    ls->height = m->height;
    envl_lights_summary *s = &ls->summary;
    s->method = o->method;
    s->remainder_order = -1;
    memcpy(s->power, m->info.power, sizeof s->power);
    double t0 = envl__seconds();
    if (!(envl__lum(s->power[0], s->power[1], s->power[2]) > 0)) {
        /* A black map: no lights, an all-zero residual, no error. */
        s->no_light = 1;
        s->seconds = envl__seconds() - t0;
        *out = ls;
        return ENVL_OK;
    }
    if (o->method == ENVL_METHOD_FIT) {
        ls->residual_skipped = options && options->skip_residual;
        if (!(rc = envl__progress(0.0, "fitting the lights")))
            rc = envl__fit_lights(m, n, order, !ls->residual_skipped, ls);
    } else if (o->method == ENVL_METHOD_SUN) {
        rc = envl__sun_lights(m, n, !(options && options->skip_residual), ls);
    } else {
        region *rs;
        int32_t k;
        rc = envl__cut_regions(m, o->method, n, &rs, &k);
        if (rc == ENVL_OK) {
            ls->lights = calloc((size_t)k, sizeof(envl_light));
            if (!ls->lights)
                rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
            else
                envl__region_lights(m, rs, k, ls->lights);
            s->count = k;
            free(rs);
            /* The regions cover the sphere: the lights take everything, the residual is zero
             * (made when asked for). */
        }
    }
    if (rc)
        goto fail;
    s->seconds = envl__seconds() - t0;
    if (o->method != ENVL_METHOD_FIT)
        for (int32_t i = 0; i < s->count; i++) {
            /* a cut's region and a sun: what the light took is what it stands for */
            envl_light *l = &ls->lights[i];
            memcpy(l->take_direction, l->direction, sizeof l->direction);
            l->take_solid_angle = l->solid_angle;
            l->take_angle = l->angle;
        }

    for (int32_t i = 0; i < s->count; i++)
        for (int k = 0; k < 3; k++)
            s->lights_power[k] += ls->lights[i].rgb[k];
    /* residual power = power - what the lights took (exact bookkeeping, in double) */
    for (int k = 0; k < 3; k++)
        s->residual_power[k] = s->power[k] - s->lights_power[k];

    s->diffuse_error = -1;
    if (options && options->measure && !(rc = envl__progress(0.8, "the error measure")))
        rc = envl__lights_measure(m, ls);
    if (rc == ENVL_OK && !lights_finite(ls))
        rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the lights overflow (a value is not finite; "
                        "the largest pixel value is %g)", m->info.file,
                        fmax(m->info.max[0], fmax(m->info.max[1], m->info.max[2])));
    if (rc == ENVL_OK)
        rc = envl__progress(1.0, "done");
    if (rc)
        goto fail;
    *out = ls;
    return ENVL_OK;
fail:
    envl_lights_free(ls);
    return rc;
}

void envl_lights_free(envl_lights *ls)
{
    if (!ls)
        return;
    free(ls->lights);
    free(ls->remainder);
    free(ls->patch);
    free(ls->residual);
    free(ls);
}

int32_t envl_lights_count(const envl_lights *ls) { return ls ? ls->summary.count : 0; }

envl_result envl_lights_get(const envl_lights *ls, int32_t i, envl_light *out)
{
    if (!ls || !out || i < 0 || i >= ls->summary.count)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_get: index %d out of range", (int)i);
    *out = ls->lights[i];
    return ENVL_OK;
}

envl_result envl_lights_get_summary(const envl_lights *ls, envl_lights_summary *out)
{
    if (!ls || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_get_summary: NULL argument");
    *out = ls->summary;
    return ENVL_OK;
}

const double *envl_lights_remainder(const envl_lights *ls, int32_t *order)
{
    if (order)
        *order = ls ? ls->summary.remainder_order : -1;
    return ls ? ls->remainder : NULL;
}

envl_result envl__lights_residual_map(const envl_envmap *m, const envl_lights *ls,
                                      int32_t threads, envl_envmap **out)
{
    *out = NULL;
    if (!ls || ls->width != m->width || ls->height != m->height)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: not the lights of this map");
    size_t n = 3 * (size_t)m->width * m->height;
    const float *kept = ls->summary.method == ENVL_METHOD_SUN ? NULL : envl_lights_residual(ls);
    if (ls->summary.method != ENVL_METHOD_SUN && !kept)
        return ls->residual_skipped ? ENVL_ERR_ARGUMENT : ENVL_ERR_MEMORY; /* it said why */
    float *px = malloc(sizeof(float) * n);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "lights: cannot allocate the residual map");
    envl__huge_pages(px, sizeof(float) * n);
    if (kept)
        memcpy(px, kept, sizeof(float) * n);
    else
        envl__sun_residual(m, ls, px);
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    return envl__envmap_adopt(px, m->width, m->height, &lo, "", out);
}

envl_result envl_lights_residual_map(const envl_envmap *m, const envl_lights *ls, int32_t width,
                                     envl_envmap **out)
{
    if (!out)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: no place for the residual map");
    *out = NULL;
    if (!m || !ls)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: no map or no lights");
    if (width < 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: residual width %d (0: the map's)",
                          (int)width);
    if (ls->width != m->width || ls->height != m->height)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: not the lights of this map");
    if (width == 0 || width >= m->width)
        return envl__lights_residual_map(m, ls, m->threads, out);
    if (ls->summary.method == ENVL_METHOD_SUN) /* the map with the suns' pixels patched */
        return envl__envmap_resampled_patched(m->px, m->width, m->height, ls->patch, ls->npatch,
                                              width, m->threads, out);
    const float *kept = envl_lights_residual(ls);
    if (!kept)
        return ls->residual_skipped ? ENVL_ERR_ARGUMENT : ENVL_ERR_MEMORY; /* it said why */
    return envl__envmap_resampled(kept, m->width, m->height, width, m->threads, out);
}

const float *envl_lights_residual(const envl_lights *ls)
{
    if (!ls)
        return NULL;
    if (ls->residual_skipped) {
        envl__fail(ENVL_ERR_ARGUMENT, "lights: no residual was kept (skip_residual)");
        return NULL;
    }
    if (!ls->residual) {
        /* Cuts and black maps: nothing is left. calloc: zero pages cost nothing until read. */
        envl_lights *mut = (envl_lights *)ls;
        mut->residual = calloc((size_t)ls->width * ls->height * 3, sizeof(float));
        if (!mut->residual)
            envl__fail(ENVL_ERR_MEMORY, "lights: cannot allocate the residual map");
    }
    return ls->residual;
}
