/* The "sun" method: the map's suns split off exactly (sun_split.c), one light each, and the rest
 * of the map as the residual environment. */
#include "lights_impl.h"
#include "sun_split.h"
#include "error_measure.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- sun: the map's suns, split off exactly (sun_split.c) ---- */

typedef struct bright {
    double y;
    int32_t i;
} bright;

/* Brighter first; ties in the split's order. */
static int cmp_bright(const void *a, const void *b)
{
    const bright *x = a, *y = b;
    if (x->y != y->y)
        return x->y < y->y ? 1 : -1;
    return (x->i > y->i) - (x->i < y->i);
}

/* The pixel rectangle of the lobes that light j took (slot[taken - 1] == j): rows y0..y1 and
 * the shortest run of columns that holds them, starting after the widest gap (x1 past W when
 * the run wraps across the seam). */
static void sun_rect(const envl_envmap *m, const envl_sun_split *sp, const int32_t *slot,
                     int32_t j, unsigned char *cols, envl_light *l)
{
    int32_t W = m->width, y0 = m->height, y1 = 0, any = -1;
    memset(cols, 0, (size_t)W);
    for (int32_t i = 0; i < sp->n; i++) {
        const envl_sun_lobe *b = sp->lobes + i;
        if (b->taken > 0 && slot[b->taken - 1] == j) {
            cols[b->c] = 1;
            any = b->c;
            y0 = b->r < y0 ? b->r : y0;
            y1 = b->r + 1 > y1 ? b->r + 1 : y1;
        }
    }
    int32_t gap = 0, gap_end = any, run = 0; /* widest run of empty columns, and its end */
    for (int32_t k = 1; any >= 0 && k <= W; k++) {
        int32_t c = (any + k) % W;
        if (!cols[c]) {
            run++;
        } else {
            if (run > gap) {
                gap = run;
                gap_end = c;
            }
            run = 0;
        }
    }
    int32_t x0 = any < 0 ? 0 : gap > 0 ? gap_end : 0;
    l->rect[0] = x0;
    l->rect[1] = any < 0 ? 0 : y0;
    l->rect[2] = x0 + (W - gap);
    l->rect[3] = any < 0 ? 0 : y1;
}

/* Splits the map's bright pixels off (sun_split.c); its suns, the brightest n of them, are
 * the lights, and the residual is the map less exactly their excess: the pixels of a kept sun
 * at the split's threshold luminance, every other pixel (of other bright groups, or of suns
 * beyond n) as it was. */
envl_result envl__sun_lights(const envl_envmap *m, int32_t n, int32_t keep_residual,
                             envl_lights *ls)
{
    envl_sun_split sp;
    envl_light *all = NULL;
    int32_t nall = 0;
    envl_result rc = envl__sun_split_lobes(m, &sp);
    if (rc == ENVL_OK)
        rc = envl__sun_split_lights(m, &sp, &all, &nall);
    if (rc) {
        envl__sun_split_free(&sp);
        return rc;
    }
    int32_t k = nall < n ? nall : n;
    size_t npx = (size_t)m->width * m->height;
    bright *order = malloc(sizeof(bright) * (size_t)(nall ? nall : 1));
    int32_t *slot = malloc(sizeof(int32_t) * (size_t)(nall ? nall : 1));
    unsigned char *cols = malloc((size_t)m->width);
    ls->lights = calloc((size_t)(k ? k : 1), sizeof(envl_light));
    ls->patch = malloc(sizeof(envl_pixel_patch) * (size_t)(sp.n ? sp.n : 1));
    ls->residual = keep_residual ? malloc(sizeof(float) * 3 * npx) : NULL;
    ls->residual_skipped = !keep_residual;
    if (!order || !slot || !cols || !ls->lights || !ls->patch ||
        (keep_residual && !ls->residual)) {
        rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < nall; i++)
        order[i] = (bright){envl__lum(all[i].rgb[0], all[i].rgb[1], all[i].rgb[2]), i};
    qsort(order, (size_t)nall, sizeof *order, cmp_bright);
    for (int32_t j = 0; j < nall; j++)
        slot[order[j].i] = j < k ? j : -1;
    for (int32_t i = 0; i < sp.n; i++) {
        const envl_sun_lobe *b = sp.lobes + i;
        if (b->taken > 0 && slot[b->taken - 1] >= 0)
            ls->patch[ls->npatch++] = (envl_pixel_patch){b->r, b->c,
                                                         {b->keep[0], b->keep[1], b->keep[2]}};
    }
    if (keep_residual)
        envl__sun_residual(m, ls, ls->residual);
    for (int32_t j = 0; j < k; j++) {
        ls->lights[j] = all[order[j].i];
        sun_rect(m, &sp, slot, j, cols, &ls->lights[j]);
    }
    ls->summary.count = k;
done:
    free(order);
    free(slot);
    free(cols);
    free(all);
    envl__sun_split_free(&sp);
    return rc;
}

