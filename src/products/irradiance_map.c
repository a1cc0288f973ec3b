/* Irradiance maps, each texel computed at its centre direction (a lat-long image or cube
 * faces): the bright pixels exactly + the rest through the kernel tree (the default), the
 * exact sum, the exact sum over the map area-averaged to 256 x 128, or the SH reconstruction. */
#include "prefilter_impl.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RESAMPLED_IRRADIANCE_WIDTH 256
/* The split method's rest is summed at the map's own pixels up to this width, resampled to it
 * beyond (split_irradiance). */
#define SPLIT_REST_WIDTH 2048
/* The share of the split's promise left to that resampling: the tree sums the rest within
 * (1 - SPLIT_RESAMPLE_SHARE) of it when it was resampled. */
#define SPLIT_RESAMPLE_SHARE 0.2

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

/* The centre directions of the texels of a product image (layout.c). */
static double *texel_dirs(int32_t layout, int32_t w, int32_t h)
{
    double *d = malloc(sizeof(double) * 3 * (size_t)w * h);
    if (d)
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++)
                envl__texel_direction(layout, w, h, c, r, d + 3 * ((size_t)r * w + c));
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

/* The map area-averaged to `width` wide when it is wider (the integral of L dw kept), else
 * NULL. */
static envl_result resampled_copy(const float *px, int32_t w, int32_t h, int32_t width,
                                  int32_t threads, envl_envmap **out)
{
    *out = NULL;
    return w <= width ? ENVL_OK : envl__envmap_resampled(px, w, h, width, threads, out);
}

/* The split-off pixels of one 16 x 16 block of the map: their sum of e d per channel and the
 * cap (centre, radius) that holds them. Where n lights the whole cap, the group
 * adds n.M exactly (max(0, n.d) is linear there); where it lights none, nothing; else each of
 * its pixels is added. */
#define LOBE_BLOCK 16
typedef struct lobe_group {
    double M[3][3], centre[3], sin_radius;
    int32_t first, count;      /* its lobes in `order` */
} lobe_group;

typedef struct lobe_key {
    int64_t block;
    int32_t k;
} lobe_key;

static int by_block(const void *a, const void *b)
{
    const lobe_key *x = a, *y = b;
    return x->block != y->block ? (x->block < y->block ? -1 : 1) : (x->k > y->k) - (x->k < y->k);
}

/* Adds each lobe's light at the n directions to e_out, its pixel (w x h) integrated exactly:
 * e / dw x the integral of max(0, n.d) dw over the pixel. Lit throughout that is e n . D / dw
 * (D: envl__pixel_moment; not e n . centre, which near a pole is off by a good part of the
 * lobe's light where n.d is small: 1.9 % of a 128-face texel on a 128 x 64 map with its top
 * row bright); across n's horizon envl__pixel_cosine. */
