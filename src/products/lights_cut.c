/* Median cut (Debevec 2005) and variance cut: the map cut into regions of equal energy (or least
 * variance), one light per region at its energy-weighted centroid. Regions wrap across the seam;
 * the first starts at the darkest column. */
#include "lights_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Keeps 0 <= x0 < W after a split of a region that wraps. */
static void normalise_columns(const envl_envmap *m, region *r)
{
    if (r->x0 >= m->width) {
        r->x0 -= m->width;
        r->x1 -= m->width;
    }
}

/* ---- median cut (Debevec 2005) ---- */

/* The longer side in angle: width x 2 pi / W x cos(latitude at the region's centre) against
 * height x pi / H. */
static int split_along_x(const envl_envmap *m, const region *r)
{
    int32_t w = r->x1 - r->x0, h = r->y1 - r->y0;
    if (w <= 1)
        return 0;
    if (h <= 1)
        return 1;
    double theta = ENVL_PI * (0.5 - 0.5 * (r->y0 + r->y1) / m->height);
    double ang_w = w * 2.0 * ENVL_PI / m->width * cos(theta), ang_h = h * ENVL_PI / m->height;
    return ang_w >= ang_h;
}

/* Splits at the energy median: the split closest to half the region's energy. Along x by
 * binary search over the region table's blocks, then column by column within one block; along
 * y from the rows' energies (each from the table plus its ragged ends). */
static int split_median(const envl_envmap *m, const region *r, region *a, region *b)
{
    int32_t w = r->x1 - r->x0, h = r->y1 - r->y0;
    if (w <= 1 && h <= 1)
        return 0;
    int along_x = split_along_x(m, r);
    double half = 0.5 * r->energy, left = 0;
    int32_t s;
    if (!(r->energy > 0)) {
        /* no light: the geometric middle */
        s = along_x ? (2 * r->x0 + w + 1) / 2 : (2 * r->y0 + h + 1) / 2;
    } else if (along_x) {
        s = envl__median_column(m, r->x0, r->x1, r->y0, r->y1, half, &left);
    } else {
        /* the smallest s in [y0 + 1, y1 - 1] with energy(rows [y0, s)) >= half, else y1 - 1;
         * then s - 1 if that is as close to half */
        int32_t lo = r->y0 + 1, hi = r->y1 - 1;
        double e = 0, e_prev = 0;
        for (s = r->y0; s < hi && (s < lo || e < half); s++) {
            e_prev = e;
            e += envl__rect_energy(m, r->x0, r->x1, s, s + 1);
        }
        if (s > lo && fabs(e_prev - half) <= fabs(e - half)) {
            s--;
            e = e_prev;
        }
        left = e;
    }
    *a = *r;
    *b = *r;
    if (along_x) {
        a->x1 = s;
        b->x0 = s;
    } else {
        a->y1 = s;
        b->y0 = s;
    }
    a->energy = left;
    b->energy = r->energy - left;
    if (b->energy < 0)
        b->energy = 0;
    a->priority = a->energy;
    b->priority = b->energy;
    normalise_columns(m, b);
    return 1;
}

/* ---- variance cut ---- */

/* Variance of a region's energy about its centroid, on the sphere:
 * sum e |d - dbar|^2 with dbar = sum(e d) / E, which is E - |sum e d|^2 / E (|d| = 1). The
 * spherical form of Viriyothai & Debevec's image-plane variance: seam and poles need no care. */
static double variance_of(double e, const double s[3])
{
    return e > 0 ? fmax(0.0, e - (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]) / e) : 0.0;
}

typedef struct best_split {
    double worst;           /* the larger of the halves' variances */
    double va, vb;
    int axis;               /* 0: columns, 1: rows, -1: none yet */
    int32_t at;
} best_split;

/* Keeps the split [.., at) | [at, ..) when its larger half-variance is the least so far; the
 * first half holds energy le and direction sum ls of the total (tot_e, tot_s). */
static void consider_split(double le, const double ls[3], double tot_e, const double tot_s[3],
                           int axis, int32_t at, best_split *b)
{
    double rs[3] = {tot_s[0] - ls[0], tot_s[1] - ls[1], tot_s[2] - ls[2]};
    double va = variance_of(le, ls), vb = variance_of(tot_e - le, rs);
    if (fmax(va, vb) < b->worst) {
        *b = (best_split){fmax(va, vb), va, vb, axis, at};
    }
}

/* Splits where the larger of the halves' variances is least, over both axes. Marginals of the
 * region (per column: sum e, e cos t, e sin t; per row: sum e, e cos p, e sin p) give every
 * candidate's sums by prefix sums; the marginals from the cut's block sums (cut_marginals.c). */
