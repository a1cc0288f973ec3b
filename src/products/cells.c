/* The filtered specular levels: P(R) summed over a pyramid of cells, each as coarse as its
 * distance from R allows (docs/methods.md, "What is computed").
 *
 * A cell of level k is a block of 2^k x 2^k map pixels; near the poles, where such a block is
 * narrower than it is tall, g of them merge (g a power of 2: at most as wide as tall, never
 * wider than the parent's cells, so cells nest), so a cell is about p_k = pi 2^k / H across
 * everywhere. Each cell keeps its power (sum of L dw, RGB), its solid angle, and the mean and
 * covariance of its pixels' centre directions weighted by luminance and by solid angle (each
 * pixel a point at its centre, as the reference sums it).
 *
 * P(R) = sum over cells c of E_c <w>_c / sum over the same cells of omega_c <w>g_c, with
 * w(u) = u / q^2 the GGX kernel of design.md and <w> its mean over the cell's directions to
 * second order (w_cell): the reference's sum over every pixel, each cell standing for its
 * pixels. The cells are a Barnes-Hut cut of the tree, made per texel: from the top level down,
 * a cell is summed whole when its luminance centroid is at least rho p_k from R (rho: options.c,
 * 2-3.8) or its level is fine enough for the lobe (at most HWHM / core_k across, HWHM the
 * kernel's half width at half maximum), and does not straddle R's horizon (where the kernel is
 * cut) unless its level is fine enough for the kernel's slope there; else its children are.
 * Each pixel is counted exactly once and a bright spot inside a coarse cell sits where it is (the first moment is
 * exact, the second is the correction); what is left is third order in p / distance. The
 * denominator is the same cut over the solid angles, so a constant map gives P = L. Cells
 * wholly behind R are skipped. Deterministic: a texel's value depends on no other texel. */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The specular levels' cut: rho is per level (envl__level_rho); cells per kernel half width
 * at the finest level a texel's cut need reach (CORE_K); how finely it resolves R's horizon
 * (HORIZON_EPS, finest_levels), and bright cells across it (HORIZON_POWER, quad_setup). */
#ifndef HORIZON_POWER
#define HORIZON_POWER 1e-5
#endif
const cut_accuracy envl__level_cut = {.rho = 2.0, .core_k = 4.0, .horizon_eps = 1.6e-2,
                                      .horizon_power = HORIZON_POWER};

typedef struct cell {
    double m[3];              /* luminance-weighted mean direction (|m| <= 1; the area's when
                                 black); doubles: a sharp lobe's peak moves with a float's
                                 rounding */
    double mg[3];             /* the same weighted by solid angle */
    float e[3];               /* sum of L dw */
    float c[6];               /* the covariance of the directions about m: xx yy zz xy xz yz */
    float cg[6];              /* ... and about mg */
    float om;                 /* solid angle */
} cell;

typedef struct cell_row {
    double lat, hh, sl, cl;   /* centre latitude, half height, sin and cos of lat */
    int32_t n, cw;            /* cells, map columns per cell (the last may have fewer) */
    size_t off;               /* first cell */
} cell_row;

struct envl_cells {
    const float *px;          /* the image they were built from (it outlives them) */
    int32_t w, h, nlev;
    int32_t base;             /* the finest level built (levels below it are not) */
    int32_t rows[40];         /* row groups of each level (2^k map rows each, the last fewer) */
    cell_row *row[40];
    cell *buf;                /* rows and cells live in the same block as this header: one free */
};

/* N(alpha): the integral of w over the sphere. */
double envl_ggx_lobe_norm(double alpha)
{
    double a2 = alpha * alpha;
    double A = 0.5 * (1 + a2), B = 0.5 * (a2 - 1), x = B / A;
    if (fabs(x) < 1e-3) /* ln(1+x) + 1/(1+x) - 1 = x^2/2 - 2x^3/3 + 3x^4/4 - ... */
        return 2 * ENVL_PI / (A * A) * (0.5 - 2 * x / 3 + 0.75 * x * x - 0.8 * x * x * x);
    return 2 * ENVL_PI / (B * B) * (log(a2 / A) + A / a2 - 1);
}

void envl__cells_free(envl_cells *c)
{
    free(c);
}

