/* Spherical-harmonic projection of the envmap, windowing against ringing, evaluation, and the
 * artist forms (ambient + deltas, hemispheric pair).
 *
 * Projection integrates each pixel exactly as a constant patch: R_lm = sum_pixels L
 * integral_pixel Y_lm dw. Y_lm = Theta_l|m|(t) Phi_m(phi) separates; the azimuth integrals are
 * closed form (integral cos(m phi) dphi = (sin m phi1 - sin m phi0) / m ...) and the elevation
 * integrals use Gauss-Legendre with GAUSS points per row (smooth integrand over a short
 * interval: error ~ (pi/H)^(2 GAUSS)). So a constant map gives exactly L00 = 2 sqrt(pi) L and
 * zero elsewhere, up to rounding, at any resolution. */
#include "envmap_impl.h"
#include "clock.h"
#include "error_measure.h"
#include "options.h"
#include "sh_basis.h"
#include "sh_forms.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GAUSS 4
#define MIN_DIRECTIONS 4096 /* where "non-negative" is checked */

struct envl_sh {
    envl_sh_summary summary;
    int32_t order, n;
    double *radiance;   /* windowed */
    double *irradiance;
    double *window;     /* order + 1 */
};

static const char *window_names[ENVL_WINDOW_COUNT] = {"none", "hann", "lanczos", "auto"};

const char *envl_window_name(int32_t w)
{
    return w >= 0 && w < ENVL_WINDOW_COUNT ? window_names[w] : NULL;
}

int32_t envl_window_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_WINDOW_COUNT; i++)
        if (!strcmp(name, window_names[i]))
            return i;
    return -1;
}

void envl_sh_basis(int32_t order, const double d[3], double *y) { envl_sh_eval(order, d, y); }
double envl_sh_cosine_lobe(int32_t l) { return envl_sh_cosine_factor(l); }

/* The azimuth sums of a row, S_m = sum over its pixels of L Phi_m, Phi_m the exact integral of
 * cos(m phi) (m > 0), sin(|m| phi) (m < 0) or 1 over the pixel's azimuth span D = 2 pi / W:
 * Phi_m = k_m cos(m phi_c) or k_m sin(|m| phi_c) with k_m = (2 / m) sin(m D / 2), k_0 = D.
 * Blocks of SH_BLOCK pixels are summed in single-precision vectors against the weights
 * cos(m c D), sin(m c D) of the pixel's step c from the block's first pixel (the same for every
 * block, so they stay in L1), then turned to the block's azimuth phi_0 in double:
 * sum L cos(m phi) = cos(m phi_0) P_m + sin(m phi_0) Q_m and
 * sum L sin(m phi) = sin(m phi_0) P_m - cos(m phi_0) Q_m (phi = phi_0 - c D), with
 * P_m, Q_m = sum L cos(m c D), sum L sin(m c D). Across blocks and rows, double. */
#define SH_BLOCK 32

/* 4-point Gauss-Legendre on [-1, 1] */
static const double gauss_x[GAUSS] = {-0.8611363115940526, -0.3399810435848563,
                                      0.3399810435848563, 0.8611363115940526};
static const double gauss_w[GAUSS] = {0.3478548451374538, 0.6521451548625461,
                                      0.6521451548625461, 0.3478548451374538};

/* four floats; unaligned loads go through memcpy */
typedef float v4f __attribute__((vector_size(16)));

static inline v4f load4(const float *p)
{
    v4f v;
    memcpy(&v, p, sizeof v);
    return v;
}

typedef struct project_job {
    const envl_envmap *m;
    int32_t order, n;
    int32_t block;           /* pixels per block, at most SH_BLOCK */
    float scale;             /* 1, or 1 / SH_BLOCK for pixels near FLT_MAX (row_sums) */
    const float *wt;         /* 2 L x 3 SH_BLOCK: per order m = 1..L, cos then sin (m c D) per
                                float of a block (repeated over the 3 channels) */
    const double *turn;      /* blocks x L x 2: cos, sin (m phi_0) of each block's first pixel */
    const double *k;         /* 2 L + 1: k_m, index L + m */
    double *row_coef;        /* H x n x 3: each row's contribution */
} project_job;

