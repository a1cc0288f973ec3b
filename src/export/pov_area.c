/* The shape of a dome light's shadow: the spread of the sky region it stands for
 * (docs/methods.md, "POV-Ray", "Soft shadows").
 *
 * A light that stands for a region of the sky casts, as a point, one hard shadow where the
 * region casts a penumbra as wide as itself; 32 of them draw a dome's shadow as rings. So the
 * light is placed as an n x n grid of `parallel` lights (envlight.inc, EnvLight_Area_Light)
 * along the directions normalize(l + s A1 + t A2), s, t on n points of [-1/2, 1/2], each of
 * 1/n^2 of its colour: in the gnomonic coordinates (u, v) = (d . e1, d . e2) / (d . l) of a
 * direction d about the light's direction l, a uniform grid. The grid is given the region's
 * second moments about l, E[(u, v)(u, v)^T] weighted by luminance x solid angle, along the
 * principal axes of that 2 x 2 matrix: an n-point grid over [-w/2, w/2] has variance
 * w^2 (n + 1) / (12 (n - 1)), so w = sigma sqrt(12 (n - 1) / (n + 1)). (A POV-Ray area_light
 * with those axes casts the same shadows, but lights with the cosine at its centre, or with
 * area_illumination multiplies each sample's cosine by the whole grid's visibility, so the
 * samples below a surface's own horizon count twice: -1.7 % on a lone sphere, where the grid
 * of lights is within 0.24 %, docs/pov_scenes.md.)
 *
 * The light's colour. Each of the grid's lights gives colour / n^2 max(0, n . s_k), s_k its
 * unit direction. A normal that sees the whole region gets n . M from the sky, M = sum L d dw;
 * from the grid colour x n . mean(s_k). Both are along l (l the luminance centroid, the grid
 * symmetric about it), so the colour is rgb_c x r_c / r_grid, r_c = (M_c . l) / P_c the
 * region's mean resultant (P_c = rgb_c, its power), r_grid = mean(s_k) . l: exact for every
 * normal that sees the whole region, and the clamped cosines of the grid follow the region
 * past a normal's horizon (unoccluded diffuse error 0.6 % with 32 lights on lebombo, where
 * points of the region's power are 2.5 %). A point (a sun, a region too small for a grid, or
 * shrunk to nothing at the horizon) is the n = 1 case: rgb_c x r_c, exact for the normals that
 * see its whole region.
 */
#include "pov_light.h"
#include "envmap_impl.h"

#include <math.h>
#include <string.h>

/* A grid's corner may come no closer to the horizon than this (radians): the plane a scene
 * stands on would shadow it. */
#define HORIZON_MARGIN 0.005
/* The widest grid, gnomonic units (2 tan 40 degrees): a flat area light cannot stand for more. */
#define MAX_WIDTH 1.678

static double lum3(const double c[3]) { return envl_luminance(c[0], c[1], c[2]); }

/* e1 horizontal (up x l), e2 = l x e1; about the pole, e1 = x. */
static void tangents(const double l[3], double e1[3], double e2[3])
{
    double h = sqrt(l[0] * l[0] + l[1] * l[1]);
    if (h > 1e-9) {
        e1[0] = -l[1] / h, e1[1] = l[0] / h, e1[2] = 0;
    } else {
        e1[0] = 1, e1[1] = 0, e1[2] = 0;
    }
    e2[0] = l[1] * e1[2] - l[2] * e1[1];
    e2[1] = l[2] * e1[0] - l[0] * e1[2];
    e2[2] = l[0] * e1[1] - l[1] * e1[0];
}

