/* The lights' region table: sums over any pixel rectangle of the map, in O(1) plus its ragged
 * edges, without a per-pixel summed-area table.
 *
 * For each row r and each block of ENVL_TABLE_BLOCK columns, six sums over the block's pixels:
 *   w R, w G, w B                           (w = the row's pixel solid angle: irradiance)
 *   w cos(theta) sum Y cos(phi), w cos(theta) sum Y sin(phi), w sin(theta) sum Y
 * (Y = Rec. 709 luminance), i.e. the region's rgb and its energy-weighted direction sum, so the
 * energy (Y x solid angle) is the luminance of the first three. The table holds their summed-area
 * table over (rows, blocks) in double: t[(r (nb + 1) + k) 6 + ch] = sum over rows < r and
 * blocks < k. A rectangle's sums are four look-ups for its whole blocks plus direct sums over the
 * at most 2 (B - 1) pixels of each row that stick out of them.
 *
 * Why not Debevec's per-pixel table: on an 8192 x 4096 map it is 268 MB of doubles, written
 * once per row and once per column, more memory traffic than the rest of median cut together;
 * this one is 50 MB (B = 32), built in one pass over the map that also gives every light its rgb
 * and direction. The rgb (and so the energy) is summed in double throughout: a dim sky next to
 * a 1e6 sun keeps its own 53 bits (the precision test in tests/test_lights.c); the direction
 * sums within a block (at most 32 pixels) are single-precision vectors, 2^-24 relative. */
#include "envmap_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* four floats, two doubles; unaligned loads go through memcpy */
typedef float v4f __attribute__((vector_size(16)));
typedef double v2d __attribute__((vector_size(16)));

static inline v2d widen(float a, float b) { return (v2d){a, b}; }

static inline v4f load4(const float *p)
{
    v4f v;
    memcpy(&v, p, sizeof v);
    return v;
}

static int32_t blocks_of(int32_t w) { return (w + ENVL_TABLE_BLOCK - 1) / ENVL_TABLE_BLOCK; }

/* Column of block boundary k: k B, the last one at the map's width. */
static int32_t boundary(int32_t w, int32_t k)
{
    int64_t x = (int64_t)k * ENVL_TABLE_BLOCK;
    return x < w ? (int32_t)x : w;
}

typedef struct table_job {
    const envl_envmap *m;
    double *t;
    /* per float of a block: luminance weight x cos / sin of the pixel's azimuth step from the
     * block's first pixel (the same for every block: 3 B floats each, in L1) */
    const float *wcos, *wsin;
} table_job;

/* Sums over pixels [c0, c1) of one row: R, G, B in double, and in single precision
 * Y cos(c d), Y sin(c d) for the pixel's step c from c0 (d = 2 pi / W). Four pixels are twelve
 * floats, three vectors; as doubles, six pairs (R G | B R | G B) x 2. The weighted sums are
 * dot products of the row's floats with wcos, wsin (which carry the luminance factors). */
static void block_sums(const float *row, const float *wcos, const float *wsin, int32_t c0,
                       int32_t c1, double out[5])
{
    v2d rg = {0}, br = {0}, gb = {0};
    v4f cs = {0}, sn = {0}, cs2 = {0}, sn2 = {0};
    const float *p = row + 3 * (size_t)c0, *wc = wcos, *ws = wsin;
    int32_t c = c0;
    for (; c + 4 <= c1; c += 4, p += 12, wc += 12, ws += 12) {
        v4f v0 = load4(p), v1 = load4(p + 4), v2 = load4(p + 8);
        rg += widen(v0[0], v0[1]) + widen(v1[2], v1[3]);
        br += widen(v0[2], v0[3]) + widen(v2[0], v2[1]);
        gb += widen(v1[0], v1[1]) + widen(v2[2], v2[3]);
        cs += v0 * load4(wc) + v2 * load4(wc + 8);
        sn += v0 * load4(ws) + v2 * load4(ws + 8);
        cs2 += v1 * load4(wc + 4);
        sn2 += v1 * load4(ws + 4);
    }
    double r = rg[0] + br[1], g = rg[1] + gb[0], b = br[0] + gb[1];
    cs += cs2;
    sn += sn2;
    float yc = cs[0] + cs[1] + cs[2] + cs[3], ys = sn[0] + sn[1] + sn[2] + sn[3];
    for (; c < c1; c++, p += 3, wc += 3, ws += 3) {
        r += p[0];
        g += p[1];
        b += p[2];
        yc += p[0] * wc[0] + p[1] * wc[1] + p[2] * wc[2];
        ys += p[0] * ws[0] + p[1] * ws[1] + p[2] * ws[2];
    }
    out[0] = r;
    out[1] = g;
    out[2] = b;
    out[3] = yc;
    out[4] = ys;
}

