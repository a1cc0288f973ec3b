/* Rotating real SH coefficients, and the output frames every export can be written in
 * (docs/design.md, "Canonical frame"). */
#include "internal.h"
#include "sh_basis.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *frame_names[ENVL_FRAME_COUNT] = {"blender", "gltf"};

const char *envl_frame_name(int32_t frame)
{
    return frame >= 0 && frame < ENVL_FRAME_COUNT ? frame_names[frame] : NULL;
}

int32_t envl_frame_from_name(const char *name)
{
    for (int32_t i = 0; name && i < ENVL_FRAME_COUNT; i++)
        if (!strcmp(name, frame_names[i]))
            return i;
    return -1;
}

/* The frame's rotation of canonical vectors: glTF's is Blender's glTF exporter's,
 * (x, y, z) -> (x, z, -y). */
static void frame_matrix(int32_t frame, double R[9])
{
    static const double id[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, gltf[9] = {1, 0, 0, 0, 0, 1, 0, -1, 0};
    memcpy(R, frame == ENVL_FRAME_GLTF ? gltf : id, sizeof id);
}

void envl_frame_vector(int32_t frame, const double in[3], double out[3])
{
    double R[9], v[3];
    frame_matrix(frame, R);
    for (int i = 0; i < 3; i++)
        v[i] = R[3 * i] * in[0] + R[3 * i + 1] * in[1] + R[3 * i + 2] * in[2];
    memcpy(out, v, sizeof v);
}

/* Gauss-Legendre nodes x and weights w on [-1, 1] (n points: exact for polynomials of degree
 * 2n - 1), by Newton's method on P_n from x = cos(pi (i + 0.75) / (n + 0.5)) (Numerical
 * Recipes, gauleg). */
static void gauss_legendre(int32_t n, double *x, double *w)
{
    for (int32_t i = 0; i < n; i++) {
        double z = cos(ENVL_PI * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; it++) {
            double p0 = 1, p1 = 0;
            for (int32_t k = 1; k <= n; k++) { /* P_k by the three-term recurrence */
                double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * k - 1) * z * p1 - (k - 1.0) * p2) / k;
            }
            dp = n * (z * p0 - p1) / (z * z - 1);
            double dz = p0 / dp;
            z -= dz;
            if (fabs(dz) < 1e-16)
                break;
        }
        x[i] = z;
        w[i] = 2 / ((1 - z * z) * dp * dp);
    }
}

/* out = the coefficients of f(R^T d) given those of f (the function turned by R). For each band
 * l, c'_m = sum_m' D_mm' c_m', D_mm' = integral of Y_lm(R e) Y_lm'(e) over the sphere: the
 * integrand is a polynomial of degree 2 L, summed exactly by L + 1 Gauss-Legendre nodes in z
 * times 2 L + 2 equally spaced azimuths (exact for degree 2 L + 1). */
envl_result envl__sh_rotate(int32_t order, const double R[9], int32_t channels, const double *in,
                            double *out)
{
    int32_t L = order, n = envl_sh_count(L), nz = L + 1, na = 2 * L + 2;
    size_t band_mem = 0;
    for (int32_t l = 0; l <= L; l++)
        band_mem += (size_t)(2 * l + 1) * (2 * l + 1);
    double *x = malloc(sizeof(double) * nz), *w = malloc(sizeof(double) * nz);
    double *y = malloc(sizeof(double) * n), *yr = malloc(sizeof(double) * n);
    double *D = calloc(band_mem ? band_mem : 1, sizeof(double));
    double *tmp = malloc(sizeof(double) * n * channels);
    if (!x || !w || !y || !yr || !D || !tmp) {
        free(x), free(w), free(y), free(yr), free(D), free(tmp);
        return envl__fail(ENVL_ERR_MEMORY, "SH rotation: out of memory");
    }
    gauss_legendre(nz, x, w);
    for (int32_t i = 0; i < nz; i++)
        for (int32_t a = 0; a < na; a++) {
            double phi = 2 * ENVL_PI * a / na, r = sqrt(fmax(0.0, 1 - x[i] * x[i]));
            double e[3] = {r * cos(phi), r * sin(phi), x[i]}, re[3];
            for (int k = 0; k < 3; k++)
                re[k] = R[3 * k] * e[0] + R[3 * k + 1] * e[1] + R[3 * k + 2] * e[2];
            envl_sh_eval(L, e, y);
            envl_sh_eval(L, re, yr);
            double wq = w[i] * 2 * ENVL_PI / na;
            size_t at = 0;
            for (int32_t l = 0; l <= L; l++) {
                int32_t b = l * l, k = 2 * l + 1;
                for (int32_t m = 0; m < k; m++)
                    for (int32_t mp = 0; mp < k; mp++)
                        D[at + (size_t)m * k + mp] += wq * yr[b + m] * y[b + mp];
                at += (size_t)k * k;
            }
        }
    size_t at = 0;
    for (int32_t l = 0; l <= L; l++) {
        int32_t b = l * l, k = 2 * l + 1;
        for (int32_t m = 0; m < k; m++)
            for (int32_t ch = 0; ch < channels; ch++) {
                double s = 0;
                for (int32_t mp = 0; mp < k; mp++)
                    s += D[at + (size_t)m * k + mp] * in[(size_t)(b + mp) * channels + ch];
                tmp[(size_t)(b + m) * channels + ch] = s;
            }
        at += (size_t)k * k;
    }
    memcpy(out, tmp, sizeof(double) * n * channels); /* out may be in */
    free(x), free(w), free(y), free(yr), free(D), free(tmp);
    return ENVL_OK;
}

envl_result envl_sh_to_frame(int32_t frame, int32_t order, int32_t channels, const double *in,
                             double *out)
{
    if (!envl_frame_name(frame) || order < 0 || order > ENVL_MAX_SH_ORDER || channels < 1 ||
        !in || !out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_sh_to_frame: bad arguments");
    double R[9];
    frame_matrix(frame, R);
    return envl__sh_rotate(order, R, channels, in, out);
}