static envl_result add_lobes(const envl_sun_split *sp, int32_t w, int32_t h, int32_t n,
                             const double *dirs, double *e_out)
{
    lobe_key *key = malloc(sizeof(lobe_key) * sp->n);
    lobe_group *g = calloc((size_t)sp->n, sizeof *g);
    double *pixel_radius = malloc(sizeof(double) * 2 * h), *omega = pixel_radius + h;
    double *mean = malloc(sizeof(double) * 3 * (size_t)sp->n); /* each lobe's D / dw */
    if (!key || !g || !pixel_radius || !mean) {
        free(key);
        free(g);
        free(pixel_radius);
        free(mean);
        return envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
    }
    for (int32_t r = 0; r < h; r++) {
        /* a pixel's directions are within half its diagonal of its centre (the row's widest
         * width), as irradiance.c's tables */
        double t1 = ENVL_PI * (0.5 - (double)r / h), t0 = ENVL_PI * (0.5 - (r + 1.0) / h);
        double widest = t0 < 0 && t1 > 0 ? 1.0 : fmax(cos(t0), cos(t1));
        double dt = t1 - t0, dw = 2 * ENVL_PI / w * widest;
        pixel_radius[r] = 0.5 * sqrt(dt * dt + dw * dw) * 1.0001 + 1e-12;
        omega[r] = envl_latlong_solid_angle(w, h, r);
    }
    for (int32_t k = 0; k < sp->n; k++) {
        const envl_sun_lobe *b = &sp->lobes[k];
        envl__pixel_moment(w, h, b->c, b->r, mean + 3 * k);
        for (int a = 0; a < 3; a++)
            mean[3 * k + a] /= omega[b->r];
    }
    int64_t across = (w + LOBE_BLOCK - 1) / LOBE_BLOCK;
    for (int32_t k = 0; k < sp->n; k++)
        key[k] = (lobe_key){sp->lobes[k].r / LOBE_BLOCK * across + sp->lobes[k].c / LOBE_BLOCK, k};
    qsort(key, (size_t)sp->n, sizeof *key, by_block);
    int32_t ng = 0;
    for (int32_t k = 0; k < sp->n; k++) {
        if (k == 0 || key[k].block != key[k - 1].block)
            g[ng++].first = k;
        lobe_group *q = &g[ng - 1];
        const envl_sun_lobe *b = &sp->lobes[key[k].k];
        q->count++;
        for (int ch = 0; ch < 3; ch++)
            for (int a = 0; a < 3; a++)
                q->M[ch][a] += b->e[ch] * mean[3 * key[k].k + a];
        for (int a = 0; a < 3; a++)
            q->centre[a] += b->d[a];
    }
    for (int32_t j = 0; j < ng; j++) {
        lobe_group *q = &g[j];
        double len = sqrt(q->centre[0] * q->centre[0] + q->centre[1] * q->centre[1] +
                          q->centre[2] * q->centre[2]);
        double radius = 0; /* the cap holds every pixel, not only its centre */
        for (int32_t k = q->first; k < q->first + q->count; k++) {
            const envl_sun_lobe *b = &sp->lobes[key[k].k];
            double c = (q->centre[0] * b->d[0] + q->centre[1] * b->d[1] +
                        q->centre[2] * b->d[2]) / len;
            radius = fmax(radius, acos(fmin(1.0, c)) * (1 + 1e-9) + 1e-12 + pixel_radius[b->r]);
        }
        for (int a = 0; a < 3; a++)
            q->centre[a] /= len;
        q->sin_radius = radius < 0.5 * ENVL_PI ? sin(radius) : 2.0; /* 2: never wholly lit */
    }
    for (int32_t i = 0; i < n; i++) {
        const double *d = dirs + 3 * i;
        double *e = e_out + 3 * i;
        for (int32_t j = 0; j < ng; j++) {
            const lobe_group *q = &g[j];
            double c = d[0] * q->centre[0] + d[1] * q->centre[1] + d[2] * q->centre[2];
            if (c > q->sin_radius) {
                for (int ch = 0; ch < 3; ch++)
                    e[ch] += d[0] * q->M[ch][0] + d[1] * q->M[ch][1] + d[2] * q->M[ch][2];
            } else if (c >= -q->sin_radius) {
                for (int32_t k = q->first; k < q->first + q->count; k++) {
                    const envl_sun_lobe *b = &sp->lobes[key[k].k];
                    double t = d[0] * b->d[0] + d[1] * b->d[1] + d[2] * b->d[2];
                    if (fabs(t) < pixel_radius[b->r]) {
                        double f = envl__pixel_cosine(w, h, b->c, b->r, d) / omega[b->r];
                        for (int ch = 0; ch < 3; ch++)
                            e[ch] += b->e[ch] * f;
                    } else if (t > 0) {
                        const double *u = mean + 3 * key[k].k;
                        double f = d[0] * u[0] + d[1] * u[1] + d[2] * u[2];
                        for (int ch = 0; ch < 3; ch++)
                            e[ch] += b->e[ch] * f;
                    }
                }
            }
        }
    }
    free(key);
    free(g);
    free(pixel_radius);
    free(mean);
    return ENVL_OK;
}

