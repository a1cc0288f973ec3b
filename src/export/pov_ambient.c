/* The POV-Ray include's ambient: the irradiance the lights did not take, E_a(n), written so
 * that POV-Ray can evaluate it without radiosity.
 *
 * E_a is an SH expansion of order L (the fit's remainder, or the SH of the residual map of a
 * cut). POV-Ray cannot evaluate SH of the normal, but its `slope { d }` pattern gives a value
 * that depends on n . d only, and a colour_map turns that value into any function of n . d. So
 * E_a is written as a sum of ridge functions g_k(d_k . n), each a Legendre series
 * sum_l C[k][l] P_l(d_k . n): by the addition theorem, P_l(d . n) = 4 pi / (2l + 1)
 * sum_m Y_lm(d) Y_lm(n), so band l of E_a, sum_m c_lm Y_lm(n), is matched exactly when
 * sum_k C[k][l] Y_lm(d_k) = (2l + 1) / (4 pi) c_lm for every m: 2l + 1 equations in K
 * unknowns; we take the least-norm solution C = M^T (M M^T)^-1 b, M[m][k] = Y_lm(d_k), with
 * K = 2L + 5 directions on a Fibonacci spiral of the upper hemisphere (the Gram matrices
 * M M^T then have condition numbers below ~300 up to L = 8; checked at 1024 normals to 1e-9
 * by the caller). The hemispheric form (sh.c's, envl__sh_artist_forms) is one term: the axis,
 * C[0][0] = (sky + ground) / 2, C[0][1] = (sky - ground) / 2.
 */
#include "pov_ambient.h"

#include <math.h>
#include <string.h>

/* P_l(c) by Bonnet's recursion: (k + 1) P_k+1 = (2k + 1) c P_k - k P_k-1. */
static double legendre(int l, double c)
{
    double p0 = 1, p1 = c;
    if (l == 0)
        return 1;
    for (int k = 1; k < l; k++) {
        double p2 = ((2 * k + 1) * c * p1 - k * p0) / (k + 1);
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

void pov_ridge_eval(const pov_ridge *r, const double n[3], double out[3])
{
    out[0] = out[1] = out[2] = 0;
    for (int k = 0; k < r->terms; k++) {
        double c = n[0] * r->dir[k][0] + n[1] * r->dir[k][1] + n[2] * r->dir[k][2];
        for (int l = 0; l <= r->order; l++) {
            double p = legendre(l, c);
            for (int ch = 0; ch < 3; ch++)
                out[ch] += r->coef[k][l][ch] * p;
        }
    }
}

/* sum_j coef_j Y_j(n), j < (order + 1)^2. */
static void sh_eval_rgb(int order, const double *coef, const double n[3], double out[3])
{
    double y[(ENVL_POV_MAX_ORDER + 1) * (ENVL_POV_MAX_ORDER + 1)];
    envl_sh_basis(order, n, y);
    out[0] = out[1] = out[2] = 0;
    for (int j = 0; j < (order + 1) * (order + 1); j++)
        for (int ch = 0; ch < 3; ch++)
            out[ch] += coef[3 * j + ch] * y[j];
}

/* Solves A x = b (n x n, row-major, A and b destroyed) by Gaussian elimination with partial
 * pivoting; -1 if singular. */
static int solve(int n, double *a, double *b)
{
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(a[r * n + c]) > fabs(a[p * n + c]))
                p = r;
        if (fabs(a[p * n + c]) < 1e-300)
            return -1;
        if (p != c) {
            for (int k = 0; k < n; k++) {
                double t = a[c * n + k];
                a[c * n + k] = a[p * n + k];
                a[p * n + k] = t;
            }
            double t = b[c];
            b[c] = b[p];
            b[p] = t;
        }
        for (int r = c + 1; r < n; r++) {
            double f = a[r * n + c] / a[c * n + c];
            for (int k = c; k < n; k++)
                a[r * n + k] -= f * a[c * n + k];
            b[r] -= f * b[c];
        }
    }
    for (int c = n - 1; c >= 0; c--) {
        for (int k = c + 1; k < n; k++)
            b[c] -= a[c * n + k] * b[k];
        b[c] /= a[c * n + c];
    }
    return 0;
}

/* K directions on a Fibonacci spiral of the upper hemisphere (antipodal directions would be
 * redundant); one term (up) for order 0. */
static void ridge_directions(int order, pov_ridge *r)
{
    r->order = order;
    r->terms = order == 0 ? 1 : 2 * order + 5;
    for (int k = 0; k < r->terms; k++) {
        double z = r->terms == 1 ? 1 : 1 - (k + 0.5) / r->terms;
        double s = sqrt(1 - z * z), ph = k * ENVL_PI * (3 - sqrt(5.0));
        r->dir[k][0] = s * cos(ph);
        r->dir[k][1] = s * sin(ph);
        r->dir[k][2] = z;
    }
}