/* Sums of a block: L dw (3), Y dw (1), Y d dw (3), Y d d^T dw (6), d dw (3), d d^T dw (6),
 * dw (1). */
#define NS 23

/* A pixel as the reference sums it: its solid angle om at its centre direction d. */
static inline void add_pixel(const float *p, double om, const double d[3], double *s)
{
    double dd[6] = {d[0] * d[0], d[1] * d[1], d[2] * d[2], d[0] * d[1], d[0] * d[2], d[1] * d[2]};
    double y = envl__lum(p[0], p[1], p[2]) * om;
    for (int k = 0; k < 3; k++) {
        s[k] += p[k] * om;
        s[4 + k] += y * d[k];
        s[13 + k] += om * d[k];
    }
    s[3] += y;
    for (int k = 0; k < 6; k++) {
        s[7 + k] += y * dd[k];
        s[16 + k] += om * dd[k];
    }
    s[22] += om;
}

/* Mean and covariance from the weight, first and second moment sums; 0 when wsum is not > 0. */
static int moments(double wsum, const double *m1, const double *m2, double m[3], float c[6])
{
    if (!(wsum > 0))
        return 0;
    double mu[3] = {m1[0] / wsum, m1[1] / wsum, m1[2] / wsum};
    const int a[6] = {0, 1, 2, 0, 0, 1}, b[6] = {0, 1, 2, 1, 2, 2};
    for (int k = 0; k < 3; k++)
        m[k] = mu[k];
    for (int k = 0; k < 6; k++)
        c[k] = (float)(m2[k] / wsum - mu[a[k]] * mu[b[k]]);
    return 1;
}

static void make_cell(const double *s, cell *c)
{
    for (int k = 0; k < 3; k++)
        c->e[k] = (float)s[k];
    if (!moments(s[22], s + 13, s + 16, c->mg, c->cg)) {
        memset(c, 0, sizeof *c);
        return;
    }
    if (!moments(s[3], s + 4, s + 7, c->m, c->c)) {
        memcpy(c->m, c->mg, sizeof c->m);
        memcpy(c->c, c->cg, sizeof c->c);
    }
    c->om = (float)s[22];
}

static int32_t level_count(int32_t h)
{
    int32_t n = 1;
    while (n < 31 && ((int64_t)1 << n) <= h / 2)
        n++;
    return n;
}

/* Map columns per cell of row group i of level k: blocks of 2^k columns, g of them merged
 * (g a power of 2) while the merged cell is at most as wide, at its widest, as it is tall; and
 * never wider than its parent's cells (row group i / 2 of level k + 1), so that cells nest. */
static int32_t cell_cols(int32_t w, int32_t h, int32_t nlev, int32_t k, int32_t i)
{
    int64_t b = (int64_t)1 << k;
    int64_t r0 = i * b, r1 = (i + 1) * b > h ? h : (i + 1) * b;
    double top = ENVL_PI * (0.5 - (double)r0 / h), bot = ENVL_PI * (0.5 - (double)r1 / h);
    double cmax = top > 0 && bot < 0 ? 1.0 : fmax(cos(top), cos(bot));
    int32_t cb = b > w ? w : (int32_t)b;
    double bw = cb * 2 * ENVL_PI / w * cmax; /* a block's widest width */
    int32_t g = 1;
    while ((int64_t)g * 2 * cb <= w && 2 * g * bw <= (top - bot) * (1 + 1e-9))
        g *= 2;
    int32_t cw = g * cb;
    if (k + 1 < nlev) {
        int32_t up = cell_cols(w, h, nlev, k + 1, i / 2);
        cw = cw < up ? cw : up;
    }
    return cw;
}

/* The levels' row groups (C->row[k] set: fills them) or only their counts. Levels go on while
 * a row group is at most half the map's height. */
