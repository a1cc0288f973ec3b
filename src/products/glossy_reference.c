/* The glossy reference: the brute force (every pixel of the map, the test oracle) and the
 * measure's, a finer cut of the cell pyramid (cells.c); the glossy error of a product against
 * it, and of an irradiance map against the exact irradiance (docs/design.md, "Error
 * measures"). */
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
    envl_cancel cancel;       /* a cancel seen between directions */
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
    for (int64_t i = begin; i < end && !envl__cancel_check(&j->cancel); i++) {
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
    envl_envmap *copy; /* a too coarse map split first, as the levels are */
    envl_result rc = envl__points_copy(m, &copy);
    if (rc)
        return rc;
    ref_job j = {copy ? copy : m, a * a, dirs, out, 0, {0}};
    envl__parallel_for(count, m->threads, ref_range, &j);
    envl_envmap_free(copy);
    if (atomic_load(&j.cancel.stop))
        return ENVL_ERR_CANCELLED; /* the message: envl__progress_poll's */
    return j.failed ? envl__fail(ENVL_ERR_MEMORY, "prefilter reference: out of memory")
                    : ENVL_OK;
}

/* The glossy measure's cut: rho 6 and the horizon to 4e-3, where the levels take rho 2-3.8
 * and 1.6e-2; as fine as the levels near R (core_k 4: the levels' pyramid serves). Against the
 * brute force over 1024 directions it was within 4.9e-4 relative RMS on the 12 maps of
 * ../shared/data and the 2048 sky at roughness 0.1-1 (worst: rooitou_park at 0.2), in 1/12 of
 * its time at 1024 x 512 and 1/35 at 2048 x 1024; test_prefilter holds it to
 * ENVL_GLOSSY_REFERENCE_TOLERANCE. The cells' mean directions are doubles: as floats they moved
 * the sharpest lobes' peaks (rooitou_park at 0.1: 2.9e-3). */
const cut_accuracy envl__reference_cut = {.rho = 6.0, .core_k = 4.0, .horizon_eps = 4e-3,
                                          .horizon_power = 1e-5};

int32_t envl__glossy_reference_base(double roughness, int32_t height)
{
    return envl__cells_base(&envl__reference_cut, roughness * roughness, height);
}

envl_result envl__glossy_reference(const envl_envmap *m, const envl_cells *C, double roughness,
                                   int32_t count, const double *dirs, double *out)
{
    if (roughness == 0)
        return envl_prefilter_reference(m, roughness, count, dirs, out);
    double alpha = roughness * roughness;
    int32_t base = envl__glossy_reference_base(roughness, m->height);
    envl_cells *own = NULL;
    if (!C || envl__cells_base_of(C) > base) {
        envl_result rc = envl__cells_build(m->px, m->width, m->height, base, m->threads, &own);
        if (rc)
            return rc;
        C = own;
    }
    envl_result rc = envl__cells_at(C, &envl__reference_cut, alpha, count, dirs, m->threads, out);
    envl__cells_free(own);
    return rc;
}

/* The error of a lat-long product read bilinearly, plus n_sun sun lights as they add to P(R)
 * at `roughness` (or to E(n) for roughness < 0). */
envl_result envl__sampled_error(const double *dirs, const double *ref, const float *rgb,
                                 int32_t layout, int32_t w, int32_t h, const envl_light *sun,
                                 int32_t n_sun, double roughness, double *error)
{
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!approx)
        return envl__fail(ENVL_ERR_MEMORY, "error measure: out of memory");
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++) {
        if (layout == ENVL_LAYOUT_STRIP_H)
            envl__strip_sample(rgb, h, dirs + 3 * i, approx + 3 * i);
        else
            envl_latlong_sample(rgb, w, h, dirs + 3 * i, approx + 3 * i);
    }
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
    envl_envmap *copy = NULL; /* a too coarse map split first, as the levels are */
    if (!rc)
        rc = envl__points_copy(m, &copy);
    if (!rc)
        rc = envl__glossy_reference(copy ? copy : m, NULL, roughness, ENVL_ERROR_NORMALS, dirs,
                                    ref);
    envl_envmap_free(copy);
    if (!rc)
        rc = envl__sampled_error(dirs, ref, rgb, ENVL_LAYOUT_LATLONG, w, h, NULL, 0, roughness,
                                 error);
    free(dirs);
    free(ref);
    return rc;
}
