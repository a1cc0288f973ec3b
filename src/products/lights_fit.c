/* Fitted lights: K non-negative lights + an SH irradiance remainder, least squares against the
 * exact irradiance, and the fit's residual map (each light takes its light from a cone). */
#include "lights_impl.h"
#include "error_measure.h"
#include "nnls.h"
#include "sh_basis.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- fit: K lights (non-negative) + an SH irradiance remainder ---- */

#define FIT_NORMALS 1031    /* a Fibonacci set other than the error measure's 1024 */
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

/* ---- cones about a direction: angular bins, and the rows and columns that hold them ---- */

#define CONE_BINS 16384
#define CONE_RINGS 128
#define RING_BINS (CONE_BINS / CONE_RINGS)
#define CONE_CHUNKS 64      /* row chunks of a pass (fewer on maps under 64 rows) */

/* Angular bin of the pixel at (cos, sin) theta = (rc, rs), (cos, sin) phi = (cc, cs) about
 * dir: floor(sin(angle / 2) BINS), sin(angle / 2) = sqrt((1 - d.dir) / 2): monotonic in the
 * angle, no trigonometry per pixel. d = (rc cc, rc cs, rs), the products of
 * envl_envmap_direction, summed in the same order. */
static inline int32_t cone_bin(double rc, double rs, double cc, double cs, const double dir[3])
{
    double v = 0.5 * (1.0 - (rc * cc * dir[0] + rc * cs * dir[1] + rs * dir[2]));
    int32_t b = (int32_t)(sqrt(v > 0.0 ? v : 0.0) * CONE_BINS);
    return b < CONE_BINS ? b : CONE_BINS - 1;
}

/* The pixels a pass about dir visits: rows r0..r1, in each a run of columns around the axis,
 * together every pixel whose bin is <= max_bin. Bin <= B means sin(angle / 2) < s =
 * (B + 1) / BINS, angle < a = 2 asin s; visited: all within a + one pixel (rounding in the
 * bin's arithmetic moves its edge by far less). */
typedef struct cone_geom {
    int full;               /* the whole map */
    double cos_r, z, xy;    /* cos of the visited radius; the axis' z and |(x, y)| */
    double col;             /* the axis' column, c = (1 - phi / pi) W / 2 - 1/2 */
    int32_t r0, r1;
} cone_geom;

static cone_geom cone_geometry(const envl_envmap *m, const double dir[3], int32_t max_bin)
{
    int32_t W = m->width, H = m->height;
    cone_geom g = {.full = 1, .r0 = 0, .r1 = H - 1};
    double rad = 2.0 * asin(fmin(1.0, (max_bin + 1.0) / CONE_BINS)) +
                 fmax(2.0 * ENVL_PI / W, ENVL_PI / H);
    if (max_bin >= CONE_BINS - 1 || rad >= ENVL_PI)
        return g;
    g.full = 0;
    g.cos_r = cos(rad);
    g.z = dir[2];
    g.xy = hypot(dir[0], dir[1]);
    g.col = (1.0 - atan2(dir[1], dir[0]) / ENVL_PI) * W / 2 - 0.5;
    /* rows whose elevation is within rad of the axis': r = H (1/2 - theta / pi) - 1/2 */
    double el = atan2(dir[2], g.xy);
    double top = floor(H * (0.5 - (el + rad) / ENVL_PI) - 0.5);
    double bottom = ceil(H * (0.5 - (el - rad) / ENVL_PI) - 0.5);
    g.r0 = top < 0 ? 0 : (int32_t)top;
    g.r1 = bottom > H - 1 ? H - 1 : (int32_t)bottom;
    return g;
}

/* Columns lo..hi (wrapping: c mod W) of row r within the visited radius; 0 if none. In the
 * row, d.dir = rc xy cos(phi - phi_axis) + rs z >= cos_r where cos(phi - phi_axis) >= q. */