static void geometry(envl_cells *C, int32_t w, int32_t h, int32_t base, int32_t *nlev,
                     size_t *nrows, size_t *ncell)
{
    *nlev = level_count(h), *nrows = 0, *ncell = 0;
    for (int32_t k = base; k < *nlev; k++) {
        int64_t b = (int64_t)1 << k;
        int32_t rows = (int32_t)((h + b - 1) / b);
        for (int32_t i = 0; i < rows; i++) {
            int64_t r0 = i * b, r1 = (i + 1) * b > h ? h : (i + 1) * b;
            double top = ENVL_PI * (0.5 - (double)r0 / h), bot = ENVL_PI * (0.5 - (double)r1 / h);
            int32_t cw = cell_cols(w, h, *nlev, k, i), n = (w + cw - 1) / cw;
            if (C) {
                cell_row *R = C->row[k] + i;
                R->lat = 0.5 * (top + bot), R->hh = 0.5 * (top - bot);
                R->sl = sin(R->lat), R->cl = cos(R->lat);
                R->cw = cw, R->n = n, R->off = *ncell;
            }
            *ncell += (size_t)n;
        }
        if (C)
            C->rows[k] = rows;
        *nrows += (size_t)rows;
    }
}

/* The build: the base level's sums from the map's pixels, each coarser level's from its
 * children's (cells nest), so the map is read once. Level L's row groups (the coarsest level
 * with at least 8 per thread) are built in parallel, each down to the base through per-thread
 * scratch, and keep their sums; the levels above L are summed from them. A parent's sums are
 * its children's added in the same order whatever L is: the same pyramid at any thread count. */
typedef struct build_job {
    envl_cells *C;
    const float *px;
    const double *cs;         /* cos, sin of each column's azimuth */
    int32_t L;
    double **sums;            /* level k >= L: NS per cell, from the level's first cell */
    double **scratch;         /* per thread: NS x w for each level below L */
    int32_t nscratch;
    int failed;
} build_job;

/* Row group i of level k: its cells' sums into s (NS per cell) and its cells made; below level
 * L, the children's sums are worked out in `scratch` (one NS x w block per level). */
static void group_sums(const build_job *b, int32_t k, int32_t i, double *s, double *scratch)
{
    const envl_cells *C = b->C;
    const cell_row *R = C->row[k] + i;
    int32_t w = C->w, h = C->h;
    memset(s, 0, sizeof(double) * NS * R->n);
    if (k == C->base) {
        int64_t bk = (int64_t)1 << k, r0 = i * bk, r1 = (i + 1) * bk > h ? h : (i + 1) * bk;
        for (int64_t r = r0; r < r1; r++) {
            double lat = ENVL_PI * (0.5 - (r + 0.5) / h), cl = cos(lat), sl = sin(lat);
            double om = envl_latlong_solid_angle(w, h, (int32_t)r);
            const float *p = b->px + 3 * (size_t)r * w;
            for (int32_t c = 0; c < w; c++) {
                double d[3] = {cl * b->cs[2 * c], cl * b->cs[2 * c + 1], sl};
                add_pixel(p + 3 * c, om, d, s + NS * (c / R->cw));
            }
        }
    } else {
        double *t = scratch, *below = scratch + (size_t)NS * w;
        for (int32_t ci = 2 * i; ci <= 2 * i + 1 && ci < C->rows[k - 1]; ci++) {
            const cell_row *H = C->row[k - 1] + ci;
            const double *cs;
            if (k - 1 >= b->L) {
                cs = b->sums[k - 1] + NS * (H->off - C->row[k - 1][0].off);
            } else {
                group_sums(b, k - 1, ci, t, below);
                cs = t;
            }
            for (int32_t j = 0; j < H->n; j++) {
                double *d = s + NS * (int64_t)((int64_t)j * H->cw / R->cw);
                for (int q = 0; q < NS; q++)
                    d[q] += cs[NS * j + q];
            }
        }
    }
    for (int32_t j = 0; j < R->n; j++)
        make_cell(s + NS * j, C->buf + R->off + j);
}

static void level_l_range(void *ctx, int64_t begin, int64_t end)
{
    build_job *b = ctx;
    const envl_cells *C = b->C;
    double *scratch = malloc(sizeof(double) * NS * (size_t)C->w * (b->L - C->base + 1));
    if (!scratch) {
        b->failed = 1;
        return;
    }
    for (int64_t i = begin; i < end; i++) {
        const cell_row *R = C->row[b->L] + i;
        group_sums(b, b->L, (int32_t)i, b->sums[b->L] + NS * (R->off - C->row[b->L][0].off),
                   scratch);
    }
    free(scratch);
}

