/* Bright pixels as point lobes in the specular levels, and sun lights added to P(R) or E(n). */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- bright pixels as point lobes ----
 * Before sampling, the bright pixels are split off the map (sun_split.c): the residual keeps
 * each pixel above T (SPLIT_K x the map's mean luminance, or raised) scaled to luminance T, and
 * the excess E_j (per channel) is a point lobe at the pixel's centre direction l_j. The
 * residual is filtered as any map (its own pyramid, not the map's cached one) and the lobes are
 * added analytically:
 *   P(R) += sum_j E_j w(R.l_j) / N(alpha),  w(u) = u / q^2,  q = ((1 + u) / 2)(a^2 - 1) + 1,
 * (D(h) R.l up to a constant, as the reference sums it), N(alpha) = integral of w over the
 * sphere = 2 pi int_0^1 u / (A + B u)^2 du = (2 pi / B^2)(ln(a^2 / A) + A / a^2 - 1) with
 * A = (1 + a^2) / 2, B = (a^2 - 1) / 2 (pi at a = 1). Lobes closer than SPLIT_CLUSTER alpha
 * (same cell of a lat-long grid that fine) are merged at their energy-weighted centroid; where
 * an output texel is wider than 2 alpha the lobe is averaged over the texel (supersampled).
 * Both parts are energy-scaled separately (the residual like any level; the lobes to sum E).
 * With options.sun_lights the groups of split pixels that are suns become lights
 * (envl__sun_split_lights) and are not baked. */
#define SPLIT_CLUSTER 0.1

typedef envl_sun_lobe lobe;

void envl__split_free(split *s)
{
    envl__sun_split_free(&s->sun);
    free(s->mip);
    memset(s, 0, sizeof *s);
}

/* The map's split and, when anything was split, the pyramid of its residual. */
envl_result envl__split_make(const envl_envmap *m, split *s)
{
    memset(s, 0, sizeof *s);
    envl_result rc = envl__sun_split_make(m, &s->sun);
    if (rc || s->sun.n == 0)
        return rc;
    rc = envl__build_pyramid(s->sun.res, m->width, m->height, &s->mip, &s->levels, s->mw, s->mh,
                       s->off);
    if (rc)
        envl__split_free(s);
    return rc;
}

/* N(alpha): the integral of w over the sphere. */
double envl_ggx_lobe_norm(double alpha)
{
    double a2 = alpha * alpha;
    double A = 0.5 * (1 + a2), B = 0.5 * (a2 - 1), x = B / A;
    if (fabs(x) < 1e-3) /* ln(1+x) + 1/(1+x) - 1 = x^2/2 - 2x^3/3 + 3x^4/4 - ... */
        return 2 * ENVL_PI / (A * A) * (0.5 - 2 * x / 3 + 0.75 * x * x - 0.8 * x * x * x);
    return 2 * ENVL_PI / (B * B) * (log(a2 / A) + A / a2 - 1);
}


typedef struct lobe_job {
    const envl_sun_lobe *l;
    int32_t n, w, h, ss;
    double a2, inv_norm;
    float *out;               /* w x h x 3, the lobes' part (overwritten) */
} lobe_job;

static void lobe_rows(void *ctx, int64_t begin, int64_t end)
{
    lobe_job *j = ctx;
    int32_t ss = j->ss;
    for (int64_t r = begin; r < end; r++)
        for (int32_t c = 0; c < j->w; c++) {
            double acc[3] = {0, 0, 0}, wt = 0;
            for (int32_t sy = 0; sy < ss; sy++)
                for (int32_t sx = 0; sx < ss; sx++) {
                    double R[3];
                    envl_latlong_direction(j->w, j->h, c + (sx + 0.5) / ss - 0.5,
                                           r + (sy + 0.5) / ss - 0.5, R);
                    double sw = ss > 1 ? sqrt(fmax(0.0, 1 - R[2] * R[2])) : 1.0;
                    wt += sw;
                    for (int32_t i = 0; i < j->n; i++) {
                        const envl_sun_lobe *l = j->l + i;
                        double u = R[0] * l->d[0] + R[1] * l->d[1] + R[2] * l->d[2];
                        if (u <= 0)
                            continue;
                        double v = sw * ggx_w(u, j->a2);
                        acc[0] += v * l->e[0], acc[1] += v * l->e[1], acc[2] += v * l->e[2];
                    }
                }
            float *o = j->out + 3 * ((size_t)r * j->w + c);
            double f = wt > 0 ? j->inv_norm / wt : 0;
            for (int k = 0; k < 3; k++)
                o[k] = (float)(acc[k] * f);
        }
}

typedef struct cluster_key {
    int64_t key;
    int32_t i;
} cluster_key;

static int cmp_key(const void *a, const void *b)
{
    const cluster_key *x = a, *y = b;
    return x->key != y->key ? (x->key < y->key ? -1 : 1) : (x->i > y->i) - (x->i < y->i);
}

/* The lobes' part of a level (w x h, alpha), energy-scaled per channel to sum E. */
envl_result envl__add_lobes(const envl_sun_split *s, int32_t mh, double alpha, int32_t w,
                             int32_t h, int32_t threads, float *px)
{
    /* merge lobes in cells of f x f map pixels, f = the largest power of 2 with
     * f pi / H <= SPLIT_CLUSTER alpha */
    int32_t f = 1;
    while (f < (1 << 20) && 2.0 * f * ENVL_PI / mh <= SPLIT_CLUSTER * alpha)
        f *= 2;
    cluster_key *k = malloc(sizeof(cluster_key) * s->n);
    lobe *cl = calloc((size_t)s->n, sizeof(lobe));
    float *lp = malloc(sizeof(float) * 3 * (size_t)w * h);
    if (!k || !cl || !lp) {
        free(k), free(cl), free(lp);
        return envl__fail(ENVL_ERR_MEMORY, "prefilter: out of memory");
    }
    int32_t nk = 0;
    for (int32_t i = 0; i < s->n; i++)
        if (!s->lobes[i].taken)
            k[nk].key = (int64_t)(s->lobes[i].r / f) * (1 << 30) + s->lobes[i].c / f,
            k[nk++].i = i;
    qsort(k, (size_t)nk, sizeof *k, cmp_key);
    int32_t nc = 0;
    double etot[3] = {0, 0, 0};
    for (int32_t i = 0; i < nk; i++) {
        if (i == 0 || k[i].key != k[i - 1].key)
            nc++;
        lobe *c = cl + nc - 1;
        const envl_sun_lobe *l = s->lobes + k[i].i;
        double y = envl__lum(l->e[0], l->e[1], l->e[2]);
        for (int q = 0; q < 3; q++)
            c->e[q] += l->e[q], c->d[q] += y * l->d[q], etot[q] += l->e[q];
    }
    for (int32_t i = 0; i < nc; i++) {
        double n = sqrt(cl[i].d[0] * cl[i].d[0] + cl[i].d[1] * cl[i].d[1] +
                        cl[i].d[2] * cl[i].d[2]);
        for (int q = 0; q < 3; q++)
            cl[i].d[q] = n > 0 ? cl[i].d[q] / n : 0;
    }
    double texel = ENVL_PI / h;
    int32_t ss = texel > 2 * alpha ? (int32_t)ceil(texel / alpha) : 1;
    ss = ss > 32 ? 32 : ss;
    lobe_job j = {cl, nc, w, h, ss, alpha * alpha, 1.0 / envl_ggx_lobe_norm(alpha), lp};
    envl__parallel_for(h, threads, lobe_rows, &j);
    double eout[3];
    envl__image_energy(lp, w, h, eout);
    for (int q = 0; q < 3; q++) {
        double sc = eout[q] > 0 && etot[q] > 0 ? etot[q] / eout[q] : 1.0;
        for (size_t i = 0; i < (size_t)w * h; i++)
            px[3 * i + q] += (float)(lp[3 * i + q] * sc);
    }
    free(k), free(cl), free(lp);
    return ENVL_OK;
}

/* x, y completing the unit z to a right-handed frame (Duff et al. 2017). */
static void orthonormal_basis(const double z[3], double x[3], double y[3])
{
    double sg = z[2] >= 0 ? 1.0 : -1.0, a = -1.0 / (sg + z[2]), b = z[0] * z[1] * a;
    x[0] = 1 + sg * z[0] * z[0] * a, x[1] = sg * b, x[2] = -sg * z[0];
    y[0] = b, y[1] = sg + z[1] * z[1] * a, y[2] = -z[1];
}

/* Adds what the lights give to P(R) at roughness > 0, or to the irradiance E(n) for roughness
 * < 0, in `count` directions. A light is the uniform disc of its solid angle about its
 * direction (a sun as Cycles draws a sun lamp of that angle), integrated over SUN_DISC points
 * spread uniformly in solid angle (a Fibonacci spiral on the cap): P += E mean w(R.l) / N(alpha),
 * E += E mean max(n.l, 0). */
#define SUN_DISC 256
void envl__sun_lights_add(const envl_light *l, int32_t n, double roughness, int32_t count,
                           const double *dirs, double *out)
{
    double a = roughness * roughness, a2 = a * a;
    double inv = roughness > 0 ? 1.0 / envl_ggx_lobe_norm(a) : 0;
    for (int32_t j = 0; j < n; j++) {
        const double *z = l[j].direction;
        double x[3], y[3];
        orthonormal_basis(z, x, y);
        double cap = fmin(2.0, l[j].solid_angle / (2 * ENVL_PI)); /* 1 - cos(radius) */
        int32_t np = cap > 0 ? SUN_DISC : 1;
        for (int32_t p = 0; p < np; p++) {
            double ct = 1 - cap * (p + 0.5) / np, st = sqrt(fmax(0.0, 1 - ct * ct));
            double ph = p * ENVL_PI * (3 - sqrt(5.0)), cp = cos(ph) * st, sp = sin(ph) * st;
            double d[3];
            for (int k = 0; k < 3; k++)
                d[k] = cp * x[k] + sp * y[k] + ct * z[k];
            for (int32_t i = 0; i < count; i++) {
                const double *R = dirs + 3 * i;
                double u = R[0] * d[0] + R[1] * d[1] + R[2] * d[2];
                if (u <= 0)
                    continue;
                double f = (roughness > 0 ? ggx_w(u, a2) * inv : u) / np;
                for (int k = 0; k < 3; k++)
                    out[3 * i + k] += f * l[j].rgb[k];
            }
        }
    }
}
