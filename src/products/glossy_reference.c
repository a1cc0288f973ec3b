/* The brute-force glossy reference (every pixel of the map, the test oracle) and the glossy
 * error of a product against it (docs/design.md, "Error measures"). */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>

/* ---- the brute-force reference ---- */

typedef struct ref_job {
    const envl_envmap *m;
    double a2;
    const double *dirs;
    double *out;
    int failed;
} ref_job;

static void ref_range(void *ctx, int64_t begin, int64_t end)
{
    ref_job *j = ctx;
    const envl_envmap *m = j->m;
    double *ac = malloc(sizeof(double) * m->width);
    if (!ac) {
        j->failed = 1;
        return;
    }
    for (int64_t i = begin; i < end; i++) {
        const double *R = j->dirs + 3 * i;
        double *o = j->out + 3 * i;
        if (j->a2 == 0) {
            double c, r;
            envl_latlong_pixel(m->width, m->height, R, &c, &r);
            int64_t ci = (int64_t)floor(c + 0.5), ri = (int64_t)floor(r + 0.5);
            ci %= m->width;
            if (ci < 0)
                ci += m->width;
            ri = ri < 0 ? 0 : ri >= m->height ? m->height - 1 : ri;
            for (int k = 0; k < 3; k++)
                o[k] = m->px[3 * (ri * m->width + ci) + k];
            continue;
        }
        for (int32_t c = 0; c < m->width; c++)
            ac[c] = R[0] * m->col_cos[c] + R[1] * m->col_sin[c];
        double s[3] = {0, 0, 0}, ws = 0;
        for (int32_t r = 0; r < m->height; r++) {
            double rc = m->row_cos[r], rz = R[2] * m->row_sin[r];
            double rs[3] = {0, 0, 0}, rw = 0;
            const float *p = m->px + (size_t)r * m->width * 3;
            for (int32_t c = 0; c < m->width; c++) {
                double d = rc * ac[c] + rz; /* R.l */
                if (d <= 0)
                    continue;
                double w = ggx_w(d, j->a2);
                rs[0] += w * p[3 * c], rs[1] += w * p[3 * c + 1], rs[2] += w * p[3 * c + 2];
                rw += w;
            }
            double om = m->row_omega[r];
            for (int k = 0; k < 3; k++)
                s[k] += om * rs[k];
            ws += om * rw;
        }
        for (int k = 0; k < 3; k++)
            o[k] = ws > 0 ? s[k] / ws : 0.0;
    }
    free(ac);
}

envl_result envl_prefilter_reference(const envl_envmap *m, double roughness, int32_t count,
                                     const double *dirs, double *out)
{
    if (!m || count < 0 || (count && (!dirs || !out)) || !(roughness >= 0 && roughness <= 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_prefilter_reference: bad arguments");
    double a = roughness * roughness;
    ref_job j = {m, a * a, dirs, out, 0};
    envl__parallel_for(count, m->threads, ref_range, &j);
    return j.failed ? envl__fail(ENVL_ERR_MEMORY, "prefilter reference: out of memory")
                    : ENVL_OK;
}

/* The width of the glossy reference's copy at roughness r: a pixel (2 pi / W) at most a
 * sixteenth of alpha = r^2, W >= 32 pi / alpha, but at least ENVL_REFERENCE_WIDTH and at most
 * the map's: roughness 0.2 keeps 2514 columns, 0.4 and up 1024. Against the sum over every
 * pixel, the built-in sky at 2048 (a 0.5-degree sun) moves by 6e-4 RMS at roughness 0.4, 3e-4
 * at 0.5, less above (test_prefilter). A quarter of alpha left 1.2 % at 0.2. */
int32_t envl__glossy_reference_width(int32_t map_width, double roughness)
{
    double a = roughness * roughness;
    double w = a > 0 ? ceil(32 * ENVL_PI / a / 2) * 2 : map_width;
    w = fmax(w, ENVL_REFERENCE_WIDTH);
    return w < map_width ? (int32_t)w : map_width;
}

envl_result envl__glossy_reference(const envl_envmap *m, double roughness, int32_t count,
                                   const double *dirs, double *out)
{
    int32_t w = envl__glossy_reference_width(m->width, roughness);
    if (w == m->width)
        return envl_prefilter_reference(m, roughness, count, dirs, out);
    envl_envmap *small;
    envl_result rc = envl__envmap_resampled(m->px, m->width, m->height, w, m->threads, &small);
    if (!rc)
        rc = envl_prefilter_reference(small, roughness, count, dirs, out);
    envl_envmap_free(small);
    return rc;
}

/* The error of a lat-long product read bilinearly, plus n_sun sun lights as they add to P(R)
 * at `roughness` (or to E(n) for roughness < 0). */
envl_result envl__sampled_error(const double *dirs, const double *ref, const float *rgb,
                                 int32_t w, int32_t h, const envl_light *sun, int32_t n_sun,
                                 double roughness, double *error)
{
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!approx)
        return envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_latlong_sample(rgb, w, h, dirs + 3 * i, approx + 3 * i);
    envl__sun_lights_add(sun, n_sun, roughness, ENVL_ERROR_NORMALS, dirs, approx);
    *error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, approx, ref);
    free(approx);
    return ENVL_OK;
}

envl_result envl_glossy_error(const envl_envmap *m, double roughness, const float *rgb,
                              int32_t w, int32_t h, double *error)
{
    if (!m || !rgb || w <= 0 || h <= 0 || !error)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_glossy_error: bad arguments");
    double *dirs = envl__fibonacci_dirs();
    double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    envl_result rc = !dirs || !ref ? envl__fail(ENVL_ERR_MEMORY, "glossy error: out of memory")
                                   : ENVL_OK;
    if (!rc)
        rc = envl__glossy_reference(m, roughness, ENVL_ERROR_NORMALS, dirs, ref);
    if (!rc)
        rc = envl__sampled_error(dirs, ref, rgb, w, h, NULL, 0, roughness, error);
    free(dirs);
    free(ref);
    return rc;
}