/* The lanes of three vectors summed over a block hold channels R G B R | G B R G | B R G B. */
static inline void lanes_to_rgb(v4f a0, v4f a1, v4f a2, double *out)
{
    out[0] = (double)a0[0] + a0[3] + a1[2] + a2[1];
    out[1] = (double)a0[1] + a1[0] + a1[3] + a2[2];
    out[2] = (double)a0[2] + a1[1] + a2[0] + a2[3];
}

/* One frequency m of a block of count pixels: P_m and Q_m per channel into pq[0..2], pq[3..5]
 * (weights wc, ws: cos, sin (m c D) per float); with sum, also sum L into sum[0..2]. Nine
 * accumulators, so they stay in registers; the block (384 bytes) is read again from L1 for
 * each further frequency. */
static void block_frequency(const float *p, int32_t count, const float *wc, const float *ws,
                            double *pq, double *sum)
{
    v4f c0 = {0}, c1 = {0}, c2 = {0}, s0 = {0}, s1 = {0}, s2 = {0}, a0 = {0}, a1 = {0}, a2 = {0};
    int32_t c = 0;
    for (; c + 4 <= count; c += 4, p += 12, wc += 12, ws += 12) {
        v4f v0 = load4(p), v1 = load4(p + 4), v2 = load4(p + 8);
        c0 += v0 * load4(wc);
        c1 += v1 * load4(wc + 4);
        c2 += v2 * load4(wc + 8);
        s0 += v0 * load4(ws);
        s1 += v1 * load4(ws + 4);
        s2 += v2 * load4(ws + 8);
        if (sum) {
            a0 += v0;
            a1 += v1;
            a2 += v2;
        }
    }
    lanes_to_rgb(c0, c1, c2, pq);
    lanes_to_rgb(s0, s1, s2, pq + 3);
    if (sum)
        lanes_to_rgb(a0, a1, a2, sum);
    for (; c < count; c++, p += 3, wc += 3, ws += 3)
        for (int ch = 0; ch < 3; ch++) {
            pq[ch] += (double)p[ch] * wc[ch];
            pq[3 + ch] += (double)p[ch] * ws[ch];
            if (sum)
                sum[ch] += p[ch];
        }
}

/* The plain sum of a block (order 0 only). */
static void block_sum(const float *p, int32_t count, double *sum)
{
    v4f a0 = {0}, a1 = {0}, a2 = {0};
    int32_t c = 0;
    for (; c + 4 <= count; c += 4, p += 12) {
        a0 += load4(p);
        a1 += load4(p + 4);
        a2 += load4(p + 8);
    }
    lanes_to_rgb(a0, a1, a2, sum);
    for (; c < count; c++, p += 3)
        for (int ch = 0; ch < 3; ch++)
            sum[ch] += p[ch];
}

/* A row's S_m (without the factors k_m): s[3 (L + m) + ch], m = -L..L. A float lane sums up
 * to SH_BLOCK / 4 products L w (|w| <= 1), which overflows for L near FLT_MAX: with scale < 1
 * (a power of two: exact) each block is first copied scaled, and the sums are divided by it in
 * double. */
static void row_sums(const float *row, int32_t w, int32_t block, const float *wt,
                     const double *turn, int32_t L, float scale, double *s)
{
    float scaled[3 * SH_BLOCK];
    memset(s, 0, sizeof(double) * 3 * (2 * L + 1));
    for (int32_t c0 = 0, k = 0; c0 < w; c0 += block, k++) {
        int32_t count = w - c0 < block ? w - c0 : block;
        const float *p = row + 3 * (size_t)c0;
        if (scale != 1.0f) {
            for (int32_t i = 0; i < 3 * count; i++)
                scaled[i] = p[i] * scale;
            p = scaled;
        }
        double sum[3];
        if (L == 0)
            block_sum(p, count, sum);
        for (int32_t m = 1; m <= L; m++) {
            double pq[6];
            const float *wc = wt + (size_t)(2 * m - 2) * 3 * SH_BLOCK;
            block_frequency(p, count, wc, wc + 3 * SH_BLOCK, pq, m == 1 ? sum : NULL);
            double cm = turn[((size_t)k * L + m - 1) * 2], sm = turn[((size_t)k * L + m - 1) * 2 + 1];
            for (int ch = 0; ch < 3; ch++) {
                s[3 * (L + m) + ch] += cm * pq[ch] + sm * pq[3 + ch];
                s[3 * (L - m) + ch] += sm * pq[ch] - cm * pq[3 + ch];
            }
        }
        for (int ch = 0; ch < 3; ch++)
            s[3 * L + ch] += sum[ch];
    }
    if (scale != 1.0f)
        for (int32_t i = 0; i < 3 * (2 * L + 1); i++)
            s[i] /= scale;
}

