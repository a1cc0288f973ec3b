/* Fitted lights: K non-negative lights + an SH irradiance remainder, least squares against the
 * exact irradiance at FIT_NORMALS normals and, weighted as much as all of them together, at
 * the normal +Z (what a ground receives). Each light then takes its light from the map
 * (lights_take.c), which gives its colour and size; the remainder is solved for the lights as
 * they are. */
#include "lights_impl.h"
#include "error_measure.h"
#include "nnls.h"
#include "sh_basis.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- fit: K lights (non-negative) + an SH irradiance remainder ---- */

#define FIT_NORMALS 1031    /* a Fibonacci set other than the error measure's 1024 */
/* The up row's weight: its squared residual counts FIT_UP_WEIGHT x FIT_NORMALS times, as much
 * as all the normals together (a ground sees the map through +Z alone; unweighted, +Z was up to
 * 2.2 % off on the maps measured, docs/fit_bench.md). */
#define FIT_UP_WEIGHT 1.0
#define FIT_CANDIDATES 64   /* from the median cut, and as many bright pixels */
#define FIT_SORTED 16384    /* bright pixels sorted at a time (envl__bright_chunk) */
/* A light must find its light nearby: its luminance irradiance may not exceed the luminance
 * power within FIT_CONE_DEGREES of it (no light "opposite the sun" that only fits numbers). */
#define FIT_CONE_DEGREES 45.0
#define FIT_CAP_WIDTH 256   /* counted on a copy of the map this wide (1.4-degree pixels) */
/* A light points along the moment of what it took unless that raises the fit's error by more
 * than this fraction of it (or FIT_MIN_GAIN, when more: point_along_takes). */
#define FIT_MOMENT_SLACK 0.03
/* A light is added only if it lowers the relative RMS irradiance error by at least this. */
#define FIT_MIN_GAIN 2e-4

typedef struct fit_problem {
    int32_t m;              /* rows: the normals, then the up row */
    double up_weight;       /* the last row's weight */
    double *normals;        /* m x 3 */
    double *target;         /* m x 3 exact irradiance (scaled) */
    double *target_y;       /* m luminance */
    int32_t nsh;            /* SH columns */
    double *sh;             /* nsh x m: Y_j(n_i) */
    double *sh_gram;        /* nsh x nsh: the SH columns' dot products (every solve's) */
    double *scratch;        /* m */
} fit_problem;

/* ---- cones about a direction: the rows and columns that hold them ---- */

envl__cone_geom envl__cone_geometry(const envl_envmap *m, const double dir[3], double radius)
{
    int32_t W = m->width, H = m->height;
    envl__cone_geom g = {.full = 1, .r0 = 0, .r1 = H - 1};
    double rad = radius + fmax(2.0 * ENVL_PI / W, ENVL_PI / H);
    if (!(rad < ENVL_PI))
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
    g.r1 = bottom > H - 1 ? H - 1 : bottom < 0 ? -1 : (int32_t)bottom;
    if (g.r0 > H - 1)
        g.r0 = H;
    return g;
}