/* The six weighted channels of a row's sums (see the top of the file). */
static void weigh_row(const envl_envmap *m, int32_t y, const double s[5], double out[6])
{
    double om = m->row_omega[y], oc = om * m->row_cos[y];
    out[0] = om * s[0];
    out[1] = om * s[1];
    out[2] = om * s[2];
    out[3] = oc * s[3];
    out[4] = oc * s[4];
    out[5] = om * m->row_sin[y] * envl__lum(s[0], s[1], s[2]);
}

/* Rows in parallel: table row r + 1 gets row r's block sums, accumulated along the blocks. */
static void table_rows(void *arg, int64_t begin, int64_t end)
{
    const table_job *j = arg;
    const envl_envmap *m = j->m;
    int32_t w = m->width, nb = blocks_of(w);
    for (int64_t r = begin; r < end; r++) {
        const float *row = m->px + (size_t)r * w * 3;
        double *t = j->t + (size_t)(r + 1) * (nb + 1) * 6, acc[6] = {0, 0, 0, 0, 0, 0};
        memset(t, 0, sizeof(double) * 6);
        if (m->window && (r < m->row0 || r >= m->row1)) { /* black: sums of 0 */
            memset(t, 0, sizeof(double) * 6 * (size_t)(nb + 1));
            continue;
        }
        for (int32_t k = 0; k < nb; k++) {
            double s[5], v[6];
            int32_t c0 = boundary(w, k);
            block_sums(row, j->wcos, j->wsin, c0, boundary(w, k + 1), s);
            /* phi(c0 + c) = phi(c0) - c d: sum Y cos(phi) = cos(phi0) P + sin(phi0) Q,
             * sum Y sin(phi) = sin(phi0) P - cos(phi0) Q with P, Q = sum Y cos, sin(c d) */
            double cp = m->col_cos[c0], sp = m->col_sin[c0], p = s[3], q = s[4];
            s[3] = cp * p + sp * q;
            s[4] = sp * p - cp * q;
            weigh_row(m, (int32_t)r, s, v);
            for (int ch = 0; ch < 6; ch++)
                t[6 * (k + 1) + ch] = acc[ch] += v[ch];
        }
    }
}

/* Columns of the table in parallel: accumulate down the rows (a fixed order per entry, so the
 * table does not depend on the thread count). */
static void table_columns(void *arg, int64_t begin, int64_t end)
{
    const table_job *j = arg;
    int32_t h = j->m->height, stride = (blocks_of(j->m->width) + 1) * 6;
    for (int32_t r = 1; r < h; r++) {
        const double *prev = j->t + (size_t)r * stride;
        double *cur = j->t + (size_t)(r + 1) * stride;
        for (int64_t i = begin; i < end; i++)
            cur[i] += prev[i];
    }
}

envl_result envl__region_table(envl_envmap *m)
{
    if (m->region_table)
        return ENVL_OK;
    int32_t w = m->width, h = m->height, nb = blocks_of(w);
    /* 2 MiB pages asked for, as for the map (envl__huge_pages). On an earlier VM plain pages
     * were the steadier (`bench --only speed` ratios 2.7-2.9 against 2.4-6.3 in huge pages);
     * on the VM of 2026-12-01 plain pages gave 5.4-6.8 and huge pages 2.3-4.8
     * (docs/performance.md, "Speed against a memory pass"). */
    size_t bytes = sizeof(double) * (size_t)(h + 1) * (nb + 1) * 6;
    double *t = malloc(bytes);
    float *wcos = malloc(sizeof(float) * 6 * ENVL_TABLE_BLOCK);
    if (!t || !wcos) {
        free(t);
        free(wcos);
        return envl__fail(ENVL_ERR_MEMORY, "lights: cannot allocate the region table (%d x %d)",
                          (int)nb + 1, (int)h + 1);
    }
    envl__huge_pages(t, bytes);
    static const double lum[3] = {0.2126, 0.7152, 0.0722};
    float *wsin = wcos + 3 * ENVL_TABLE_BLOCK;
    for (int32_t c = 0; c < ENVL_TABLE_BLOCK; c++)
        for (int ch = 0; ch < 3; ch++) {
            wcos[3 * c + ch] = (float)(lum[ch] * cos(2.0 * ENVL_PI * c / w));
            wsin[3 * c + ch] = (float)(lum[ch] * sin(2.0 * ENVL_PI * c / w));
        }
    memset(t, 0, sizeof(double) * (nb + 1) * 6);
    table_job job = {m, t, wcos, wsin};
    envl__parallel_for(h, m->threads, table_rows, &job);
    envl__parallel_for((int64_t)(nb + 1) * 6, m->threads, table_columns, &job);
    free(wcos);
    m->region_table = t;
    return ENVL_OK;
}