static void project_rows(void *arg, int64_t begin, int64_t end)
{
    const project_job *j = arg;
    const envl_envmap *m = j->m;
    int32_t L = j->order, n = j->n, w = m->width, nm = 2 * L + 1;
    double *theta = malloc(sizeof(double) * n), *y = malloc(sizeof(double) * n);
    double *s = malloc(sizeof(double) * nm * 3);
    if (!theta || !y || !s)
        goto out; /* row_coef stays zero; the caller checks the allocation up front */
    for (int64_t r = begin; r < end; r++) {
        /* Theta_lm(r) = integral over the row of (Y_lm at phi = 0, i.e. without the azimuth
         * factor) cos t dt, by Gauss-Legendre in t on pieces no taller than pi / 64 (a map only
         * a few rows tall needs them). */
        double t1 = ENVL_PI * (0.5 - (double)r / m->height);
        double t0 = ENVL_PI * (0.5 - (r + 1.0) / m->height);
        int32_t pieces = (64 + m->height - 1) / m->height;
        memset(theta, 0, sizeof(double) * n);
        for (int32_t q = 0; q < pieces; q++) {
            double a0 = t0 + (t1 - t0) * q / pieces, a1 = t0 + (t1 - t0) * (q + 1) / pieces;
            for (int g = 0; g < GAUSS; g++) {
                double t = 0.5 * (a0 + a1) + 0.5 * (a1 - a0) * gauss_x[g];
                double wt = 0.5 * (a1 - a0) * gauss_w[g] * cos(t);
                double d[3] = {cos(t), 0.0, sin(t)};
                envl_sh_eval(L, d, y);
                for (int32_t l = 0; l <= L; l++)
                    for (int32_t mm = 0; mm <= l; mm++)
                        theta[l * (l + 1) + mm] += wt * y[l * (l + 1) + mm];
            }
        }
        /* S_m = sum over the row of L(c) Phi_m(c) = k_m x the row's sums, m = -L..L */
        const float *p = m->px + (size_t)r * w * 3;
        row_sums(p, w, j->block, j->wt, j->turn, L, j->scale, s);
        double *out = j->row_coef + (size_t)r * n * 3;
        for (int32_t l = 0; l <= L; l++)
            for (int32_t mm = -l; mm <= l; mm++) {
                int32_t i = l * (l + 1) + mm;
                double th = theta[l * (l + 1) + (mm < 0 ? -mm : mm)];
                for (int ch = 0; ch < 3; ch++)
                    out[3 * i + ch] = th * j->k[L + mm] * s[3 * (L + mm) + ch];
            }
    }
out:
    free(theta);
    free(y);
    free(s);
}

