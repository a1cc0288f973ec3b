/* The variance cut's marginals from block sums (lights_cut.c, split_variance).
 *
 * A variance split of a region [x0, x1) x [y0, y1) needs its column marginals (per column, over
 * the region's rows: sum e, e cos t, e sin t) and its row marginals (per row, over the region's
 * columns: sum e, e cos p, e sin p), e = a pixel's luminance x its solid angle, t its
 * elevation, p its azimuth. From the pixels that is a pass over the region for every split: six
 * passes over an 8K map for a cut of 64 regions, 42 % of `lights --method variance` there.
 * Here two tables of block sums, built in one pass per cut:
 *   cols[by][x]  column x over the rows of row block by (CUT_BLOCK rows),
 *   rows[y][bx]  row y over the columns of column block bx (CUT_BLOCK columns),
 * give a region's marginals from its whole blocks, plus the pixels of its ragged rows (outside
 * whole row blocks, at most 2 (B - 1): both marginals) and of each other row's ragged columns
 * (its row marginal). A split then reads (w + h) (1 + 2 B) values instead of w h pixels.
 * Everything in double, a block summed in pixel order: the pixels' sums up to rounding
 * (test_lights.c, test_cut_marginals). Memory: 2 x 3 doubles per B pixels, 0.75 bytes a pixel
 * with B = 64 (25 MB beside an 8K map's 384 MB of floats), freed when the cut ends. */
#include "lights_impl.h"

#include <stdlib.h>
#include <string.h>

static int32_t blocks(int32_t n) { return (n + CUT_BLOCK - 1) / CUT_BLOCK; }

/* One pixel's energy, as split_variance has always summed it. */
static inline double energy(const envl_envmap *m, int32_t y, int32_t c)
{
    const float *p = m->px + 3 * ((size_t)y * m->width + c);
    return envl__lum(p[0], p[1], p[2]) * m->row_omega[y];
}

typedef struct build_job {
    const envl_envmap *m;
    cut_marginals *t;
} build_job;

/* Row blocks [begin, end): each writes its own cols[by] and its rows' rows[y]. A row's
 * energies first (e), then the two kinds of sums over them, in the pixels' order. */
static void build_blocks(void *arg, int64_t begin, int64_t end)
{
    const build_job *j = arg;
    const envl_envmap *m = j->m;
    cut_marginals *t = j->t;
    int32_t W = m->width;
    double *e = malloc(sizeof(double) * (size_t)W);
    if (!e) {
        t->failed = 1; /* benign race: every writer stores 1 */
        return;
    }
    for (int64_t by = begin; by < end; by++) {
        int32_t ya = (int32_t)by * CUT_BLOCK, yb = ya + CUT_BLOCK < m->height ? ya + CUT_BLOCK
                                                                              : m->height;
        envl__window_rows(m, &ya, &yb);
        double *col = t->cols + 3 * (size_t)by * W;
        for (int32_t y = ya; y < yb; y++) {
            for (int32_t c = 0; c < W; c++)
                e[c] = energy(m, y, c);
            double ct = m->row_cos[y], st = m->row_sin[y];
            for (int32_t c = 0; c < W; c++) {
                col[3 * c] += e[c];
                col[3 * c + 1] += e[c] * ct;
                col[3 * c + 2] += e[c] * st;
            }
            double *row = t->rows + 3 * (size_t)y * t->nbx;
            for (int32_t bx = 0; bx < t->nbx; bx++) {
                int32_t c1 = (bx + 1) * CUT_BLOCK < W ? (bx + 1) * CUT_BLOCK : W;
                double s0 = 0, s1 = 0, s2 = 0;
                for (int32_t c = bx * CUT_BLOCK; c < c1; c++) {
                    s0 += e[c];
                    s1 += e[c] * m->col_cos[c];
                    s2 += e[c] * m->col_sin[c];
                }
                row[3 * bx] = s0;
                row[3 * bx + 1] = s1;
                row[3 * bx + 2] = s2;
            }
        }
    }
    free(e);
}

envl_result envl__cut_marginals_build(const envl_envmap *m, cut_marginals *t)
{
    memset(t, 0, sizeof *t);
    t->nbx = blocks(m->width);
    t->nby = blocks(m->height);
    t->cols = calloc(3 * (size_t)t->nby * m->width, sizeof(double));
    t->rows = calloc(3 * (size_t)m->height * t->nbx, sizeof(double));
    if (!t->cols || !t->rows) {
        envl__cut_marginals_free(t);
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    }
    envl__huge_pages(t->cols, sizeof(double) * 3 * t->nby * m->width);
    envl__huge_pages(t->rows, sizeof(double) * 3 * m->height * t->nbx);
    build_job job = {m, t};
    envl__parallel_for(t->nby, m->threads, build_blocks, &job);
    if (t->failed) {
        envl__cut_marginals_free(t);
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    }
    return ENVL_OK;
}