envl_result envl__cells_build(const float *px, int32_t w, int32_t h, int32_t base,
                              int32_t threads, envl_cells **out)
{
    *out = NULL;
    int32_t nlev;
    size_t nrows, ncell;
    base = base < 0 ? 0 : base < level_count(h) ? base : level_count(h) - 1;
    geometry(NULL, w, h, base, &nlev, &nrows, &ncell);
    size_t head = (sizeof(envl_cells) + 15) / 16 * 16;
    envl_cells *C = malloc(head + sizeof(cell_row) * nrows + sizeof(cell) * ncell);
    double *cs = malloc(sizeof(double) * 2 * (size_t)w);
    if (!C || !cs) {
        free(C), free(cs);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for the cell pyramid");
    }
    memset(C, 0, sizeof *C);
    C->px = px, C->w = w, C->h = h, C->nlev = nlev, C->base = base;
    cell_row *rows = (cell_row *)((char *)C + head);
    for (int32_t k = base, at = 0; k < nlev; k++) {
        C->row[k] = rows + at;
        at += (int32_t)((h + ((int64_t)1 << k) - 1) >> k);
    }
    C->buf = (cell *)(rows + nrows);
    geometry(C, w, h, base, &nlev, &nrows, &ncell);
    for (int32_t c = 0; c < w; c++) {
        double phi = ENVL_PI * (1.0 - 2.0 * (c + 0.5) / w);
        cs[2 * c] = cos(phi), cs[2 * c + 1] = sin(phi);
    }
    threads = envl__threads(threads);
    build_job b = {.C = C, .px = px, .cs = cs, .L = base};
    while (b.L + 1 < nlev && C->rows[b.L + 1] >= 8 * threads)
        b.L++;
    double *sums[40] = {0};
    b.sums = sums;
    size_t first = C->row[b.L][0].off;
    double *store = malloc(sizeof(double) * NS * (ncell - first));
    if (!store) {
        free(C), free(cs);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for the cell pyramid");
    }
    for (int32_t k = b.L; k < nlev; k++)
        sums[k] = store + NS * (C->row[k][0].off - first);
    envl__parallel_for(C->rows[b.L], threads, level_l_range, &b);
    for (int32_t k = b.L + 1; k < nlev && !b.failed; k++)
        for (int32_t i = 0; i < C->rows[k]; i++)
            group_sums(&b, k, i, sums[k] + NS * (C->row[k][i].off - C->row[k][0].off), NULL);
    free(store), free(cs);
    if (b.failed) {
        free(C);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory for the cell pyramid");
    }
    *out = C;
    return ENVL_OK;
}

/* The kernel's half width at half maximum (angle from R where w falls to w(1) / 2). */
static double half_width(double a2)
{
    double lo = 0, hi = ENVL_PI / 2, top = ggx_w(1.0, a2);
    for (int i = 0; i < 60; i++) {
        double m = 0.5 * (lo + hi);
        if (ggx_w(cos(m), a2) > 0.5 * top)
            lo = m;
        else
            hi = m;
    }
    return lo;
}

typedef struct quad_job {
    const envl_cells *C;
    double a2, A, B;          /* alpha^2, (1 + alpha^2) / 2, (alpha^2 - 1) / 2 */
    int32_t kmin;             /* levels up to kmin: never opened for their distance */
    int32_t kh;               /* levels above kh: opened where they may straddle R's horizon */
    double horiz[40];         /* ... when |R.mg| < horiz[k] */
    double open_x[40];        /* level k > kmin: a cell opens when 1 - R.d < open_x[k] (nearer
                                 than rho p_k) */
    double behind[40];        /* a cell of level k lies wholly behind R when R.g < behind[k] */
    double bright[40];        /* ... and one across R's horizon opens (k above the base) when
                                 its luminance power exceeds bright[k] */
    int32_t layout, w, h;     /* the level's texels (layout.c) */
    float *out;
    int64_t *terms;           /* cells summed, per output row */
    envl_cancel cancel;       /* a cancel seen between rows or directions */
} quad_job;

typedef struct texel {
    double R[3];
    double acc[4];            /* sum w E (RGB), sum w omega */
    int64_t terms;
} texel;

