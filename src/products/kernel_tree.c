/* Sums of a kernel f(n.d) against a lat-long map through a tree of block sums (kernel_tree.h):
 * a Barnes-Hut sum whose every shortcut states its bound.
 *
 * The range of n.d over a block [phi0, phi1] x [t0, t1] (t: elevation, phi1 - phi0 < pi):
 * n.d = A(phi) cos t + nz sin t with A(phi) = nx cos phi + ny sin phi. For a fixed t it grows
 * with A (cos t >= 0), so its largest value is that of the sinusoid in t at the largest A, and
 * its smallest that at the smallest A. A over [phi0, phi1]: its end values, or +-|(nx, ny)|
 * where its derivative changes sign inside; a sinusoid over [t0, t1] likewise. Exact, from the
 * edges' sines and cosines, without inverse trigonometry. The range also holds every mean of
 * the block's directions, such as M / S.
 *
 * rho, the angular radius of a block from its centre, (t1 - t0) / 2 + (phi1 - phi0) / 2
 * max cos t (along the meridian, then the parallel), measures how much of a horizon a block
 * can hold: the kernels share their allowance by it. */
#include "kernel_tree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define KTREE_MAX_LEVELS 24
#define KTREE_TOP_WIDTH 16    /* the top level has at most this many blocks across */

typedef struct ktree_level {
    int32_t bs, lw, lh;        /* block side in pixels, blocks across and down */
    double *sums;              /* lw x lh blocks of 4 x channels doubles: S[ch], M[3 ch] */
    double *p0c, *p0s, *p1c, *p1s, *dphi; /* per column: cos, sin of phi0 and phi1; width */
    double *t0c, *t0s, *t1c, *t1s, *band, *rho; /* per row: cos, sin of t0 and t1;
                                                   sin t1 - sin t0; radius */
} ktree_level;

struct ktree {
    const float *px;
    int32_t w, h, channels, leaf, levels;
    ktree_moments mo;
    double *moment_mem;        /* the copied moment tables */
    ktree_level pixel;         /* the pixels' geometry (bs 1; no sums) */
    ktree_level level[KTREE_MAX_LEVELS];
};

static int32_t stride(const ktree *t) { return 4 * t->channels; }

static envl_result level_geometry(const ktree *t, ktree_level *L)
{
    int32_t lw = L->lw, lh = L->lh;
    double *mem = malloc(sizeof(double) * (5 * (size_t)lw + 6 * (size_t)lh));
    if (!mem)
        return envl__fail(ENVL_ERR_MEMORY, "reference: out of memory");
    L->p0c = mem, L->p0s = mem + lw, L->p1c = mem + 2 * lw, L->p1s = mem + 3 * lw;
    L->dphi = mem + 4 * lw;
    double *q = mem + 5 * lw;
    L->t0c = q, L->t0s = q + lh, L->t1c = q + 2 * lh, L->t1s = q + 3 * lh;
    L->band = q + 4 * lh, L->rho = q + 5 * lh;
    double widest_dphi = 0;
    for (int32_t c = 0; c < lw; c++) {
        /* column x spans phi from pi (1 - 2 (x + 1) / W) up to pi (1 - 2 x / W) */
        int32_t c0 = c * L->bs, c1 = c0 + L->bs < t->w ? c0 + L->bs : t->w;
        double p1 = ENVL_PI * (1.0 - 2.0 * c0 / t->w), p0 = ENVL_PI * (1.0 - 2.0 * c1 / t->w);
        L->p0c[c] = cos(p0), L->p0s[c] = sin(p0);
        L->p1c[c] = cos(p1), L->p1s[c] = sin(p1);
        L->dphi[c] = p1 - p0;
        widest_dphi = fmax(widest_dphi, p1 - p0);
    }
    for (int32_t r = 0; r < lh; r++) {
        int32_t r0 = r * L->bs, r1 = r0 + L->bs < t->h ? r0 + L->bs : t->h;
        double t1 = ENVL_PI * (0.5 - (double)r0 / t->h), t0 = ENVL_PI * (0.5 - (double)r1 / t->h);
        L->t0c[r] = cos(t0), L->t0s[r] = sin(t0);
        L->t1c[r] = cos(t1), L->t1s[r] = sin(t1);
        L->band[r] = sin(t1) - sin(t0);
        double widest = t0 < 0 && t1 > 0 ? 1.0 : fmax(cos(t0), cos(t1));
        L->rho[r] = 0.5 * (t1 - t0) + 0.5 * widest_dphi * widest;
    }
    return ENVL_OK;
}