void envl__cut_marginals_free(cut_marginals *t)
{
    free(t->cols);
    free(t->rows);
    memset(t, 0, sizeof *t);
}

/* Adds the pixels of rows [ya, yb) and unwrapped columns [xa, xb) of region r to its column
 * marginals (when col) and its row marginals. */
static void add_pixels(const envl_envmap *m, const region *r, int32_t ya, int32_t yb,
                       int32_t xa, int32_t xb, double *col, double *row)
{
    int32_t W = m->width;
    for (int32_t y = ya; y < yb; y++) {
        double ct = m->row_cos[y], st = m->row_sin[y];
        double *rw = row + 3 * (y - r->y0);
        for (int32_t x = xa; x < xb; x++) {
            int32_t c = x < W ? x : x - W;
            double e = energy(m, y, c);
            if (col) {
                double *cl = col + 3 * (x - r->x0);
                cl[0] += e;
                cl[1] += e * ct;
                cl[2] += e * st;
            }
            rw[0] += e;
            rw[1] += e * m->col_cos[c];
            rw[2] += e * m->col_sin[c];
        }
    }
}

/* Adds to row y's marginal its columns [ca, cb) of the map (no wrap), at unwrapped offset
 * xo (the region's column x = c + xo): whole column blocks from the table, the rest pixels. */
static void add_row_span(const envl_envmap *m, const cut_marginals *t, const region *r,
                         int32_t y, int32_t ca, int32_t cb, int32_t xo, double *row)
{
    int32_t fa = (ca + CUT_BLOCK - 1) / CUT_BLOCK * CUT_BLOCK, fb = cb / CUT_BLOCK * CUT_BLOCK;
    if (cb >= m->width)
        fb = cb; /* the last block, short or not, ends at the map's edge */
    if (fa >= fb) {
        add_pixels(m, r, y, y + 1, ca + xo, cb + xo, NULL, row);
        return;
    }
    add_pixels(m, r, y, y + 1, ca + xo, fa + xo, NULL, row);
    double *rw = row + 3 * (y - r->y0);
    const double *tb = t->rows + 3 * (size_t)y * t->nbx;
    for (int32_t bx = fa / CUT_BLOCK; bx < blocks(fb); bx++) {
        rw[0] += tb[3 * bx];
        rw[1] += tb[3 * bx + 1];
        rw[2] += tb[3 * bx + 2];
    }
    add_pixels(m, r, y, y + 1, fb + xo, cb + xo, NULL, row);
}

void envl__cut_marginals_of(const envl_envmap *m, const cut_marginals *t, const region *r,
                            double *col, double *row)
{
    int32_t W = m->width, w = r->x1 - r->x0;
    int32_t ya = r->y0, yb = r->y1; /* a window's other rows add nothing */
    envl__window_rows(m, &ya, &yb);
    if (ya >= yb)
        return;
    int32_t fa = (ya + CUT_BLOCK - 1) / CUT_BLOCK * CUT_BLOCK, fb = yb / CUT_BLOCK * CUT_BLOCK;
    if (yb >= m->height)
        fb = yb; /* the last row block ends at the map's edge */
    if (fa >= fb) { /* no whole row block: the pixels */
        add_pixels(m, r, ya, yb, r->x0, r->x1, col, row);
        return;
    }
    add_pixels(m, r, ya, fa, r->x0, r->x1, col, row);
    /* whole row blocks: the columns from cols, each row from its column blocks */
    for (int32_t by = fa / CUT_BLOCK; by < blocks(fb); by++) {
        const double *tb = t->cols + 3 * (size_t)by * W;
        for (int32_t i = 0; i < w; i++) {
            int32_t x = r->x0 + i, c = x < W ? x : x - W;
            col[3 * i] += tb[3 * c];
            col[3 * i + 1] += tb[3 * c + 1];
            col[3 * i + 2] += tb[3 * c + 2];
        }
    }
    int32_t east = r->x1 < W ? r->x1 : W; /* [x0, east) before the seam, [W, x1) after it */
    for (int32_t y = fa; y < fb; y++) {
        add_row_span(m, t, r, y, r->x0, east, 0, row);
        if (r->x1 > W)
            add_row_span(m, t, r, y, 0, r->x1 - W, W, row);
    }
    add_pixels(m, r, fb, yb, r->x0, r->x1, col, row);
}
