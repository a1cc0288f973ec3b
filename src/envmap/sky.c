/* The built-in procedural sky: a sun disc of 0.53 degrees, a sky whose radiance rises towards
 * the horizon and around the sun, and a uniform diffuse ground lit by both.
 *
 * Units follow the Poly Haven maps (sky radiance of order 1). The sun's irradiance at normal
 * incidence defaults to 12, about five times the sky's horizontal irradiance, as on a clear
 * day (direct normal ~ 800 W/m^2 against diffuse horizontal ~ 100-150 W/m^2); its radiance is
 * then ~ 2e5 times the sky's, the "sun a million times brighter" class of map. */
#include "envmap_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Colours of luminance 1 (Rec.709 weights), so parameters given as luminance stay luminance. */
static void unit_luminance(const double in[3], double out[3])
{
    double y = envl__lum(in[0], in[1], in[2]);
    for (int k = 0; k < 3; k++)
        out[k] = in[k] / y;
}

envl_result envl_envmap_sky(const envl_sky_options *options, envl_envmap **out)
{
    static const envl_sky_options defaults;
    const envl_sky_options *o = options ? options : &defaults;
    if (!out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_sky: out is NULL");
    *out = NULL;
    double elev_deg = (o->sun_elevation_degrees != 0.0 || o->sun_elevation_is_set)
                          ? o->sun_elevation_degrees : 35.0;
    double azim_deg = o->sun_azimuth_degrees;
    int32_t w = o->width > 0 ? o->width : 1024;
    int32_t h = w / 2 > 0 ? w / 2 : 1;
    double e_sun = o->sun_irradiance > 0 ? o->sun_irradiance : 12.0;
    double zenith = o->zenith_radiance > 0 ? o->zenith_radiance : 0.6;
    double albedo = o->ground_albedo > 0 ? o->ground_albedo : 0.2;
    if (!(elev_deg >= -90 && elev_deg <= 90) || !isfinite(azim_deg) || w > 65536)
        return envl__fail(ENVL_ERR_ARGUMENT,
                          "sky: sun elevation %g must be within [-90, 90], width %d <= 65536",
                          elev_deg, (int)w);

    envl_image img = {0};
    envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};
    envl_result rc = envl__image_alloc(&img, w, h, &lim, "sky");
    if (rc)
        return rc;
    snprintf(img.meta.format, sizeof img.meta.format, "sky");
    img.meta.channels = 3;
    img.meta.exposure = 1.0;

    double el = elev_deg * ENVL_PI / 180.0, az = azim_deg * ENVL_PI / 180.0;
    double sun[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)};
    double zenith_col[3], horizon_col[3], glow_col[3], sun_col[3], ground_col[3];
    unit_luminance((double[3]){0.45, 0.65, 1.0}, zenith_col);
    unit_luminance((double[3]){0.85, 0.90, 1.0}, horizon_col);
    unit_luminance((double[3]){1.0, 0.85, 0.65}, glow_col);
    unit_luminance((double[3]){1.0, 0.93, 0.83}, sun_col);
    unit_luminance((double[3]){1.0, 0.92, 0.80}, ground_col);

    /* Sky (z > 0): luminance zenith * (1 + 1.5 (1 - z)^3) (brighter towards the horizon)
     * plus a circumsolar glow 3 * zenith * exp(-gamma / 0.2) (gamma: angle to the sun),
     * colour from zenith blue to horizon white. */
    double sky_horizontal[3] = {0, 0, 0};
    for (int32_t r = 0; r < h; r++) {
        double omega = envl_latlong_solid_angle(w, h, r);
        for (int32_t c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            if (d[2] <= 0)
                continue;
            double t = (1 - d[2]) * (1 - d[2]);
            double base = zenith * (1.0 + 1.5 * (1 - d[2]) * (1 - d[2]) * (1 - d[2]));
            double cosg = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
            double gamma = acos(cosg > 1 ? 1 : cosg < -1 ? -1 : cosg);
            double glow = 3.0 * zenith * exp(-gamma / 0.2);
            float *p = img.px + 3 * ((size_t)r * w + c);
            for (int k = 0; k < 3; k++) {
                double v = base * ((1 - t) * zenith_col[k] + t * horizon_col[k]) +
                           glow * glow_col[k];
                p[k] = (float)v;
                sky_horizontal[k] += v * omega * d[2];
            }
        }
    }

    /* Sun disc: each pixel's share of the disc's solid angle by 16 x 16 sub-samples, then
     * normalised so the whole disc delivers exactly e_sun (luminance) at normal incidence.
     * Only the part above the horizon shows (a setting sun delivers its visible fraction). */
    const double radius = 0.5 * ENVL_SKY_SUN_DIAMETER_DEGREES * ENVL_PI / 180.0;
    const double cos_radius = cos(radius);
    double sun_c, sun_r;
    envl_latlong_pixel(w, h, sun, &sun_c, &sun_r);
    double pix = ENVL_PI / h; /* angular height of a row */
    int32_t reach_r = (int32_t)ceil(radius / pix) + 2;
    double cos_el = cos(el) > 1e-9 ? cos(el) : 1e-9;
    int32_t reach_c = (int32_t)ceil(radius / (2 * ENVL_PI / w) / cos_el) + 2;
    if (reach_c > w / 2 + 1)
        reach_c = w / 2 + 1;
    int32_t r0 = (int32_t)floor(sun_r) - reach_r, r1 = (int32_t)floor(sun_r) + reach_r;
    int32_t c0 = (int32_t)floor(sun_c) - reach_c, c1 = (int32_t)floor(sun_c) + reach_c;
    if (r0 < 0)
        r0 = 0;
    if (r1 > h - 1)
        r1 = h - 1;
    size_t cells = (size_t)(r1 - r0 + 1) * (size_t)(c1 - c0 + 1);
    double *share = calloc(cells, sizeof(double));
    if (!share) {
        envl__image_free(&img);
        return envl__fail(ENVL_ERR_MEMORY, "sky: out of memory");
    }
    const int S = 16;
    double total = 0.0; /* the whole disc's sampled solid angle, hidden part included */
    for (int32_t r = r0; r <= r1; r++) {
        double omega = envl_latlong_solid_angle(w, h, r);
        for (int32_t cc = c0; cc <= c1; cc++) {
            int32_t c = ((cc % w) + w) % w;
            int inside = 0, visible = 0;
            for (int i = 0; i < S; i++)
                for (int j = 0; j < S; j++) {
                    double d[3];
                    envl_latlong_direction(w, h, c - 0.5 + (j + 0.5) / S,
                                           r - 0.5 + (i + 0.5) / S, d);
                    double cosg = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
                    inside += cosg >= cos_radius;
                    visible += cosg >= cos_radius && d[2] > 0;
                }
            share[(size_t)(r - r0) * (c1 - c0 + 1) + (cc - c0)] = omega * visible / (S * S);
            total += omega * inside / (S * S);
        }
    }
    double sun_horizontal = 0.0;
    if (total > 0) {
        for (int32_t r = r0; r <= r1; r++) {
            double omega = envl_latlong_solid_angle(w, h, r);
            for (int32_t cc = c0; cc <= c1; cc++) {
                double s = share[(size_t)(r - r0) * (c1 - c0 + 1) + (cc - c0)];
                if (s <= 0)
                    continue;
                int32_t c = ((cc % w) + w) % w;
                /* L * omega summed over the disc = e_sun * (visible share / total). */
                double l = e_sun * (s / total) / omega;
                float *p = img.px + 3 * ((size_t)r * w + c);
                for (int k = 0; k < 3; k++)
                    p[k] += (float)(l * sun_col[k]);
            }
        }
        sun_horizontal = e_sun * fmax(0.0, sin(el));
    }
    free(share);

    /* Ground (z <= 0): Lambertian, radiance = albedo * E_horizontal / pi. */
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            if (d[2] > 0)
                continue;
            float *p = img.px + 3 * ((size_t)r * w + c);
            for (int k = 0; k < 3; k++)
                p[k] = (float)(albedo * ground_col[k] *
                               (envl__lum(sky_horizontal[0], sky_horizontal[1],
                                               sky_horizontal[2]) + sun_horizontal) / ENVL_PI);
        }

    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    rc = envl__envmap_from_image(&img, &lo, "sky", out);
    if (rc == ENVL_OK)
        snprintf((*out)->info.file, sizeof(*out)->info.file, "built-in sky (sun elevation %g, "
                 "azimuth %g degrees)", elev_deg, azim_deg);
    return rc;
}
