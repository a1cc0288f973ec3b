/* Lights that stand in for the environment: median cut, variance cut, fitted lights + SH
 * remainder, the map's suns split off; each with its physical irradiance, region, and the
 * residual environment.
 *
 * Energy of a pixel = luminance x its solid angle. Regions are pixel rectangles of the
 * canonical lat-long map, [x0, x1) x [y0, y1), where x1 may exceed the width: the region then
 * wraps across the seam. The first region starts at the darkest column, so a sun on the seam
 * is never cut in two. */
#include "envmap_impl.h"
#include "clock.h"
#include "nnls.h"
#include "sh_basis.h"
#include "sun_split.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct envl_lights {
    envl_lights_summary summary;
    envl_light *lights;
    double *remainder;      /* irradiance SH, (order+1)^2 x 3, or NULL */
    int32_t width, height;
    float *residual;        /* width x height x 3 (fit: what the cones left; sun: the map
                               less the suns' excess); for the cuts (which take everything)
                               made, all zero, only when asked for */
};

static const char *method_names[ENVL_METHOD_COUNT] = {"median", "variance", "fit", "sun"};

const char *envl_method_name(int32_t method)
{
    return method >= 0 && method < ENVL_METHOD_COUNT ? method_names[method] : NULL;
}

int32_t envl_method_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_METHOD_COUNT; i++)
        if (!strcmp(name, method_names[i]))
            return i;
    return -1;
}

typedef struct region {
    int32_t x0, x1, y0, y1;
    double energy;
    double priority;        /* which region to split next */
} region;

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
 * candidate's sums by prefix sums. Cost: one pass over the region. */
static int split_variance(const envl_envmap *m, region *r, region *a, region *b, double *var_a,
                          double *var_b)
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
    for (int32_t y = r->y0; y < r->y1; y++) {
        double omega = m->row_omega[y], ct = m->row_cos[y], st = m->row_sin[y];
        double *rw = row + 3 * (y - r->y0);
        for (int32_t x = r->x0; x < r->x1; x++) {
            int32_t c = x < W ? x : x - W;
            const float *p = m->px + 3 * ((size_t)y * W + c);
            double e = envl__lum(p[0], p[1], p[2]) * omega;
            double *cl = col + 3 * (x - r->x0);
            cl[0] += e;
            cl[1] += e * ct;
            cl[2] += e * st;
            rw[0] += e;
            rw[1] += e * m->col_cos[c];
            rw[2] += e * m->col_sin[c];
        }
    }
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

