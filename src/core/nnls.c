/* Least squares with non-negativity on some variables, in Gram form: minimise
 * |A x - y|^2 = x'Gx - 2 h'x + y'y (G = A'A, h = A'y) with x_i >= 0 for i < n_nonneg and the
 * rest free. Lawson & Hanson's active-set NNLS (Solving Least Squares Problems, 1974, ch. 23),
 * with the free variables always in the passive set. Small n (lights + SH coefficients). */
#include "nnls.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Solves G_PP z_P = h_P by Cholesky with a tiny ridge (nearly parallel lobes make G close to
 * singular); z is zero outside P. Returns 0 on success. */
static int solve_passive(int n, const double *G, const double *h, const int *passive, double *z,
                         double *work)
{
    int idx[ENVL_NNLS_MAX], m = 0;
    for (int i = 0; i < n; i++)
        if (passive[i])
            idx[m++] = i;
    memset(z, 0, sizeof(double) * n);
    if (!m)
        return 0;
    double trace = 0;
    for (int a = 0; a < m; a++)
        trace += G[idx[a] * n + idx[a]];
    double ridge = 1e-12 * (trace / m + 1e-300);
    for (int attempt = 0; attempt < 8; attempt++, ridge *= 100) {
        double *L = work; /* m x m lower triangle */
        int ok = 1;
        for (int a = 0; a < m && ok; a++)
            for (int b = 0; b <= a; b++) {
                double s = G[idx[a] * n + idx[b]] + (a == b ? ridge : 0.0);
                for (int k = 0; k < b; k++)
                    s -= L[a * m + k] * L[b * m + k];
                if (a == b) {
                    if (!(s > 0)) {
                        ok = 0;
                        break;
                    }
                    L[a * m + a] = sqrt(s);
                } else {
                    L[a * m + b] = s / L[b * m + b];
                }
            }
        if (!ok)
            continue;
        double v[ENVL_NNLS_MAX];
        for (int a = 0; a < m; a++) {
            double s = h[idx[a]];
            for (int k = 0; k < a; k++)
                s -= L[a * m + k] * v[k];
            v[a] = s / L[a * m + a];
        }
        for (int a = m - 1; a >= 0; a--) {
            double s = v[a];
            for (int k = a + 1; k < m; k++)
                s -= L[k * m + a] * v[k];
            v[a] = s / L[a * m + a];
        }
        for (int a = 0; a < m; a++)
            z[idx[a]] = v[a];
        return 0;
    }
    return -1;
}

int envl__nnls_gram(int n, int n_nonneg, const double *G, const double *h, double *x)
{
    if (n <= 0 || n > ENVL_NNLS_MAX || n_nonneg < 0 || n_nonneg > n)
        return -1;
    int passive[ENVL_NNLS_MAX];
    double z[ENVL_NNLS_MAX];
    double *work = malloc(sizeof(double) * n * n);
    if (!work)
        return -1;
    for (int i = 0; i < n; i++)
        passive[i] = i >= n_nonneg;
    double hmax = 0;
    for (int i = 0; i < n; i++)
        hmax = fmax(hmax, fabs(h[i]));
    const double tol = 1e-11 * (hmax + 1e-300);
    int rc = solve_passive(n, G, h, passive, x, work);
    for (int iter = 0; rc == 0 && iter < 3 * n + 10; iter++) {
        /* w = h - G x: the negative gradient; a zero variable with w_j > 0 wants to grow. */
        int j = -1;
        double best = tol;
        for (int i = 0; i < n; i++) {
            double s = h[i];
            for (int k = 0; k < n; k++)
                s -= G[i * n + k] * x[k];
            if (i < n_nonneg && !passive[i] && s > best) {
                best = s;
                j = i;
            }
        }
        if (j < 0)
            break;
        passive[j] = 1;
        for (int inner = 0; inner < 3 * n + 10; inner++) {
            if (solve_passive(n, G, h, passive, z, work)) {
                rc = -1;
                break;
            }
            double alpha = 2.0;
            for (int i = 0; i < n_nonneg; i++)
                if (passive[i] && z[i] <= 0) {
                    double a = x[i] / (x[i] - z[i]);
                    if (a < alpha)
                        alpha = a;
                }
            if (alpha > 1.0) {
                memcpy(x, z, sizeof(double) * n);
                break;
            }
            for (int i = 0; i < n; i++)
                x[i] += alpha * (z[i] - x[i]);
            /* The blocking variable reaches 0 (up to rounding): back to the zero set. */
            double xmax = 0;
            for (int i = 0; i < n; i++)
                xmax = fmax(xmax, fabs(x[i]));
            for (int i = 0; i < n_nonneg; i++)
                if (passive[i] && x[i] <= 1e-14 * xmax) {
                    passive[i] = 0;
                    x[i] = 0;
                }
        }
    }
    for (int i = 0; i < n_nonneg; i++)
        if (x[i] < 0)
            x[i] = 0;
    free(work);
    return rc;
}