/* The mean of w(R.l) over a cell's directions l (w = 0 behind R), U = R.l having mean
 * u = R.m and variance v = R^T C R (m, C: the cell's mean direction and covariance). Away from
 * the horizon, to second order: w(u) + w''(u) v / 2. With w = u / q^2, q = A + B u,
 * A = (1 + a^2) / 2, B = (a^2 - 1) / 2: w'' = -2 B (2 A - B u) / q^4. Within 3 standard
 * deviations of the horizon, where w = u g(u) is cut to 0: g(u) E[max(U, 0)], the latter as
 * (u + sqrt(u^2 + 2 v / pi)) / 2 (a normal U's value at u = 0, u and 0 far from it). The
 * cell's own spread thus counts, and so does a line (only its variance along R). */
static inline double w_cell(const quad_job *J, const double R[3], double u, const float *c)
{
    double var = c[0] * R[0] * R[0] + c[1] * R[1] * R[1] + c[2] * R[2] * R[2] +
                 2 * (c[3] * R[0] * R[1] + c[4] * R[0] * R[2] + c[5] * R[1] * R[2]);
    var = var > 0 ? var : 0;
    double A = J->A, B = J->B, iq = 1 / (A + B * u), iq2 = iq * iq;
    if (u * u < 9 * var) /* E max(U, 0) ~ (u + sqrt(u^2 + 2 v / pi)) / 2: a normal's at u = 0 */
        return iq2 * 0.5 * (u + sqrt(u * u + 0.63661977236758134 * var));
    if (u <= 0)
        return 0;
    double r = u * iq2 - B * (2 * A - B * u) * iq2 * iq2 * var;
    return r > 0 ? r : 0;
}

/* A cell of the base level summed pixel by pixel, each at its centre (as the brute force sums
 * it): sum L dw w(R.d) and dw w(R.d), w = 0 behind R. */
static void cell_pixels(const quad_job *J, texel *t, const cell_row *G, int32_t i, int32_t j)
{
    const envl_cells *C = J->C;
    int64_t b = (int64_t)1 << C->base, r1 = (i + 1) * b < C->h ? (i + 1) * b : C->h;
    int32_t c1 = (j + 1) * G->cw < C->w ? (j + 1) * G->cw : C->w;
    const double *R = t->R;
    for (int64_t r = i * b; r < r1; r++) {
        double lat = ENVL_PI * (0.5 - (r + 0.5) / C->h), cl = cos(lat), sl = sin(lat);
        double om = envl_latlong_solid_angle(C->w, C->h, (int32_t)r);
        const float *p = C->px + 3 * (size_t)r * C->w;
        for (int32_t c = j * G->cw; c < c1; c++) {
            double phi = ENVL_PI * (1.0 - 2.0 * (c + 0.5) / C->w);
            double u = cl * (R[0] * cos(phi) + R[1] * sin(phi)) + sl * R[2];
            if (u <= 0)
                continue;
            double q = J->A + J->B * u, f = om * u / (q * q);
            t->acc[0] += f * p[3 * c], t->acc[1] += f * p[3 * c + 1], t->acc[2] += f * p[3 * c + 2];
            t->acc[3] += f;
        }
    }
    t->terms++;
}

/* Barnes-Hut over the cell tree: a cell far enough from R (or of a level fine enough for the
 * lobe) adds its power at its luminance centroid and its solid angle at its area centroid;
 * else its children (level k - 1) are visited; a bright cell across R's horizon at the base,
 * which has no children, adds its pixels. Every bit of the sphere is counted once. */
static void visit(const quad_job *J, texel *t, int32_t k, int32_t i, int32_t j)
{
    const envl_cells *C = J->C;
    const cell_row *G = C->row[k] + i;
    const cell *c = C->buf + G->off + j;
    const double *R = t->R;
    double ug = R[0] * c->mg[0] + R[1] * c->mg[1] + R[2] * c->mg[2];
    if (ug < J->behind[k])
        return;
    double u = R[0] * c->m[0] + R[1] * c->m[1] + R[2] * c->m[2];
    int across = fabs(ug) < J->horiz[k];
    int bright = across && envl__lum(c->e[0], c->e[1], c->e[2]) > J->bright[k];
    if (bright && k == C->base) {
        cell_pixels(J, t, G, i, j);
        return;
    }
    if ((k > J->kmin && 1 - u < J->open_x[k]) || (k > J->kh && across) || bright) {
        int32_t i1 = 2 * i + 1 < C->rows[k - 1] ? 2 * i + 1 : 2 * i;
        for (int32_t ci = 2 * i; ci <= i1; ci++) {
            const cell_row *H = C->row[k - 1] + ci;
            int32_t ratio = G->cw / H->cw, j0 = j * ratio, j1 = (j + 1) * ratio;
            j1 = j1 < H->n ? j1 : H->n;
            for (int32_t cj = j0; cj < j1; cj++)
                visit(J, t, k - 1, ci, cj);
        }
        return;
    }
    t->terms++;
    double f = w_cell(J, R, u, c->c);
    t->acc[0] += f * c->e[0], t->acc[1] += f * c->e[1], t->acc[2] += f * c->e[2];
    t->acc[3] += w_cell(J, R, ug, c->cg) * c->om;
}

