/* The split-sum BRDF table (Karis 2013): GGX with height-correlated Smith visibility.
 *
 * The specular BRDF is f = D(h) Vis(l, v) F(v.h) with Vis = G2 / (4 NoL NoV); for the
 * height-correlated Smith G2 (Heitz 2014) Vis = 0.5 / (NoL sqrt(NoV^2 (1 - a^2) + a^2) +
 * NoV sqrt(NoL^2 (1 - a^2) + a^2)), a = alpha = roughness^2. With Schlick's Fresnel
 * F = F0 + (1 - F0) Fc, Fc = (1 - VoH)^5, the directional albedo splits into
 *   int f NoL dl = F0 A + B,  A = int (1 - Fc) D Vis NoL dl,  B = int Fc D Vis NoL dl.
 * Integrated by importance sampling half vectors from D (pdf of l = D NoH / (4 VoH)): each
 * sample weighs Vis NoL 4 VoH / NoH. Hammersley points (first coordinate (i + 0.5) / n), sums in
 * double. At roughness 0 every sample is h = N and the weight is exactly 1: A + B = 1 for
 * every NoV. At NoV = 1 (and any roughness) the integral reduces to one dimension, which the
 * test evaluates by quadrature; at roughness 1 it is 1 - ln 2 in closed form.
 *
 * Multiscatter form (Turquin 2019, Fdez-Aguera 2019, as Filament stores it): channels
 * (B, A + B). Single scattering is mix(B, A + B, F0) = F0 A + B; the energy lost to single
 * scattering is restored by specular *= 1 + F0 (1 / (A + B) - 1). */
#include "internal.h"
#include "options.h"
#include "envmap_impl.h"

#include <math.h>
#include <stdlib.h>



static double vis_smith_correlated(double nov, double nol, double a)
{
    double a2 = a * a;
    double gv = nol * sqrt(nov * nov * (1.0 - a2) + a2);
    double gl = nov * sqrt(nol * nol * (1.0 - a2) + a2);
    double s = gv + gl;
    return s > 0 ? 0.5 / s : 0.0;
}

/* (A, B) at (nov, roughness) with n samples. */
static void integrate(double nov, double roughness, int32_t n, double ab[2])
{
    double a = roughness * roughness, a2 = a * a;
    nov = nov < 1e-6 ? 1e-6 : nov > 1 ? 1 : nov;
    double vx = sqrt(1.0 - nov * nov), vz = nov; /* v = (vx, 0, vz) */
    double A = 0, B = 0;
    for (int32_t i = 0; i < n; i++) {
        double e1 = (i + 0.5) / n, e2 = envl__radical_inverse((uint32_t)i);
        /* GGX: cos^2(theta_h) = (1 - e1) / (1 + (a^2 - 1) e1) */
        double c2 = (1.0 - e1) / (1.0 + (a2 - 1.0) * e1);
        double ct = sqrt(c2), st = sqrt(fmax(0.0, 1.0 - c2));
        double phi = 2.0 * ENVL_PI * e2;
        double hx = st * cos(phi), hz = ct;
        double voh = vx * hx + vz * hz;
        double nol = 2.0 * voh * hz - vz; /* l = 2 (v.h) h - v, z component */
        if (nol <= 0 || voh <= 0)
            continue;
        double w = vis_smith_correlated(nov, nol, a) * nol * 4.0 * voh / hz;
        double fc = pow(1.0 - voh, 5.0);
        A += (1.0 - fc) * w;
        B += fc * w;
    }
    ab[0] = A / n;
    ab[1] = B / n;
}

envl_result envl_brdf_eval(double nov, double roughness, int32_t samples, double ab[2])
{
    if (!ab || !(nov >= 0 && nov <= 1) || !(roughness >= 0 && roughness <= 1) || samples < 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "brdf: NoV %g and roughness %g must be in [0, 1]",
                          nov, roughness);
    integrate(nov, roughness, samples ? samples : ENVL_BRDF_DEFAULT_SAMPLES, ab);
    return ENVL_OK;
}

typedef struct lut_job {
    int32_t size, samples, multiscatter;
    float *rg;
} lut_job;

static void lut_rows(void *ctx, int64_t begin, int64_t end)
{
    lut_job *j = ctx;
    for (int64_t r = begin; r < end; r++) {
        double rough = (r + 0.5) / j->size;
        for (int32_t c = 0; c < j->size; c++) {
            double ab[2];
            integrate((c + 0.5) / j->size, rough, j->samples, ab);
            float *p = j->rg + 2 * ((size_t)r * j->size + c);
            if (j->multiscatter) {
                p[0] = (float)ab[1];
                p[1] = (float)(ab[0] + ab[1]);
            } else {
                p[0] = (float)ab[0];
                p[1] = (float)ab[1];
            }
        }
    }
}

envl_result envl_brdf_lut(const envl_brdf_options *options, float **rg, int32_t *size)
{
    if (!rg)
        return envl__fail(ENVL_ERR_ARGUMENT, "brdf-lut: NULL output");
    *rg = NULL;
    envl_brdf_options o;
    envl_result rc = envl__brdf_resolve(options, &o);
    if (rc)
        return rc;
    int32_t s = o.size, n = o.samples;
    float *t = malloc(sizeof(float) * 2 * (size_t)s * s);
    if (!t)
        return envl__fail(ENVL_ERR_MEMORY, "brdf-lut: cannot allocate %d x %d", (int)s, (int)s);
    lut_job job = {s, n, o.multiscatter, t};
    envl__parallel_for(s, o.threads, lut_rows, &job);
    *rg = t;
    if (size)
        *size = s;
    return ENVL_OK;
}