/* Direct sums over columns [x0, x1) (0 <= x0 <= x1 <= W) of rows [y0, y1), in double. */
static void direct_sums(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                        double out[6])
{
    if (x0 >= x1)
        return;
    int32_t w = m->width;
    envl__window_rows(m, &y0, &y1);
    for (int32_t y = y0; y < y1; y++) {
        const float *p = m->px + 3 * ((size_t)y * w + x0);
        double s[5] = {0, 0, 0, 0, 0}, v[6];
        for (int32_t c = x0; c < x1; c++, p += 3) {
            double yl = envl__lum(p[0], p[1], p[2]);
            s[0] += p[0];
            s[1] += p[1];
            s[2] += p[2];
            s[3] += yl * m->col_cos[c];
            s[4] += yl * m->col_sin[c];
        }
        weigh_row(m, y, s, v);
        for (int ch = 0; ch < 6; ch++)
            out[ch] += v[ch];
    }
}

/* Adds the table's sums over blocks [k0, k1) of rows [y0, y1). */
static void table_sums(const envl_envmap *m, int32_t k0, int32_t k1, int32_t y0, int32_t y1,
                       double out[6])
{
    size_t stride = (size_t)(blocks_of(m->width) + 1) * 6;
    const double *a = m->region_table + y0 * stride, *b = m->region_table + y1 * stride;
    for (int ch = 0; ch < 6; ch++)
        out[ch] += (b[6 * k1 + ch] - b[6 * k0 + ch]) - (a[6 * k1 + ch] - a[6 * k0 + ch]);
}

/* The whole blocks [k0, k1) inside columns [x0, x1) (0 <= x0 <= x1 <= W); k0 >= k1: none. */
static void whole_blocks(int32_t w, int32_t x0, int32_t x1, int32_t *k0, int32_t *k1)
{
    *k0 = (x0 + ENVL_TABLE_BLOCK - 1) / ENVL_TABLE_BLOCK;
    *k1 = x1 == w ? blocks_of(w) : x1 / ENVL_TABLE_BLOCK;
}

/* Columns [x0, x1) without the seam: the whole blocks from the table, the ragged ends directly. */
static void span_sums(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                      double out[6])
{
    int32_t w = m->width, k0, k1;
    whole_blocks(w, x0, x1, &k0, &k1);
    if (k0 >= k1) {
        direct_sums(m, x0, x1, y0, y1, out);
        return;
    }
    table_sums(m, k0, k1, y0, y1, out);
    direct_sums(m, x0, boundary(w, k0), y0, y1, out);
    direct_sums(m, boundary(w, k1), x1, y0, y1, out);
}

void envl__rect_sums(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                     double out[6])
{
    int32_t w = m->width;
    memset(out, 0, sizeof(double) * 6);
    if (x1 <= w) {
        span_sums(m, x0, x1, y0, y1, out);
    } else {
        span_sums(m, x0, w, y0, y1, out);
        span_sums(m, 0, x1 - w, y0, y1, out);
    }
}

/* Energy (sum of Y dw) over columns [x0, x1) (0 <= x0 <= x1 <= W) of rows [y0, y1), directly:
 * the cheaper sibling of direct_sums for the cuts, which need no rgb or direction. */
static double direct_energy(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1)
{
    double e = 0;
    envl__window_rows(m, &y0, &y1);
    for (int32_t y = y0; x0 < x1 && y < y1; y++) {
        const float *p = m->px + 3 * ((size_t)y * m->width + x0);
        double r = 0, g = 0, b = 0;
        for (int32_t c = x0; c < x1; c++, p += 3) {
            r += p[0];
            g += p[1];
            b += p[2];
        }
        e += m->row_omega[y] * envl__lum(r, g, b);
    }
    return e;
}