/* Band l of every term: the least-norm C[.][l] = M^T (M M^T)^-1 b, b = (2l + 1) / (4 pi) c_lm,
 * M[m][k] = Y_lm(d_k) (the top of the file). -1 if the Gram matrix is singular. */
static int ridge_band(int l, const double *sh, double y[][(ENVL_POV_MAX_ORDER + 1) * (ENVL_POV_MAX_ORDER + 1)],
                      pov_ridge *r)
{
    int m = 2 * l + 1, base = l * l, K = r->terms;
    double g[(2 * ENVL_POV_MAX_ORDER + 1) * (2 * ENVL_POV_MAX_ORDER + 1)], rhs[2 * ENVL_POV_MAX_ORDER + 1];
    for (int ch = 0; ch < 3; ch++) {
        for (int i = 0; i < m; i++) {
            for (int j = 0; j < m; j++) {
                double s = 0;
                for (int k = 0; k < K; k++)
                    s += y[k][base + i] * y[k][base + j];
                g[i * m + j] = s;
            }
            rhs[i] = (2 * l + 1) / (4 * ENVL_PI) * sh[3 * (base + i) + ch];
        }
        if (solve(m, g, rhs))
            return -1;
        for (int k = 0; k < K; k++) {
            double s = 0;
            for (int i = 0; i < m; i++)
                s += y[k][base + i] * rhs[i];
            r->coef[k][l][ch] = s;
        }
    }
    return 0;
}

double pov_ridge_from_sh(int order, const double *sh, pov_ridge *r)
{
    memset(r, 0, sizeof *r);
    if (order < 0 || order > ENVL_POV_MAX_ORDER)
        return -1;
    ridge_directions(order, r);
    double y[POV_MAX_TERMS][(ENVL_POV_MAX_ORDER + 1) * (ENVL_POV_MAX_ORDER + 1)];
    for (int k = 0; k < r->terms; k++)
        envl_sh_basis(order, r->dir[k], y[k]);
    for (int l = 0; l <= order; l++)
        if (ridge_band(l, sh, y, r))
            return -1;
    double worst = 0, scale = 0;
    for (int i = 0; i < ENVL_ERROR_NORMALS; i++) {
        double n[3], a[3], b[3];
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, n);
        sh_eval_rgb(order, sh, n, a);
        pov_ridge_eval(r, n, b);
        for (int ch = 0; ch < 3; ch++) {
            worst = fmax(worst, fabs(a[ch] - b[ch]));
            scale = fmax(scale, fabs(a[ch]));
        }
    }
    return scale > 0 ? worst / scale : worst;
}

void pov_ridge_from_hemi(const double axis[3], const double sky[3], const double ground[3],
                         pov_ridge *r)
{
    memset(r, 0, sizeof *r);
    r->terms = 1;
    r->order = 1;
    memcpy(r->dir[0], axis, sizeof r->dir[0]);
    for (int ch = 0; ch < 3; ch++) {
        r->coef[0][0][ch] = 0.5 * (sky[ch] + ground[ch]);
        r->coef[0][1][ch] = 0.5 * (sky[ch] - ground[ch]);
    }
}

double pov_ridge_least(const pov_ridge *r, int *negative)
{
    double least = INFINITY;
    *negative = 0;
    for (int i = 0; i < 4096; i++) {
        double n[3], a[3];
        envl_fibonacci_direction(i, 4096, n);
        pov_ridge_eval(r, n, a);
        double m = fmin(a[0], fmin(a[1], a[2]));
        least = fmin(least, m);
        *negative += m < 0;
    }
    return least;
}

double pov_emitted_error(const pov_light *lights, int32_t count, const pov_ridge *r,
                         const double *ref, double *emit)
{
    for (int i = 0; i < ENVL_ERROR_NORMALS; i++) {
        double n[3], e[3] = {0, 0, 0};
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, n);
        /* a light delivers its colour max(0, n . l) (docs/design.md, "Units"), an area light
         * the mean over its grid (pov_area.c) */
        for (int32_t j = 0; j < count; j++) {
            double a[3];
            pov_light_irradiance(lights + j, n, a);
            for (int ch = 0; ch < 3; ch++)
                e[ch] += a[ch];
        }
        if (r) {
            double a[3];
            pov_ridge_eval(r, n, a);
            for (int ch = 0; ch < 3; ch++)
                e[ch] += a[ch];
        }
        memcpy(emit + 3 * i, e, sizeof e);
    }
    return envl_relative_rms_luminance(ENVL_ERROR_NORMALS, emit, ref);
}