/* The range [*lo, *hi] of A cos t + nz sin t over t in [t0, t1] (t1 - t0 <= pi). */
static void sinusoid_range(double A, double nz, double c0, double s0, double c1, double s1,
                           double *lo, double *hi)
{
    double g0 = A * c0 + nz * s0, g1 = A * c1 + nz * s1;
    double d0 = nz * c0 - A * s0, d1 = nz * c1 - A * s1; /* the derivative at t0, t1 */
    *lo = g0 < g1 ? g0 : g1, *hi = g0 < g1 ? g1 : g0; /* not fmin / fmax: libm calls here */
    if (d0 > 0 && d1 < 0)
        *hi = sqrt(A * A + nz * nz);
    else if (d0 < 0 && d1 > 0)
        *lo = -sqrt(A * A + nz * nz);
}

/* The exact range of n.d over block (c, r) of L; [-1, 1] for a block pi or more across. */
static void block_range(const ktree_level *L, const double n[3], int32_t c, int32_t r,
                        double *lo, double *hi)
{
    if (L->dphi[c] >= ENVL_PI) {
        *lo = -1, *hi = 1;
        return;
    }
    double a0 = n[0] * L->p0c[c] + n[1] * L->p0s[c], a1 = n[0] * L->p1c[c] + n[1] * L->p1s[c];
    double d0 = n[1] * L->p0c[c] - n[0] * L->p0s[c], d1 = n[1] * L->p1c[c] - n[0] * L->p1s[c];
    double amin = a0 < a1 ? a0 : a1, amax = a0 < a1 ? a1 : a0, rn = sqrt(n[0] * n[0] + n[1] * n[1]);
    if (d0 > 0 && d1 < 0)
        amax = rn;
    else if (d0 < 0 && d1 > 0)
        amin = -rn;
    double l, h;
    sinusoid_range(amax, n[2], L->t0c[r], L->t0s[r], L->t1c[r], L->t1s[r], &l, hi);
    sinusoid_range(amin, n[2], L->t0c[r], L->t0s[r], L->t1c[r], L->t1s[r], lo, &h);
    /* a hair wider, for the rounding of the tests against the range */
    *hi += 1e-12, *lo -= 1e-12;
}

void envl__ktree_pixel_range(const ktree *t, const double n[3], int32_t c, int32_t r,
                             double *lo, double *hi)
{
    block_range(&t->pixel, n, c, r, lo, hi);
}

typedef struct build_job {
    ktree *t;
    int32_t k;                 /* the level being built */
} build_job;

