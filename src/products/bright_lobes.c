/* The split of a map's bright pixels for the prefiltered levels, the GGX lobe's norm and sun
 * lights added to P(R) or E(n).
 *
 * The bright pixels (sun_split.c) matter to the prefiltered maps only with options.sun_lights:
 * the groups that are suns become lights (envl__sun_split_lights) and the levels filter the
 * map less what they took (cells.c; the other split pixels stay in it as they are). Without
 * sun lights the levels filter the map itself: its cell pyramid keeps each cell's luminance
 * centroid, so a sun sits where it is at every level. */
#include "prefilter_impl.h"
#include "ggx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void envl__split_free(split *s)
{
    envl__sun_split_free(&s->sun);
    envl__cells_free(s->cells);
    free(s->cells_px);
    memset(s, 0, sizeof *s);
}

envl_result envl__split_make(const envl_envmap *m, split *s)
{
    memset(s, 0, sizeof *s);
    return envl__sun_split_lobes(m, &s->sun); /* no residual copy: request.c makes its own */
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
