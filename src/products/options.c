/* The one defaults pass: every options struct of the public API is resolved here, its zero
 * fields replaced by their defaults (the constants in envlight.h) and its ranges checked, in
 * the manner of sokol's _sg_desc_defaults. The products read only resolved values. */
#include "options.h"

#include <math.h>
#include <string.h>

#define DEFAULT_WIDTH 512
#define DEFAULT_MIN_WIDTH 64
#define DEFAULT_SAMPLES 64
#define DEFAULT_IRRADIANCE_WIDTH 64

int32_t envl__order(int32_t field, int32_t dflt)
{
    return field == 0 ? dflt : field == ENVL_ORDER_0 ? 0 : field;
}

int32_t envl__order_option(int32_t order)
{
    return order == 0 ? ENVL_ORDER_0 : order;
}

/* ---- lights ---- */

envl_result envl__lights_resolve(const envl_lights_options *options, resolved_lights *r)
{
    static const envl_lights_options defaults;
    const envl_lights_options *o = options ? options : &defaults;
    if (o->method < 0 || o->method >= ENVL_METHOD_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: unknown method %d", (int)o->method);
    r->method = o->method;
    r->count = o->count > 0                     ? o->count
               : o->method == ENVL_METHOD_FIT ? ENVL_DEFAULT_FIT_LIGHTS
               : o->method == ENVL_METHOD_SUN ? ENVL_DEFAULT_SUN_LIGHTS
                                              : ENVL_DEFAULT_CUT_LIGHTS;
    r->order = o->remainder_order == ENVL_REMAINDER_NONE
                   ? -1
                   : envl__order(o->remainder_order, ENVL_DEFAULT_ORDER);
    int fit = o->method == ENVL_METHOD_FIT;
    if (o->count < 0 || (fit && r->count > ENVL_FIT_MAX_LIGHTS) || r->count > (1 << 24))
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: count %d out of range (1..%d)",
                          (int)o->count, fit ? ENVL_FIT_MAX_LIGHTS : 1 << 24);
    if (fit && (r->order < -1 || r->order > ENVL_MAX_REMAINDER_ORDER))
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: remainder order %d out of range (0..%d)",
                          (int)o->remainder_order, ENVL_MAX_REMAINDER_ORDER);
    return ENVL_OK;
}

/* ---- spherical harmonics ---- */

envl_result envl__sh_resolve(const envl_sh_options *options, int32_t *order, int32_t *window)
{
    static const envl_sh_options defaults;
    const envl_sh_options *o = options ? options : &defaults;
    *order = envl__order(o->order, ENVL_DEFAULT_ORDER);
    *window = o->window;
    if (*order < 0 || *order > 32 || o->window < 0 || o->window >= ENVL_WINDOW_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "sh: order %d (0..32) or window %d out of range",
                          (int)o->order, (int)o->window);
    return ENVL_OK;
}

/* ---- the BRDF table ---- */

envl_result envl__brdf_resolve(const envl_brdf_options *options, envl_brdf_options *r)
{
    static const envl_brdf_options defaults;
    *r = options ? *options : defaults;
    r->size = r->size ? r->size : ENVL_BRDF_DEFAULT_SIZE;
    r->samples = r->samples ? r->samples : ENVL_BRDF_DEFAULT_SAMPLES;
    r->multiscatter = r->multiscatter != 0;
    if (r->size < 1 || r->size > 4096 || r->samples < 1 || r->samples > (1 << 24) ||
        r->threads < 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "brdf-lut: size %d (1..4096) or samples %d "
                          "(1..2^24) out of range", (int)r->size, (int)r->samples);
    r->threads = envl__threads(r->threads);
    return ENVL_OK;
}

/* ---- prefiltering ---- */