/* Cube faces wider than REST_FACE get the rest's irradiance (the map less its bright pixels:
 * at most the threshold anywhere, so its E is smooth) at faces of REST_FACE texels, read
 * bilinearly (envl__strip_sample) at their texels; the bright pixels stay exact per texel.
 * Bilinear reading of f at spacing h is off by h^2/8 (|f_ss| + |f_tt|) where f is smooth: the
 * second differences D2 at the coarse texels are h^2 f'', so (|D2_s| + |D2_t|) / 8; a kink of
 * slope jump g inside a cell (a source's horizon) is off by up to g h / 4, and the fourth
 * difference D4 at one of the cell's corners is at least g h / 2 (h^4 f'''' where f is
 * smooth), so |D4| / 2 more. The coarse texels are summed within REST_COARSE x the rest's
 * budget (the split's promise, ENVL_SPLIT_RELATIVE x max(E, the floor), less what a resampled
 * rest was allowed); a texel where the largest estimate of its cell's corners passes
 * REST_READ x the budget (2x of margin on the 0.9 left: an estimate, not a bound), and a
 * texel beyond the outermost coarse centres on both axes (read across two face edges at once,
 * which the differences along s and t do not see: up to 0.52 % off on studio_small_03_1k),
 * gets the rest summed through the kernel tree at its own direction. Read everywhere,
 * 128-texel faces were up to 9 % of a dark texel off (tests/test_irradiance.c). With 0.2 and
 * 0.3 (8/3 of margin; until 2026-12-02) 20-53 % of a 1K map's 128-face texels were summed,
 * with 0.1 and 0.45 5-42 % (the coarse sums' own scatter enters the differences). */
#define REST_FACE 32
#define REST_COARSE 0.1
#define REST_READ 0.45

/* The bound of reading the coarse faces bilinearly near each coarse texel, per channel:
 * (|D2_s| + |D2_t|) / 8 + (|D4_s| + |D4_t|) / 2 from the second and fourth differences along
 * s and t of the values 2 texels either side (across a face's edge: read where the face's
 * plane continues, envl__strip_sample). */
static void rest_curvature(const float *rest, double *bound)
{
    const int32_t f = REST_FACE, w = 6 * REST_FACE;
    for (int32_t r = 0; r < f; r++)
        for (int32_t c = 0; c < w; c++) {
            double s = 2 * (c % f + 0.5) / f - 1, t = 1 - 2 * (r + 0.5) / f, step = 2.0 / f;
            double v[2][5][3]; /* along s, along t: the values at -2 .. 2 steps */
            for (int axis = 0; axis < 2; axis++)
                for (int k = -2; k <= 2; k++) {
                    double d[3];
                    envl__face_direction(c / f, s + (axis ? 0 : k * step),
                                         t + (axis ? k * step : 0), d);
                    envl__strip_sample(rest, f, d, v[axis][k + 2]);
                }
            for (int ch = 0; ch < 3; ch++) {
                double sum = 0;
                for (int axis = 0; axis < 2; axis++) {
                    const double(*q)[3] = v[axis];
                    double d2 = q[1][ch] - 2 * q[2][ch] + q[3][ch];
                    double d4 = q[0][ch] - 4 * q[1][ch] + 6 * q[2][ch] - 4 * q[3][ch] + q[4][ch];
                    sum += fabs(d2) / 8 + fabs(d4) / 2;
                }
                bound[3 * ((size_t)r * w + c) + ch] = sum;
            }
        }
}

/* The largest bound of the (up to 4) coarse texels around fine texel (c, r) of faces of
 * `face` texels (the same face; its texel centres at (i + 0.5) / face of the face's width). */
static void cell_bound(const double *bound, int32_t face, int32_t c, int32_t r, double out[3])
{
    const int32_t f = REST_FACE, w = 6 * REST_FACE;
    int32_t base = c / face * f;
    double x = ((c % face) + 0.5) * f / face - 0.5, y = (r + 0.5) * f / face - 0.5;
    int32_t x0 = (int32_t)floor(x), y0 = (int32_t)floor(y);
    out[0] = out[1] = out[2] = 0;
    for (int32_t v = y0; v <= y0 + 1; v++)
        for (int32_t u = x0; u <= x0 + 1; u++) {
            int32_t uu = u < 0 ? 0 : u > f - 1 ? f - 1 : u, vv = v < 0 ? 0 : v > f - 1 ? f - 1 : v;
            const double *b = bound + 3 * ((size_t)vv * w + base + uu);
            for (int ch = 0; ch < 3; ch++)
                out[ch] = fmax(out[ch], b[ch]);
        }
}

/* The rest's E at the n texels of faces of `face` > REST_FACE texels (dirs; lobes: the
 * bright pixels' E there, the base of the tolerance), within `budget` x max(E, floor) where the
 * estimate above holds, see above. */
