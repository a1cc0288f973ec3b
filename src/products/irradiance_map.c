/* Irradiance maps: the exact sum, the exact sum over the map area-averaged to 256 x 128, or the
 * SH reconstruction. */
#include "prefilter_impl.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RESAMPLED_IRRADIANCE_WIDTH 256

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

/* ---- irradiance maps ---- */

static double *latlong_dirs(int32_t w, int32_t h)
{
    double *d = malloc(sizeof(double) * 3 * (size_t)w * h);
    if (d)
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++)
                envl_latlong_direction(w, h, c, r, d + 3 * ((size_t)r * w + c));
    return d;
}

/* Every value of a float product is finite (checked before anything is written). */
int envl__floats_finite(const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* `sh` may be given (an SH object of the right order, shared with the diffuse product). */
envl_result envl__irradiance_map(envl_envmap *m, const resolved *o, const envl_sh *sh,
                                  float **out, envl_irradiance_map *st, int *projected)
{
    double t0 = envl__seconds();
    int32_t w = o->irr_width, h = w / 2 > 0 ? w / 2 : 1;
    size_t n = (size_t)w * h;
    *out = NULL;
    double *dirs = latlong_dirs(w, h), *e = malloc(sizeof(double) * 3 * n);
    float *px = malloc(sizeof(float) * 3 * n);
    envl_result rc = ENVL_OK;
    envl_sh *own = NULL;
    envl_envmap *small = NULL;
    if (!dirs || !e || !px) {
        rc = envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
        goto done;
    }
    if (o->irr_method == ENVL_IRRADIANCE_SH) {
        if (!sh) {
            /* window auto: the least windowing that keeps the irradiance non-negative */
            envl_sh_options so = {.order = envl__order_option(o->irr_order),
                                  .window = ENVL_WINDOW_AUTO};
            if ((rc = envl_sh_compute(m, &so, &own)))
                goto done;
            sh = own;
            *projected = 1;
        }
        rc = envl_sh_eval_irradiance(sh, (int32_t)n, dirs, e);
        /* the auto window keeps it >= 0 at its 4096 test directions; a dip between them
         * (small) becomes 0 */
        for (size_t i = 0; !rc && i < 3 * n; i++)
            e[i] = e[i] < 0 ? 0 : e[i];
    } else if (o->irr_method == ENVL_IRRADIANCE_EXACT || m->width <= RESAMPLED_IRRADIANCE_WIDTH) {
        rc = envl_irradiance_exact(m, (int32_t)n, dirs, e);
    } else {
        /* The clamped cosine is smooth: the map area-averaged to 256 x 128 changes E by about
         * h^2 relative (h = pi / 128: ~6e-4), at a fraction of the cost. */
        float *spx;
        int32_t sw = RESAMPLED_IRRADIANCE_WIDTH, sh_ = sw / 2;
        if ((rc = envl__latlong_resample(m->px, m->width, m->height, sw, sh_, 0.0, &spx)))
            goto done;
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = o->threads};
        rc = envl_envmap_from_pixels(spx, sw, sh_, 3, &lo, &small);
        free(spx);
        if (!rc)
            rc = envl_irradiance_exact(small, (int32_t)n, dirs, e);
    }
    if (rc)
        goto done;
    for (size_t i = 0; i < 3 * n; i++) {
        /* stored as float: a map near FLT_MAX has irradiance (pi L) beyond it */
        if (!(fabs(e[i]) <= FLT_MAX)) {
            rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the irradiance map overflows the float "
                            "range (%g; the largest is %g)", m->info.file, e[i], FLT_MAX);
            goto done;
        }
        px[i] = (float)e[i];
    }
    memset(st, 0, sizeof *st);
    st->method = o->irr_method;
    st->width = w;
    st->height = h;
    st->diffuse_error = -1;
    st->seconds = envl__seconds() - t0;
    *out = px;
    px = NULL;
done:
    free(dirs);
    free(e);
    free(px);
    envl_sh_free(own);
    envl_envmap_free(small);
    return rc;
}
