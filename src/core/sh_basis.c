/* Real spherical harmonics without the Condon-Shortley phase, any order, and the clamped-cosine
 * convolution factors A_l.
 *
 * Y_l^0 = K_l^0 P_l^0(z),  Y_l^m = sqrt2 K_l^m P_l^m(z) cos(m phi),  Y_l^-m = sqrt2 K_l^m
 * P_l^m(z) sin(m phi), K_l^m = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!). With r = sin(theta),
 * P_l^m(z) = r^m Pbar_l^m(z) and r^m cos(m phi), r^m sin(m phi) = Re, Im (x + i y)^m, so
 * everything is a polynomial in x, y, z (no trigonometry, no pole singularity):
 *   Pbar_m^m = (2m-1)!!, Pbar_{m+1}^m = (2m+1) z Pbar_m^m,
 *   Pbar_l^m = ((2l-1) z Pbar_{l-1}^m - (l+m-1) Pbar_{l-2}^m) / (l-m).
 * For l <= 2 this is Ramamoorthi & Hanrahan 2001's basis, as docs/design.md lists it. Coefficient
 * index: l (l + 1) + m. */
#include "sh_basis.h"

#include <math.h>

int32_t envl_sh_count(int32_t order) { return (order + 1) * (order + 1); }

/* The recurrence above. The factors (K_l^0, sqrt2 K_l^m) come from `norm` when it is given
 * (envl_sh_norms: the same doubles), else are computed as l grows, and stored in norm_out when
 * that is given. */
static void basis(int32_t order, const double *norm, double *norm_out, const double d[3],
                  double *y)
{
    double x = d[0], yy = d[1], z = d[2];
    double cm = 1.0, sm = 0.0;  /* Re, Im (x + i y)^m */
    double pmm = 1.0;           /* Pbar_m^m = (2m-1)!! */
    for (int32_t m = 0; m <= order; m++) {
        if (m > 0) {
            double c = cm * x - sm * yy, s = cm * yy + sm * x;
            cm = c;
            sm = s;
            pmm *= 2.0 * m - 1.0;
        }
        double p_prev2 = 0.0, p_prev = pmm; /* Pbar_{l-2}^m, Pbar_{l-1}^m */
        /* K_l^m = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), computed incrementally over l. */
        double fact_ratio = 1.0; /* (l-m)!/(l+m)! at l = m: 1/(2m)! */
        for (int32_t k = 1; !norm && k <= 2 * m; k++)
            fact_ratio /= k;
        for (int32_t l = m; l <= order; l++) {
            double p;
            if (l == m)
                p = pmm;
            else if (l == m + 1)
                p = (2.0 * m + 1.0) * z * pmm;
            else
                p = ((2.0 * l - 1.0) * z * p_prev - (l + m - 1.0) * p_prev2) / (l - m);
            if (l > m) {
                /* (l-m)!/(l+m)! from (l-1-m)!/(l-1+m)!: times (l-m)/(l+m) */
                if (!norm)
                    fact_ratio *= (double)(l - m) / (double)(l + m);
                p_prev2 = p_prev;
                p_prev = p;
            }
            int32_t i = l * (l + 1) + m;
            double k = norm ? norm[i]
                            : (m ? sqrt(2.0) : 1.0) *
                                  sqrt((2.0 * l + 1.0) / (4.0 * ENVL_PI) * fact_ratio);
            if (norm_out)
                norm_out[i] = norm_out[l * (l + 1) - m] = k;
            if (m == 0) {
                y[i] = k * p;
            } else {
                y[i] = k * p * cm;
                y[l * (l + 1) - m] = k * p * sm;
            }
        }
    }
}

void envl_sh_eval(int32_t order, const double d[3], double *y) { basis(order, NULL, NULL, d, y); }

void envl_sh_norms(int32_t order, double *norm, double *scratch)
{
    const double up[3] = {0, 0, 1};
    basis(order, NULL, norm, up, scratch);
}

void envl_sh_eval_normed(int32_t order, const double *norm, const double d[3], double *y)
{
    basis(order, norm, NULL, d, y);
}

/* Clamped cosine max(0, cos) in Legendre terms (Ramamoorthi & Hanrahan 2001, eq. 8-9):
 * A_0 = pi, A_1 = 2 pi / 3, A_l = 0 for odd l > 1, and for even l
 * A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2). */
double envl_sh_cosine_factor(int32_t l)
{
    if (l < 0) /* no such band ((l / 2 - 1) below would make A_-2 infinite) */
        return 0.0;
    if (l == 0)
        return ENVL_PI;
    if (l == 1)
        return 2.0 * ENVL_PI / 3.0;
    if (l % 2)
        return 0.0;
    /* l! / (2^l ((l/2)!)^2) = C(l, l/2) / 2^l, built as a product to avoid overflow. */
    double c = 1.0;
    for (int32_t k = 1; k <= l / 2; k++)
        c *= (double)(l / 2 + k) / (double)k / 4.0;
    double sign = ((l / 2 - 1) % 2) ? -1.0 : 1.0;
    return 2.0 * ENVL_PI * sign / ((l + 2.0) * (l - 1.0)) * c;
}