/* Radiance coefficients, unwindowed: (order+1)^2 x 3. */
static envl_result project(const envl_envmap *m, int32_t L, double *coef)
{
    /* Blocks of at most 32 pixels that divide the row evenly, more than 2 L + 1 of them: then
     * the float rounding of the weights, the same in every block, cancels over the row (the
     * sum over evenly spaced phi_0 of cos, sin(m phi_0) is 0 for 0 < m < blocks) and a constant
     * map's coefficients stay at double rounding (1e-16 of L00) instead of ~1e-8. A width with
     * no such divisor of at least 4 gets blocks of the largest size and a shorter last one. */
    int32_t w = m->width, h = m->height, n = envl_sh_count(L);
    int32_t limit = w / (2 * L + 2), block = 0;
    limit = limit < 4 ? 4 : limit > SH_BLOCK ? SH_BLOCK : limit;
    for (int32_t d = limit; d >= 4 && !block; d--)
        if (w % d == 0)
            block = d;
    if (!block)
        block = limit;
    int32_t nb = (w + block - 1) / block;
    float *wt = malloc(sizeof(float) * (2 * (size_t)L * 3 * SH_BLOCK + 1));
    double *turn = malloc(sizeof(double) * (2 * (size_t)L * nb + 1));
    double *row_coef = calloc((size_t)h * n * 3, sizeof(double));
    if (!wt || !turn || !row_coef) {
        free(wt);
        free(turn);
        free(row_coef);
        return envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
    }
    for (int32_t mm = 1; mm <= L; mm++)
        for (int32_t c = 0; c < block; c++)
            for (int ch = 0; ch < 3; ch++) {
                double a = mm * 2.0 * ENVL_PI * c / w;
                wt[(size_t)(2 * mm - 2) * 3 * SH_BLOCK + 3 * c + ch] = (float)cos(a);
                wt[(size_t)(2 * mm - 1) * 3 * SH_BLOCK + 3 * c + ch] = (float)sin(a);
            }
    for (int32_t k = 0; k < nb; k++) {
        double phi0 = ENVL_PI * (1.0 - 2.0 * ((double)k * block + 0.5) / w);
        for (int32_t mm = 1; mm <= L; mm++) {
            turn[((size_t)k * L + mm - 1) * 2] = cos(mm * phi0);
            turn[((size_t)k * L + mm - 1) * 2 + 1] = sin(mm * phi0);
        }
    }
    /* k_m = (2 / |m|) sin(|m| D / 2), k_0 = D */
    double k[2 * 32 + 1];
    for (int32_t mm = -L; mm <= L; mm++)
        k[L + mm] = mm == 0 ? 2.0 * ENVL_PI / w : 2.0 / abs(mm) * sin(abs(mm) * ENVL_PI / w);
    double top = fmax(m->info.max[0], fmax(m->info.max[1], m->info.max[2]));
    float scale = top > FLT_MAX / SH_BLOCK ? 1.0f / SH_BLOCK : 1.0f;
    project_job job = {m, L, n, block, scale, wt, turn, k, row_coef};
    envl__parallel_for(h, m->threads, project_rows, &job);
    /* Rows summed in order: the same result at any thread count. */
    memset(coef, 0, sizeof(double) * n * 3);
    for (int32_t r = 0; r < h; r++)
        for (int32_t i = 0; i < n * 3; i++)
            coef[i] += row_coef[(size_t)r * n * 3 + i];
    free(wt);
    free(turn);
    free(row_coef);
    return ENVL_OK;
}

/* Hann-type factor of band l for width wd: (1 + cos(pi l / wd)) / 2 for l < wd, else 0. */
static double hann(int32_t l, double wd)
{
    return wd <= 0 ? 1.0 : l < wd ? 0.5 * (1 + cos(ENVL_PI * l / wd)) : 0.0;
}

static void apply_window(envl_sh *sh, const double *raw, const double *factors)
{
    for (int32_t l = 0; l <= sh->order; l++) {
        double a = envl_sh_cosine_factor(l);
        for (int32_t mm = -l; mm <= l; mm++) {
            int32_t i = l * (l + 1) + mm;
            for (int ch = 0; ch < 3; ch++) {
                sh->radiance[3 * i + ch] = factors[l] * raw[3 * i + ch];
                sh->irradiance[3 * i + ch] = a * sh->radiance[3 * i + ch];
            }
        }
    }
}

/* y: 2 sh->n doubles (the basis at a direction, the basis' factors). */
static void eval(const envl_sh *sh, const double *coef, int32_t count, const double *dirs,
                 double *out, double *y)
{
    double *norm = y + sh->n;
    envl_sh_norms(sh->order, norm, y);
    for (int32_t i = 0; i < count; i++) {
        envl_sh_eval_normed(sh->order, norm, dirs + 3 * i, y);
        double e[3] = {0, 0, 0};
        for (int32_t j = 0; j < sh->n; j++)
            for (int ch = 0; ch < 3; ch++)
                e[ch] += coef[3 * j + ch] * y[j];
        memcpy(out + 3 * i, e, sizeof e);
    }
}

/* Least luminance irradiance over MIN_DIRECTIONS Fibonacci directions; *channel (may be
 * NULL): the least of any channel (what "non-negative" means for the auto window). */
static double min_irradiance(const envl_sh *sh, const double *dirs, double *buf, double *y,
                             double *channel)
{
    eval(sh, sh->irradiance, MIN_DIRECTIONS, dirs, buf, y);
    double mn = INFINITY, mc = INFINITY;
    for (int32_t i = 0; i < MIN_DIRECTIONS; i++) {
        mn = fmin(mn, envl__lum(buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]));
        mc = fmin(mc, fmin(buf[3 * i], fmin(buf[3 * i + 1], buf[3 * i + 2])));
    }
    if (channel)
        *channel = mc;
    return mn;
}