/* Level 0 rows from the pixels: each block's sums accumulated in double over its pixels. */
static void build_leaf_rows(void *ctx, int64_t begin, int64_t end)
{
    build_job *j = ctx;
    const ktree *t = j->t;
    const ktree_moments *mo = &t->mo;
    const ktree_level *L = &t->level[0];
    int32_t ns = stride(t), ch = t->channels;
    for (int64_t r = begin; r < end; r++) {
        double *row = L->sums + (size_t)r * L->lw * ns;
        memset(row, 0, sizeof(double) * (size_t)L->lw * ns);
        int32_t r0 = (int32_t)r * L->bs, r1 = r0 + L->bs < t->h ? r0 + L->bs : t->h;
        for (int32_t pr = r0; pr < r1; pr++) {
            double mw = mo->row_w[pr], ma = mo->row_a[pr], mz = mo->row_z[pr];
            const float *p = t->px + (size_t)pr * t->w * 3;
            /* block by block, each block's pixels in column order into locals (registers,
             * not a load and a store per term): every sum takes its terms in the same order */
            for (int32_t b = 0, c0 = 0; b < L->lw; b++, c0 += L->bs) {
                double *s = row + (size_t)b * ns, *m = s + ch;
                int32_t c1 = c0 + L->bs < t->w ? c0 + L->bs : t->w;
                double s0 = s[0], s1 = s[1], s2 = s[2];
                double m0 = m[0], m1 = m[1], m2 = m[2], m3 = m[3], m4 = m[4], m5 = m[5];
                double m6 = m[6], m7 = m[7], m8 = m[8];
                for (int32_t c = c0; c < c1; c++) {
                    double dx = ma * mo->col_x[c], dy = ma * mo->col_y[c];
                    double l0 = p[3 * c], l1 = p[3 * c + 1], l2 = p[3 * c + 2];
                    s0 += l0 * mw, m0 += l0 * dx, m1 += l0 * dy, m2 += l0 * mz;
                    s1 += l1 * mw, m3 += l1 * dx, m4 += l1 * dy, m5 += l1 * mz;
                    s2 += l2 * mw, m6 += l2 * dx, m7 += l2 * dy, m8 += l2 * mz;
                }
                s[0] = s0, s[1] = s1, s[2] = s2;
                m[0] = m0, m[1] = m1, m[2] = m2, m[3] = m3, m[4] = m4, m[5] = m5;
                m[6] = m6, m[7] = m7, m[8] = m8;
                if (ch == 4)
                    for (int32_t c = c0; c < c1; c++) {
                        double dx = ma * mo->col_x[c], dy = ma * mo->col_y[c];
                        s[3] += mw;
                        m[9] += dx, m[10] += dy, m[11] += mz;
                    }
            }
        }
    }
}

/* Level k rows from level k - 1: each block the sum of its (up to) four children. */
static void build_upper_rows(void *ctx, int64_t begin, int64_t end)
{
    build_job *j = ctx;
    const ktree *t = j->t;
    const ktree_level *L = &t->level[j->k], *C = &t->level[j->k - 1];
    int32_t ns = stride(t);
    for (int64_t r = begin; r < end; r++)
        for (int32_t c = 0; c < L->lw; c++) {
            double *s = L->sums + ((size_t)r * L->lw + c) * ns;
            memset(s, 0, sizeof(double) * ns);
            for (int32_t cr = 2 * (int32_t)r; cr < 2 * r + 2 && cr < C->lh; cr++)
                for (int32_t cc = 2 * c; cc < 2 * c + 2 && cc < C->lw; cc++) {
                    const double *x = C->sums + ((size_t)cr * C->lw + cc) * ns;
                    for (int32_t i = 0; i < ns; i++)
                        s[i] += x[i];
                }
        }
}

void envl__ktree_free(ktree *t)
{
    if (!t)
        return;
    for (int32_t k = 0; k < t->levels; k++) {
        free(t->level[k].sums);
        free(t->level[k].p0c);
    }
    free(t->pixel.p0c);
    free(t->moment_mem);
    free(t);
}