static double span_energy(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1)
{
    int32_t w = m->width, k0, k1;
    whole_blocks(w, x0, x1, &k0, &k1);
    if (k0 >= k1)
        return direct_energy(m, x0, x1, y0, y1);
    double s[6] = {0, 0, 0, 0, 0, 0};
    table_sums(m, k0, k1, y0, y1, s);
    return envl__lum(s[0], s[1], s[2]) + direct_energy(m, x0, boundary(w, k0), y0, y1) +
           direct_energy(m, boundary(w, k1), x1, y0, y1);
}

double envl__rect_energy(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1)
{
    int32_t w = m->width;
    if (x1 <= w)
        return span_energy(m, x0, x1, y0, y1);
    return span_energy(m, x0, w, y0, y1) + span_energy(m, 0, x1 - w, y0, y1);
}

/* Energy of rows [y0, y1) over columns [0, x) for x at a block boundary of the unwrapped
 * line [0, 2W): boundary j <= nb is column boundary(j), j > nb is W + boundary(j - nb). */
static int32_t unwrapped_boundary(int32_t w, int32_t j)
{
    int32_t nb = blocks_of(w);
    return j <= nb ? boundary(w, j) : w + boundary(w, j - nb);
}

static double prefix_energy(const envl_envmap *m, int32_t j, int32_t y0, int32_t y1)
{
    int32_t nb = blocks_of(m->width);
    double s[6] = {0, 0, 0, 0, 0, 0};
    if (j <= nb) {
        table_sums(m, 0, j, y0, y1, s);
    } else {
        table_sums(m, 0, nb, y0, y1, s);
        table_sums(m, 0, j - nb, y0, y1, s);
    }
    return envl__lum(s[0], s[1], s[2]);
}

void envl__column_energies(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                           double *out)
{
    int32_t w = m->width;
    memset(out, 0, sizeof(double) * (size_t)(x1 - x0));
    envl__window_rows(m, &y0, &y1);
    for (int32_t y = y0; y < y1; y++) {
        double om = m->row_omega[y];
        const float *row = m->px + (size_t)y * w * 3;
        for (int32_t x = x0; x < x1; x++) {
            const float *p = row + 3 * (x < w ? x : x - w);
            out[x - x0] += envl__lum(p[0], p[1], p[2]) * om;
        }
    }
}

int32_t envl__median_column(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                            double half, double *left)
{
    int32_t w = m->width, nb = blocks_of(w);
    /* the block boundaries strictly inside (x0, x1) of the unwrapped line: indices ja..jb */
    int32_t ja = x0 / ENVL_TABLE_BLOCK + 1;
    int32_t jb = x1 <= w ? (x1 - 1) / ENVL_TABLE_BLOCK : nb + (x1 - w - 1) / ENVL_TABLE_BLOCK;
    /* the segment [sa, sb] in which the running energy reaches half, and the energy of
     * [x0, sa) */
    int32_t sa = x0, sb = x1;
    double before = 0;
    if (ja <= jb) {
        /* energy of columns [0, x0) of these rows: x0's block from the table, the rest
         * directly (0 <= x0 < W) */
        double s[6] = {0, 0, 0, 0, 0, 0};
        int32_t k = x0 / ENVL_TABLE_BLOCK;
        table_sums(m, 0, k, y0, y1, s);
        double base = envl__lum(s[0], s[1], s[2]) + direct_energy(m, boundary(w, k), x0, y0, y1);
        /* binary search: the first boundary whose running energy reaches half (jb + 1: none) */
        int32_t l = ja, u = jb + 1;
        while (l < u) {
            int32_t mid = l + (u - l) / 2;
            if (prefix_energy(m, mid, y0, y1) - base >= half)
                u = mid;
            else
                l = mid + 1;
        }
        if (l > ja) {
            sa = unwrapped_boundary(w, l - 1);
            before = prefix_energy(m, l - 1, y0, y1) - base;
        }
        if (l <= jb)
            sb = unwrapped_boundary(w, l);
    }
    /* column by column through the segment (at most one block wide): the smallest s in
     * [x0 + 1, x1 - 1] with energy([x0, s)) >= half, else x1 - 1; then s - 1 if that is as
     * close to half */
    double cols[ENVL_TABLE_BLOCK];
    envl__column_energies(m, sa, sb, y0, y1, cols);
    int32_t lo = x0 + 1, hi = x1 - 1, s = sa;
    double e = before, e_prev = before;
    while (s < hi && s < sb && (s < lo || e < half)) {
        e_prev = e;
        e += cols[s - sa];
        s++;
    }
    if (s > sa && s > lo && fabs(e_prev - half) <= fabs(e - half)) {
        s--;
        e = e_prev;
    }
    *left = e;
    return s;
}