/* The auto window's search at the MIN_DIRECTIONS directions: per direction i, band l and
 * channel, the band's part of the unwindowed irradiance B_l(i) = A_l sum_m raw_lm Y_lm(d_i),
 * and per direction and channel the magnitude sum_l |A_l| sum_m |raw_lm Y_lm(d_i)|. A window
 * w_l (0 <= w_l <= 1) then gives E(d_i) = sum_l w_l B_l(i): L + 1 products a direction and
 * channel where eval() takes n and the basis again, at each of the bisection's 50 steps
 * (rooitou_park at order 4: 60 % of a 128-face irradiance cube's CPU). */
static void band_table(const envl_sh *sh, const double *raw, const double *dirs, double *y,
                       double *band, double *mag)
{
    const int32_t L = sh->order;
    for (int32_t i = 0; i < MIN_DIRECTIONS; i++) {
        envl_sh_eval(L, dirs + 3 * i, y);
        double *b = band + (size_t)i * (L + 1) * 3, *g = mag + 3 * (size_t)i;
        g[0] = g[1] = g[2] = 0;
        for (int32_t l = 0; l <= L; l++) {
            double a = envl_sh_cosine_factor(l);
            for (int ch = 0; ch < 3; ch++) {
                double sum = 0, abs_sum = 0;
                for (int32_t j = l * l; j < (l + 1) * (l + 1); j++) {
                    double t = raw[3 * j + ch] * y[j];
                    sum += t;
                    abs_sum += fabs(t);
                }
                b[3 * l + ch] = a * sum;
                g[ch] += fabs(a) * abs_sum;
            }
        }
    }
}

/* Whether window w keeps every channel's E >= 0 at every direction of the table, with a
 * margin of 1e-12 of its magnitude: the rounding of these sums and of eval()'s (each within
 * about (n + L) DBL_EPSILON = 3e-13 of the magnitude, n <= 1089) cannot take the window's
 * E below 0 there when eval() sums it. */
static int window_non_negative(int32_t L, const double *band, const double *mag,
                               const double *w)
{
    for (int32_t i = 0; i < MIN_DIRECTIONS; i++) {
        const double *b = band + (size_t)i * (L + 1) * 3;
        for (int ch = 0; ch < 3; ch++) {
            double e = 0;
            for (int32_t l = 0; l <= L; l++)
                e += w[l] * b[3 * l + ch];
            if (e < 1e-12 * mag[3 * (size_t)i + ch])
                return 0;
        }
    }
    return 1;
}

/* The hemispheric pair of one channel: c0 + c1 t (t = axis . n) closest to E over the sphere
 * with sky = c0 + c1 >= 0 and ground = c0 - c1 >= 0. Unconstrained it is c0 = a (the ambient,
 * >= 0), c1 = b; the squared error grows by 4 pi ((c0 - a)^2 + (c1 - b)^2 / 3), so when
 * a - |b| < 0 the best on the boundary c1 = +-c0 is c0 = (3 a + |b|) / 4: the negative end
 * becomes 0, the other (3 a + |b|) / 2. */
static void hemi_pair(double a, double b, double *sky, double *ground)
{
    if (a - fabs(b) >= 0) {
        *sky = a + b;
        *ground = a - b;
        return;
    }
    double lit = (3 * a + fabs(b)) / 2;
    *sky = b > 0 ? lit : 0;
    *ground = b > 0 ? 0 : lit;
}