static envl_result rest_from_coarse(const envl_envmap *rest_map, const envl_sun_split *sp,
                                    int32_t map_w, int32_t map_h, int32_t face,
                                    const double *dirs, double budget, const double floor[3],
                                    const double *lobes, double *e)
{
    const int32_t nc = 6 * REST_FACE * REST_FACE;
    size_t n = (size_t)6 * face * face;
    double *cdirs = texel_dirs(ENVL_LAYOUT_STRIP_H, 6 * REST_FACE, REST_FACE);
    double *clobes = calloc(3 * (size_t)nc, sizeof(double)), *ce = malloc(sizeof(double) * 3 * nc);
    double *bound = malloc(sizeof(double) * 3 * nc);
    float *strip = malloc(sizeof(float) * 3 * nc);
    int32_t *redo = malloc(sizeof(int32_t) * n);
    envl_result rc = cdirs && clobes && ce && bound && strip && redo
                         ? ENVL_OK
                         : envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
    if (!rc && sp->n)
        rc = add_lobes(sp, map_w, map_h, nc, cdirs, clobes);
    if (!rc)
        rc = envl__irradiance_relative(rest_map, nc, cdirs, REST_COARSE * budget, floor, clobes,
                                       ce);
    int32_t nredo = 0;
    if (!rc) {
        for (int32_t i = 0; i < 3 * nc; i++)
            strip[i] = (float)ce[i];
        rest_curvature(strip, bound);
        for (size_t i = 0; i < n; i++) {
            double b[3];
            int32_t c = (int32_t)(i % (6 * (size_t)face)), r = (int32_t)(i / (6 * (size_t)face));
            envl__strip_sample(strip, REST_FACE, dirs + 3 * i, e + 3 * i);
            cell_bound(bound, face, c, r, b);
            /* beyond the outermost coarse centres on both axes: a corner of the face */
            double x = (c % face + 0.5) * REST_FACE / face - 0.5;
            double y = (r + 0.5) * REST_FACE / face - 0.5;
            int over = (x < 0 || x > REST_FACE - 1) && (y < 0 || y > REST_FACE - 1);
            for (int ch = 0; ch < 3; ch++)
                over |= b[ch] > REST_READ * budget *
                                    fmax(lobes[3 * i + ch] + e[3 * i + ch], floor[ch]);
            if (over)
                redo[nredo++] = (int32_t)i;
        }
    }
    if (!rc && nredo) {
        /* the texels the cells cannot promise: summed at their own directions */
        double *rd = malloc(sizeof(double) * 3 * nredo), *rl = malloc(sizeof(double) * 3 * nredo);
        double *re = malloc(sizeof(double) * 3 * nredo);
        rc = rd && rl && re ? ENVL_OK
                            : envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
        for (int32_t k = 0; !rc && k < nredo; k++)
            for (int a = 0; a < 3; a++) {
                rd[3 * k + a] = dirs[3 * (size_t)redo[k] + a];
                rl[3 * k + a] = lobes[3 * (size_t)redo[k] + a];
            }
        if (!rc)
            rc = envl__irradiance_relative(rest_map, nredo, rd, budget, floor, rl, re);
        for (int32_t k = 0; !rc && k < nredo; k++)
            for (int a = 0; a < 3; a++)
                e[3 * (size_t)redo[k] + a] = re[3 * k + a];
        free(rd);
        free(rl);
        free(re);
    }
    free(cdirs);
    free(clobes);
    free(ce);
    free(bound);
    free(strip);
    free(redo);
    return rc;
}

/* The split method: E(n) = sum over the split-off pixels of e / dw x the integral of
 * max(0, n.d) dw over the pixel (e: their excess over the threshold, L dw less T's share;
 * add_lobes) + the irradiance of the rest (every split pixel at the threshold) summed through
 * the kernel tree (irradiance.c), within ENVL_SPLIT_RELATIVE of each texel's E (at least
 * ENVL_TEXEL_DARK x the mean of E): the rest's sharp edges (the threshold's plateau) stay
 * exact where an SH expansion of them rang by several percent in the dark directions
 * (docs/accuracy.md). The tree's block sums keep each block's first moment, so its cost
 * hardly depends on the map's size; the rest is summed at the map's own pixels up to
 * SPLIT_REST_WIDTH. Area-averaging moves light within a coarse pixel (a plateau's edge most):
 * to 256 wide it moved E by up to 0.39 % (studio_small_03_1k, dikhololo_night_1k; measured
 * against the rest at 1024 wide), to 512 wide by 0.085 %; a map wider than SPLIT_REST_WIDTH is
 * averaged to it, at most 1/8 of 256's pixel, and the tree sums within the promise less
 * SPLIT_RESAMPLE_SHARE (0.1 % of E: an estimate from those figures, not a bound). On cube faces
 * wider than REST_FACE the rest comes from faces of REST_FACE texels where that keeps the
 * promise (above). face: the cube's face width, or 0 (a lat-long image). */