/* In the row, d.dir = rc xy cos(phi - phi_axis) + rs z >= cos_r where cos(phi - phi_axis) >= q. */
int envl__cone_span(const envl_envmap *m, const envl__cone_geom *g, int32_t r, int32_t *lo,
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
    /* the rows and columns within the cone (and a pixel), each pixel then tested */
    envl__cone_geom g = envl__cone_geometry(fm, d, FIT_CONE_DEGREES * ENVL_PI / 180.0);
    double acc[3] = {0, 0, 0};
    int32_t W = fm->width;
    for (int32_t r = g.r0; r <= g.r1; r++) {
        int32_t lo, hi;
        if (!envl__cone_span(fm, &g, r, &lo, &hi))
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
    col[p->m - 1] *= p->up_weight;
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
            G[a * n + b] = G[b * n + a] =
                b >= k ? p->sh_gram[(a - k) * p->nsh + (b - k)] : dot_n(ca, cb, p->m);
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

static int cmp_desc(const void *a, const void *b)
{
    double x = ((const double *)a)[0], y = ((const double *)b)[0];
    if (x != y)
        return x < y ? 1 : -1;
    double i = ((const double *)a)[1], j = ((const double *)b)[1];
    return i < j ? -1 : i > j;
}

/* Luminance binades for envl__bright_chunk: 0 for y <= 0 (or NaN), else the double's biased
 * exponent e + 1023 of 2^e <= y < 2^(e+1) (1 for the subnormals, 2047 for +Inf): BINADES of
 * them, in the order of y. */
#define BINADES 2048

static int binade(double y)
{
    if (!(y > 0))
        return 0;
    uint64_t bits;
    memcpy(&bits, &y, sizeof bits);
    int b = (int)((bits >> 52) & 0x7ff);
    return b < 1 ? 1 : b;
}

size_t envl__bright_chunk(const float *px, size_t n, size_t least, int *top, double *out)
{
    /* one pass over the pixels: every positive one below *top into out, counted by binade;
     * then those from the chunk's lowest binade up kept, in place */
    size_t count_at[BINADES] = {0}, all = 0, m = 0;
    int hi = *top < BINADES ? *top : BINADES;
    for (size_t i = 0; i < n; i++) {
        double y = envl__lum(px[3 * i], px[3 * i + 1], px[3 * i + 2]);
        int b = binade(y);
        if (b > 0 && b < hi) {
            out[2 * all] = y, out[2 * all + 1] = (double)i, all++;
            count_at[b]++;
        }
    }
    int lo = hi;
    for (size_t got = 0; lo > 1 && got < least;)
        got += count_at[--lo];
    for (size_t i = 0; i < all; i++)
        if (binade(out[2 * i]) >= lo) {
            out[2 * m] = out[2 * i], out[2 * m + 1] = out[2 * i + 1];
            m++;
        }
    qsort(out, m, 2 * sizeof(double), cmp_desc);
    *top = lo;
    return m;
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
    size_t n = (size_t)fm->width * fm->height, len;
    double *order = malloc(sizeof(double) * 2 * n);
    if (!order)
        return envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
    const double min_cos = cos(2.0 * ENVL_PI / 180.0);
    int32_t first_bright = k;
    int top = INT32_MAX;
    /* the pixels brightest first, a chunk of FIT_SORTED or more at a time (a full sort of the
     * map cost 16 % of a 1K fit; the scan reads 356-9,853 of them on the 23 maps measured) */
    while (k < first_bright + FIT_CANDIDATES &&
           (len = envl__bright_chunk(fm->px, n, FIT_SORTED, &top, order)) > 0)
        for (size_t i = 0; i < len && k < first_bright + FIT_CANDIDATES; i++) {
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

/* The fit's error (relative RMS of luminance at the fit's normals, the up row in the sum) of the
 * lights as they are, their luminance fixed, with the remainder solved for them. */
static double lights_error(const fit_problem *p, double ymean, int32_t K, double *const *cols,
                           const envl_lights *ls)
{
    double y[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < K; i++)
        light_column(p, ls->lights[i].direction, cols[i]);
    for (int32_t i = 0; i < p->m; i++) {
        p->scratch[i] = p->target_y[i];
        for (int32_t l = 0; l < K; l++)
            p->scratch[i] -= envl__lum(ls->lights[l].rgb[0], ls->lights[l].rgb[1],
                                       ls->lights[l].rgb[2]) * cols[l][i];
    }
    double r = solve_fit(p, 0, NULL, p->scratch, y);
    return sqrt(fmax(0.0, r) / FIT_NORMALS) / ymean;
}

/* Each light points along the first moment of what it took (a disc light of its irradiance
 * there, a Blender sun, then gives a surface that sees all of it exactly that) wherever this
 * keeps the fit's error within FIT_MOMENT_SLACK of the fit's own, or FIT_MIN_GAIN when that is
 * more; the lights whose take left its moment nearest the fit's direction go first. Then every
 * light's size is that of its take about its direction. */
static void point_along_takes(fit_problem *p, double ymean, int32_t K, double *const *cols,
                              const envl__take *takes, envl_lights *ls)
{
    double off[ENVL_NNLS_MAX];
    int32_t order[ENVL_NNLS_MAX];
    double e = lights_error(p, ymean, K, cols, ls);
    double limit = e + fmax(FIT_MOMENT_SLACK * e, FIT_MIN_GAIN);
    for (int32_t i = 0; i < K; i++) {
        double len = sqrt(dot_n(takes[i].moment, takes[i].moment, 3));
        off[i] = len > 0 ? 1.0 - dot_n(takes[i].moment, ls->lights[i].direction, 3) / len : -1.0;
        int32_t j = i;
        for (; j > 0 && off[order[j - 1]] > off[i]; j--)
            order[j] = order[j - 1];
        order[j] = i;
    }
    for (int32_t o = 0; o < K; o++) {
        int32_t i = order[o];
        if (off[i] < 0)
            continue; /* it took nothing */
        envl_light *l = &ls->lights[i];
        double aim[3], len = sqrt(dot_n(takes[i].moment, takes[i].moment, 3));
        memcpy(aim, l->direction, sizeof aim);
        for (int k = 0; k < 3; k++)
            l->direction[k] = takes[i].moment[k] / len;
        if (!(lights_error(p, ymean, K, cols, ls) <= limit))
            memcpy(l->direction, aim, sizeof aim);
    }
    for (int32_t i = 0; i < K; i++) {
        envl__light_size(&takes[i], &ls->lights[i]);
        envl__light_take_size(&takes[i], &ls->lights[i]);
    }
}

envl_result envl__fit_lights(envl_envmap *m, int32_t K, int32_t order, int keep_residual,
                             envl_lights *ls)
{
    envl_result rc;
    /* The fit's target: exact irradiance at FIT_NORMALS normals of the error reference's copy,
     * the map resampled (by area) to at most ENVL_REFERENCE_WIDTH (a 512-wide copy left 0.2 %
     * where 1024 leaves 0.15 % on the built-in sky: the sun's lobe). */
    const envl_envmap *fm;
    if ((rc = envl__reference_copy(m, &fm)))
        return rc;
    fit_problem p = {.m = FIT_NORMALS + 1, .nsh = order >= 0 ? envl_sh_count(order) : 0};
    envl_envmap *coarse = NULL; /* before the first goto done: it frees it */
    p.up_weight = sqrt(FIT_UP_WEIGHT * FIT_NORMALS);
    double *cand = malloc(sizeof(double) * 3 * (2 * FIT_CANDIDATES + 1));
    p.normals = malloc(sizeof(double) * 3 * p.m);
    p.target = malloc(sizeof(double) * 3 * p.m);
    p.target_y = malloc(sizeof(double) * p.m);
    p.sh = malloc(sizeof(double) * (p.nsh ? p.nsh : 1) * p.m);
    p.sh_gram = malloc(sizeof(double) * (p.nsh ? p.nsh * p.nsh : 1));
    double *colmem = malloc(sizeof(double) * p.m * (K + 1));
    p.scratch = malloc(sizeof(double) * p.m);
    if (!cand || !p.normals || !p.target || !p.target_y || !p.sh || !p.sh_gram || !colmem ||
        !p.scratch) {
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    for (int32_t i = 0; i < FIT_NORMALS; i++)
        envl_fibonacci_direction(i, FIT_NORMALS, p.normals + 3 * i);
    p.normals[3 * FIT_NORMALS] = p.normals[3 * FIT_NORMALS + 1] = 0.0;
    p.normals[3 * FIT_NORMALS + 2] = 1.0;
    /* as the error measure's reference is (error_measure.h) */
    rc = envl__irradiance_reference(fm, p.m, p.normals, p.target);
    if (rc)
        goto done;
    for (int k = 0; k < 3; k++)
        p.target[3 * FIT_NORMALS + k] *= p.up_weight;
    double ysh[ENVL_NNLS_MAX];
    for (int32_t i = 0; i < p.m; i++) {
        p.target_y[i] = envl__lum(p.target[3 * i], p.target[3 * i + 1], p.target[3 * i + 2]);
        if (p.nsh) {
            envl_sh_eval(order, p.normals + 3 * i, ysh);
            for (int32_t j = 0; j < p.nsh; j++)
                p.sh[(size_t)j * p.m + i] = ysh[j] * (i == FIT_NORMALS ? p.up_weight : 1.0);
        }
    }
    for (int32_t a = 0; a < p.nsh; a++)
        for (int32_t b = 0; b <= a; b++)
            p.sh_gram[a * p.nsh + b] = p.sh_gram[b * p.nsh + a] =
                dot_n(p.sh + (size_t)a * p.m, p.sh + (size_t)b * p.m, p.m);
    /* the caps (cone_power) are counted on a copy FIT_CAP_WIDTH wide, as the take starts */
    if (fm->width > FIT_CAP_WIDTH &&
        (rc = envl__envmap_resampled(fm->px, fm->width, fm->height, FIT_CAP_WIDTH, m->threads,
                                     &coarse)))
        goto done;
    const envl_envmap *cm = coarse ? coarse : fm;
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
        cand_avail[c] = cone_power(cm, cand + 3 * c, NULL);
    double avail[ENVL_NNLS_MAX];
    double ymean = 0;
    for (int32_t i = 0; i < FIT_NORMALS; i++)
        ymean += fabs(p.target_y[i]);
    ymean /= FIT_NORMALS;
    double prev_err = INFINITY;
    if (p.nsh) {
        double r0 = solve_fit(&p, 0, NULL, p.target_y, x);
        prev_err = sqrt(fmax(0, r0) / FIT_NORMALS) / ymean;
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
        double err = sqrt(fmax(0, best) / FIT_NORMALS) / ymean;
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
                envl__tangents(dirs[i], t1, t2);
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
                    avail[i] = cone_power(cm, d, NULL);
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

    /* The lights' luminance as the fit found it; each light then takes that much from the map
     * (lights_take.c), which gives its colour and its final direction, the moment of what it
     * took (where the fit aimed it, but where the light nearby cannot put it there) */
    ls->lights = calloc((size_t)(K ? K : 1), sizeof(envl_light));
    ls->remainder = p.nsh ? calloc((size_t)p.nsh * 3, sizeof(double)) : NULL;
    if (keep_residual && !rc) {
        size_t npx = (size_t)m->width * m->height * 3;
        if ((ls->residual = malloc(sizeof(float) * npx)))
            memcpy(ls->residual, m->px, sizeof(float) * npx);
    }
    if (!ls->lights || (p.nsh && !ls->remainder) || (keep_residual && !ls->residual)) {
        rc = envl__fail(ENVL_ERR_MEMORY, "fit: out of memory");
        goto done;
    }
    if (K > 0)
        solve_bounded(&p, K, cols, p.target_y, avail, x);
    ls->summary.count = K;
    ls->summary.remainder_order = order;
    for (int32_t i = 0; i < K; i++) {
        memcpy(ls->lights[i].direction, dirs[i], sizeof dirs[i]);
        for (int c = 0; c < 3; c++)
            ls->lights[i].rgb[c] = x[i]; /* luminance x: grey of that luminance */
    }
    envl__take takes[ENVL_NNLS_MAX];
    if ((rc = envl__progress(0.6, "the lights' takes")) || (rc = envl__take_lights(m, cm, ls, takes)))
        goto done;
    point_along_takes(&p, ymean, K, cols, takes, ls);
    if (!p.nsh)
        goto done;
    /* The remainder for these lights, channel by channel: least squares of what they leave of
     * the target (the up row included) */
    for (int32_t i = 0; i < K; i++)
        light_column(&p, ls->lights[i].direction, cols[i]);
    for (int c = 0; c < 3; c++) {
        for (int32_t i = 0; i < p.m; i++) {
            p.scratch[i] = p.target[3 * i + c];
            for (int32_t l = 0; l < K; l++)
                p.scratch[i] -= ls->lights[l].rgb[c] * cols[l][i];
        }
        solve_fit(&p, 0, NULL, p.scratch, x);
        for (int32_t j = 0; j < p.nsh; j++)
            ls->remainder[3 * j + c] = x[j];
    }
done:
    envl_envmap_free(coarse);
    free(cand);
    free(p.normals);
    free(p.target);
    free(p.target_y);
    free(p.sh);
    free(p.sh_gram);
    free(colmem);
    free(p.scratch);
    return rc;
}
