/* The environment as a scene on a ground plane sees it (envlight pov --ground).
 *
 * A scene standing on an infinite Lambertian plane (canonical z = 0, normal +Z) of albedo a
 * never sees the map's lower hemisphere: the plane hides it and shows its own radiance
 * instead. Lit by the upper hemisphere alone (the plane cannot see itself), the plane's
 * irradiance is E_up = integral over z > 0 of L(d) d_z dw: the exact irradiance of the map at
 * the normal +Z (the lower hemisphere has n . d <= 0 there), from envl_irradiance_exact. A
 * Lambertian surface (BRDF a / pi) under irradiance E reflects the uniform radiance a E / pi
 * (e.g. Pharr, Jakob & Humphreys, Physically Based Rendering, 3rd ed., 8.3, LambertianReflection),
 * so the plane shows
 *     L_ground = a E_up / pi
 * in every direction below the horizon. The returned map keeps the upper hemisphere and sets
 * every pixel below the horizon to L_ground. A row straddling the horizon (the middle row of
 * an odd height) gets the mix of both by the solid-angle share on each side, so the map's power
 * stays exact. Left out: the scene's own objects (their shadows on the plane, occlusion near a
 * contact point) and the plane's finite size. */
#include "envlight.h"
#include "internal.h"

#include <math.h>
#include <stdlib.h>


/* The fraction of row r's solid angle below the horizon: the row spans the elevations
 * [t1, t0], t = pi (0.5 - v) (docs/design.md), and dw ~ cos t dt, so the part below 0 is
 * -sin t1 / (sin t0 - sin t1). */
static double row_below(int32_t r, int32_t h)
{
    double t0 = ENVL_PI * (0.5 - (double)r / h), t1 = ENVL_PI * (0.5 - (r + 1.0) / h);
    return t0 <= 0 ? 1 : t1 >= 0 ? 0 : -sin(t1) / (sin(t0) - sin(t1));
}

/* A copy of map whose lower hemisphere is the uniform radiance rgb (a row straddling the
 * horizon mixed by solid angle, so the power stays exact). The pixels are the new map's own
 * (adopted, not copied again); a black lower hemisphere is left as calloc gave it, pages the
 * system backs with its one zero page until written: half a map of memory, not a whole one. */
static envl_result replace_lower_hemisphere(const envl_envmap *map, const double rgb[3],
                                            int32_t threads, envl_envmap **out)
{
    int32_t w = envl_envmap_width(map), h = envl_envmap_height(map);
    const float *src = envl_envmap_pixels(map);
    int black = rgb[0] == 0 && rgb[1] == 0 && rgb[2] == 0;
    float *px = calloc((size_t)3 * w * h, sizeof(float));
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "ground plane: cannot allocate a copy of the map");
    envl__huge_pages(px, sizeof(float) * 3 * w * h);
    for (int32_t r = 0; r < h; r++) {
        double below = row_below(r, h);
        if (below == 1 && black)
            continue; /* zero already */
        const float *s = src + (size_t)3 * w * r;
        float *d = px + (size_t)3 * w * r;
        for (int32_t i = 0; i < 3 * w; i++)
            d[i] = below == 0 ? s[i] : (float)((1 - below) * s[i] + below * rgb[i % 3]);
    }
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    return envl__envmap_adopt(px, w, h, &lo, "", out);
}

envl_result envl__ground_radiance(const envl_envmap *map, double albedo, double ground_rgb[3],
                                  double e_up_out[3])
{
    if (!(albedo >= 0 && albedo <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "ground plane: albedo %g is not in 0..1", albedo);
    const double up[3] = {0, 0, 1};
    double e_up[3];
    envl_result rc = envl_irradiance_exact(map, 1, up, e_up);
    if (rc)
        return rc;
    for (int k = 0; k < 3; k++) {
        ground_rgb[k] = albedo * e_up[k] / ENVL_PI;
        if (e_up_out)
            e_up_out[k] = e_up[k];
    }
    return ENVL_OK;
}

envl_result envl_ground_plane_map(const envl_envmap *map, double albedo, int32_t threads,
                                  envl_envmap **out, double ground_rgb[3])
{
    *out = NULL;
    double ground[3];
    envl_result rc = envl__ground_radiance(map, albedo, ground, NULL);
    if (rc)
        return rc;
    if (ground_rgb)
        for (int k = 0; k < 3; k++)
            ground_rgb[k] = ground[k];
    return replace_lower_hemisphere(map, ground, threads, out);
}

envl_result envl_sky_hemisphere_map(const envl_envmap *map, int32_t threads, envl_envmap **out)
{
    static const double black[3] = {0, 0, 0};
    *out = NULL;
    return replace_lower_hemisphere(map, black, threads, out);
}
