/* The per-texel error of a map product (docs/design.md, "Error measures"): at each texel's
 * centre direction, e = (Y - Y_exact) / max(Y_exact, ENVL_TEXEL_DARK x the mean of Y_exact
 * over the sphere), luminance; the RMS weighted by the texels' solid angles and the largest |e|,
 * over every texel or ENVL_TEXEL_SAMPLES of them spread evenly through the image.
 *
 * The exact values: the irradiance through the kernel tree over the map itself (not the
 * reference's 1024-wide copy: that moves a sun by up to half its pixel, a large part of what a
 * normal near the sun's horizon receives), each within TEXEL_REFERENCE_RELATIVE of
 * max(E, the floor); P(R) by the glossy reference's cut of the cell pyramid (glossy_reference.c);
 * at roughness 0 the map's mean over the texel's footprint: exact for a lat-long texel (the
 * area resampling of resample.c); for a face's texel by 4 times as many sub-texels per side as
 * the mirror faces use, over a mip level 4 times as fine as theirs (or the map: a pixel's
 * share of the texel found to 1/16 of its width). */
#include "prefilter_impl.h"

#include <math.h>
#include <stdlib.h>

#define TEXEL_REFERENCE_RELATIVE 1e-3

const envl_texel_error envl__texel_error_none = {.rms = -1, .worst = -1};

/* The texels measured: every one, or `count` spread evenly in scan order. */
static int64_t texel_index(int64_t i, int64_t count, int64_t all)
{
    return count == all ? i : (int64_t)(((double)i + 0.5) * (double)all / (double)count);
}

typedef struct footprint_job {
    envl_image map;
    int32_t layout, w, h, n;
    const int64_t *index;
    double *out;
} footprint_job;

static void footprint_range(void *ctx, int64_t begin, int64_t end)
{
    footprint_job *j = ctx;
    for (int64_t i = begin; i < end; i++)
        envl__texel_footprint_mean(&j->map, j->layout, j->w, j->h, (int32_t)(j->index[i] % j->w),
                                   (int32_t)(j->index[i] / j->w), j->n, j->out + 3 * i);
}

/* The exact values at the measured texels (dirs), see above. */
static envl_result exact_values(envl_envmap *m, const envl_cells *C, int32_t layout, int32_t w,
                                int32_t h, const int64_t *index, int32_t count,
                                const double *dirs, double roughness, double *out)
{
    if (roughness < 0) {
        double floor[3]; /* the mean of E over the sphere is the power / 4 */
        for (int c = 0; c < 3; c++)
            floor[c] = ENVL_TEXEL_DARK * m->info.power[c] / 4;
        return envl__irradiance_relative(m, count, dirs, TEXEL_REFERENCE_RELATIVE, floor, NULL,
                                         out);
    }
    if (roughness > 0)
        return envl__glossy_reference(m, C, roughness, count, dirs, out);
    if (layout == ENVL_LAYOUT_LATLONG) {
        /* the exact area mean: the overlaps of the map's pixels in azimuth and in z */
        float *mean;
        envl_result rc = envl__latlong_resample(m->px, m->width, m->height, w, h, 0.0, &mean);
        for (int32_t i = 0; !rc && i < count; i++)
            for (int k = 0; k < 3; k++)
                out[3 * i + k] = mean[3 * index[i] + k];
        if (!rc)
            free(mean);
        return rc;
    }
    /* a face's widest texel (at its centre) is 2 / h radians across: 4 times as many
     * sub-texels per side as the mirror faces use, over a mip level with pixels a quarter as
     * wide as the texel (or the map itself) */
    envl_image theirs, map;
    envl_result rc = envl__mip_level_for(m, 2.0 / h, &theirs);
    if (!rc)
        rc = envl__mip_level_for(m, 0.5 / h, &map);
    if (rc)
        return rc;
    footprint_job j = {map, layout, w, h, 4 * envl__footprint_subdivision(2.0 / h, theirs.height),
                       index, out};
    envl__parallel_for(count, m->threads, footprint_range, &j);
    return ENVL_OK;
}

envl_result envl__texel_error(envl_envmap *m, const envl_cells *C, const float *rgb,
                              int32_t layout, int32_t w, int32_t h, const envl_light *sun,
                              int32_t n_sun, double roughness, envl_texel_error *out)
{
    *out = envl__texel_error_none;
    int64_t all = (int64_t)w * h;
    int32_t count = all < ENVL_TEXEL_SAMPLES ? (int32_t)all : ENVL_TEXEL_SAMPLES;
    int64_t *index = malloc(sizeof(int64_t) * count);
    double *dirs = malloc(sizeof(double) * 3 * count), *omega = malloc(sizeof(double) * count);
    double *approx = calloc(3 * (size_t)count, sizeof(double));
    double *exact = malloc(sizeof(double) * 3 * count);
    envl_result rc = index && dirs && omega && approx && exact
                         ? ENVL_OK
                         : envl__fail(ENVL_ERR_MEMORY, "texel error: out of memory");
    for (int32_t i = 0; !rc && i < count; i++) {
        int64_t t = index[i] = texel_index(i, count, all);
        int32_t c = (int32_t)(t % w), r = (int32_t)(t / w);
        envl__texel_direction(layout, w, h, c, r, dirs + 3 * i);
        omega[i] = envl__texel_solid_angle(layout, w, h, c, r);
        for (int k = 0; k < 3; k++)
            approx[3 * i + k] = rgb[3 * t + k];
    }
    if (!rc && roughness != 0)
        envl__sun_lights_add(sun, n_sun, roughness, count, dirs, approx);
    if (!rc)
        rc = exact_values(m, C, layout, w, h, index, count, dirs, roughness, exact);
    if (!rc) {
        /* the mean over the sphere of E is the power / 4, of P(R) (any roughness) the power
         * / 4 pi: P keeps the map's integral */
        double power = envl__lum(m->info.power[0], m->info.power[1], m->info.power[2]);
        double dark = ENVL_TEXEL_DARK * power / (roughness < 0 ? 4 : 4 * ENVL_PI);
        double se = 0, so = 0, worst = 0;
        int32_t at = 0;
        for (int32_t i = 0; i < count; i++) {
            const double *a = approx + 3 * i, *x = exact + 3 * i;
            double ye = envl__lum(x[0], x[1], x[2]);
            double e = (envl__lum(a[0], a[1], a[2]) - ye) / fmax(ye, dark);
            if (!(dark > 0)) /* a black map: exact where the product is black too */
                e = envl__lum(a[0], a[1], a[2]) == ye ? 0 : INFINITY;
            se += omega[i] * e * e;
            so += omega[i];
            if (!(fabs(e) <= worst))
                worst = fabs(e), at = i;
        }
        out->rms = so > 0 ? sqrt(se / so) : 0;
        out->worst = worst;
        for (int k = 0; k < 3; k++)
            out->worst_direction[k] = dirs[3 * at + k];
        out->measured = count;
        out->texels = all > INT32_MAX ? INT32_MAX : (int32_t)all;
    }
    free(index);
    free(dirs);
    free(omega);
    free(approx);
    free(exact);
    return rc;
}
