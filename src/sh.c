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
#include "sh_basis.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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

typedef struct project_job {
    const envl_envmap *m;
    int32_t order, n;
    const double *phi_tab;   /* W x (2 order + 1): column integrals, index c (2L+1) + L + m */
    double *row_coef;        /* H x n x 3: each row's contribution */
} project_job;

/* 4-point Gauss-Legendre on [-1, 1] */
static const double gauss_x[GAUSS] = {-0.8611363115940526, -0.3399810435848563,
                                      0.3399810435848563, 0.8611363115940526};
static const double gauss_w[GAUSS] = {0.3478548451374538, 0.6521451548625461,
                                      0.6521451548625461, 0.3478548451374538};

/* phi_tab is laid out column-major: phi_tab[c * nm + k] = Phi_(k - L)(c). */
static void row_sums_any(const float *p, const double *phi, int32_t w, int32_t nm, double *s)
{
    memset(s, 0, sizeof(double) * nm * 3);
    for (int32_t c = 0; c < w; c++, p += 3, phi += nm)
        for (int32_t k = 0; k < nm; k++) {
            s[3 * k] += phi[k] * p[0];
            s[3 * k + 1] += phi[k] * p[1];
            s[3 * k + 2] += phi[k] * p[2];
        }
}

/* The same for order 2 (5 frequencies), the 15 sums spelled out so they stay in registers. */
static void row_sums_order2(const float *p, const double *phi, int32_t w, double *s)
{
    double r0 = 0, g0 = 0, b0 = 0, r1 = 0, g1 = 0, b1 = 0, r2 = 0, g2 = 0, b2 = 0;
    double r3 = 0, g3 = 0, b3 = 0, r4 = 0, g4 = 0, b4 = 0;
    for (int32_t c = 0; c < w; c++, p += 3, phi += 5) {
        double r = p[0], g = p[1], b = p[2];
        r0 += phi[0] * r, g0 += phi[0] * g, b0 += phi[0] * b;
        r1 += phi[1] * r, g1 += phi[1] * g, b1 += phi[1] * b;
        r2 += phi[2] * r, g2 += phi[2] * g, b2 += phi[2] * b;
        r3 += phi[3] * r, g3 += phi[3] * g, b3 += phi[3] * b;
        r4 += phi[4] * r, g4 += phi[4] * g, b4 += phi[4] * b;
    }
    const double a[15] = {r0, g0, b0, r1, g1, b1, r2, g2, b2, r3, g3, b3, r4, g4, b4};
    memcpy(s, a, sizeof a);
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
        /* S_m = sum over the row of L(c) Phi_m(c), for m = -L..L, per channel: every column
         * feeds 3 (2L+1) independent accumulators (no add waits for another). */
        const float *p = m->px + (size_t)r * w * 3;
        if (L == 2)
            row_sums_order2(p, j->phi_tab, w, s);
        else
            row_sums_any(p, j->phi_tab, w, nm, s);
        double *out = j->row_coef + (size_t)r * n * 3;
        for (int32_t l = 0; l <= L; l++)
            for (int32_t mm = -l; mm <= l; mm++) {
                int32_t i = l * (l + 1) + mm;
                double th = theta[l * (l + 1) + (mm < 0 ? -mm : mm)];
                for (int ch = 0; ch < 3; ch++)
                    out[3 * i + ch] = th * s[3 * (L + mm) + ch];
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
    int32_t w = m->width, h = m->height, n = envl_sh_count(L), nm = 2 * L + 1;
    double *phi_tab = malloc(sizeof(double) * (size_t)nm * w);
    double *row_coef = calloc((size_t)h * n * 3, sizeof(double));
    if (!phi_tab || !row_coef) {
        free(phi_tab);
        free(row_coef);
        return envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
    }
    for (int32_t c = 0; c < w; c++) {
        double p0 = ENVL_PI * (1.0 - 2.0 * (c + 1.0) / w), p1 = ENVL_PI * (1.0 - 2.0 * c / w);
        for (int32_t mm = -L; mm <= L; mm++) {
            double v;
            if (mm == 0)
                v = p1 - p0;
            else if (mm > 0)
                v = (sin(mm * p1) - sin(mm * p0)) / mm;
            else
                v = (cos(-mm * p0) - cos(-mm * p1)) / -mm;
            phi_tab[(size_t)c * nm + (L + mm)] = v;
        }
    }
    project_job job = {m, L, n, phi_tab, row_coef};
    envl__parallel_for(h, m->threads, project_rows, &job);
    /* Rows summed in order: the same result at any thread count. */
    memset(coef, 0, sizeof(double) * n * 3);
    for (int32_t r = 0; r < h; r++)
        for (int32_t i = 0; i < n * 3; i++)
            coef[i] += row_coef[(size_t)r * n * 3 + i];
    free(phi_tab);
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

static void eval(const envl_sh *sh, const double *coef, int32_t count, const double *dirs,
                 double *out, double *y)
{
    for (int32_t i = 0; i < count; i++) {
        envl_sh_eval(sh->order, dirs + 3 * i, y);
        double e[3] = {0, 0, 0};
        for (int32_t j = 0; j < sh->n; j++)
            for (int ch = 0; ch < 3; ch++)
                e[ch] += coef[3 * j + ch] * y[j];
        memcpy(out + 3 * i, e, sizeof e);
    }
}

/* Least luminance irradiance over MIN_DIRECTIONS Fibonacci directions. */
static double min_irradiance(const envl_sh *sh, const double *dirs, double *buf, double *y)
{
    eval(sh, sh->irradiance, MIN_DIRECTIONS, dirs, buf, y);
    double mn = INFINITY;
    for (int32_t i = 0; i < MIN_DIRECTIONS; i++)
        mn = fmin(mn, envl__lum(buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]));
    return mn;
}

envl_result envl_sh_compute(envl_envmap *m, const envl_sh_options *options, envl_sh **out)
{
    static const envl_sh_options defaults;
    const envl_sh_options *o = options ? options : &defaults;
    if (!m || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_sh_compute: NULL argument");
    *out = NULL;
    int32_t bands = o->bands ? o->bands : 3;
    if (bands < 1 || bands > 33 || o->window < 0 || o->window >= ENVL_WINDOW_COUNT)
        return envl__fail(ENVL_ERR_ARGUMENT, "sh: order %d (0..32) or window %d out of range",
                          (int)bands - 1, (int)o->window);
    struct timespec ts0, ts1;
    clock_gettime(CLOCK_MONOTONIC, &ts0);
    envl_sh *sh = calloc(1, sizeof *sh);
    int32_t L = bands - 1, n = envl_sh_count(L);
    double *raw = malloc(sizeof(double) * n * 3);
    double *dirs = malloc(sizeof(double) * 3 * MIN_DIRECTIONS);
    double *buf = malloc(sizeof(double) * 3 * MIN_DIRECTIONS);
    double *y = malloc(sizeof(double) * n);
    envl_result rc = ENVL_OK;
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
    s->window = o->window;
    for (int32_t l = 0; l <= L; l++) {
        double x = ENVL_PI * l / (L + 1);
        sh->window[l] = o->window == ENVL_WINDOW_HANN      ? hann(l, L + 1)
                        : o->window == ENVL_WINDOW_LANCZOS ? (l ? sin(x) / x : 1.0)
                                                           : 1.0;
    }
    s->window_width = o->window == ENVL_WINDOW_NONE || o->window == ENVL_WINDOW_AUTO ? 0 : L + 1;
    apply_window(sh, raw, sh->window);
    s->min_irradiance = min_irradiance(sh, dirs, buf, y);
    if (o->window == ENVL_WINDOW_AUTO && s->min_irradiance < 0) {
        /* The least windowing: the largest Hann width wd with non-negative irradiance, by
         * bisection on 1/wd in (0, 1]. Width L+1 is the plain Hann window; narrower ones
         * window harder, down to wd = 1 (band 0 only: the mean, never negative). */
        double lo = 0.0, hi = 1.0; /* lo: rings (no window), hi: non-negative */
        for (int it = 0; it < 50; it++) {
            double mid = 0.5 * (lo + hi);
            for (int32_t l = 0; l <= L; l++)
                sh->window[l] = hann(l, 1.0 / mid);
            apply_window(sh, raw, sh->window);
            if (min_irradiance(sh, dirs, buf, y) >= 0)
                hi = mid;
            else
                lo = mid;
        }
        for (int32_t l = 0; l <= L; l++)
            sh->window[l] = hann(l, 1.0 / hi);
        apply_window(sh, raw, sh->window);
        s->window_width = 1.0 / hi;
        s->min_irradiance = min_irradiance(sh, dirs, buf, y);
    }
    clock_gettime(CLOCK_MONOTONIC, &ts1);
    s->seconds = (ts1.tv_sec - ts0.tv_sec) + 1e-9 * (ts1.tv_nsec - ts0.tv_nsec);

    /* Artist forms from bands 0 and 1 (the least-squares linear fit over the sphere, by
     * orthogonality): E(n) ~ Y00 E00 + 0.488603 (E11 x + E1-1 y + E10 z). */
    const double y00 = 0.28209479177387814, y1 = 0.4886025119029199;
    double dy[3] = {0, 0, 0};
    for (int ch = 0; ch < 3; ch++) {
        s->ambient[ch] = y00 * sh->irradiance[ch];
        s->deltas[0][ch] = L >= 1 ? y1 * sh->irradiance[3 * 3 + ch] : 0;
        s->deltas[1][ch] = L >= 1 ? y1 * sh->irradiance[3 * 1 + ch] : 0;
        s->deltas[2][ch] = L >= 1 ? y1 * sh->irradiance[3 * 2 + ch] : 0;
    }
    for (int a = 0; a < 3; a++)
        dy[a] = envl__lum(s->deltas[a][0], s->deltas[a][1], s->deltas[a][2]);
    double len = sqrt(dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2]);
    /* Hemispheric: axis along the luminance gradient (up when there is none); per channel
     * the best fit of c0 + c1 (axis . n) is c0 = ambient, c1 = deltas . axis. */
    for (int a = 0; a < 3; a++)
        s->hemi_axis[a] = len > 0 ? dy[a] / len : (a == 2);
    for (int ch = 0; ch < 3; ch++) {
        double c1 = 0;
        for (int a = 0; a < 3; a++)
            c1 += s->deltas[a][ch] * s->hemi_axis[a];
        s->hemi_sky[ch] = s->ambient[ch] + c1;
        s->hemi_ground[ch] = s->ambient[ch] - c1;
    }

    /* Error of the irradiance reconstruction against the exact integrator. */
    const double *ref;
    rc = envl_envmap_reference_irradiance(m, &ref);
    if (rc)
        goto fail;
    double *normals = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    if (!normals) {
        rc = envl__fail(ENVL_ERR_MEMORY, "sh: out of memory");
        goto fail;
    }
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, normals + 3 * i);
    eval(sh, sh->irradiance, ENVL_ERROR_NORMALS, normals, buf, y);
    s->diffuse_error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, buf, ref);
    free(normals);
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
    double *y = malloc(sizeof(double) * sh->n);
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