void pov_area_shape(const envl_envmap *m, double sun_threshold, pov_light *p)
{
    const double *l = p->l.direction;
    double e1[3], e2[3];
    tangents(l, e1, e2);
    int32_t w = m->width, x0 = p->l.rect[0], x1 = p->l.rect[2];
    int32_t y0 = p->l.rect[1] < 0 ? 0 : p->l.rect[1], y1 = p->l.rect[3] > m->height ? m->height : p->l.rect[3];
    envl__window_rows(m, &y0, &y1);
    /* one local per sum (not arrays): they stay in registers, a third of the instructions
     * of an 8K map's `pov`; each summed in the same order as one pass */
    double p0 = 0, p1 = 0, p2 = 0, a0 = 0, a1 = 0, a2 = 0, m0 = 0, m1 = 0, m2 = 0, weight = 0;
    for (int32_t r = y0; r < y1; r++) {
        double dw = m->row_omega[r], rc = m->row_cos[r], z = m->row_sin[r];
        int32_t c = x0 % w;
        const float *row = m->px + 3 * (size_t)w * r;
        for (int32_t x = x0; x < x1; x++, c = c + 1 == w ? 0 : c + 1) {
            const float *px = row + 3 * (size_t)c;
            double y = envl__lum(px[0], px[1], px[2]);
            /* a sun is its excess over the split's threshold (sun_split.c) */
            double keep = sun_threshold > 0 ? (y > sun_threshold ? 1 - sun_threshold / y : 0) : 1;
            if (!(keep > 0))
                continue;
            double d[3] = {rc * m->col_cos[c], rc * m->col_sin[c], z};
            double t = d[0] * l[0] + d[1] * l[1] + d[2] * l[2];
            double k0 = keep * px[0] * dw, k1 = keep * px[1] * dw, k2 = keep * px[2] * dw;
            p0 += k0, p1 += k1, p2 += k2;
            a0 += k0 * t, a1 += k1 * t, a2 += k2 * t;
            double wy = keep * y * dw;
            if (t > 0.1) { /* within 84 degrees: gnomonic coordinates are finite */
                double u = (d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2]) / t;
                double v = (d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2]) / t;
                m0 += wy * u * u, m1 += wy * u * v, m2 += wy * v * v;
            }
            weight += wy;
        }
    }
    double power[3] = {p0, p1, p2}, along[3] = {a0, a1, a2}, mom[3] = {m0, m1, m2};
    for (int ch = 0; ch < 3; ch++)
        p->resultant[ch] = power[ch] > 0 ? fmax(0, along[ch] / power[ch]) : 1;
    memcpy(p->colour, p->l.rgb, sizeof p->colour);
    p->samples = 1;
    memset(p->axis, 0, sizeof p->axis);
    if (!(weight > 0))
        return;
    /* principal axes of [[a, b], [b, c]] */
    double a = mom[0] / weight, b = mom[1] / weight, c = mom[2] / weight;
    double mid = 0.5 * (a + c), half = sqrt(0.25 * (a - c) * (a - c) + b * b);
    double lam[2] = {mid + half, fmax(0, mid - half)};
    double ax = 1, ay = 0; /* eigenvector of lam[0] */
    if (fabs(b) > 1e-300) {
        ax = b, ay = lam[0] - a;
        double n = sqrt(ax * ax + ay * ay);
        ax /= n, ay /= n;
    } else if (c > a) {
        ax = 0, ay = 1;
    }
    /* the axes scaled by the standard deviations; pov_area_samples turns them into widths */
    for (int k = 0; k < 3; k++) {
        p->axis[0][k] = sqrt(lam[0]) * (ax * e1[k] + ay * e2[k]);
        p->axis[1][k] = sqrt(lam[1]) * (-ay * e1[k] + ax * e2[k]);
    }
}

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* Shrinks the grid so that its corners stay on the light's side of the horizon: the corner
 * l + s A1 + t A2 (s, t = +-1/2) lowest in z is l_z - (|A1_z| + |A2_z|) / 2. */