static int split_variance(const envl_envmap *m, const cut_marginals *t, region *r, region *a,
                          region *b, double *var_a, double *var_b)
{
    int32_t w = r->x1 - r->x0, h = r->y1 - r->y0, W = m->width;
    if (w <= 1 && h <= 1)
        return 0;
    double *col = calloc((size_t)w * 3, sizeof(double)), *row = calloc((size_t)h * 3,
                                                                        sizeof(double));
    if (!col || !row) {
        free(col);
        free(row);
        return -1;
    }
    envl__cut_marginals_of(m, t, r, col, row);
    best_split best = {INFINITY, 0, 0, -1, 0};
    double tot_e = 0, tot_s[3] = {0, 0, 0};
    for (int32_t i = 0; i < w; i++) {
        int32_t c = r->x0 + i < W ? r->x0 + i : r->x0 + i - W;
        tot_e += col[3 * i];
        tot_s[0] += m->col_cos[c] * col[3 * i + 1];
        tot_s[1] += m->col_sin[c] * col[3 * i + 1];
        tot_s[2] += col[3 * i + 2];
    }
    /* along x: left = columns [x0, x0 + i) */
    double le = 0, ls[3] = {0, 0, 0};
    for (int32_t i = 1; i < w; i++) {
        int32_t c = r->x0 + i - 1 < W ? r->x0 + i - 1 : r->x0 + i - 1 - W;
        le += col[3 * (i - 1)];
        ls[0] += m->col_cos[c] * col[3 * (i - 1) + 1];
        ls[1] += m->col_sin[c] * col[3 * (i - 1) + 1];
        ls[2] += col[3 * (i - 1) + 2];
        consider_split(le, ls, tot_e, tot_s, 0, r->x0 + i, &best);
    }
    /* along y: top = rows [y0, y0 + i) */
    le = 0;
    ls[0] = ls[1] = ls[2] = 0;
    for (int32_t i = 1; i < h; i++) {
        int32_t y = r->y0 + i - 1;
        const double *rw = row + 3 * (i - 1);
        le += rw[0];
        ls[0] += m->row_cos[y] * rw[1];
        ls[1] += m->row_cos[y] * rw[2];
        ls[2] += m->row_sin[y] * rw[0];
        consider_split(le, ls, tot_e, tot_s, 1, r->y0 + i, &best);
    }
    free(col);
    free(row);
    if (best.axis < 0)
        return 0;
    *a = *r;
    *b = *r;
    if (best.axis == 0) {
        a->x1 = best.at;
        b->x0 = best.at;
    } else {
        a->y1 = best.at;
        b->y0 = best.at;
    }
    normalise_columns(m, b);
    *var_a = best.va;
    *var_b = best.vb;
    return 1;
}

typedef struct level_job {
    const envl_envmap *m;
    const region *rs;
    region *halves;     /* 2 per region; x1 = -1: not split */
} level_job;

static void split_level(void *arg, int64_t begin, int64_t end)
{
    const level_job *j = arg;
    for (int64_t i = begin; i < end; i++)
        if (!split_median(j->m, &j->rs[i], &j->halves[2 * i], &j->halves[2 * i + 1]))
            j->halves[2 * i].x1 = -1;
}

/* Cuts the map into at most n regions. Median: level by level while the count can double
 * (2^k lights exactly as Debevec's paper), then the region with the most energy next.
 * Variance: always the region of largest variance next. */