void envl__sun_residual(const envl_envmap *m, const envl_lights *ls, float *out)
{
    memcpy(out, m->px, sizeof(float) * 3 * (size_t)m->width * m->height);
    for (int32_t i = 0; i < ls->npatch; i++)
        memcpy(out + 3 * ((size_t)ls->patch[i].r * m->width + ls->patch[i].c), ls->patch[i].rgb,
               sizeof ls->patch[i].rgb);
}

envl_result envl__sun_residual_view(envl_envmap *m, const envl_lights *ls, int32_t threads,
                                    float **saved, envl_envmap **out)
{
    *saved = NULL;
    *out = NULL;
    float *keep = malloc(sizeof(float) * 3 * (size_t)(ls->npatch > 0 ? ls->npatch : 1));
    if (!keep)
        return envl__fail(ENVL_ERR_MEMORY, "lights: cannot save the suns' pixels");
    for (int32_t i = 0; i < ls->npatch; i++)
        memcpy(keep + 3 * (size_t)i, m->px + 3 * ((size_t)ls->patch[i].r * m->width +
                                                  ls->patch[i].c), sizeof(float) * 3);
    for (int32_t i = 0; i < ls->npatch; i++)
        memcpy(m->px + 3 * ((size_t)ls->patch[i].r * m->width + ls->patch[i].c),
               ls->patch[i].rgb, sizeof ls->patch[i].rgb);
    *saved = keep;
    /* a window's rest is the same window */
    envl_result rc = m->window ? envl__envmap_window_patched(m, m->row0, m->row1, ls->patch,
                                                             ls->npatch, out)
                               : envl__envmap_borrow(m->px, m->width, m->height, threads, out);
    if (rc) {
        envl__sun_residual_view_end(m, ls, keep, NULL);
        *saved = NULL;
    }
    return rc;
}

void envl__sun_residual_view_end(envl_envmap *m, const envl_lights *ls, float *saved,
                                 envl_envmap *view)
{
    envl_envmap_free(view);
    if (!saved)
        return;
    /* backwards: a pixel patched twice gets the value saved first, the map's own */
    for (int32_t i = ls->npatch - 1; i >= 0; i--)
        memcpy(m->px + 3 * ((size_t)ls->patch[i].r * m->width + ls->patch[i].c),
               saved + 3 * (size_t)i, sizeof(float) * 3);
    free(saved);
}

/* Exact irradiance of the sun method's residual at the error measure's normals, added to
 * approx: the residual stays an environment map (drawn as one), so it is part of what the
 * method hands a renderer. The residual is the map with the suns' pixels patched, and
 * irradiance is linear in the pixels: E_res(n) = E_map(n) + sum over the patched pixels of
 * (keep - L) integral of max(0, n . d) dw over the pixel (as envl_irradiance_exact integrates
 * it), E_map the map's reference `ref`. At most 4096 pixels (sun_split.c): no resampled copy
 * of the residual (which made the sun map's measure cost 1.5x the sun-free map's at 8K and
 * 16K, docs/performance.md). */
envl_result envl__add_residual_irradiance(const envl_envmap *m, const envl_lights *ls,
                                          const double *ref, const double *normals,
                                          double *approx)
{
    double *f = malloc(sizeof(double) * ENVL_ERROR_NORMALS);
    if (!f)
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    for (int32_t i = 0; i < 3 * ENVL_ERROR_NORMALS; i++)
        approx[i] += ref[i];
    for (int32_t p = 0; p < ls->npatch; p++) {
        const envl_pixel_patch *q = ls->patch + p;
        const float *px = m->px + 3 * ((size_t)q->r * m->width + q->c);
        double dl[3] = {q->rgb[0] - (double)px[0], q->rgb[1] - (double)px[1],
                        q->rgb[2] - (double)px[2]};
        envl__pixel_cosines(m, q->c, q->r, ENVL_ERROR_NORMALS, normals, f);
        for (int32_t j = 0; j < ENVL_ERROR_NORMALS; j++)
            for (int k = 0; k < 3; k++)
                approx[3 * j + k] += dl[k] * f[j];
    }
    free(f);
    return ENVL_OK;
}