void envl__sh_artist_forms(int32_t order, const double *irradiance, double ambient[3],
                           double deltas[3][3], double axis[3], double sky[3], double ground[3])
{
    /* E(n) ~ Y00 E00 + 0.488603 (E11 x + E1-1 y + E10 z) */
    const double y00 = 0.28209479177387814, y1 = 0.4886025119029199;
    double amb[3], d[3][3], dy[3];
    for (int ch = 0; ch < 3; ch++) {
        amb[ch] = y00 * irradiance[ch];
        d[0][ch] = order >= 1 ? y1 * irradiance[3 * 3 + ch] : 0;
        d[1][ch] = order >= 1 ? y1 * irradiance[3 * 1 + ch] : 0;
        d[2][ch] = order >= 1 ? y1 * irradiance[3 * 2 + ch] : 0;
    }
    for (int a = 0; a < 3; a++)
        dy[a] = envl__lum(d[a][0], d[a][1], d[a][2]);
    double len = sqrt(dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2]);
    /* Hemispheric: axis along the luminance gradient (up when there is none); per channel
     * the best fit of c0 + c1 (axis . n) is c0 = ambient, c1 = deltas . axis, unless that
     * makes sky or ground negative (hemi_pair: never negative). */
    for (int a = 0; a < 3; a++)
        axis[a] = len > 0 ? dy[a] / len : (a == 2);
    for (int ch = 0; ch < 3; ch++) {
        double c1 = 0;
        for (int a = 0; a < 3; a++)
            c1 += d[a][ch] * axis[a];
        hemi_pair(amb[ch], c1, &sky[ch], &ground[ch]);
    }
    if (ambient)
        memcpy(ambient, amb, sizeof amb);
    if (deltas)
        memcpy(deltas, d, sizeof d);
}

/* Every number a product carries must be finite (a map near FLT_MAX could overflow). */
static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

envl_result envl__sh_measure(envl_envmap *m, envl_sh *sh)
{
    const double *ref;
    envl_result rc = envl_envmap_reference_irradiance(m, &ref);
    if (rc)
        return rc;
    int32_t n = envl_sh_count(sh->summary.order);
    double *normals = envl__fibonacci_dirs();
    double *approx = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    double *y = malloc(sizeof(double) * 2 * n); /* eval()'s */
    if (normals && approx && y) {
        eval(sh, sh->irradiance, ENVL_ERROR_NORMALS, normals, approx, y);
        sh->summary.diffuse_error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, approx, ref);
    } else {
        rc = envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
    }
    free(normals);
    free(approx);
    free(y);
    return rc;
}