envl_result envl__cut_regions(envl_envmap *m, int32_t method, int32_t n, region **out,
                               int32_t *count)
{
    envl_result rc = envl__region_table(m);
    if (rc)
        return rc;
    /* A region holds at least one pixel: never more regions than pixels. */
    if ((int64_t)n > (int64_t)m->width * m->height)
        n = (int32_t)((int64_t)m->width * m->height);
    region *rs = malloc(sizeof(region) * (size_t)n);
    if (!rs)
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    cut_marginals marg = {0}; /* the variance cut's block sums */
    /* Start at the darkest column of the darkest block of the table: the seam of the first
     * region lies where there is least light. */
    int32_t x0 = 0, b0 = 0;
    double dark = INFINITY, cols[ENVL_TABLE_BLOCK];
    for (int32_t c = 0; c < m->width; c += ENVL_TABLE_BLOCK) {
        int32_t c1 = c + ENVL_TABLE_BLOCK < m->width ? c + ENVL_TABLE_BLOCK : m->width;
        double e = envl__rect_energy(m, c, c1, 0, m->height);
        if (e < dark) {
            dark = e;
            b0 = c;
        }
    }
    int32_t b1 = b0 + ENVL_TABLE_BLOCK < m->width ? b0 + ENVL_TABLE_BLOCK : m->width;
    envl__column_energies(m, b0, b1, 0, m->height, cols);
    for (int32_t c = b0; c < b1; c++)
        if (c == b0 || cols[c - b0] < cols[x0 - b0])
            x0 = c;
    rs[0] = (region){x0, x0 + m->width, 0, m->height, 0, 0};
    rs[0].energy = envl__rect_energy(m, rs[0].x0, rs[0].x1, 0, m->height);
    int32_t k = 1;
    if (method == ENVL_METHOD_MEDIAN) {
        rs[0].priority = rs[0].energy;
        /* a level's splits are independent: computed in parallel, collected in order */
        region *halves = malloc(sizeof(region) * 2 * (size_t)(n / 2 > 0 ? n / 2 : 1));
        if (!halves) {
            free(rs);
            return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
        }
        while (2 * k <= n) {
            int32_t before = k;
            level_job job = {m, rs, halves};
            envl__parallel_for(before, m->threads, split_level, &job);
            for (int32_t i = 0; i < before; i++)
                if (halves[2 * i].x1 >= 0) {
                    rs[i] = halves[2 * i];
                    rs[k++] = halves[2 * i + 1];
                }
            if (k == before)
                break;
        }
        free(halves);
    } else if ((rc = envl__cut_marginals_build(m, &marg))) {
        free(rs);
        return rc;
    } /* (the first region's variance: no other region to weigh it against) */
    /* Then the splittable region of highest priority (energy, or variance) next. */
    while (k < n) {
        int32_t best = -1;
        for (int32_t i = 0; i < k; i++)
            if ((rs[i].x1 - rs[i].x0 > 1 || rs[i].y1 - rs[i].y0 > 1) &&
                (best < 0 || rs[i].priority > rs[best].priority))
                best = i;
        if (best < 0)
            break;
        region a, b;
        if (method == ENVL_METHOD_MEDIAN) {
            split_median(m, &rs[best], &a, &b);
        } else {
            int s = split_variance(m, &marg, &rs[best], &a, &b, &a.priority, &b.priority);
            if (s < 0) {
                envl__cut_marginals_free(&marg);
                free(rs);
                return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
            }
            if (s == 0)
                break;
            a.energy = envl__rect_energy(m, a.x0, a.x1, a.y0, a.y1);
            b.energy = envl__rect_energy(m, b.x0, b.x1, b.y0, b.y1);
        }
        rs[best] = a;
        rs[k++] = b;
    }
    envl__cut_marginals_free(&marg);
    *out = rs;
    *count = k;
    return ENVL_OK;
}

/* A region's light: rgb = sum of L dw, at the energy-weighted centroid of its pixels' 3D
 * directions (the region's centre when it holds no light); both from the region table. */
static void region_light(const envl_envmap *m, const region *r, envl_light *l)
{
    double t[6], omega = 0;
    envl__rect_sums(m, r->x0, r->x1, r->y0, r->y1, t);
    for (int32_t y = r->y0; y < r->y1; y++)
        omega += m->row_omega[y] * (r->x1 - r->x0);
    double e = envl__lum(t[0], t[1], t[2]), len = sqrt(t[3] * t[3] + t[4] * t[4] + t[5] * t[5]);
    if (len > 1e-12 * e && len > 0) {
        for (int k = 0; k < 3; k++)
            l->direction[k] = t[3 + k] / len;
    } else {
        double cx = 0.5 * (r->x0 + r->x1) - 0.5, cy = 0.5 * (r->y0 + r->y1) - 0.5;
        envl_latlong_direction(m->width, m->height, cx, cy, l->direction);
    }
    memcpy(l->rgb, t, sizeof l->rgb);
    l->solid_angle = omega;
    envl__light_set_angle(l);
    l->rect[0] = r->x0;
    l->rect[1] = r->y0;
    l->rect[2] = r->x1;
    l->rect[3] = r->y1;
}

typedef struct region_job {
    const envl_envmap *m;
    const region *rs;
    envl_light *lights;
} region_job;

static void region_range(void *arg, int64_t begin, int64_t end)
{
    const region_job *j = arg;
    for (int64_t i = begin; i < end; i++)
        region_light(j->m, &j->rs[i], &j->lights[i]);
}

/* All regions' lights, regions shared out between the threads. */
void envl__region_lights(const envl_envmap *m, const region *rs, int32_t k, envl_light *out)
{
    region_job job = {m, rs, out};
    envl__parallel_for(k, m->threads, region_range, &job);
}
