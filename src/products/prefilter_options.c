/* Prefiltering's options: the defaults resolved in one pass (envl__prefilter_resolve), the
 * width and samples of each level, and the names of the irradiance methods. */
#include "prefilter_impl.h"

#include <math.h>
#include <string.h>

#define DEFAULT_WIDTH 512
#define DEFAULT_MIN_WIDTH 64
#define DEFAULT_SAMPLES 64
#define DEFAULT_IRRADIANCE_WIDTH 64

/* ---- names ---- */

static const char *irr_names[ENVL_IRRADIANCE_COUNT] = {"resampled", "sh", "exact"};

const char *envl_irradiance_method_name(int32_t m)
{
    return m >= 0 && m < ENVL_IRRADIANCE_COUNT ? irr_names[m] : NULL;
}

int32_t envl_irradiance_method_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_IRRADIANCE_COUNT; i++)
        if (!strcmp(name, irr_names[i]))
            return i;
    return -1;
}

/* ---- options ---- */

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
    r->irr_order = o->irradiance_order ? o->irradiance_order : 2;
    r->threads = o->threads > 0 ? o->threads : m ? m->threads : envl__threads(0);
    r->sun_lights = o->sun_lights != 0;
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

int32_t envl__level_width(const resolved *r, double roughness)
{
    int32_t k = r->levels > 1 ? (int32_t)floor(roughness * (r->levels - 1) + 1e-9) : 0;
    if (k < 0)
        k = 0;
    int32_t w = k >= 31 ? 0 : r->width >> k;
    int32_t mn = r->min_width < r->width ? r->min_width : r->width;
    return w < mn ? mn : w;
}

/* GGX samples per texel of a filtered level w wide: M at the base width W and M (W / w)^2 below
 * it, at most ROUGH_SAMPLES_MAX x M: a rough level's few texels get the samples its wide lobe
 * needs for about the base level's cost (at roughness 1 the sum of 128 mip footprints was
 * 0.4-6.8 % off the lobe on the built-in sky, adams_place_bridge, lebombo and forest_slope;
 * of 512, 0.1-2.9 %; README "Accuracy against time (specular)" has today's figures). The
 * unfiltered baseline always takes M. */
#define ROUGH_SAMPLES_MAX 8
int32_t envl__level_samples(const resolved *r, int32_t w)
{
    if (r->unfiltered || w >= r->width)
        return r->samples;
    double f = (double)r->width / w;
    double n = r->samples * fmin(f * f, ROUGH_SAMPLES_MAX);
    return n > (1 << 20) ? (1 << 20) : (int32_t)n;
}

int32_t envl_prefilter_level_width(const envl_prefilter_options *options, double roughness)
{
    resolved r;
    if (envl__prefilter_resolve(options, NULL, &r) || !(roughness >= 0 && roughness <= 1))
        return 0;
    return envl__level_width(&r, roughness);
}