envl_result envl_sh_compute(envl_envmap *m, const envl_sh_options *options, envl_sh **out)
{
    if (!m || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_sh_compute: NULL argument");
    *out = NULL;
    int32_t L, window;
    envl_result rc = envl__sh_resolve(options, &L, &window);
    if (rc)
        return rc;
    double t0 = envl__seconds();
    envl_sh *sh = calloc(1, sizeof *sh);
    int32_t n = envl_sh_count(L);
    double *raw = malloc(sizeof(double) * n * 3);
    double *dirs = malloc(sizeof(double) * 3 * MIN_DIRECTIONS);
    double *buf = malloc(sizeof(double) * 3 * MIN_DIRECTIONS);
    double *y = malloc(sizeof(double) * 2 * n); /* eval()'s */
    rc = ENVL_OK;
    if (!sh || !raw || !dirs || !buf || !y) {
        rc = envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
        goto fail;
    }
    sh->order = L;
    sh->n = n;
    sh->radiance = malloc(sizeof(double) * n * 3);
    sh->irradiance = malloc(sizeof(double) * n * 3);
    sh->window = malloc(sizeof(double) * (L + 1));
    if (!sh->radiance || !sh->irradiance || !sh->window) {
        rc = envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
        goto fail;
    }
    rc = project(m, L, raw);
    if (rc)
        goto fail;
    for (int32_t i = 0; i < MIN_DIRECTIONS; i++)
        envl_fibonacci_direction(i, MIN_DIRECTIONS, dirs + 3 * i);
    envl_sh_summary *s = &sh->summary;
    s->order = L;
    s->window = window;
    for (int32_t l = 0; l <= L; l++) {
        double x = ENVL_PI * l / (L + 1);
        sh->window[l] = window == ENVL_WINDOW_HANN      ? hann(l, L + 1)
                        : window == ENVL_WINDOW_LANCZOS ? (l ? sin(x) / x : 1.0)
                                                           : 1.0;
    }
    s->window_width = window == ENVL_WINDOW_NONE || window == ENVL_WINDOW_AUTO ? 0 : L + 1;
    apply_window(sh, raw, sh->window);
    double least;
    s->min_irradiance = min_irradiance(sh, dirs, buf, y, &least);
    if (window == ENVL_WINDOW_AUTO && least < 0) {
        /* The least windowing: the largest Hann width wd with non-negative irradiance, by
         * bisection on 1/wd in (0, 1]. Width L+1 is the plain Hann window; narrower ones
         * window harder, down to wd = 1 (band 0 only: the mean, never negative). */
        double lo = 0.0, hi = 1.0; /* lo: rings (no window), hi: non-negative */
        double *band = malloc(sizeof(double) * 3 * MIN_DIRECTIONS * (L + 1));
        double *mag = malloc(sizeof(double) * 3 * MIN_DIRECTIONS);
        if (!band || !mag) {
            free(band);
            free(mag);
            rc = envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
            goto fail;
        }
        band_table(sh, raw, dirs, y, band, mag);
        for (int it = 0; it < 50; it++) {
            double mid = 0.5 * (lo + hi);
            for (int32_t l = 0; l <= L; l++)
                sh->window[l] = hann(l, 1.0 / mid);
            if (window_non_negative(L, band, mag, sh->window))
                hi = mid;
            else
                lo = mid;
        }
        free(band);
        free(mag);
        for (int32_t l = 0; l <= L; l++)
            sh->window[l] = hann(l, 1.0 / hi);
        apply_window(sh, raw, sh->window);
        s->window_width = 1.0 / hi;
        s->min_irradiance = min_irradiance(sh, dirs, buf, y, NULL);
    }
    s->seconds = envl__seconds() - t0;

    envl__sh_artist_forms(L, sh->irradiance, s->ambient, s->deltas, s->hemi_axis, s->hemi_sky,
                          s->hemi_ground);

    s->diffuse_error = -1;
    if (options && options->measure && (rc = envl__sh_measure(m, sh)))
        goto fail;
    double figures[] = {s->min_irradiance, s->diffuse_error, s->ambient[0], s->ambient[1],
                        s->ambient[2], s->hemi_sky[0], s->hemi_sky[1], s->hemi_sky[2],
                        s->hemi_ground[0], s->hemi_ground[1], s->hemi_ground[2]};
    if (!all_finite(sh->radiance, 3 * (size_t)n) || !all_finite(sh->irradiance, 3 * (size_t)n) ||
        !all_finite(figures, sizeof figures / sizeof *figures)) {
        rc = envl__fail(ENVL_ERR_NONFINITE, "%s: the SH coefficients overflow (not finite; the "
                        "largest pixel value is %g)", m->info.file,
                        fmax(m->info.max[0], fmax(m->info.max[1], m->info.max[2])));
        goto fail;
    }
    free(raw);
    free(dirs);
    free(buf);
    free(y);
    *out = sh;
    return ENVL_OK;
fail:
    free(raw);
    free(dirs);
    free(buf);
    free(y);
    envl_sh_free(sh);
    return rc;
}

void envl_sh_free(envl_sh *sh)
{
    if (!sh)
        return;
    free(sh->radiance);
    free(sh->irradiance);
    free(sh->window);
    free(sh);
}

envl_result envl_sh_get_summary(const envl_sh *sh, envl_sh_summary *out)
{
    if (!sh || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_sh_get_summary: NULL argument");
    *out = sh->summary;
    return ENVL_OK;
}

const double *envl_sh_radiance(const envl_sh *sh) { return sh ? sh->radiance : NULL; }
const double *envl_sh_irradiance(const envl_sh *sh) { return sh ? sh->irradiance : NULL; }
const double *envl_sh_window_factors(const envl_sh *sh) { return sh ? sh->window : NULL; }

static envl_result eval_public(const envl_sh *sh, const double *coef, int32_t count,
                               const double *dirs, double *out)
{
    if (!sh || count < 0 || (count && (!dirs || !out)))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_sh_eval: bad arguments");
    double *y = malloc(sizeof(double) * 2 * sh->n); /* eval()'s */
    if (!y)
        return envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
    eval(sh, coef, count, dirs, out, y);
    free(y);
    return ENVL_OK;
}

envl_result envl_sh_eval_radiance(const envl_sh *sh, int32_t count, const double *dirs,
                                  double *out)
{
    return eval_public(sh, sh ? sh->radiance : NULL, count, dirs, out);
}

envl_result envl_sh_eval_irradiance(const envl_sh *sh, int32_t count, const double *normals,
                                    double *out)
{
    return eval_public(sh, sh ? sh->irradiance : NULL, count, normals, out);
}