static envl_result split_irradiance(envl_envmap *m, int32_t threads, int32_t face, size_t n,
                                    const double *dirs, double *e)
{
    envl_sun_split sp;
    envl_envmap *small = NULL;
    envl_pixel_patch *patch = NULL;
    double *lobes = calloc(3 * n, sizeof(double));
    envl_result rc = lobes ? envl__sun_split_lobes(m, &sp)
                           : envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
    if (!lobes)
        memset(&sp, 0, sizeof sp);
    if (!rc && sp.n) {
        /* the rest resampled straight from the map with the split pixels as patches: the same
         * floats as resampling a residual copy, without the copy */
        int32_t w = m->width < SPLIT_REST_WIDTH ? m->width : SPLIT_REST_WIDTH;
        rc = (patch = envl__sun_split_patches(&sp))
                 ? envl__envmap_resampled_patched(m->px, m->width, m->height, patch, sp.n, w,
                                                  threads, &small)
                 : envl__fail(ENVL_ERR_MEMORY, "irradiance map: out of memory");
    } else if (!rc) {
        rc = resampled_copy(m->px, m->width, m->height, SPLIT_REST_WIDTH, threads, &small);
    }
    if (!rc && sp.n)
        rc = add_lobes(&sp, m->width, m->height, (int32_t)n, dirs, lobes);
    if (!rc) {
        double floor[3]; /* the mean of E over the sphere is the power / 4 */
        for (int c = 0; c < 3; c++)
            floor[c] = ENVL_TEXEL_DARK * m->info.power[c] / 4;
        double budget = ENVL_SPLIT_RELATIVE *
                        (m->width > SPLIT_REST_WIDTH ? 1 - SPLIT_RESAMPLE_SHARE : 1);
        rc = face > REST_FACE
                 ? rest_from_coarse(small ? small : m, &sp, m->width, m->height, face, dirs,
                                    budget, floor, lobes, e)
                 : envl__irradiance_relative(small ? small : m, (int32_t)n, dirs, budget,
                                             floor, lobes, e);
    }
    for (size_t i = 0; !rc && i < 3 * n; i++)
        e[i] += lobes[i];
    free(lobes);
    free(patch);
    envl_envmap_free(small);
    envl__sun_split_free(&sp);
    return rc;
}

/* `sh` may be given (an SH object of the right order, shared with the diffuse product). */
envl_result envl__irradiance_map(envl_envmap *m, const resolved *o, const envl_sh *sh,
                                  float **out, envl_irradiance_map *st, int *projected)
{
    double t0 = envl__seconds();
    int32_t layout = o->faces ? ENVL_LAYOUT_STRIP_H : ENVL_LAYOUT_LATLONG;
    int32_t face = o->irr_width / 4 > 0 ? o->irr_width / 4 : 1;
    int32_t w = o->faces ? 6 * face : o->irr_width;
    int32_t h = o->faces ? face : w / 2 > 0 ? w / 2 : 1;
    size_t n = (size_t)w * h;
    *out = NULL;
    double *dirs = texel_dirs(layout, w, h), *e = malloc(sizeof(double) * 3 * n);
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
        rc = split_irradiance(m, o->threads, o->faces ? face : 0, n, dirs, e);
    } else {
        /* resampled: the map area-averaged to 256 x 128, at a fraction of the cost; averaging
         * moves light within a coarse pixel, most at a bright edge: worst texel 0.04-3.0 % on
         * the 12 maps of docs/performance.md (not the h^2 ~6e-4 once assumed here) */
        if (o->irr_method == ENVL_IRRADIANCE_RESAMPLED &&
            (rc = resampled_copy(m->px, m->width, m->height, RESAMPLED_IRRADIANCE_WIDTH,
                                 o->threads, &small)))
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
    st->layout = layout;
    st->diffuse_error = -1;
    st->texel_error = envl__texel_error_none;
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