static int cone_span(const envl_envmap *m, const cone_geom *g, int32_t r, int32_t *lo,
                     int32_t *hi)
{
    int32_t W = m->width;
    *lo = 0;
    *hi = W - 1;
    if (g->full)
        return 1;
    double den = m->row_cos[r] * g->xy, base = m->row_sin[r] * g->z;
    if (base + den < g->cos_r)
        return 0;
    if (base - den >= g->cos_r)
        return 1;
    double q = (g->cos_r - base) / den;
    double half = acos(q < -1 ? -1 : q > 1 ? 1 : q) * W / (2.0 * ENVL_PI);
    double a = floor(g->col - half) - 1, b = ceil(g->col + half) + 1;
    if (b - a + 1 >= W)
        return 1;
    *lo = (int32_t)a;
    *hi = (int32_t)b;
    return 1;
}

/* Power (sum of L dw) of the fit map within FIT_CONE_DEGREES of d: rgb (if asked) and the
 * luminance, returned. */
static double cone_power(const envl_envmap *fm, const double d[3], double *rgb)
{
    const double cmin = cos(FIT_CONE_DEGREES * ENVL_PI / 180.0);
    /* the rows and columns within the cone's bin (and a pixel), each pixel then tested */
    cone_geom g = cone_geometry(fm, d, (int32_t)(sin(FIT_CONE_DEGREES * ENVL_PI / 360.0) *
                                                 CONE_BINS));
    double acc[3] = {0, 0, 0};
    int32_t W = fm->width;
    for (int32_t r = g.r0; r <= g.r1; r++) {
        int32_t lo, hi;
        if (!cone_span(fm, &g, r, &lo, &hi))
            continue;
        double ct = fm->row_cos[r], z = d[2] * fm->row_sin[r], row[3] = {0, 0, 0};
        for (int32_t cw = lo; cw <= hi; cw++) {
            int32_t c = cw < 0 ? cw + W : cw >= W ? cw - W : cw;
            const float *p = fm->px + 3 * ((size_t)r * W + c);
            if (ct * (d[0] * fm->col_cos[c] + d[1] * fm->col_sin[c]) + z >= cmin)
                for (int k = 0; k < 3; k++)
                    row[k] += p[k];
        }
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
        col[i] = envl__clamped_dot(p->normals + 3 * i, d);
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
    envl_result rc = envl__cut_regions(m, ENVL_METHOD_MEDIAN, FIT_CANDIDATES, &rs, &nr);
    if (rc)
        return rc;
    envl_light *ls = malloc(sizeof(envl_light) * (nr ? nr : 1));
    if (!ls) {
        free(rs);
        return envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
    }
    envl__region_lights(m, rs, nr, ls);
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

envl_result envl__fit_lights(envl_envmap *m, int32_t K, int32_t order, envl_lights *ls)
{
    envl_result rc;
    /* The fit's target: exact irradiance at FIT_NORMALS normals of the error reference's copy,
     * the map resampled (by area) to at most ENVL_REFERENCE_WIDTH (a 512-wide copy left 0.2 %
     * where 1024 leaves 0.15 % on the built-in sky: the sun's lobe). */
    const envl_envmap *fm;
    if ((rc = envl__reference_copy(m, &fm)))
        return rc;
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
    /* as the error measure's reference is (error_measure.h) */
    rc = envl__irradiance_reference(fm, p.m, p.normals, p.target);
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
    return rc;
}

/* ---- residual of the fit: each light takes its rgb from the smallest cone around it that
 * holds that much light, the same fraction from every pixel of the cone ----
 *
 * Lights go brightest first, each taking from what the ones before it left: light i's cone
 * is the first angular bin b about it where the sum of the residual's L dw over bins <= b
 * reaches its rgb (every channel). One parallel pass over the map sums every light's
 * histogram in CONE_RINGS coarse rings of RING_BINS bins; then, light by light, only the
 * pixels of its cone are visited: the ring where its rgb is reached is resolved to bins (the
 * pixels within that ring's outer edge), the cone taken, and what it took is subtracted from
 * the later lights' rings. Partial sums belong to fixed chunks of rows and are combined in
 * chunk order: the same result at any thread count. */

/* A chunk's partial sums in one pass. */
typedef struct cone_chunk {
    double *rings;          /* K x CONE_RINGS x 3: the histograms, or changes to them */
    double fine[RING_BINS][3];
    double inner[3];        /* the pixels of the rings inside `ring` */
    double taken, own, moment[3];
    int32_t x0, x1, y0, y1;
} cone_chunk;

typedef struct cone_job {
    const envl_envmap *m;
    float *res;             /* the residual, or NULL: none kept (residual_at) */
    const float *scan;      /* what the rings pass reads: the map, or a coarser copy's pixels */
    int32_t k, rows;        /* lights; rows per chunk */
    const double (*dirs)[3]; /* in take order */
    cone_chunk *chunks;
    double *rings;          /* K x CONE_RINGS x 3: each light's histogram of the residual */
    /* the pass about light `light`: chunks from `chunk0`, its rows and columns */
    int32_t light, ring, last, chunk0;
    cone_geom g;
    double keep[3];
    int32_t lasts[ENVL_NNLS_MAX];      /* each light taken so far (take order): its last bin */
    double keeps[ENVL_NNLS_MAX][3];    /* ... and the fraction of its cone it left */
} cone_job;

/* The residual at pixel (c, r) before light `light` takes: the one kept, or, with none kept,
 * the map's pixel scaled by the keep of each light taken so far whose cone holds it, in take
 * order, rounded to float after each as the kept one is: the same floats. */
static inline void residual_at(const cone_job *j, int32_t c, int32_t r, float v[3])
{
    const envl_envmap *m = j->m;
    size_t at = 3 * ((size_t)r * m->width + c);
    const float *p = (j->res ? j->res : m->px) + at;
    v[0] = p[0], v[1] = p[1], v[2] = p[2];
    if (j->res)
        return;
    double rc = m->row_cos[r], rs = m->row_sin[r];
    for (int32_t i = 0; i < j->light; i++)
        if (cone_bin(rc, rs, m->col_cos[c], m->col_sin[c], j->dirs[i]) <= j->lasts[i])
            for (int k = 0; k < 3; k++)
                v[k] = (float)(v[k] * j->keeps[i][k]);
}

/* Rows of chunk j within the pass's rows. */
static void chunk_rows(const cone_job *j, int64_t chunk, int32_t *r0, int32_t *r1)
{
    int32_t a = (int32_t)chunk * j->rows, b = a + j->rows - 1;
    *r0 = a > j->g.r0 ? a : j->g.r0;
    *r1 = b < j->g.r1 ? b : j->g.r1;
}

/* One row into light i's rings: runs of pixels in the same ring summed, then added (one
 * dependent add per run, not per pixel). */
static void row_rings(const cone_job *j, int32_t r, int32_t i, double *h)
{
    const envl_envmap *m = j->m;
    const float *p = j->scan + (size_t)r * m->width * 3;
    double om = m->row_omega[r], rc = m->row_cos[r], rs = m->row_sin[r], run[3] = {0, 0, 0};
    int32_t ring = 0;
    for (int32_t c = 0; c < m->width; c++, p += 3) {
        int32_t b = cone_bin(rc, rs, m->col_cos[c], m->col_sin[c], j->dirs[i]) / RING_BINS;
        if (b != ring) {
            for (int k = 0; k < 3; k++) {
                h[3 * ring + k] += run[k];
                run[k] = 0;
            }
            ring = b;
        }
        for (int k = 0; k < 3; k++)
            run[k] += p[k] * om;
    }
    for (int k = 0; k < 3; k++)
        h[3 * ring + k] += run[k];
}

/* The one pass over the map: every light's histogram of L dw in rings. */
static void rings_range(void *ctx, int64_t begin, int64_t end)
{
    const cone_job *j = ctx;
    for (int64_t ch = begin; ch < end; ch++) {
        double *h = j->chunks[ch].rings;
        memset(h, 0, sizeof(double) * 3 * CONE_RINGS * j->k);
        int32_t r0, r1;
        chunk_rows(j, ch, &r0, &r1);
        for (int32_t r = r0; r <= r1; r++)
            for (int32_t i = 0; i < j->k; i++)
                row_rings(j, r, i, h + (size_t)3 * CONE_RINGS * i);
    }
}

/* Light `light`'s bins in ring `ring`, and the rings inside it: their pixels' L dw. */
static void ring_range(void *ctx, int64_t begin, int64_t end)
{
    const cone_job *j = ctx;
    const envl_envmap *m = j->m;
    int32_t W = m->width;
    for (int64_t it = begin; it < end; it++) {
        cone_chunk *ch = &j->chunks[j->chunk0 + it];
        memset(ch->fine, 0, sizeof ch->fine);
        memset(ch->inner, 0, sizeof ch->inner);
        int32_t r0, r1;
        chunk_rows(j, j->chunk0 + it, &r0, &r1);
        for (int32_t r = r0; r <= r1; r++) {
            double om = m->row_omega[r], rc = m->row_cos[r], rs = m->row_sin[r];
            int32_t lo, hi;
            if (!cone_span(m, &j->g, r, &lo, &hi))
                continue;
            for (int32_t cw = lo; cw <= hi; cw++) {
                int32_t c = (cw % W + W) % W;
                int32_t b = cone_bin(rc, rs, m->col_cos[c], m->col_sin[c], j->dirs[j->light]);
                if (b / RING_BINS > j->ring)
                    continue;
                float p[3];
                residual_at(j, c, r, p);
                double *to = b / RING_BINS == j->ring ? ch->fine[b % RING_BINS] : ch->inner;
                for (int k = 0; k < 3; k++)
                    to[k] += p[k] * om;
            }
        }
    }
}

/* One pixel of the cone of light `light` taken: its e = L (1 - keep) dw (luminance) into the
 * chunk's sums, the pixel scaled by keep, and its change taken off the later lights' rings. */
static void take_pixel(const cone_job *j, cone_chunk *ch, int32_t c, int32_t r)
{
    const envl_envmap *m = j->m;
    double om = m->row_omega[r], rc = m->row_cos[r], rs = m->row_sin[r];
    float p[3];
    residual_at(j, c, r, p);
    const double *keep = j->keep;
    double e = om * envl__lum(p[0] * (1 - keep[0]), p[1] * (1 - keep[1]), p[2] * (1 - keep[2])),
           d[3] = {rc * m->col_cos[c], rc * m->col_sin[c], rs}, change[3];
    ch->taken += e;
    ch->own += e * om / (4.0 * ENVL_PI);
    for (int k = 0; k < 3; k++) {
        ch->moment[k] += e * d[k];
        float now = (float)(p[k] * keep[k]);
        change[k] = ((double)now - p[k]) * om;
        p[k] = now;
    }
    if (j->res)
        memcpy(j->res + 3 * ((size_t)r * m->width + c), p, sizeof p);
    for (int32_t i = j->light + 1; i < j->k; i++) {
        int32_t b = cone_bin(rc, rs, m->col_cos[c], m->col_sin[c], j->dirs[i]);
        double *hb = ch->rings + 3 * ((size_t)i * CONE_RINGS + b / RING_BINS);
        for (int k = 0; k < 3; k++)
            hb[k] += change[k];
    }
    ch->x0 = c < ch->x0 ? c : ch->x0;
    ch->x1 = c + 1 > ch->x1 ? c + 1 : ch->x1;
    ch->y0 = r < ch->y0 ? r : ch->y0;
    ch->y1 = r + 1 > ch->y1 ? r + 1 : ch->y1;
}

/* Light `light` takes the pixels of bins <= last. */
static void take_range(void *ctx, int64_t begin, int64_t end)
{
    const cone_job *j = ctx;
    const envl_envmap *m = j->m;
    int32_t W = m->width;
    for (int64_t it = begin; it < end; it++) {
        cone_chunk *ch = &j->chunks[j->chunk0 + it];
        memset(ch->rings, 0, sizeof(double) * 3 * CONE_RINGS * j->k);
        ch->taken = ch->own = ch->moment[0] = ch->moment[1] = ch->moment[2] = 0;
        ch->x0 = W;
        ch->y0 = m->height;
        ch->x1 = ch->y1 = -1;
        int32_t r0, r1;
        chunk_rows(j, j->chunk0 + it, &r0, &r1);
        for (int32_t r = r0; r <= r1; r++) {
            double rc = m->row_cos[r], rs = m->row_sin[r];
            int32_t lo, hi;
            if (!cone_span(m, &j->g, r, &lo, &hi))
                continue;
            for (int32_t cw = lo; cw <= hi; cw++) {
                int32_t c = (cw % W + W) % W;
                if (cone_bin(rc, rs, m->col_cos[c], m->col_sin[c], j->dirs[j->light]) <= j->last)
                    take_pixel(j, ch, c, r);
            }
        }
    }
}

/* Runs fn over the chunks that hold rows of j->g (set for light `light`, bins <= max_bin);
 * returns how many, from j->chunk0. */
static int32_t cone_pass(cone_job *j, int32_t max_bin, envl_range_fn fn)
{
    j->g = cone_geometry(j->m, j->dirs[j->light], max_bin);
    j->chunk0 = j->g.r0 / j->rows;
    int32_t n = j->g.r1 / j->rows - j->chunk0 + 1;
    envl__parallel_for(n, j->m->threads, fn, j);
    return n;
}

static int reaches(const double *sum, const double rgb[3])
{
    return sum[0] >= rgb[0] && sum[1] >= rgb[1] && sum[2] >= rgb[2];
}

/* The first bin where the light's L dw, summed from bin 0, reaches rgb in every channel
 * (CONE_BINS - 1 if none); avail = that sum. The rings (an estimate: of a coarser copy, or
 * rounded differently) point at a ring; a pass over the pixels within it decides: if the rings
 * inside it already hold rgb, the ring before; if the ring's last bin does not reach it, the
 * next; else the bin. Once moved, it keeps its direction: the search ends. */
static int32_t cone_last(cone_job *j, const double rgb[3], double avail[3])
{
    const double *h = j->rings + (size_t)3 * CONE_RINGS * j->light;
    double est[3] = {0, 0, 0};
    int32_t ring = 0;
    for (; ring < CONE_RINGS - 1; ring++) {
        for (int k = 0; k < 3; k++)
            est[k] += h[3 * ring + k];
        if (reaches(est, rgb))
            break;
    }
    for (int step = 0;;) {
        j->ring = ring;
        int32_t n = cone_pass(j, (ring + 1) * RING_BINS - 1, ring_range);
        double cum[3] = {0, 0, 0};
        for (int32_t it = 0; it < n; it++)
            for (int k = 0; k < 3; k++)
                cum[k] += j->chunks[j->chunk0 + it].inner[k];
        if (ring > 0 && step <= 0 && reaches(cum, rgb)) {
            ring--, step = -1;
            continue;
        }
        for (int32_t b = 0; b < RING_BINS; b++) {
            for (int32_t it = 0; it < n; it++)
                for (int k = 0; k < 3; k++)
                    cum[k] += j->chunks[j->chunk0 + it].fine[b][k];
            if (reaches(cum, rgb)) {
                memcpy(avail, cum, sizeof cum);
                return ring * RING_BINS + b;
            }
        }
        if (ring == CONE_RINGS - 1 || step < 0) {
            /* the whole sphere holds less; or (rounding) the ring before reached it, this one
             * not: its last bin */
            memcpy(avail, cum, sizeof cum);
            return ring * RING_BINS + RING_BINS - 1;
        }
        ring++, step = 1;
    }
}

/* Lights' indices brightest (luminance) first, ties in index order. */
static void take_order(const envl_lights *ls, int32_t *order)
{
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
}

/* The job's light `light` takes its cone; its direction, size and rect from what it took. */
static void take_cone(cone_job *j, envl_light *l)
{
    int32_t W = j->m->width, H = j->m->height;
    double avail[3];
    j->last = cone_last(j, l->rgb, avail);
    for (int k = 0; k < 3; k++) {
        if (l->rgb[k] > avail[k])
            l->rgb[k] = avail[k]; /* the whole sphere holds less: take all there is */
        j->keep[k] = avail[k] > 0 ? 1.0 - l->rgb[k] / avail[k] : 1.0;
    }
    int32_t n = cone_pass(j, j->last, take_range);
    j->lasts[j->light] = j->last;
    memcpy(j->keeps[j->light], j->keep, sizeof j->keep);
    /* what it takes, sum e, and its first moment, sum e d; the later lights' rings less it */
    double taken = 0, moment[3] = {0, 0, 0}, own = 0;
    int32_t x0 = W, x1 = -1, y0 = H, y1 = -1;
    for (int32_t it = 0; it < n; it++) {
        const cone_chunk *ch = &j->chunks[j->chunk0 + it];
        taken += ch->taken;
        own += ch->own;
        for (int k = 0; k < 3; k++)
            moment[k] += ch->moment[k];
        x0 = ch->x0 < x0 ? ch->x0 : x0;
        x1 = ch->x1 > x1 ? ch->x1 : x1;
        y0 = ch->y0 < y0 ? ch->y0 : y0;
        y1 = ch->y1 > y1 ? ch->y1 : y1;
        for (size_t i = (size_t)3 * CONE_RINGS * (j->light + 1); i < (size_t)3 * CONE_RINGS * j->k;
             i++)
            j->rings[i] += ch->rings[i];
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

/* Every light's rings of the residual (in j->rings), in one pass over `e` (the map, or a
 * coarser copy of it: then an estimate, which cone_last corrects): fixed chunks of rows,
 * summed in chunk order. */
static envl_result ring_estimates(const cone_job *j, const envl_envmap *e, const float *px)
{
    int32_t H = e->height, rows = (H + CONE_CHUNKS - 1) / CONE_CHUNKS;
    int32_t nch = (H + rows - 1) / rows;
    size_t per = (size_t)3 * CONE_RINGS * j->k;
    cone_job p = {.m = e, .scan = px, .k = j->k, .rows = rows, .dirs = j->dirs};
    p.chunks = malloc(sizeof(cone_chunk) * nch);
    double *mem = malloc(sizeof(double) * per * nch);
    if (!p.chunks || !mem) {
        free(p.chunks);
        free(mem);
        return envl__fail(ENVL_ERR_MEMORY, "lights: out of memory");
    }
    for (int32_t c = 0; c < nch; c++)
        p.chunks[c].rings = mem + per * c;
    p.g = (cone_geom){.full = 1, .r0 = 0, .r1 = H - 1};
    envl__parallel_for(nch, e->threads, rings_range, &p);
    memset(j->rings, 0, sizeof(double) * per);
    for (int32_t c = 0; c < nch; c++)
        for (size_t i = 0; i < per; i++)
            j->rings[i] += p.chunks[c].rings[i];
    free(p.chunks);
    free(mem);
    return ENVL_OK;
}

envl_result envl__take_cones(const envl_envmap *m, const envl_envmap *coarse, envl_lights *ls)
{
    int32_t K = ls->summary.count, H = m->height, order[ENVL_NNLS_MAX];
    if (K <= 0)
        return ENVL_OK;
    double dirs[ENVL_NNLS_MAX][3];
    take_order(ls, order);
    for (int32_t i = 0; i < K; i++)
        memcpy(dirs[i], ls->lights[order[i]].direction, sizeof dirs[i]);
    int32_t rows = (H + CONE_CHUNKS - 1) / CONE_CHUNKS, nch = (H + rows - 1) / rows;
    size_t per = (size_t)3 * CONE_RINGS * K;
    cone_job j = {.m = m, .res = ls->residual, .scan = m->px, .k = K, .rows = rows,
                  .dirs = (const double(*)[3])dirs};
    j.chunks = malloc(sizeof(cone_chunk) * nch);
    j.rings = calloc(per * (nch + 1), sizeof(double));
    envl_result rc = !j.chunks || !j.rings ? envl__fail(ENVL_ERR_MEMORY, "lights: out of memory")
                                           : ENVL_OK;
    for (int32_t c = 0; !rc && c < nch; c++)
        j.chunks[c].rings = j.rings + per * (c + 1);
    if (!rc)
        rc = coarse ? ring_estimates(&j, coarse, coarse->px) : ring_estimates(&j, m, m->px);
    for (j.light = 0; !rc && j.light < K; j.light++)
        take_cone(&j, &ls->lights[order[j.light]]);
    free(j.chunks);
    free(j.rings);
    return rc;
}