/* P(R) at one direction: the cut from the top level down. */
static void cut_at(const quad_job *J, const double R[3], float out[3], int64_t *terms)
{
    const envl_cells *C = J->C;
    int32_t top = C->nlev - 1;
    texel t = {{R[0], R[1], R[2]}, {0, 0, 0, 0}, 0};
    for (int32_t i = 0; i < C->rows[top]; i++)
        for (int32_t j = 0; j < C->row[top][i].n; j++)
            visit(J, &t, top, i, j);
    for (int k = 0; k < 3; k++)
        out[k] = t.acc[3] > 0 ? (float)(t.acc[k] / t.acc[3]) : 0.0f;
    *terms += t.terms;
}

static void quad_rows(void *ctx, int64_t begin, int64_t end)
{
    quad_job *J = ctx;
    for (int64_t r = begin; r < end && !envl__cancel_check(&J->cancel); r++) {
        int64_t terms = 0;
        for (int32_t col = 0; col < J->w; col++) {
            double R[3];
            envl__texel_direction(J->layout, J->w, J->h, col, (int32_t)r, R);
            cut_at(J, R, J->out + 3 * ((size_t)r * J->w + col), &terms);
        }
        J->terms[r] = terms;
    }
}

/* The finest levels a cut needs for GGX alpha on a map H tall: *kmin, the coarsest whose cells
 * are at most HWHM / core_k across (HWHM: the kernel's half width at half maximum); *kh, down
 * to which cells across R's horizon open. The kernel is cut there (w = 0 for R.l < 0, slope
 * w'(0) = 1 / A^2 above): a cell across it is summed by the model of w_cell, off by up to
 * E w'(0) sd / 2 for a cell of power E, sd ~ p / 3.5 for a cell p across; kh keeps that within
 * heps / 7 of E N(alpha) (the whole lobe's weight): w'(0) p_kh <= heps N(alpha) (for the
 * levels' HORIZON_EPS, at roughness 1: 0.05 rad; at 0.5 and below it is never needed). */
static void finest_levels(const cut_accuracy *a, double alpha, int32_t h, int32_t *kmin,
                          int32_t *kh)
{
    int32_t n = level_count(h);
    double a2 = alpha * alpha, hw = half_width(a2), A = 0.5 * (1 + a2);
    double wslope = 1 / (A * A), norm = envl_ggx_lobe_norm(alpha);
    *kmin = 0, *kh = 0;
    while (*kmin + 1 < n && ENVL_PI * (double)((int64_t)1 << (*kmin + 1)) / h <= hw / a->core_k)
        (*kmin)++;
    while (*kh + 1 < n &&
           wslope * ENVL_PI * (double)((int64_t)1 << (*kh + 1)) / h <= a->horizon_eps * norm)
        (*kh)++;
}

int32_t envl__cells_base(const cut_accuracy *a, double alpha, int32_t h)
{
    int32_t kmin, kh;
    finest_levels(a ? a : &envl__level_cut, alpha, h, &kmin, &kh);
    return kmin < kh ? kmin : kh;
}

int32_t envl__cells_base_of(const envl_cells *C)
{
    return C->base;
}