envl_result envl__prefilter_resolve(const envl_prefilter_options *o, const envl_envmap *m, resolved *r)
{
    static const envl_prefilter_options defaults;
    if (!o)
        o = &defaults;
    r->levels = o->levels ? o->levels : ENVL_DEFAULT_LEVELS;
    r->width = o->width ? o->width : DEFAULT_WIDTH;
    r->min_width = o->min_width ? o->min_width : DEFAULT_MIN_WIDTH;
    r->samples = o->samples ? o->samples : DEFAULT_SAMPLES;
    r->unfiltered = o->unfiltered != 0;
    r->irr_method = o->irradiance_method;
    r->irr_width = o->irradiance_width ? o->irradiance_width : DEFAULT_IRRADIANCE_WIDTH;
    r->irr_order = envl__order(o->irradiance_order, ENVL_DEFAULT_ORDER);
    r->threads = o->threads > 0 ? o->threads : m ? m->threads : envl__threads(0);
    r->sun_lights = o->sun_lights != 0;
    r->half = o->half != 0;
    r->faces = o->layout == ENVL_EXPORT_CUBE || o->layout == ENVL_EXPORT_CROSS;
    if (o->layout < 0 || o->layout >= ENVL_EXPORT_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: unknown layout %d (ENVL_EXPORT_*)",
                          (int)o->layout);
    if (r->sun_lights && r->unfiltered)
        return envl__fail(ENVL_ERR_ARGUMENT, "prefilter: sun lights need the filtered levels "
                          "(the unfiltered baseline samples the map as it is)");
    if (r->levels < 1 || r->levels > 16 || r->width < 2 || r->width > 65536 ||
        r->min_width < 2 || r->samples < 1 || r->samples > (1 << 20) || r->irr_method < 0 ||
        r->irr_method >= ENVL_IRRADIANCE_COUNT || r->irr_width < 2 || r->irr_width > 65536 ||
        r->irr_order < 0 || r->irr_order > 32 || o->threads < 0)
        return envl__fail(ENVL_ERR_ARGUMENT,
                          "prefilter: levels %d (1..16), width %d (2..65536), min width %d (>= "
                          "2), samples %d (1..2^20), irradiance method %d, width %d or order %d "
                          "out of range", (int)r->levels, (int)r->width, (int)r->min_width,
                          (int)r->samples, (int)r->irr_method, (int)r->irr_width,
                          (int)r->irr_order);
    return ENVL_OK;
}

int32_t envl__level_shift(const resolved *r, double roughness)
{
    int32_t k = r->levels > 1 ? (int32_t)floor(roughness * (r->levels - 1) + 1e-9) : 0;
    return k < 0 ? 0 : k;
}

int32_t envl__level_width(const resolved *r, double roughness)
{
    int32_t k = envl__level_shift(r, roughness);
    int32_t w = k >= 31 ? 0 : r->width >> k;
    int32_t mn = r->min_width < r->width ? r->min_width : r->width;
    return w < mn ? mn : w;
}

/* The quadrature's opening distance of a filtered level w wide (cells.c: a cell of the
 * pyramid is summed whole when its centroid is at least rho of its widths from R; the cells
 * summed per texel grow as rho^2): rho = 1 + sqrt(n) / 8, n = M (W / w)^2 at least
 * ROUGH_SAMPLES_MIN M and at most ROUGH_SAMPLES_MAX M (M samples, W the base width): rho 3 at
 * the base width and at half of it, 3.8 below (M 64). A narrower level's few texels get a
 * finer quadrature for little cost; rho 2, which the base width had before issue 30, left a
 * dark texel beside studio lamps 4.7 % off (studio_small_03 at roughness 0.19; 0.6 % at 3). */
#define ROUGH_SAMPLES_MIN 4
#define ROUGH_SAMPLES_MAX 8
double envl__level_rho(const resolved *r, int32_t w)
{
    double f = w >= r->width ? 1.0 : (double)r->width / w;
    double n = r->samples * fmin(fmax(f * f, ROUGH_SAMPLES_MIN), ROUGH_SAMPLES_MAX);
    return 1 + sqrt(n) / 8.0;
}

int32_t envl_prefilter_level_width(const envl_prefilter_options *options, double roughness)
{
    resolved r;
    if (envl__prefilter_resolve(options, NULL, &r) || !(roughness >= 0 && roughness <= 1))
        return 0;
    return envl__level_width(&r, roughness);
}