envl_result envl__ktree_build(const float *px, int32_t w, int32_t h, const ktree_moments *mo,
                              int32_t threads, ktree **out)
{
    *out = NULL;
    ktree *t = calloc(1, sizeof *t);
    double *mem = malloc(sizeof(double) * (3 * (size_t)h + 2 * (size_t)w));
    if (!t || !mem) {
        free(t);
        free(mem);
        return envl__fail(ENVL_ERR_MEMORY, "reference: out of memory");
    }
    t->px = px, t->w = w, t->h = h, t->channels = mo->ones ? 4 : 3;
    /* 4 x 4 blocks up to 2048 columns; 8 x 8 above, so that the tree stays under a quarter of
     * the map's own memory (2.7 bytes a pixel at 4 channels against the map's 12) */
    t->leaf = w > 2048 ? 2 * KTREE_LEAF : KTREE_LEAF;
    t->moment_mem = mem;
    memcpy(mem, mo->row_w, sizeof(double) * h);
    memcpy(mem + h, mo->row_a, sizeof(double) * h);
    memcpy(mem + 2 * h, mo->row_z, sizeof(double) * h);
    memcpy(mem + 3 * h, mo->col_x, sizeof(double) * w);
    memcpy(mem + 3 * h + w, mo->col_y, sizeof(double) * w);
    t->mo = (ktree_moments){mem, mem + h, mem + 2 * h, mem + 3 * h, mem + 3 * h + w, mo->ones};
    t->pixel = (ktree_level){.bs = 1, .lw = w, .lh = h};
    envl_result rc = level_geometry(t, &t->pixel);
    for (int32_t k = 0; !rc && k < KTREE_MAX_LEVELS; k++) {
        ktree_level *L = &t->level[k];
        L->bs = t->leaf << k;
        L->lw = (w + L->bs - 1) / L->bs;
        L->lh = (h + L->bs - 1) / L->bs;
        L->sums = malloc(sizeof(double) * (size_t)L->lw * L->lh * stride(t));
        t->levels = k + 1;
        if (!L->sums) {
            rc = envl__fail(ENVL_ERR_MEMORY, "reference: out of memory");
            break;
        }
        envl__huge_pages(L->sums, sizeof(double) * (size_t)L->lw * L->lh * stride(t));
        if ((rc = level_geometry(t, L)))
            break;
        build_job j = {t, k};
        envl__parallel_for(L->lh, threads, k ? build_upper_rows : build_leaf_rows, &j);
        if (L->lw <= KTREE_TOP_WIDTH && L->lh <= KTREE_TOP_WIDTH)
            break;
    }
    if (rc) {
        envl__ktree_free(t);
        return rc;
    }
    *out = t;
    return ENVL_OK;
}

int32_t envl__ktree_channels(const ktree *t) { return t->channels; }

void envl__ktree_total(const ktree *t, double *s)
{
    const ktree_level *L = &t->level[t->levels - 1];
    int32_t ns = stride(t);
    for (int32_t k = 0; k < t->channels; k++)
        s[k] = 0;
    for (size_t i = 0; i < (size_t)L->lw * L->lh; i++)
        for (int32_t k = 0; k < t->channels; k++)
            s[k] += L->sums[i * ns + k];
}

typedef struct node_ref {
    int32_t k, c, r;
} node_ref;

void envl__ktree_sum(const ktree *t, const ktree_kernel *kn, const double n[3], double *est,
                     double *bound)
{
    int32_t ch = t->channels, ns = stride(t);
    for (int32_t k = 0; k < ch; k++)
        est[k] = bound[k] = 0;
    const ktree_level *top = &t->level[t->levels - 1];
    /* depth-first: the top blocks, then at most 3 siblings waiting per level below */
    node_ref stack[KTREE_TOP_WIDTH * KTREE_TOP_WIDTH + 4 * KTREE_MAX_LEVELS];
    int32_t sp = 0;
    for (int32_t r = 0; r < top->lh; r++)
        for (int32_t c = 0; c < top->lw; c++)
            stack[sp++] = (node_ref){t->levels - 1, c, r};
    while (sp > 0) {
        node_ref b = stack[--sp];
        const ktree_level *L = &t->level[b.k];
        double lo, hi;
        block_range(L, n, b.c, b.r, &lo, &hi);
        double omega = L->dphi[b.c] * L->band[b.r];
        const double *s = L->sums + ((size_t)b.r * L->lw + b.c) * ns;
        if (kn->block(kn->ctx, n, s, ch, lo, hi, omega, L->rho[b.r], est, bound))
            continue;
        if (b.k == 0) {
            int32_t c0 = b.c * L->bs, r0 = b.r * L->bs;
            kn->pixels(kn->ctx, n, c0, c0 + L->bs < t->w ? c0 + L->bs : t->w, r0,
                       r0 + L->bs < t->h ? r0 + L->bs : t->h, est, bound);
            continue;
        }
        const ktree_level *C = &t->level[b.k - 1];
        for (int32_t cr2 = 2 * b.r; cr2 < 2 * b.r + 2 && cr2 < C->lh; cr2++)
            for (int32_t cc = 2 * b.c; cc < 2 * b.c + 2 && cc < C->lw; cc++)
                stack[sp++] = (node_ref){b.k - 1, cc, cr2};
    }
}