/* The cut's settings for GGX alpha; J->terms is the caller's. */
static void quad_setup(quad_job *J, const envl_cells *C, const cut_accuracy *a, double alpha)
{
    J->C = C, J->a2 = alpha * alpha;
    J->A = 0.5 * (1 + J->a2), J->B = 0.5 * (J->a2 - 1);
    finest_levels(a, alpha, C->h, &J->kmin, &J->kh);
    J->kmin = J->kmin > C->base ? J->kmin : C->base;
    J->kh = J->kh > C->base ? J->kh : C->base;
    /* A cell of power E across R's horizon is off by up to E w'(0) sd / 2 (sd ~ p / 3.5, see
     * finest_levels) in the numerator of P, whose denominator is about N(alpha): it opens
     * while E w'(0) p / (7 N(alpha)) exceeds horizon_power x the mean radiance, and at the
     * base its pixels are summed. A lamp's or the sun's edge along the horizon then stays
     * exact where P is small (a dark wall's texel beside a studio lamp: 8 % off at 1.6e-2 of
     * the lobe alone; the glossy reference 1.3 % off with cells of 8 x 8 pixels at the base). */
    double e[3];
    envl__cells_energy(C, e);
    double mean = envl__lum(e[0], e[1], e[2]) / (4 * ENVL_PI);
    double allow = a->horizon_power * 7 * envl_ggx_lobe_norm(alpha) * J->A * J->A * mean;
    for (int32_t k = C->base; k < C->nlev; k++) {
        double p = ENVL_PI * (double)((int64_t)1 << k) / C->h; /* a cell's height */
        J->open_x[k] = a->rho * p >= ENVL_PI ? 3.0 : 1 - cos(a->rho * p);
        /* a cell is within 1.5 p of its area centroid (at most as wide as tall) */
        J->behind[k] = 1.5 * p >= ENVL_PI / 2 ? -2.0 : -sin(1.5 * p);
        J->horiz[k] = 1.5 * p >= ENVL_PI / 2 ? 2.0 : sin(1.5 * p);
        J->bright[k] = allow > 0 ? allow / p : INFINITY;
    }
}

envl_result envl__cells_level(const envl_cells *C, double alpha, double rho, int32_t layout,
                              int32_t w, int32_t h, int32_t threads, float *out, double *terms)
{
    quad_job J = {.layout = layout, .w = w, .h = h, .out = out};
    cut_accuracy a = envl__level_cut;
    a.rho = rho;
    quad_setup(&J, C, &a, alpha);
    J.terms = calloc((size_t)h, sizeof(int64_t));
    if (!J.terms)
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
    envl__parallel_for(h, threads, quad_rows, &J);
    if (atomic_load(&J.cancel.stop)) {
        free(J.terms);
        return ENVL_ERR_CANCELLED; /* the message: envl__progress_poll's */
    }
    double t = 0;
    for (int32_t r = 0; r < h; r++)
        t += (double)J.terms[r];
    free(J.terms);
    *terms = t / ((double)w * h);
    return ENVL_OK;
}

typedef struct dirs_job {
    quad_job J;
    const double *dirs;
    double *out;
} dirs_job;

static void dirs_range(void *ctx, int64_t begin, int64_t end)
{
    dirs_job *d = ctx;
    for (int64_t i = begin; i < end && !envl__cancel_check(&d->J.cancel); i++) {
        float o[3];
        int64_t terms = 0;
        cut_at(&d->J, d->dirs + 3 * i, o, &terms);
        for (int k = 0; k < 3; k++)
            d->out[3 * i + k] = o[k];
    }
}

envl_result envl__cells_at(const envl_cells *C, const cut_accuracy *a, double alpha,
                           int32_t count, const double *dirs, int32_t threads, double *out)
{
    dirs_job d = {.dirs = dirs, .out = out};
    quad_setup(&d.J, C, a, alpha);
    envl__parallel_for(count, threads, dirs_range, &d);
    /* the message of a cancel: envl__progress_poll's */
    return atomic_load(&d.J.cancel.stop) ? ENVL_ERR_CANCELLED : ENVL_OK;
}

void envl__cells_energy(const envl_cells *C, double e[3])
{
    e[0] = e[1] = e[2] = 0;
    for (int32_t i = 0; i < C->rows[C->base]; i++) {
        const cell_row *R = C->row[C->base] + i;
        for (int32_t j = 0; j < R->n; j++)
            for (int k = 0; k < 3; k++)
                e[k] += C->buf[R->off + j].e[k];
    }
}

int32_t envl__cells_levels(const envl_cells *C)
{
    return C ? C->nlev : 0;
}
