/* Irradiance maps: the bright pixels exactly + the SH of the rest (the default), the exact sum,
 * the exact sum over the map area-averaged to 256 x 128, or the SH reconstruction. */
#include "prefilter_impl.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RESAMPLED_IRRADIANCE_WIDTH 256
/* The split method's SH order for the rest: its clamped cosine passes band l by A_l ~ l^-5/2;
 * with no pixel above 50x the mean left, order 16 stays within about 1e-3 of the exact sum
 * over the map area-averaged to 256 x 128 (docs/accuracy.md measures both on every map). */
#define SPLIT_ORDER 16

static const char *irr_names[ENVL_IRRADIANCE_COUNT] = {"split", "sh", "exact", "resampled"};

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

/* The map area-averaged to 256 x 128 when it is wider (the integral of L dw kept), else NULL. */
static envl_result resampled_copy(const float *px, int32_t w, int32_t h, int32_t threads,
                                  envl_envmap **out)
{
    *out = NULL;
    if (w <= RESAMPLED_IRRADIANCE_WIDTH)
        return ENVL_OK;
    float *spx;
    int32_t sw = RESAMPLED_IRRADIANCE_WIDTH, sh = sw / 2;
    envl_result rc = envl__latlong_resample(px, w, h, sw, sh, 0.0, &spx);
    if (rc)
        return rc;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    rc = envl_envmap_from_pixels(spx, sw, sh, 3, &lo, out);
    free(spx);
    return rc;
}

/* The split method: E(n) = sum over the split-off pixels of e max(0, n.d) (e: their excess
 * over the threshold, L dw less T's share, at their centre: a pixel as a point, off by
 * O(pixel^2) of its own part) + the SH order-8 irradiance of the rest (every split pixel at
 * the threshold), projected from its 256-wide copy. */
static envl_result split_irradiance(envl_envmap *m, int32_t threads, int32_t n,
                                    const double *dirs, double *e)
{
    envl_sun_split sp;
    envl_envmap *rest = NULL, *small = NULL;
    envl_sh *sh = NULL;
    envl_result rc = envl__sun_split_make(m, &sp);
    if (!rc && sp.n) {
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
        rc = envl_envmap_from_pixels(sp.res, m->width, m->height, 3, &lo, &rest);
    }
    envl_envmap *r = rest ? rest : m;
    if (!rc)
        rc = resampled_copy(r->px, r->width, r->height, threads, &small);
    if (!rc) {
        envl_sh_options so = {.order = SPLIT_ORDER, .window = ENVL_WINDOW_NONE};
        rc = envl_sh_compute(small ? small : r, &so, &sh);
    }
    if (!rc)
        rc = envl_sh_eval_irradiance(sh, n, dirs, e);
    for (int32_t k = 0; !rc && k < sp.n; k++) {
        const envl_sun_lobe *b = &sp.lobes[k];
        for (int32_t i = 0; i < n; i++) {
            const double *d = dirs + 3 * i;
            double c = d[0] * b->d[0] + d[1] * b->d[1] + d[2] * b->d[2];
            if (c > 0)
                for (int ch = 0; ch < 3; ch++)
                    e[3 * i + ch] += b->e[ch] * c;
        }
    }
    envl_sh_free(sh);
    envl_envmap_free(small);
    envl_envmap_free(rest);
    envl__sun_split_free(&sp);
    return rc;
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
    } else if (o->irr_method == ENVL_IRRADIANCE_SPLIT) {
        rc = split_irradiance(m, o->threads, (int32_t)n, dirs, e);
        /* the SH of the rest may dip a little below 0 between its lobes: 0 */
        for (size_t i = 0; !rc && i < 3 * n; i++)
            e[i] = e[i] < 0 ? 0 : e[i];
    } else {
        /* resampled: the clamped cosine is smooth: the map area-averaged to 256 x 128 changes
         * E by about h^2 relative (h = pi / 128: ~6e-4), at a fraction of the cost */
        if (o->irr_method == ENVL_IRRADIANCE_RESAMPLED &&
            (rc = resampled_copy(m->px, m->width, m->height, o->threads, &small)))
            goto done;
        rc = envl_irradiance_exact(small ? small : m, (int32_t)n, dirs, e);
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