static void keep_side(pov_light *p)
{
    double sign = p->side == POV_SIDE_UP ? 1 : p->side == POV_SIDE_DOWN ? -1 : 0;
    if (sign == 0)
        return;
    double lz = sign * p->l.direction[2];
    double reach = 0.5 * (fabs(p->axis[0][2]) + fabs(p->axis[1][2]));
    double room = lz - sin(HORIZON_MARGIN);
    if (reach <= room)
        return;
    double k = room > 0 && reach > 0 ? room / reach : 0;
    for (int j = 0; j < 2; j++)
        for (int c = 0; c < 3; c++)
            p->axis[j][c] *= k;
}

/* The grid's unit direction (i, j) of n x n. */
static void grid_direction(const pov_light *p, int i, int j, double d[3])
{
    double s = p->samples > 1 ? (double)i / (p->samples - 1) - 0.5 : 0;
    double t = p->samples > 1 ? (double)j / (p->samples - 1) - 0.5 : 0;
    for (int c = 0; c < 3; c++)
        d[c] = p->l.direction[c] + s * p->axis[0][c] + t * p->axis[1][c];
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int c = 0; c < 3; c++)
        d[c] /= len;
}

void pov_light_irradiance(const pov_light *p, const double n[3], double out[3])
{
    double sum = 0;
    for (int i = 0; i < p->samples; i++)
        for (int j = 0; j < p->samples; j++) {
            double d[3];
            grid_direction(p, i, j, d);
            sum += fmax(0, n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
        }
    sum /= (double)p->samples * p->samples;
    for (int c = 0; c < 3; c++)
        out[c] = p->colour[c] * sum;
}

void pov_area_samples(pov_light *lights, int32_t count)
{
    double total = 0;
    for (int32_t j = 0; j < count; j++)
        total += lum3(lights[j].l.rgb);
    for (int32_t j = 0; j < count; j++) {
        pov_light *p = lights + j;
        double share = total > 0 ? lum3(p->l.rgb) / total : 0;
        int n = (int)ceil(sqrt(share / POV_AREA_STEP) - 1e-9);
        n = n < 2 ? 2 : n > POV_AREA_MAX_SAMPLES ? POV_AREA_MAX_SAMPLES : n;
        double sigma[2] = {norm3(p->axis[0]), norm3(p->axis[1])};
        /* no closer than POV_AREA_MIN_SPACING along the wider axis: a sun's grid of a degree
         * needs no 4 x 4 */
        while (n > 2 && sigma[0] * sqrt(12.0 * (n - 1) / (n + 1)) / (n - 1) < POV_AREA_MIN_SPACING)
            n--;
        if (sqrt(12.0) * sigma[0] < POV_AREA_MIN_WIDTH)
            n = 1;
        p->samples = n;
        for (int k = 0; k < 2; k++) {
            double width = n > 1 ? sigma[k] * sqrt(12.0 * (n - 1) / (n + 1)) : 0;
            width = fmin(width, MAX_WIDTH);
            double s = sigma[k] > 0 ? width / sigma[k] : 0;
            for (int c = 0; c < 3; c++)
                p->axis[k][c] *= s;
        }
        keep_side(p);
        if (norm3(p->axis[0]) < POV_AREA_MIN_WIDTH) { /* a point along l: r_grid = 1 */
            p->samples = 1;
            memset(p->axis, 0, sizeof p->axis);
            for (int c = 0; c < 3; c++)
                p->colour[c] = p->l.rgb[c] * p->resultant[c];
            continue;
        }
        double grid = 0; /* r_grid: the grid's mean direction along l */
        for (int a = 0; a < n; a++)
            for (int b = 0; b < n; b++) {
                double d[3];
                grid_direction(p, a, b, d);
                grid += d[0] * p->l.direction[0] + d[1] * p->l.direction[1] +
                        d[2] * p->l.direction[2];
            }
        grid /= (double)n * n;
        for (int c = 0; c < 3; c++)
            p->colour[c] = p->l.rgb[c] * p->resultant[c] / grid;
    }
}