/* Variance of a whole region (one pass). */
static double region_variance(const envl_envmap *m, const region *r)
{
    int32_t W = m->width;
    double e = 0, s[3] = {0, 0, 0};
    for (int32_t y = r->y0; y < r->y1; y++) {
        double omega = m->row_omega[y], ct = m->row_cos[y], st = m->row_sin[y];
        for (int32_t x = r->x0; x < r->x1; x++) {
            int32_t c = x < W ? x : x - W;
            const float *p = m->px + 3 * ((size_t)y * W + c);
            double v = envl__lum(p[0], p[1], p[2]) * omega;
            e += v;
            s[0] += v * ct * m->col_cos[c];
            s[1] += v * ct * m->col_sin[c];
            s[2] += v * st;
        }
    }
    return variance_of(e, s);
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
static envl_result cut_regions(envl_envmap *m, int32_t method, int32_t n, region **out,
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
    } else {
        rs[0].priority = region_variance(m, &rs[0]);
    }
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
            int s = split_variance(m, &rs[best], &a, &b, &a.priority, &b.priority);
            if (s < 0) {
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
static void region_lights(const envl_envmap *m, const region *rs, int32_t k, envl_light *out)
{
    region_job job = {m, rs, out};
    envl__parallel_for(k, m->threads, region_range, &job);
}

/* ---- evaluation ---- */

static double clamped_dot(const double a[3], const double b[3])
{
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return d > 0 ? d : 0;
}

envl_result envl_lights_irradiance(const envl_lights *ls, int32_t count, const double *normals,
                                   double *out)
{
    if (!ls || count < 0 || (count && (!normals || !out)))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_irradiance: bad arguments");
    int32_t order = ls->summary.remainder_order;
    double y[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < count; i++) {
        const double *n = normals + 3 * i;
        double e[3] = {0, 0, 0};
        for (int32_t j = 0; j < ls->summary.count; j++) {
            double c = clamped_dot(n, ls->lights[j].direction);
            for (int k = 0; k < 3; k++)
                e[k] += ls->lights[j].rgb[k] * c;
        }
        if (order >= 0) {
            envl_sh_eval(order, n, y);
            for (int32_t j = 0; j < envl_sh_count(order); j++)
                for (int k = 0; k < 3; k++)
                    e[k] += ls->remainder[3 * j + k] * y[j];
        }
        memcpy(out + 3 * i, e, sizeof e);
    }
    return ENVL_OK;
}

/* ---- fit: K lights (non-negative) + an SH irradiance remainder ---- */

#define FIT_NORMALS 1031    /* a Fibonacci set other than the error measure's 1024 */
/* The fit's target irradiance comes from the map resampled to the error reference's width (a
 * 512-wide map left 0.2 % where 1024 leaves 0.15 % on the built-in sky: the sun's lobe). */
#define FIT_MAP_WIDTH ENVL_REFERENCE_WIDTH
#define FIT_CANDIDATES 64   /* from the median cut, and as many bright pixels */
/* A light must find its light nearby: its luminance irradiance may not exceed the luminance
 * power within FIT_CONE_DEGREES of it (no light "opposite the sun" that only fits numbers). */
#define FIT_CONE_DEGREES 45.0
/* A light is added only if it lowers the relative RMS irradiance error by at least this. */
#define FIT_MIN_GAIN 2e-4

typedef struct fit_problem {
    int32_t m;              /* normals */
    double *normals;        /* m x 3 */
    double *target;         /* m x 3 exact irradiance (scaled) */
    double *target_y;       /* m luminance */
    int32_t nsh;            /* SH columns */
    double *sh;             /* nsh x m: Y_j(n_i) */
    double *scratch;        /* m */
} fit_problem;

/* Power (sum of L dw) of the fit map within FIT_CONE_DEGREES of d: rgb (if asked) and the
 * luminance, returned. */
static double cone_power(const envl_envmap *fm, const double d[3], double *rgb)
{
    const double cmin = cos(FIT_CONE_DEGREES * ENVL_PI / 180.0);
    double acc[3] = {0, 0, 0};
    for (int32_t r = 0; r < fm->height; r++) {
        double ct = fm->row_cos[r], z = d[2] * fm->row_sin[r], row[3] = {0, 0, 0};
        const float *p = fm->px + (size_t)r * fm->width * 3;
        for (int32_t c = 0; c < fm->width; c++, p += 3)
            if (ct * (d[0] * fm->col_cos[c] + d[1] * fm->col_sin[c]) + z >= cmin)
                for (int k = 0; k < 3; k++)
                    row[k] += p[k];
        for (int k = 0; k < 3; k++)
            acc[k] += row[k] * fm->row_omega[r];
    }
    if (rgb)
        memcpy(rgb, acc, sizeof acc);
    return envl__lum(acc[0], acc[1], acc[2]);
}

static void light_column(const fit_problem *p, const double d[3], double *col)
{
    for (int32_t i = 0; i < p->m; i++)
        col[i] = clamped_dot(p->normals + 3 * i, d);
}

static double dot_n(const double *a, const double *b, int32_t n)
{
    double s = 0;
    for (int32_t i = 0; i < n; i++)
        s += a[i] * b[i];
    return s;
}

/* Least squares of target (one channel) on k light columns + the SH columns with the lights'
 * weights >= 0. Returns the residual sum of squares; x gets k + nsh weights. */
static double solve_fit(const fit_problem *p, int32_t k, double *const *cols,
                        const double *target, double *x)
{
    int32_t n = k + p->nsh;
    if (n == 0)
        return dot_n(target, target, p->m); /* nothing to fit: all of it is left */
    double G[ENVL_NNLS_MAX * ENVL_NNLS_MAX], h[ENVL_NNLS_MAX];
    for (int32_t a = 0; a < n; a++) {
        const double *ca = a < k ? cols[a] : p->sh + (size_t)(a - k) * p->m;
        h[a] = dot_n(ca, target, p->m);
        for (int32_t b = 0; b <= a; b++) {
            const double *cb = b < k ? cols[b] : p->sh + (size_t)(b - k) * p->m;
            G[a * n + b] = G[b * n + a] = dot_n(ca, cb, p->m);
        }
    }
    if (envl__nnls_gram(n, k, G, h, x))
        return INFINITY;
    /* |Ax - y|^2 = y'y - 2 h'x + x'Gx */
    double r = dot_n(target, target, p->m) - 2 * dot_n(h, x, n);
    for (int32_t a = 0; a < n; a++)
        r += x[a] * dot_n(G + a * n, x, n);
    return r;
}

/* solve_fit with each light's weight also at most avail (the power of its cone: no light
 * carries more than there is around it): lights whose weight comes out above that are held
 * there, their share taken off the target, and the others solved again, until none is. */
static double solve_bounded(const fit_problem *p, int32_t k, double *const *cols,
                            const double *target, const double *avail, double *x)
{
    int held[ENVL_NNLS_MAX] = {0};
    for (;;) {
        double *free_cols[ENVL_NNLS_MAX] = {NULL}, y[ENVL_NNLS_MAX];
        int32_t map[ENVL_NNLS_MAX], nf = 0;
        memcpy(p->scratch, target, sizeof(double) * p->m);
        for (int32_t i = 0; i < k; i++) {
            if (held[i]) {
                for (int32_t j = 0; j < p->m; j++)
                    p->scratch[j] -= avail[i] * cols[i][j];
            } else {
                free_cols[nf] = cols[i];
                map[nf++] = i;
            }
        }
        double r = solve_fit(p, nf, free_cols, p->scratch, y);
        int over = 0;
        for (int32_t j = 0; j < nf; j++)
            if (y[j] > avail[map[j]] * (1 + 1e-9)) {
                held[map[j]] = 1;
                over = 1;
            }
        if (over && isfinite(r))
            continue;
        for (int32_t i = 0; i < k; i++)
            x[i] = held[i] ? avail[i] : 0.0;
        for (int32_t j = 0; j < nf; j++)
            x[map[j]] = y[j];
        for (int32_t j = 0; j < p->nsh; j++)
            x[k + j] = y[nf + j];
        return r;
    }
}

/* Tangent frame of a unit vector. */
static void tangents(const double d[3], double t1[3], double t2[3])
{
    double a[3] = {fabs(d[0]) < 0.9 ? 1.0 : 0.0, fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    t1[0] = a[1] * d[2] - a[2] * d[1];
    t1[1] = a[2] * d[0] - a[0] * d[2];
    t1[2] = a[0] * d[1] - a[1] * d[0];
    double l = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (int i = 0; i < 3; i++)
        t1[i] /= l;
    t2[0] = d[1] * t1[2] - d[2] * t1[1];
    t2[1] = d[2] * t1[0] - d[0] * t1[2];
    t2[2] = d[0] * t1[1] - d[1] * t1[0];
}

static int cmp_desc(const void *a, const void *b)
{
    double x = ((const double *)a)[0], y = ((const double *)b)[0];
    if (x != y)
        return x < y ? 1 : -1;
    double i = ((const double *)a)[1], j = ((const double *)b)[1];
    return i < j ? -1 : i > j;
}

/* Candidate directions: the median-cut centroids (compact bright regions) and the brightest
 * pixels of the fit map, no two bright pixels closer than 2 degrees. */
static envl_result fit_candidates(envl_envmap *m, const envl_envmap *fm, double *cand,
                                  int32_t *count)
{
    region *rs;
    int32_t nr, k = 0;
    envl_result rc = cut_regions(m, ENVL_METHOD_MEDIAN, FIT_CANDIDATES, &rs, &nr);
    if (rc)
        return rc;
    envl_light *ls = malloc(sizeof(envl_light) * (nr ? nr : 1));
    if (!ls) {
        free(rs);
        return envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
    }
    region_lights(m, rs, nr, ls);
    for (int32_t i = 0; i < nr; i++)
        if (rs[i].energy > 0)
            memcpy(cand + 3 * k++, ls[i].direction, sizeof ls[i].direction);
    free(ls);
    free(rs);
    size_t n = (size_t)fm->width * fm->height;
    double *order = malloc(sizeof(double) * 2 * n);
    if (!order)
        return envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
    for (size_t i = 0; i < n; i++) {
        const float *p = fm->px + 3 * i;
        order[2 * i] = envl__lum(p[0], p[1], p[2]);
        order[2 * i + 1] = (double)i;
    }
    qsort(order, n, 2 * sizeof(double), cmp_desc);
    const double min_cos = cos(2.0 * ENVL_PI / 180.0);
    int32_t first_bright = k;
    for (size_t i = 0; i < n && k < first_bright + FIT_CANDIDATES && order[2 * i] > 0; i++) {
        size_t idx = (size_t)order[2 * i + 1];
        double d[3];
        envl_envmap_direction(fm, (int32_t)(idx % fm->width), (int32_t)(idx / fm->width), d);
        int near = 0;
        for (int32_t j = first_bright; j < k && !near; j++)
            near = dot_n(d, cand + 3 * j, 3) > min_cos;
        if (!near)
            memcpy(cand + 3 * k++, d, sizeof d);
    }
    free(order);
    *count = k;
    return ENVL_OK;
}

static envl_result fit_lights(envl_envmap *m, int32_t K, int32_t order, envl_lights *ls)
{
    envl_result rc;
    /* The fit's reference: exact irradiance of the map resampled (exactly, by area) to at most
     * FIT_MAP_WIDTH, at FIT_NORMALS normals. */
    envl_envmap *fm = m, *owned = NULL;
    if (m->width > FIT_MAP_WIDTH) {
        float *px;
        int32_t fw = FIT_MAP_WIDTH;
        int32_t fh = (int32_t)fmax(1, llround((double)fw * m->height / m->width));
        rc = envl__latlong_resample(m->px, m->width, m->height, fw, fh, 0.0, &px);
        if (rc)
            return rc;
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = m->threads};
        rc = envl_envmap_from_pixels(px, fw, fh, 3, &lo, &owned);
        free(px);
        if (rc)
            return rc;
        fm = owned;
    }
    fit_problem p = {.m = FIT_NORMALS, .nsh = order >= 0 ? envl_sh_count(order) : 0};
    double *cand = malloc(sizeof(double) * 3 * (2 * FIT_CANDIDATES + 1));
    p.normals = malloc(sizeof(double) * 3 * p.m);
    p.target = malloc(sizeof(double) * 3 * p.m);
    p.target_y = malloc(sizeof(double) * p.m);
    p.sh = malloc(sizeof(double) * (p.nsh ? p.nsh : 1) * p.m);
    double *colmem = malloc(sizeof(double) * p.m * (K + 1));
    p.scratch = malloc(sizeof(double) * p.m);
    if (!cand || !p.normals || !p.target || !p.target_y || !p.sh || !colmem || !p.scratch) {
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < p.m; i++)
        envl_fibonacci_direction(i, p.m, p.normals + 3 * i);
    rc = envl_irradiance_exact(fm, p.m, p.normals, p.target);
    if (rc)
        goto done;
    double ysh[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < p.m; i++) {
        p.target_y[i] = envl__lum(p.target[3 * i], p.target[3 * i + 1], p.target[3 * i + 2]);
        if (p.nsh) {
            envl_sh_eval(order, p.normals + 3 * i, ysh);
            for (int32_t j = 0; j < p.nsh; j++)
                p.sh[(size_t)j * p.m + i] = ysh[j];
        }
    }
    int32_t nc = 0;
    rc = fit_candidates(m, fm, cand, &nc);
    if (rc)
        goto done;
    if (K > nc)
        K = nc;

    double dirs[ENVL_NNLS_MAX][3], x[ENVL_NNLS_MAX];
    /* Greedy: add the feasible candidate that most reduces the luminance residual, while
     * that gains at least FIT_MIN_GAIN of relative RMS error. */
    double *cand_avail = malloc(sizeof(double) * (nc ? nc : 1));
    if (!cand_avail) {
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    for (int32_t c = 0; c < nc; c++)
        cand_avail[c] = cone_power(fm, cand + 3 * c, NULL);
    double avail[ENVL_NNLS_MAX];
    double ymean = 0;
    for (int32_t i = 0; i < p.m; i++)
        ymean += fabs(p.target_y[i]);
    ymean /= p.m;
    double prev_err = INFINITY;
    if (p.nsh) {
        double r0 = solve_fit(&p, 0, NULL, p.target_y, x);
        prev_err = sqrt(fmax(0, r0) / p.m) / ymean;
    }
    double *cols[ENVL_NNLS_MAX];
    for (int32_t i = 0; i <= K; i++)
        cols[i] = colmem + (size_t)i * p.m;
    char *used = calloc((size_t)nc + 1, 1);
    if (!used) {
        free(cand_avail);
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    int32_t k = 0;
    for (; k < K; k++) {
        double best = INFINITY;
        int32_t best_c = -1;
        for (int32_t c = 0; c < nc; c++) {
            if (used[c])
                continue;
            light_column(&p, cand + 3 * c, cols[k]);
            avail[k] = cand_avail[c];
            double r = solve_bounded(&p, k + 1, cols, p.target_y, avail, x);
            if (r < best) {
                best = r;
                best_c = c;
            }
        }
        double err = sqrt(fmax(0, best) / p.m) / ymean;
        if (best_c < 0 || !(prev_err - err >= FIT_MIN_GAIN))
            break;
        prev_err = err;
        used[best_c] = 1;
        memcpy(dirs[k], cand + 3 * best_c, sizeof dirs[k]);
        avail[k] = cand_avail[best_c];
        light_column(&p, dirs[k], cols[k]);
    }
    free(used);
    free(cand_avail);
    K = k;

    /* Refine each direction by a pattern search in its tangent plane, steps 2 down to 1/32
     * degree. */
    double cur = K ? solve_bounded(&p, K, cols, p.target_y, avail, x) : INFINITY;
    for (double step = 2.0; step >= 1.0 / 32 && K; step *= 0.5) {
        int improved = 1;
        for (int pass = 0; improved && pass < 8; pass++) {
            improved = 0;
            for (int32_t i = 0; i < K; i++) {
                double t1[3], t2[3], keep[3];
                tangents(dirs[i], t1, t2);
                memcpy(keep, dirs[i], sizeof keep);
                double s = step * ENVL_PI / 180.0;
                const double moves[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
                for (int mv = 0; mv < 4; mv++) {
                    double d[3];
                    for (int a = 0; a < 3; a++)
                        d[a] = keep[a] + s * (moves[mv][0] * t1[a] + moves[mv][1] * t2[a]);
                    double l = sqrt(dot_n(d, d, 3));
                    for (int a = 0; a < 3; a++)
                        d[a] /= l;
                    light_column(&p, d, cols[K]);
                    double *saved = cols[i], saved_avail = avail[i];
                    cols[i] = cols[K];
                    avail[i] = cone_power(fm, d, NULL);
                    double r = solve_bounded(&p, K, cols, p.target_y, avail, x);
                    cols[i] = saved;
                    if (r < cur * (1 - 1e-12)) {
                        cur = r;
                        memcpy(dirs[i], d, sizeof d);
                        memcpy(cols[i], cols[K], sizeof(double) * p.m);
                        improved = 1;
                        break;
                    }
                    avail[i] = saved_avail;
                }
            }
        }
    }

    /* Final colours and remainder, channel by channel. */
    double *chan = malloc(sizeof(double) * p.m);
    ls->lights = calloc((size_t)(K ? K : 1), sizeof(envl_light));
    ls->remainder = p.nsh ? calloc((size_t)p.nsh * 3, sizeof(double)) : NULL;
    if (!chan || !ls->lights || (p.nsh && !ls->remainder)) {
        free(chan);
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    double cap[ENVL_NNLS_MAX][3], cap_c[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < K; i++)
        cone_power(fm, dirs[i], cap[i]);
    for (int c = 0; c < 3; c++) {
        for (int32_t i = 0; i < p.m; i++)
            chan[i] = p.target[3 * i + c];
        for (int32_t i = 0; i < K; i++)
            cap_c[i] = cap[i][c];
        if (K + p.nsh > 0)
            solve_bounded(&p, K, cols, chan, cap_c, x);
        for (int32_t i = 0; i < K; i++)
            ls->lights[i].rgb[c] = x[i];
        for (int32_t j = 0; j < p.nsh; j++)
            ls->remainder[3 * j + c] = x[K + j];
    }
    free(chan);
    for (int32_t i = 0; i < K; i++)
        memcpy(ls->lights[i].direction, dirs[i], sizeof dirs[i]);
    ls->summary.count = K;
    ls->summary.remainder_order = order;
done:
    free(cand);
    free(p.normals);
    free(p.target);
    free(p.target_y);
    free(p.sh);
    free(colmem);
    free(p.scratch);
    envl_envmap_free(owned);
    return rc;
}

/* ---- residual of the fit: each light takes its rgb from the smallest cone around it that
 * holds that much light, the same fraction from every pixel of the cone ---- */

#define CONE_BINS 16384

/* Angular bin of pixel (c, r) around `dir`: floor(sin(angle / 2) BINS), with sin(angle/2) =
 * sqrt((1 - cos) / 2): monotonic in the angle, no trigonometry per pixel. */
static int32_t cone_bin(const envl_envmap *m, int32_t c, int32_t r, const double dir[3])
{
    double d[3];
    envl_envmap_direction(m, c, r, d);
    double t = sqrt(fmax(0.0, 0.5 * (1.0 - dot_n(d, dir, 3))));
    int32_t b = (int32_t)(t * CONE_BINS);
    return b < CONE_BINS ? b : CONE_BINS - 1;
}

static envl_result take_cones(const envl_envmap *m, envl_lights *ls)
{
    int32_t W = m->width, H = m->height;
    double (*hist)[3] = malloc(sizeof(double[3]) * CONE_BINS);
    if (!hist)
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    /* brightest first */
    int32_t order[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < ls->summary.count; i++)
        order[i] = i;
    for (int32_t i = 1; i < ls->summary.count; i++)
        for (int32_t j = i; j > 0; j--) {
            const double *a = ls->lights[order[j]].rgb, *b = ls->lights[order[j - 1]].rgb;
            if (envl__lum(a[0], a[1], a[2]) <= envl__lum(b[0], b[1], b[2]))
                break;
            int32_t t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    for (int32_t oi = 0; oi < ls->summary.count; oi++) {
        envl_light *l = &ls->lights[order[oi]];
        memset(hist, 0, sizeof(double[3]) * CONE_BINS);
        for (int32_t r = 0; r < H; r++) {
            double om = m->row_omega[r];
            for (int32_t c = 0; c < W; c++) {
                int32_t b = cone_bin(m, c, r, l->direction);
                const float *p = ls->residual + 3 * ((size_t)r * W + c);
                for (int k = 0; k < 3; k++)
                    hist[b][k] += p[k] * om;
            }
        }
        double cum[3] = {0, 0, 0};
        int32_t last = CONE_BINS - 1;
        for (int32_t b = 0; b < CONE_BINS; b++) {
            for (int k = 0; k < 3; k++)
                cum[k] += hist[b][k];
            if (cum[0] >= l->rgb[0] && cum[1] >= l->rgb[1] && cum[2] >= l->rgb[2]) {
                last = b;
                break;
            }
        }
        double avail[3] = {0, 0, 0};
        for (int32_t b = 0; b <= last; b++)
            for (int k = 0; k < 3; k++)
                avail[k] += hist[b][k];
        double keep[3];
        for (int k = 0; k < 3; k++) {
            if (l->rgb[k] > avail[k])
                l->rgb[k] = avail[k]; /* the whole sphere holds less: take all there is */
            keep[k] = avail[k] > 0 ? 1.0 - l->rgb[k] / avail[k] : 1.0;
        }
        /* what it takes, sum e, and its first moment, sum e d */
        double taken = 0, moment[3] = {0, 0, 0}, own = 0;
        int32_t x0 = W, x1 = -1, y0 = H, y1 = -1;
        for (int32_t r = 0; r < H; r++) {
            double om = m->row_omega[r];
            for (int32_t c = 0; c < W; c++) {
                int32_t b = cone_bin(m, c, r, l->direction);
                if (b > last)
                    continue;
                float *p = ls->residual + 3 * ((size_t)r * W + c);
                double e = om * envl__lum(p[0] * (1 - keep[0]), p[1] * (1 - keep[1]),
                                          p[2] * (1 - keep[2])), d[3];
                envl_envmap_direction(m, c, r, d);
                taken += e;
                own += e * om / (4.0 * ENVL_PI);
                for (int k = 0; k < 3; k++)
                    moment[k] += e * d[k];
                for (int k = 0; k < 3; k++)
                    p[k] = (float)(p[k] * keep[k]);
                x0 = c < x0 ? c : x0;
                x1 = c + 1 > x1 ? c + 1 : x1;
                y0 = r < y0 ? r : y0;
                y1 = r + 1 > y1 ? r + 1 : y1;
            }
        }
        /* Its size: the uniform disc with the same spread. A disc of solid angle w has
         * mean (1 - cos t) = w / 4 pi (uniform in cos t), so w = 4 pi sum e (1 - cos t) / sum e.
         * The cone that holds the light's rgb is far wider than a sun in it (15 degrees
         * around a 0.5-degree sun with its glow): as a disc it would soften the terminator of
         * a lit sphere the sun leaves sharp. */
        /* The light points along the first moment V = sum e d of what it took: a surface
         * that sees all of it receives E(n) = n . V. Its spread about that direction is
         * sum e (1 - cos t) = taken - |V|, plus each pixel's own extent (a pixel of solid
         * angle om as its own disc: om / 4 pi, as sun_split.c counts it), so the disc of the
         * same spread (solid angle w) has |V| = rgb (1 - w / 4 pi) up to the pixels' own
         * extent (a few 1e-6 of rgb on a 1K map): a disc light of that irradiance at normal
         * incidence (a Blender sun: energy) reproduces E(n). (Pointed along the fit's lobe
         * centre, a wide light near the horizon gave a ground plane 3 % too much light on
         * kiara_1_dawn: scripts/scene_bench.py --host blender.) */
        double len = sqrt(dot_n(moment, moment, 3)), spread = taken - len + own;
        if (len > 0)
            for (int k = 0; k < 3; k++)
                l->direction[k] = moment[k] / len;
        l->solid_angle = taken > 0 ? fmin(4.0 * ENVL_PI, 4.0 * ENVL_PI * fmax(spread, 0.0) / taken)
                                   : 0.0;
        envl__light_set_angle(l);
        l->rect[0] = x0 < W ? x0 : 0;
        l->rect[1] = y0 < H ? y0 : 0;
        l->rect[2] = x1 > 0 ? x1 : 0;
        l->rect[3] = y1 > 0 ? y1 : 0;
    }
    free(hist);
    return ENVL_OK;
}

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
static envl_result sun_lights(const envl_envmap *m, int32_t n, envl_lights *ls)
{
    envl_sun_split sp;
    envl_light *all = NULL;
    int32_t nall = 0;
    envl_result rc = envl__sun_split_make(m, &sp);
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
    ls->residual = malloc(sizeof(float) * 3 * npx);
    if (!order || !slot || !cols || !ls->lights || !ls->residual) {
        rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < nall; i++)
        order[i] = (bright){envl__lum(all[i].rgb[0], all[i].rgb[1], all[i].rgb[2]), i};
    qsort(order, (size_t)nall, sizeof *order, cmp_bright);
    for (int32_t j = 0; j < nall; j++)
        slot[order[j].i] = j < k ? j : -1;
    memcpy(ls->residual, m->px, sizeof(float) * 3 * npx);
    for (int32_t i = 0; i < sp.n; i++) {
        const envl_sun_lobe *b = sp.lobes + i;
        if (b->taken > 0 && slot[b->taken - 1] >= 0) {
            size_t at = 3 * ((size_t)b->r * m->width + b->c);
            memcpy(ls->residual + at, sp.res + at, sizeof(float) * 3);
        }
    }
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

/* Exact irradiance of the sun method's residual at the error measure's normals, added to
 * approx: the residual stays an environment map (drawn as one), so it is part of what the
 * method hands a renderer. Computed as the map's reference is (envl_envmap_reference_irradiance,
 * the same resampling for wide maps); with no light the residual is the map itself. */
static envl_result add_residual_irradiance(const envl_envmap *m, const envl_lights *ls,
                                           const double *ref, double *approx)
{
    const double *e = ref;
    envl_envmap *rm = NULL;
    if (ls->summary.count > 0) {
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = m->threads,
                                .max_pixels = (int64_t)m->width * m->height};
        envl_result rc = envl_envmap_from_pixels(ls->residual, m->width, m->height, 3, &lo, &rm);
        if (rc == ENVL_OK)
            rc = envl_envmap_reference_irradiance(rm, &e);
        if (rc) {
            envl_envmap_free(rm);
            return rc;
        }
    }
    for (int32_t i = 0; i < 3 * ENVL_ERROR_NORMALS; i++)
        approx[i] += e[i];
    envl_envmap_free(rm);
    return ENVL_OK;
}

/* ---- the call ---- */

/* Every number the lights carry is finite: their directions, colours and sizes, the SH
 * remainder, the residual map (float) and the summary (a map near FLT_MAX could overflow). */
static int lights_finite(const envl_lights *ls)
{
    const envl_lights_summary *s = &ls->summary;
    int ok = isfinite(s->diffuse_error);
    for (int k = 0; k < 3; k++)
        ok &= isfinite(s->power[k]) && isfinite(s->lights_power[k]) &&
              isfinite(s->residual_power[k]);
    for (int32_t i = 0; ok && i < s->count; i++) {
        const envl_light *l = ls->lights + i;
        for (int k = 0; k < 3; k++)
            ok &= isfinite(l->direction[k]) && isfinite(l->rgb[k]);
        ok &= isfinite(l->solid_angle) && isfinite(l->angle);
    }
    int32_t nsh = s->remainder_order >= 0 ? (s->remainder_order + 1) * (s->remainder_order + 1)
                                          : 0;
    for (int32_t j = 0; ok && ls->remainder && j < 3 * nsh; j++)
        ok &= isfinite(ls->remainder[j]);
    size_t npx = (size_t)ls->width * ls->height * 3;
    for (size_t i = 0; ok && ls->residual && i < npx; i++)
        ok &= isfinite(ls->residual[i]);
    return ok;
}

envl_result envl_lights_compute(envl_envmap *m, const envl_lights_options *options,
                                envl_lights **out)
{
    static const envl_lights_options defaults;
    const envl_lights_options *o = options ? options : &defaults;
    if (!m || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_compute: NULL argument");
    *out = NULL;
    if (o->method < 0 || o->method >= ENVL_METHOD_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: unknown method %d", (int)o->method);
    int32_t n = o->count > 0 ? o->count
                             : (o->method == ENVL_METHOD_FIT || o->method == ENVL_METHOD_SUN ? 4
                                                                                          : 16);
    int32_t order = o->remainder_bands == 0 ? 2 : o->remainder_bands < 0 ? -1
                                                 : o->remainder_bands - 1;
    if (o->count < 0 || (o->method == ENVL_METHOD_FIT && n > 32) || n > (1 << 24))
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: count %d out of range (1..%d)",
                          (int)o->count, o->method == ENVL_METHOD_FIT ? 32 : 1 << 24);
    if (o->method == ENVL_METHOD_FIT && (o->remainder_bands < -1 || o->remainder_bands > 9))
        return envl__fail(ENVL_ERR_ARGUMENT, "lights: remainder bands %d out of range (1..9)",
                          (int)o->remainder_bands);
    envl_lights *ls = calloc(1, sizeof *ls);
    if (!ls)
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    ls->width = m->width;
    ls->height = m->height;
    envl_lights_summary *s = &ls->summary;
    s->method = o->method;
    s->remainder_order = -1;
    memcpy(s->power, m->info.power, sizeof s->power);
    size_t npx = (size_t)m->width * m->height * 3;
    envl_result rc = ENVL_OK;
    double t0 = envl__seconds();
    if (!(envl__lum(s->power[0], s->power[1], s->power[2]) > 0)) {
        /* A black map: no lights, an all-zero residual, no error. */
        s->no_light = 1;
        s->seconds = envl__seconds() - t0;
        *out = ls;
        return ENVL_OK;
    }
    if (o->method == ENVL_METHOD_FIT) {
        ls->residual = malloc(sizeof(float) * npx);
        if (!ls->residual) {
            rc = envl__fail(ENVL_ERR_MEMORY, "lights: cannot allocate the residual map");
            goto fail;
        }
        memcpy(ls->residual, m->px, sizeof(float) * npx);
        rc = fit_lights(m, n, order, ls);
        if (rc == ENVL_OK)
            rc = take_cones(m, ls);
    } else if (o->method == ENVL_METHOD_SUN) {
        rc = sun_lights(m, n, ls);
    } else {
        region *rs;
        int32_t k;
        rc = cut_regions(m, o->method, n, &rs, &k);
        if (rc == ENVL_OK) {
            ls->lights = calloc((size_t)k, sizeof(envl_light));
            if (!ls->lights)
                rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
            else
                region_lights(m, rs, k, ls->lights);
            s->count = k;
            free(rs);
            /* The regions cover the sphere: the lights take everything, the residual is zero
             * (made when asked for). */
        }
    }
    if (rc)
        goto fail;
    s->seconds = envl__seconds() - t0;

    for (int32_t i = 0; i < s->count; i++)
        for (int k = 0; k < 3; k++)
            s->lights_power[k] += ls->lights[i].rgb[k];
    /* residual power = power - what the lights took (exact bookkeeping, in double) */
    for (int k = 0; k < 3; k++)
        s->residual_power[k] = s->power[k] - s->lights_power[k];

    const double *ref;
    rc = envl_envmap_reference_irradiance(m, &ref);
    if (rc)
        goto fail;
    double *normals = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!normals || !approx) {
        free(normals);
        free(approx);
        rc = envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
        goto fail;
    }
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, normals + 3 * i);
    envl_lights_irradiance(ls, ENVL_ERROR_NORMALS, normals, approx);
    if (o->method == ENVL_METHOD_SUN)
        rc = add_residual_irradiance(m, ls, ref, approx);
    if (rc == ENVL_OK)
        s->diffuse_error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, approx, ref);
    free(normals);
    free(approx);
    if (rc == ENVL_OK && !lights_finite(ls))
        rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the lights overflow (a value is not finite; "
                        "the largest pixel value is %g)", m->info.file,
                        fmax(m->info.max[0], fmax(m->info.max[1], m->info.max[2])));
    if (rc)
        goto fail;
    *out = ls;
    return ENVL_OK;
fail:
    envl_lights_free(ls);
    return rc;
}

void envl_lights_free(envl_lights *ls)
{
    if (!ls)
        return;
    free(ls->lights);
    free(ls->remainder);
    free(ls->residual);
    free(ls);
}

int32_t envl_lights_count(const envl_lights *ls) { return ls ? ls->summary.count : 0; }

envl_result envl_lights_get(const envl_lights *ls, int32_t i, envl_light *out)
{
    if (!ls || !out || i < 0 || i >= ls->summary.count)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_get: index %d out of range", (int)i);
    *out = ls->lights[i];
    return ENVL_OK;
}

envl_result envl_lights_get_summary(const envl_lights *ls, envl_lights_summary *out)
{
    if (!ls || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_lights_get_summary: NULL argument");
    *out = ls->summary;
    return ENVL_OK;
}

const double *envl_lights_remainder(const envl_lights *ls, int32_t *order)
{
    if (order)
        *order = ls ? ls->summary.remainder_order : -1;
    return ls ? ls->remainder : NULL;
}

const float *envl_lights_residual(const envl_lights *ls)
{
    if (!ls)
        return NULL;
    if (!ls->residual) {
        /* Cuts and black maps: nothing is left. calloc: zero pages cost nothing until read. */
        envl_lights *mut = (envl_lights *)ls;
        mut->residual = calloc((size_t)ls->width * ls->height * 3, sizeof(float));
        if (!mut->residual)
            envl__fail(ENVL_ERR_MEMORY, "lights: cannot allocate the residual map");
    }
    return ls->residual;
}
