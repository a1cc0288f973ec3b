/* `envlight preview`: one picture with the lat-long map (median cut regions outlined, median cut
 * and fitted lights marked) and a grid of spheres: rows = shading (diffuse, glossy at two
 * roughness values, mirror), columns = lighting (exact reference, median cut N, fit K + SH
 * remainder, SH order 2, prefiltered maps), each with its error and seconds under it; a cell
 * whose method does not serve its row (preview_serves) is left empty with a note.
 *
 * Shading (docs/methods.md, "Preview"): the camera is orthographic, looking along -v, v = the horizontal
 * direction of azimuth 45 degrees (between +X and +Y), +Z up on screen.
 *  - diffuse: radiance = E(n) / pi (Lambert, albedo 1), or Oren-Nayar;
 *  - glossy and mirror: the prefiltered radiance of docs/design.md (split sum, N = V = R) at the
 *    reflection direction R = 2 (n.v) n - v, P(R) = sum L w(R.l) dw / sum w(R.l) dw with the
 *    GGX lobe w(u) = u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1, or Blinn-Phong's
 *    w(u) = u ((1 + u) / 2)^(e / 2) (since (n.h)^2 = (1 + R.l) / 2 for h = normalize(R + l)).
 * Part of the library (export layer): envl_preview_write is the public entry. */
#include "preview.h"
#include "clock.h"
#include "ggx.h"
#include "internal.h"
#include "sun_split.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define ON_SIGMA 0.3 /* Oren-Nayar surface roughness (radians) */

void preview_defaults(envl_preview_options *o)
{
    if (o->median_count <= 0)
        o->median_count = 16;
    if (o->fit_count <= 0)
        o->fit_count = 4;
    if (!(o->roughness[0] > 0))
        o->roughness[0] = 0.25;
    if (!(o->roughness[1] > 0))
        o->roughness[1] = 0.5;
    if (o->sphere_size <= 0)
        o->sphere_size = 96;
    if (o->reference_width <= 0)
        o->reference_width = 256;
}

/* ACES filmic, Narkowicz 2015 ("ACES Filmic Tone Mapping Curve"):
 * f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clamped to [0, 1]. */
double preview_aces(double x)
{
    if (!(x > 0))
        return 0;
    double y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    return y < 1 ? y : 1;
}

/* Reinhard et al. 2002, the simple operator: x / (1 + x). */
double preview_reinhard(double x) { return x > 0 ? (isinf(x) ? 1 : x / (1 + x)) : 0; }

static double tone_curve(int32_t tonemap, double x)
{
    return tonemap == ENVL_PREVIEW_TONEMAP_REINHARD ? preview_reinhard(x) : preview_aces(x);
}

double preview_auto_exposure(const envl_envmap *map)
{
    int32_t w = envl_envmap_width(map), h = envl_envmap_height(map);
    const float *px = envl_envmap_pixels(map);
    double s = 0, ws = 0;
    for (int32_t r = 0; r < h; r++) {
        double om = envl_envmap_solid_angle(map, r), rs = 0;
        for (int32_t c = 0; c < w; c++) {
            const float *p = px + 3 * ((size_t)r * w + c);
            rs += log(1e-4 + envl__lum(p[0], p[1], p[2]));
        }
        s += om * rs;
        ws += om * w;
    }
    return log2(0.18 / exp(s / ws));
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Screen axes of the camera: up = +Z made orthogonal to v, right = up x v. */
static void camera_axes(const double v[3], double right[3], double up[3])
{
    double z[3] = {0, 0, 1}, d = dot3(z, v), len;
    for (int k = 0; k < 3; k++)
        up[k] = z[k] - d * v[k];
    len = sqrt(dot3(up, up));
    for (int k = 0; k < 3; k++)
        up[k] /= len;
    right[0] = up[1] * v[2] - up[2] * v[1];
    right[1] = up[2] * v[0] - up[0] * v[2];
    right[2] = up[0] * v[1] - up[1] * v[0];
}

int preview_sphere_normal(int32_t size, const double v[3], int32_t i, int32_t j, double n[3])
{
    double sx = 2.0 * (i + 0.5) / size - 1, sy = 1 - 2.0 * (j + 0.5) / size;
    double s2 = sx * sx + sy * sy;
    if (s2 >= 1)
        return 0;
    double right[3], up[3], sz = sqrt(1 - s2);
    camera_axes(v, right, up);
    for (int k = 0; k < 3; k++)
        n[k] = sx * right[k] + sy * up[k] + sz * v[k];
    return 1;
}

/* ---- layout ---------------------------------------------------------------------------- */
#define MARGIN 8
#define LABEL_W 80
#define TITLE_H 18
#define CELL_PAD 24  /* a cell is sphere + 24 wide */
#define CELL_TEXT 28 /* and sphere + 28 high (two text lines) */

typedef struct layout {
    int32_t w, h, map_w, map_h, legend_y, header_y, cells_y, cell_w, cell_h;
} layout;

static layout get_layout(int32_t s)
{
    layout l;
    l.cell_w = s + CELL_PAD;
    l.cell_h = s + CELL_TEXT;
    l.w = LABEL_W + PREVIEW_COLS * l.cell_w + MARGIN;
    l.map_w = (l.w - 2 * MARGIN) & ~1;
    l.map_h = l.map_w / 2;
    l.legend_y = TITLE_H + l.map_h + 6;
    l.header_y = l.legend_y + 14;
    l.cells_y = l.header_y + 24;
    l.h = l.cells_y + PREVIEW_ROWS * l.cell_h + 4;
    return l;
}

void preview_layout(int32_t size, int32_t *width, int32_t *height)
{
    layout l = get_layout(size);
    *width = l.w;
    *height = l.h;
}

void preview_sphere_origin(int32_t size, int32_t row, int32_t col, int32_t *x, int32_t *y)
{
    layout l = get_layout(size);
    *x = LABEL_W + col * l.cell_w + CELL_PAD / 2;
    *y = l.cells_y + row * l.cell_h;
}

/* ---- shading models ---------------------------------------------------------------------- */

/* Oren-Nayar 1994 (qualitative model), albedo 1, times the cosine:
 *   f cos = max(0, n.l) (A + B max(0, cos(phi_i - phi_r)) sin(a) tan(b)) / pi,
 *   A = 1 - 0.5 s^2 / (s^2 + 0.33), B = 0.45 s^2 / (s^2 + 0.09), a = max(t_i, t_r),
 *   b = min(t_i, t_r). (sigma = 0: Lambert.) */
static double oren_nayar(const double n[3], const double v[3], const double l[3])
{
    const double s2 = ON_SIGMA * ON_SIGMA, A = 1 - 0.5 * s2 / (s2 + 0.33),
                 B = 0.45 * s2 / (s2 + 0.09);
    double ci = dot3(n, l), cr = dot3(n, v);
    if (ci <= 0)
        return 0;
    cr = cr > 1e-6 ? cr : 1e-6;
    double si = sqrt(fmax(0, 1 - ci * ci)), sr = sqrt(fmax(0, 1 - cr * cr));
    double cphi = 0;
    if (si > 1e-9 && sr > 1e-9) /* cos(phi_i - phi_r) of l and v projected on the plane */
        cphi = (dot3(l, v) - ci * cr) / (si * sr);
    double sa_tb = ci < cr ? si * sr / cr : sr * si / ci; /* sin(max) tan(min) */
    return ci * (A + B * fmax(0, cphi) * sa_tb) / ENVL_PI;
}

typedef struct lobe {
    int specular;
    double a2, e; /* GGX alpha^2; Blinn-Phong exponent */
    double norm;  /* integral of w over the sphere */
} lobe;

/* w(u), u = R.l: GGX's from ggx.h (the prefilter's), Blinn-Phong's u ((1 + u) / 2)^(e / 2)
 * ((n.h)^2 = (1 + u) / 2), 0 for u <= 0. */
static double lobe_w(const lobe *b, double u)
{
    if (u <= 0)
        return 0;
    if (b->specular == ENVL_PREVIEW_SPECULAR_GGX)
        return ggx_w(u, b->a2);
    return u * pow(0.5 * (1 + u), 0.5 * b->e);
}

/* Blinn-Phong exponent matching GGX alpha: e = 2 / alpha^2 - 2 (Walter et al. 2007). The norm:
 * GGX's closed form (the prefilter's, envl_ggx_lobe_norm); Blinn-Phong's 2 pi int_0^1 w(u) du by
 * the midpoint rule in s, u = 1 - s^2 (du = 2 s ds), which resolves the peak at u = 1 (its
 * width in s is ~alpha) for alpha >= 0.0025. */
static lobe make_lobe(int specular, double roughness)
{
    lobe b = {specular, 0, 0, 0};
    double alpha = roughness * roughness;
    b.a2 = alpha * alpha;
    b.e = 2 / b.a2 - 2;
    if (specular != ENVL_PREVIEW_SPECULAR_BLINN_PHONG) {
        b.norm = envl_ggx_lobe_norm(alpha);
        return b;
    }
    const int n = 20000;
    double s = 0;
    for (int i = 0; i < n; i++) {
        double t = (i + 0.5) / n;
        s += lobe_w(&b, 1 - t * t) * 2 * t;
    }
    b.norm = 2 * ENVL_PI * s / n;
    return b;
}

/* ---- the grid ------------------------------------------------------------------------------- */

typedef struct pixels {
    int32_t count;
    int32_t *index;   /* sphere pixel j * size + i of each */
    double *n, *r;    /* normals, reflection directions */
    double *r16;      /* mirror: 4 x 4 reflection directions inside each pixel */
    int32_t *slot;    /* size x size: the pixel's place in the lists, -1 outside */
} pixels;

static envl_result make_pixels(int32_t size, const double v[3], pixels *p)
{
    memset(p, 0, sizeof *p);
    size_t cap = (size_t)size * size;
    p->index = malloc(sizeof(int32_t) * cap);
    p->n = malloc(sizeof(double) * 3 * cap);
    p->r = malloc(sizeof(double) * 3 * cap);
    p->r16 = malloc(sizeof(double) * 48 * cap);
    p->slot = malloc(sizeof(int32_t) * cap);
    if (!p->index || !p->n || !p->r || !p->r16 || !p->slot)
        return ENVL_ERR_MEMORY;
    for (size_t i = 0; i < cap; i++)
        p->slot[i] = -1;
    for (int32_t j = 0; j < size; j++)
        for (int32_t i = 0; i < size; i++) {
            double *n = p->n + 3 * p->count, *r = p->r + 3 * p->count;
            if (!preview_sphere_normal(size, v, i, j, n))
                continue;
            double nv = dot3(n, v);
            for (int k = 0; k < 3; k++)
                r[k] = 2 * nv * n[k] - v[k];
            /* sub-pixel (a, b) of 4 x 4: the normal at its centre (clamped into the disc) */
            for (int b = 0; b < 4; b++)
                for (int a = 0; a < 4; a++) {
                    double sx = 2.0 * (i + (a + 0.5) / 4) / size - 1;
                    double sy = 1 - 2.0 * (j + (b + 0.5) / 4) / size;
                    double s2 = sx * sx + sy * sy, f = s2 > 0.999 ? sqrt(0.999 / s2) : 1;
                    double right[3], up[3], m[3], sz = sqrt(fmax(0, 1 - s2 * f * f));
                    camera_axes(v, right, up);
                    for (int k = 0; k < 3; k++)
                        m[k] = f * (sx * right[k] + sy * up[k]) + sz * v[k];
                    double *q = p->r16 + 48 * (size_t)p->count + 3 * (4 * b + a);
                    double mv = dot3(m, v);
                    for (int k = 0; k < 3; k++)
                        q[k] = 2 * mv * m[k] - v[k];
                }
            p->slot[j * size + i] = p->count;
            p->index[p->count++] = j * size + i;
        }
    return ENVL_OK;
}

static void free_pixels(pixels *p)
{
    free(p->index);
    free(p->n);
    free(p->r);
    free(p->r16);
    free(p->slot);
}

/* Mirror reference: a source of irradiance rgb in direction d smaller than a pixel adds rgb / dW
 * to the pixel that reflects it, dW = 16 / size^2 the solid angle of R a pixel covers
 * (orthographic mirror ball: R turns twice as fast as n, dW/dA = 4 on the unit disc, pixel
 * side 2 / size). */
static void deposit(const pixels *p, int32_t size, const double v[3], const double d[3],
                    const double rgb[3], double *out)
{
    double n[3] = {d[0] + v[0], d[1] + v[1], d[2] + v[2]}, len = sqrt(dot3(n, n));
    if (!(len > 1e-9))
        return;
    double right[3], up[3];
    camera_axes(v, right, up);
    double sx = dot3(n, right) / len, sy = dot3(n, up) / len;
    int32_t i = (int32_t)floor((sx + 1) / 2 * size), j = (int32_t)floor((1 - sy) / 2 * size);
    if (i < 0 || j < 0 || i >= size || j >= size || p->slot[j * size + i] < 0)
        return;
    double dw = 16.0 / ((double)size * size);
    for (int k = 0; k < 3; k++)
        out[3 * p->slot[j * size + i] + k] += rgb[k] / dw;
}

/* The mirror row: mean of the 16 sub-pixel values of each pixel, in place into out. */
static void average16(int32_t np, const double *v16, double *out)
{
    for (int32_t i = 0; i < np; i++)
        for (int k = 0; k < 3; k++) {
            double s = 0;
            for (int j = 0; j < 16; j++)
                s += v16[48 * (size_t)i + 3 * j + k];
            out[3 * i + k] = s / 16;
        }
}

/* Brute force over the (resampled) map of sum L dw f(d) for one pixel: Oren-Nayar diffuse
 * (f = on(n, v, d)) or a Blinn-Phong P(R) (f = w(R.d), normalised by the sum of w dw). */
static void brute_force(const envl_envmap *m, const double *dirs, const double v[3],
                        const double n[3], const lobe *b, double out[3])
{
    int32_t w = envl_envmap_width(m), h = envl_envmap_height(m);
    const float *px = envl_envmap_pixels(m);
    double s[3] = {0, 0, 0}, ws = 0;
    for (int32_t r = 0; r < h; r++) {
        double om = envl_envmap_solid_angle(m, r), rs[3] = {0, 0, 0}, rw = 0;
        for (int32_t c = 0; c < w; c++) {
            size_t i = (size_t)r * w + c;
            const double *d = dirs + 3 * i;
            double f = b ? lobe_w(b, dot3(n, d)) : oren_nayar(n, v, d);
            if (f <= 0)
                continue;
            for (int k = 0; k < 3; k++)
                rs[k] += f * px[3 * i + k];
            rw += f;
        }
        for (int k = 0; k < 3; k++)
            s[k] += om * rs[k];
        ws += om * rw;
    }
    for (int k = 0; k < 3; k++)
        out[k] = b ? (ws > 0 ? s[k] / ws : 0) : s[k];
}

/* The reference's split is the library's (sun_split.c, as the prefilter's): the pixels above
 * T = 50 x the mean luminance (at most 4096, T raised if needed) keep luminance T in the
 * residual, and the excess E_j = L_j (1 - T / Y_j) dw_j is an exact point at the pixel's
 * centre l_j. The residual is area-resampled to reference_width (the integral of L dw kept). */
typedef struct split {
    envl_sun_split s;   /* s.n points (s.lobes, row-major) */
    const envl_envmap *map; /* the residual at full size is the map but at the points' pixels */
    envl_envmap *rest;  /* the residual resampled (no full-size copy: the points are patches) */
} split;

static envl_result make_split(const envl_envmap *m, int32_t width, split *sp)
{
    memset(sp, 0, sizeof *sp);
    sp->map = m;
    envl_result rc = envl__sun_split_lobes(m, &sp->s);
    if (rc)
        return rc;
    int32_t w = envl_envmap_width(m), h = envl_envmap_height(m);
    envl_pixel_patch *patch = envl__sun_split_patches(&sp->s);
    if (!patch)
        return envl__fail(ENVL_ERR_MEMORY, "preview: out of memory");
    rc = envl__envmap_resampled_patched(envl_envmap_pixels(m), w, h, patch, sp->s.n,
                                        w > width ? width : w, 0, &sp->rest);
    free(patch);
    return rc;
}

/* The residual's pixel (r, c) at full size: a point's kept value, else the map's. */
static const float *residual_pixel(const split *sp, int32_t r, int32_t c)
{
    int32_t lo = 0, hi = sp->s.n; /* the lobes are in row-major order */
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        const envl_sun_lobe *l = sp->s.lobes + mid;
        if (l->r < r || (l->r == r && l->c < c))
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo < sp->s.n && sp->s.lobes[lo].r == r && sp->s.lobes[lo].c == c)
        return sp->s.lobes[lo].keep;
    return envl_envmap_pixels(sp->map) + 3 * ((size_t)r * envl_envmap_width(sp->map) + c);
}

static void free_split(split *sp)
{
    envl__sun_split_free(&sp->s);
    envl_envmap_free(sp->rest);
}

/* Adds the points: E_j f(l_j), f(d) = max(0, n.d) / pi (Lambert), on(n, v, d), or
 * w(R.d) / norm (the lobe's integral: the point's E spread as the lobe). */
static void add_points(const split *sp, int model, const lobe *b, const double v[3],
                       const double x[3], double out[3])
{
    for (int32_t i = 0; i < sp->s.n; i++) {
        const envl_sun_lobe *l = sp->s.lobes + i;
        double f = model == 0 ? fmax(0, dot3(x, l->d)) / ENVL_PI
                   : model == 1 ? oren_nayar(x, v, l->d) : lobe_w(b, dot3(x, l->d)) / b->norm;
        for (int k = 0; k < 3; k++)
            out[k] += f * l->e[k];
    }
}

static double *map_dirs(const envl_envmap *m)
{
    int32_t w = envl_envmap_width(m), h = envl_envmap_height(m);
    double *d = malloc(sizeof(double) * 3 * (size_t)w * h);
    if (d)
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++)
                envl_envmap_direction(m, c, r, d + 3 * ((size_t)r * w + c));
    return d;
}

/* Radiance of the fit's SH remainder at d: irradiance coefficients / A_l (order <= 2 is far
 * smoother than the glossy lobes, so no lobe convolution is applied). */
static void remainder_radiance(const envl_lights *l, const double d[3], double out[3])
{
    int32_t order;
    const double *irr = envl_lights_remainder(l, &order);
    out[0] = out[1] = out[2] = 0;
    if (!irr || order < 0 || order > 32)
        return;
    double y[(32 + 1) * (32 + 1)];
    envl_sh_basis(order, d, y);
    for (int32_t li = 0, i = 0; li <= order; li++) {
        double a = envl_sh_cosine_lobe(li);
        for (int32_t m = -li; m <= li; m++, i++)
            if (a != 0)
                for (int k = 0; k < 3; k++)
                    out[k] += irr[3 * i + k] / a * y[i];
    }
}

/* Lights (+ remainder) for row `row` (0: Oren-Nayar per light, 1, 2: a glossy lobe per light;
 * lights do not serve the mirror row). */
static void shade_lights(const envl_lights *l, int row, const lobe *b,
                         const double v[3], const double n[3], const double r[3],
                         double out[3])
{
    out[0] = out[1] = out[2] = 0;
    int32_t count = envl_lights_count(l);
    for (int32_t i = 0; i < count; i++) {
        envl_light li;
        envl_lights_get(l, i, &li);
        double f = 0;
        if (row == 0)
            f = oren_nayar(n, v, li.direction);
        else
            f = lobe_w(b, dot3(r, li.direction)) / b->norm;
        for (int k = 0; k < 3; k++)
            out[k] += f * li.rgb[k];
    }
    double rem[3];
    if (row == 0) { /* the remainder is irradiance only: Lambert */
        double e[3];
        envl_lights_irradiance(l, 1, n, e);
        for (int32_t i = 0; i < count; i++) {
            envl_light li;
            envl_lights_get(l, i, &li);
            double c = fmax(0, dot3(n, li.direction));
            for (int k = 0; k < 3; k++)
                e[k] -= c * li.rgb[k];
        }
        for (int k = 0; k < 3; k++)
            out[k] += e[k] / ENVL_PI;
    } else {
        remainder_radiance(l, r, rem);
        for (int k = 0; k < 3; k++)
            out[k] += rem[k];
    }
}

/* docs/design.md's diffuse error of an irradiance lat-long map (sampled bilinearly). */
static envl_result map_diffuse_error(envl_envmap *m, const float *rgb, int32_t w, int32_t h,
                                     double *err)
{
    const double *ref;
    envl_result rc = envl_envmap_reference_irradiance(m, &ref);
    if (rc)
        return rc;
    double a[3 * ENVL_ERROR_NORMALS];
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++) {
        double d[3];
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, d);
        envl_latlong_sample(rgb, w, h, d, a + 3 * i);
    }
    *err = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, a, ref);
    return ENVL_OK;
}

int preview_serves(int32_t row, int32_t col)
{
    if (row < 0 || row >= PREVIEW_ROWS || col < 0 || col >= PREVIEW_COLS)
        return 0;
    if (col == 1 || col == 2) /* lights */
        return row < 3;
    if (col == 3) /* SH order 2 */
        return row == 0;
    return 1;
}

/* e = sqrt(mean((Ya - Yr)^2)) / mean(Yr) over the disc's pixels, Y = 0.2126 T(s R) + 0.7152
 * T(s G) + 0.0722 T(s B), s = 2^EV, T the tone curve: docs/design.md's formula on the colours the
 * picture shows (display-linear, before the sRGB OETF) instead of radiance.
 * Why on the displayed values: a sun is thousands of times the sky's radiance, and where the
 * approximation's lookup puts part of it one sphere pixel over (the mirror level is the map
 * resampled to 512 and sampled bilinearly; the reference deposits each sun pixel whole), a
 * radiance measure is all sun: rooitou_park's prefiltered mirror, drawn identical to the
 * reference, measured 1516 %. On the screen both pixels are white. */
double preview_picture_error(int32_t tonemap, double exposure_ev, int32_t count,
                             const double *a, const double *r)
{
    const double scale = exp2(exposure_ev);
    double se = 0, sr = 0;
    for (int32_t i = 0; i < count; i++) {
        double ya = envl_luminance(tone_curve(tonemap, scale * a[3 * i]),
                                   tone_curve(tonemap, scale * a[3 * i + 1]),
                                   tone_curve(tonemap, scale * a[3 * i + 2]));
        double yr = envl_luminance(tone_curve(tonemap, scale * r[3 * i]),
                                   tone_curve(tonemap, scale * r[3 * i + 1]),
                                   tone_curve(tonemap, scale * r[3 * i + 2]));
        se += (ya - yr) * (ya - yr);
        sr += yr;
    }
    return count > 0 && sr > 0 ? sqrt(se / count) / (sr / count) : -1;
}

void preview_data_free(preview_data *d)
{
    for (int r = 0; r < PREVIEW_ROWS; r++)
        for (int c = 0; c < PREVIEW_COLS; c++)
            free(d->sphere[r][c]);
    envl_lights_free(d->median);
    envl_lights_free(d->fit);
    memset(d, 0, sizeof *d);
}

/* One line per approximation: its name (with the count), each served row's text as the
 * picture prints it and its seconds, and docs/design.md's diffuse error of the product. */
static void print_notes(FILE *f, const envl_preview_options *o, const preview_data *d)
{
    for (int32_t col = 1; col < PREVIEW_COLS; col++) {
        char h0[32], h1[32], t[32];
        preview_column_head(d, col, 0, h0, sizeof h0);
        preview_column_head(d, col, 1, h1, sizeof h1);
        fprintf(f, "envlight preview: %s %s:", h0, h1);
        for (int32_t row = 0; row < PREVIEW_ROWS; row++) {
            if (!d->served[row][col])
                continue;
            preview_cell_text(o, d, row, col, 0, t, sizeof t);
            if (row == 0)
                fprintf(f, " diffuse %s %.3g s,", t, d->seconds[row][col]);
            else if (row < 3)
                fprintf(f, " glossy %.2f %s %.3g s,", o->roughness[row - 1], t,
                        d->seconds[row][col]);
            else
                fprintf(f, " mirror %s %.3g s,", t, d->seconds[row][col]);
        }
        fprintf(f, " docs/design.md diffuse error %.3f %%\n", 100 * d->diffuse_error[col]);
    }
}

/* What preview_compute's stages share. */
typedef struct work {
    envl_envmap *map;
    envl_preview_options o;
    preview_data *d;
    pixels p;
    split sp;
    lobe lobes[3];            /* per row; the diffuse row's is the first glossy row's */
    double *dirs, *buf, *refv, *buf16;
} work;

/* Sphere (row, col) gets the np values of src (the sphere's pixels in p's order). */
static void store(work *w, int row, int col, const double *src)
{
    for (int32_t q = 0; q < w->p.count; q++)
        for (int ch = 0; ch < 3; ch++)
            w->d->sphere[row][col][3 * w->p.index[q] + ch] = src[3 * q + ch];
}

/* The mirror reference: the full map's pixel that contains R, 16 per sphere pixel, + the
 * points deposited where they reflect. */
static void mirror_reference(work *w)
{
    const pixels *p = &w->p;
    int32_t W = envl_envmap_width(w->map), H = envl_envmap_height(w->map);
    for (int32_t i = 0; i < 16 * p->count; i++) {
        double c, r;
        envl_latlong_pixel(W, H, p->r16 + 3 * i, &c, &r);
        int32_t ci = (int32_t)floor(c + 0.5) % W, ri = (int32_t)floor(r + 0.5);
        ci = ci < 0 ? ci + W : ci;
        ri = ri < 0 ? 0 : ri >= H ? H - 1 : ri;
        const float *px = residual_pixel(&w->sp, ri, ci);
        for (int k = 0; k < 3; k++)
            w->buf16[3 * i + k] = px[k];
    }
    average16(p->count, w->buf16, w->refv);
    for (int32_t i = 0; i < w->sp.s.n; i++)
        deposit(p, w->d->size, w->d->view, w->sp.s.lobes[i].d, w->sp.s.lobes[i].e, w->refv);
}

/* The references (column 0): the residual (resampled) + the points, exact. */
static envl_result references(work *w)
{
    const envl_envmap *rm = w->sp.rest;
    const pixels *p = &w->p;
    const double *v = w->d->view;
    int32_t np = p->count;
    envl_result rc = ENVL_OK;
    for (int row = 0; row < PREVIEW_ROWS && !rc; row++) {
        double t0 = envl__seconds();
        if (row == 0 && w->o.diffuse == ENVL_PREVIEW_DIFFUSE_LAMBERT) {
            rc = envl_irradiance_exact(rm, np, p->n, w->refv);
            for (int32_t i = 0; i < np; i++) {
                for (int k = 0; k < 3; k++)
                    w->refv[3 * i + k] /= ENVL_PI;
                add_points(&w->sp, 0, NULL, v, p->n + 3 * i, w->refv + 3 * i);
            }
        } else if (row == 0) {
            for (int32_t i = 0; i < np; i++) {
                brute_force(rm, w->dirs, v, p->n + 3 * i, NULL, w->refv + 3 * i);
                add_points(&w->sp, 1, NULL, v, p->n + 3 * i, w->refv + 3 * i);
            }
        } else if (row < 3) {
            /* P = (sum over the rest of L w dw + sum over the points of E w) / norm; the
             * rest's own normaliser sum w dw (split pixels included) is norm to within its
             * discretisation, as the lobe is several rest pixels wide */
            if (w->o.specular == ENVL_PREVIEW_SPECULAR_GGX)
                rc = envl_prefilter_reference(rm, w->o.roughness[row - 1], np, p->r, w->refv);
            else
                for (int32_t i = 0; i < np; i++)
                    brute_force(rm, w->dirs, v, p->r + 3 * i, &w->lobes[row], w->refv + 3 * i);
            for (int32_t i = 0; i < np; i++)
                add_points(&w->sp, 2, &w->lobes[row], v, p->r + 3 * i, w->refv + 3 * i);
        } else {
            mirror_reference(w);
        }
        w->d->seconds[row][0] = envl__seconds() - t0;
        store(w, row, 0, w->refv);
    }
    return rc;
}

/* How far the resampled copy's diffuse reference is from the full map's (docs/design.md). */
static envl_result reference_distance(work *w)
{
    const double *full;
    double e[3 * ENVL_ERROR_NORMALS], fib[3 * ENVL_ERROR_NORMALS];
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, fib + 3 * i);
    envl_result rc = envl_envmap_reference_irradiance(w->map, &full);
    if (!rc)
        rc = envl_irradiance_exact(w->sp.rest, ENVL_ERROR_NORMALS, fib, e);
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS && !rc; i++) {
        double x[3] = {0, 0, 0};
        add_points(&w->sp, 0, NULL, w->d->view, fib + 3 * i, x);
        for (int k = 0; k < 3; k++)
            e[3 * i + k] += ENVL_PI * x[k];
    }
    if (!rc)
        w->d->reference_error = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, e, full);
    return rc;
}

/* Columns 1 and 2: median cut N, fit K + SH remainder; diffuse and glossy rows. */
static envl_result lights_columns(work *w)
{
    preview_data *d = w->d;
    int32_t np = w->p.count;
    for (int col = 1; col <= 2; col++) {
        envl_lights_options lo = {.method = col == 1 ? ENVL_METHOD_MEDIAN : ENVL_METHOD_FIT,
                                  .count = col == 1 ? w->o.median_count : w->o.fit_count,
                                  .measure = 1, .skip_residual = 1}; /* not drawn */
        envl_lights **l = col == 1 ? &d->median : &d->fit;
        envl_result rc = envl_lights_compute(w->map, &lo, l);
        if (rc)
            return rc;
        envl_lights_summary s;
        envl_lights_get_summary(*l, &s);
        *(col == 1 ? &d->median_lights : &d->fit_lights) = envl_lights_count(*l);
        for (int row = 0; row < PREVIEW_ROWS; row++) {
            if (!d->served[row][col])
                continue;
            if (row == 0 && w->o.diffuse == ENVL_PREVIEW_DIFFUSE_LAMBERT) {
                envl_lights_irradiance(*l, np, w->p.n, w->buf);
                for (int32_t i = 0; i < 3 * np; i++)
                    w->buf[i] /= ENVL_PI;
            } else {
                for (int32_t i = 0; i < np; i++)
                    shade_lights(*l, row, &w->lobes[row], d->view, w->p.n + 3 * i,
                                 w->p.r + 3 * i, w->buf + 3 * i);
            }
            store(w, row, col, w->buf);
            d->seconds[row][col] = s.seconds;
        }
        d->diffuse_error[col] = s.diffuse_error;
    }
    return ENVL_OK;
}

/* Column 3: SH order 2, irradiance, so the diffuse row only (Lambert whatever the model). */
static envl_result sh_column(work *w)
{
    envl_sh *sh = NULL;
    envl_result rc = envl_sh_compute(w->map, &(envl_sh_options){.order = 2, .measure = 1}, &sh);
    if (rc)
        return rc;
    envl_sh_summary s;
    envl_sh_get_summary(sh, &s);
    envl_sh_eval_irradiance(sh, w->p.count, w->p.n, w->buf);
    for (int32_t i = 0; i < 3 * w->p.count; i++)
        w->buf[i] /= ENVL_PI;
    store(w, 0, 3, w->buf);
    w->d->seconds[0][3] = s.seconds;
    w->d->diffuse_error[3] = s.diffuse_error;
    envl_sh_free(sh);
    return ENVL_OK;
}

/* Column 4: the prefiltered maps (irradiance map, the two glossy levels, the mirror level). */
static envl_result prefiltered_column(work *w)
{
    preview_data *d = w->d;
    const pixels *p = &w->p;
    int32_t np = p->count;
    envl_products *pre = NULL;
    envl_request q = {.irradiance_map = 1, .mirror = 1, .n_roughness = 2,
                      .roughness = w->o.roughness};
    envl_result rc = envl_compute(w->map, &q, &pre);
    if (rc)
        return rc;
    envl_irradiance_map im;
    envl_products_irradiance(pre, &im);
    for (int32_t i = 0; i < np; i++) {
        envl_latlong_sample(im.rgb, im.width, im.height, p->n + 3 * i, w->buf + 3 * i);
        for (int k = 0; k < 3; k++)
            w->buf[3 * i + k] /= ENVL_PI;
    }
    store(w, 0, 4, w->buf);
    d->seconds[0][4] = im.seconds;
    rc = map_diffuse_error(w->map, im.rgb, im.width, im.height, &d->diffuse_error[4]);
    for (int row = 1; row < PREVIEW_ROWS && !rc; row++) {
        envl_level lv;
        int32_t k = envl_products_find_level(pre, row < 3 ? w->o.roughness[row - 1] : 0);
        if ((rc = envl_products_level(pre, k, &lv)))
            break;
        if (row < 3) {
            for (int32_t i = 0; i < np; i++)
                envl_latlong_sample(lv.rgb, lv.width, lv.height, p->r + 3 * i, w->buf + 3 * i);
        } else {
            for (int32_t i = 0; i < 16 * np; i++)
                envl_latlong_sample(lv.rgb, lv.width, lv.height, p->r16 + 3 * i,
                                    w->buf16 + 3 * i);
            average16(np, w->buf16, w->buf);
        }
        store(w, row, 4, w->buf);
        d->seconds[row][4] = lv.seconds;
    }
    envl_products_free(pre);
    return rc;
}

/* The error under each served sphere: preview_picture_error against the row's reference
 * (the formula is in preview.h). */
static void picture_errors(work *w)
{
    preview_data *d = w->d;
    int32_t np = w->p.count;
    for (int row = 0; row < PREVIEW_ROWS; row++) {
        for (int32_t q = 0; q < np; q++)
            for (int k = 0; k < 3; k++)
                w->refv[3 * q + k] = d->sphere[row][0][3 * w->p.index[q] + k];
        for (int col = 1; col < PREVIEW_COLS; col++) {
            if (!d->served[row][col])
                continue;
            for (int32_t q = 0; q < np; q++)
                for (int k = 0; k < 3; k++)
                    w->buf[3 * q + k] = d->sphere[row][col][3 * w->p.index[q] + k];
            d->error[row][col] = preview_picture_error(w->o.tonemap, d->exposure_ev, np, w->buf,
                                                       w->refv);
        }
    }
}

/* d's spheres, errors and seconds set to their start (every error -1: none yet). */
static envl_result start_data(const envl_preview_options *o, envl_envmap *map, preview_data *d)
{
    memset(d, 0, sizeof *d);
    const int32_t S = o->sphere_size;
    d->size = S;
    d->view[0] = d->view[1] = sqrt(0.5);
    d->exposure_ev = o->exposure_set ? o->exposure_ev : preview_auto_exposure(map);
    for (int c = 0; c < PREVIEW_COLS; c++)
        d->diffuse_error[c] = -1;
    for (int r = 0; r < PREVIEW_ROWS; r++)
        for (int c = 0; c < PREVIEW_COLS; c++) {
            d->error[r][c] = -1;
            d->served[r][c] = preview_serves(r, c);
            d->sphere[r][c] = calloc((size_t)S * S * 3, sizeof(double));
            if (!d->sphere[r][c])
                return ENVL_ERR_MEMORY;
        }
    return ENVL_OK;
}

envl_result preview_compute(envl_envmap *map, const envl_preview_options *opt, FILE *notes,
                            preview_data *d)
{
    work w = {.map = map, .o = *opt, .d = d};
    preview_defaults(&w.o);
    envl_result rc = start_data(&w.o, map, d);
    if (rc)
        return rc;
    rc = make_pixels(d->size, d->view, &w.p);
    int32_t np = w.p.count;
    if (!rc && (!(w.buf = malloc(sizeof(double) * 3 * np)) ||
                !(w.refv = malloc(sizeof(double) * 3 * np)) ||
                !(w.buf16 = malloc(sizeof(double) * 48 * np))))
        rc = ENVL_ERR_MEMORY;
    w.lobes[1] = make_lobe(w.o.specular, w.o.roughness[0]);
    w.lobes[2] = make_lobe(w.o.specular, w.o.roughness[1]);
    w.lobes[0] = w.lobes[1]; /* the diffuse row has no lobe; keeps the table defined */
    if (!rc)
        rc = make_split(map, w.o.reference_width, &w.sp);
    if (!rc && !(w.dirs = map_dirs(w.sp.rest)))
        rc = ENVL_ERR_MEMORY;
    if (!rc)
        rc = references(&w);
    if (!rc)
        rc = reference_distance(&w);
    if (!rc)
        rc = lights_columns(&w);
    if (!rc)
        rc = sh_column(&w);
    if (!rc)
        rc = prefiltered_column(&w);
    if (!rc)
        picture_errors(&w);
    if (!rc && notes) {
        print_notes(notes, &w.o, d);
        fprintf(notes, "envlight preview: references on a %d-wide copy + %d points (diffuse %.4f "
                "%% from the full map, docs/design.md's measure): %.3f, %.3f, %.3f s; mirror "
                "%.3f s\n", envl_envmap_width(w.sp.rest), (int)w.sp.s.n,
                100 * d->reference_error, d->seconds[0][0], d->seconds[1][0], d->seconds[2][0],
                d->seconds[3][0]);
    }
    free_pixels(&w.p);
    free(w.dirs);
    free(w.buf);
    free(w.refv);
    free(w.buf16);
    free_split(&w.sp);
    return rc;
}

/* ---- the picture ------------------------------------------------------------------------ */

typedef struct canvas {
    float *px;
    int32_t w, h;
} canvas;

static void put(canvas *cv, int32_t x, int32_t y, const float c[3])
{
    if (x < 0 || y < 0 || x >= cv->w || y >= cv->h)
        return;
    memcpy(cv->px + 3 * ((size_t)y * cv->w + x), c, 3 * sizeof(float));
}

static int32_t text_width(const char *s) { return 6 * (int32_t)strlen(s) - 1; }

/* Draws s with its top-left corner at (x, y): 5 x 7 glyphs, 6 pixels apart. */
static void text(canvas *cv, int32_t x, int32_t y, const char *s, const float c[3])
{
    for (; *s; s++, x += 6) {
        const unsigned char *g = preview_glyph((unsigned char)*s);
        for (int i = 0; i < 5; i++)
            for (int j = 0; j < 7; j++)
                if (g[i] >> j & 1)
                    put(cv, x + i, y + j, c);
    }
}

static void text_centred(canvas *cv, int32_t cx, int32_t y, const char *s, const float c[3])
{
    text(cv, cx - text_width(s) / 2, y, s, c);
}

static double tone(const envl_preview_options *o, double x) { return tone_curve(o->tonemap, x); }

/* Marks on the map (x wraps around the seam): map pixel (x, y) at canvas (x0 + x, y0 + y). */
typedef struct mapview {
    canvas *cv;
    int32_t x0, y0, w, h;
} mapview;

static void map_put(const mapview *m, int32_t x, int32_t y, const float c[3])
{
    if (y < 0 || y >= m->h)
        return;
    x %= m->w;
    if (x < 0)
        x += m->w;
    put(m->cv, m->x0 + x, m->y0 + y, c);
}

static void marker(const mapview *m, const double dir[3], int32_t radius, int circle,
                   const float c[3])
{
    double fx, fy;
    envl_latlong_pixel(m->w, m->h, dir, &fx, &fy);
    int32_t x = (int32_t)floor(fx + 0.5), y = (int32_t)floor(fy + 0.5);
    if (!circle) {
        for (int32_t t = -radius; t <= radius; t++) {
            map_put(m, x + t, y, c);
            map_put(m, x, y + t, c);
        }
        return;
    }
    int32_t steps = 8 * radius + 8;
    for (int32_t i = 0; i < steps; i++) {
        double a = 2 * ENVL_PI * i / steps;
        map_put(m, x + (int32_t)lround(radius * cos(a)), y + (int32_t)lround(radius * sin(a)),
                c);
    }
}

/* Markers scaled by strength: radius lo + span sqrt(Y / Ymax). */
static void mark_lights(const mapview *m, const envl_lights *l, int circle, const float c[3])
{
    int32_t n = envl_lights_count(l);
    double ymax = 0;
    for (int32_t i = 0; i < n; i++) {
        envl_light li;
        envl_lights_get(l, i, &li);
        ymax = fmax(ymax, envl_luminance(li.rgb[0], li.rgb[1], li.rgb[2]));
    }
    for (int32_t i = 0; i < n && ymax > 0; i++) {
        envl_light li;
        envl_lights_get(l, i, &li);
        double y = envl_luminance(li.rgb[0], li.rgb[1], li.rgb[2]);
        int32_t r = (circle ? 3 : 2) + (int32_t)lround((circle ? 6 : 5) * sqrt(y / ymax));
        marker(m, li.direction, r, circle, c);
    }
}

/* The median cut regions: pixel rectangles of the map scaled to the view. */
static void outline_regions(const mapview *m, const envl_lights *l, int32_t mw, int32_t mh,
                            const float c[3])
{
    int32_t n = envl_lights_count(l);
    double sx = (double)m->w / mw, sy = (double)m->h / mh;
    for (int32_t i = 0; i < n; i++) {
        envl_light li;
        envl_lights_get(l, i, &li);
        int32_t x0 = (int32_t)floor(li.rect[0] * sx), x1 = (int32_t)ceil(li.rect[2] * sx) - 1;
        int32_t y0 = (int32_t)floor(li.rect[1] * sy), y1 = (int32_t)ceil(li.rect[3] * sy) - 1;
        for (int32_t x = x0; x <= x1; x++) {
            map_put(m, x, y0, c);
            map_put(m, x, y1, c);
        }
        for (int32_t y = y0; y <= y1; y++) {
            map_put(m, x0, y, c);
            map_put(m, x1, y, c);
        }
    }
}

void preview_column_head(const preview_data *d, int32_t col, int32_t line, char *s, size_t n)
{
    int32_t k = col == 1 ? d->median_lights : d->fit_lights;
    const char *plural = k == 1 ? "" : "s";
    if (col == 1 && line == 1)
        snprintf(s, n, "%d light%s", (int)k, plural);
    else if (col == 2 && line == 0)
        snprintf(s, n, "fit %d light%s", (int)k, plural);
    else {
        static const char *const heads[PREVIEW_COLS][2] = {
            {"reference", "(exact)"}, {"median cut", ""}, {"", "+ SH order 2"},
            {"SH", "order 2"}, {"prefiltered", "maps"}};
        snprintf(s, n, "%s", col >= 0 && col < PREVIEW_COLS ? heads[col][line != 0] : "");
    }
}

void preview_cell_text(const envl_preview_options *o, const preview_data *d, int32_t row,
                       int32_t col, int32_t line, char *s, size_t n)
{
    double e = d->error[row][col];
    if (col == 0)
        snprintf(s, n, "%s", line ? "" : row == 0 && o->diffuse == ENVL_PREVIEW_DIFFUSE_LAMBERT
                                              ? "exact E/pi" : "brute force");
    else if (!d->served[row][col])
        snprintf(s, n, "%s", col == 3 ? (line ? "diffuse only" : "SH:")
                                      : (line ? "no mirror" : "lights:"));
    else if (line)
        snprintf(s, n, "%s", "");
    else if (!(e >= 0) || !isfinite(e))
        snprintf(s, n, "err n/a");
    else
        snprintf(s, n, e < 0.1 ? "err %.2f%%" : "err %.1f%%", 100 * e);
}

envl_result preview_compose(const envl_envmap *map, const envl_preview_options *opt,
                            const preview_data *d, float **rgb, int32_t *width, int32_t *height)
{
    envl_preview_options o = *opt;
    preview_defaults(&o);
    const int32_t S = d->size;
    layout L = get_layout(S);
    canvas cv = {calloc((size_t)L.w * L.h * 3, sizeof(float)), L.w, L.h};
    if (!cv.px)
        return ENVL_ERR_MEMORY;
    static const float bg[3] = {0.012f, 0.012f, 0.012f}, white[3] = {1, 1, 1},
                       grey[3] = {0.45f, 0.45f, 0.45f}, cyan[3] = {0, 0.75f, 0.75f},
                       yellow[3] = {1, 1, 0}, magenta[3] = {1, 0.2f, 1},
                       dim[3] = {0.08f, 0.08f, 0.08f};
    for (size_t i = 0; i < (size_t)L.w * L.h; i++)
        memcpy(cv.px + 3 * i, bg, sizeof bg);
    const double scale = exp2(d->exposure_ev);
    char s[256];

    snprintf(s, sizeof s, "%.40s   exposure %+.2f EV%s   %s", o.title ? o.title : "",
             d->exposure_ev, o.exposure_set ? "" : " (auto)",
             o.tonemap == ENVL_PREVIEW_TONEMAP_REINHARD ? "Reinhard" : "ACES filmic");
    text(&cv, MARGIN, 6, s, white);

    /* The map, area-resampled to the view (map_w x map_h whatever the map's own aspect: a
     * 3 x 1 map was resampled in proportion, 1/3 as tall as the view it was read over),
     * tone-mapped. */
    float *sp = NULL;
    envl_result rc = envl__latlong_resample(envl_envmap_pixels(map), envl_envmap_width(map),
                                            envl_envmap_height(map), L.map_w, L.map_h, 0.0, &sp);
    if (rc) {
        free(cv.px);
        return rc;
    }
    for (int32_t y = 0; y < L.map_h; y++)
        for (int32_t x = 0; x < L.map_w; x++) {
            float c[3];
            for (int k = 0; k < 3; k++)
                c[k] = (float)tone(&o, scale * sp[3 * ((size_t)y * L.map_w + x) + k]);
            put(&cv, MARGIN + x, TITLE_H + y, c);
        }
    free(sp);
    mapview mv = {&cv, MARGIN, TITLE_H, L.map_w, L.map_h};
    if (d->median) {
        outline_regions(&mv, d->median, envl_envmap_width(map), envl_envmap_height(map), cyan);
        mark_lights(&mv, d->median, 0, yellow);
    }
    if (d->fit)
        mark_lights(&mv, d->fit, 1, magenta);
    int32_t x = MARGIN;
    char h[32];
    snprintf(s, sizeof s, "median cut %d: regions", (int)d->median_lights);
    text(&cv, x, L.legend_y, s, cyan);
    x += text_width(s) + 12;
    text(&cv, x, L.legend_y, "+ lights", yellow);
    x += text_width("+ lights") + 12;
    preview_column_head(d, 2, 0, h, sizeof h);
    snprintf(s, sizeof s, "o %s", h);
    text(&cv, x, L.legend_y, s, magenta);
    x += text_width(s) + 12;
    if (x + text_width("(marker size ~ strength)") < L.w - MARGIN)
        text(&cv, x, L.legend_y, "(marker size ~ strength)", grey);

    /* Column headers, row labels, spheres and their numbers. */
    for (int c = 0; c < PREVIEW_COLS; c++)
        for (int k = 0; k < 2; k++) {
            preview_column_head(d, c, k, h, sizeof h);
            text_centred(&cv, LABEL_W + c * L.cell_w + L.cell_w / 2, L.header_y + 10 * k, h,
                         white);
        }
    const char *spec = o.specular == ENVL_PREVIEW_SPECULAR_GGX ? "GGX" : "Blinn-Phong";
    for (int r = 0; r < PREVIEW_ROWS; r++) {
        int32_t x0, y0;
        preview_sphere_origin(S, r, 0, &x0, &y0);
        const char *l1 = r == 0 ? "diffuse" : r < 3 ? "glossy" : "mirror", *l2 = "";
        char l3[32] = "";
        if (r == 0)
            l2 = o.diffuse == ENVL_PREVIEW_DIFFUSE_LAMBERT ? "Lambert" : "Oren-Nayar";
        else if (r < 3) {
            l2 = spec;
            snprintf(l3, sizeof l3, "rough %.2f", o.roughness[r - 1]);
        }
        text(&cv, MARGIN, y0 + S / 2 - 14, l1, white);
        text(&cv, MARGIN, y0 + S / 2 - 3, l2, grey);
        text(&cv, MARGIN, y0 + S / 2 + 8, l3, grey);
        for (int c = 0; c < PREVIEW_COLS; c++) {
            preview_sphere_origin(S, r, c, &x0, &y0);
            int32_t cx = x0 + S / 2;
            if (!d->served[r][c]) { /* the disc's rim, dim, and what the method is for */
                for (int32_t j = 0; j < S; j++)
                    for (int32_t i = 0; i < S; i++) {
                        double n[3];
                        if (preview_sphere_normal(S, d->view, i, j, n) &&
                            (!preview_sphere_normal(S, d->view, i - 1, j, n) ||
                             !preview_sphere_normal(S, d->view, i + 1, j, n) ||
                             !preview_sphere_normal(S, d->view, i, j - 1, n) ||
                             !preview_sphere_normal(S, d->view, i, j + 1, n)))
                            put(&cv, x0 + i, y0 + j, dim);
                    }
                for (int k = 0; k < 2; k++) {
                    preview_cell_text(&o, d, r, c, k, s, sizeof s);
                    text_centred(&cv, cx, y0 + S / 2 - 9 + 11 * k, s, grey);
                }
                continue;
            }
            const double *sph = d->sphere[r][c];
            for (int32_t j = 0; j < S; j++)
                for (int32_t i = 0; i < S; i++) {
                    double n[3];
                    if (!preview_sphere_normal(S, d->view, i, j, n))
                        continue;
                    float col[3];
                    for (int k = 0; k < 3; k++)
                        col[k] = (float)tone(&o, scale * sph[3 * ((size_t)j * S + i) + k]);
                    put(&cv, x0 + i, y0 + j, col);
                }
            preview_cell_text(&o, d, r, c, 0, s, sizeof s);
            text_centred(&cv, cx, y0 + S + 4, s, c == 0 ? grey : white);
            snprintf(s, sizeof s, "%.3g s", d->seconds[r][c]);
            text_centred(&cv, cx, y0 + S + 14, s, grey);
        }
    }
    *rgb = cv.px;
    *width = L.w;
    *height = L.h;
    return ENVL_OK;
}

/* ---- the public entry -------------------------------------------------------------------- */

/* The ranges the command line takes (cli_preview.c); 0 is the default. */
static int options_ok(const envl_preview_options *o)
{
    int ok = o->median_count >= 0 && o->median_count <= 4096 && o->fit_count >= 0 &&
             o->fit_count <= 32 && (o->tonemap == 0 || o->tonemap == 1) &&
             (o->diffuse == 0 || o->diffuse == 1) && (o->specular == 0 || o->specular == 1);
    ok = ok && (!o->exposure_set || (o->exposure_ev >= -64 && o->exposure_ev <= 64));
    for (int k = 0; k < 2; k++)
        ok = ok && (o->roughness[k] == 0 || (o->roughness[k] >= 0.05 && o->roughness[k] <= 1));
    ok = ok && (o->sphere_size == 0 || (o->sphere_size >= 48 && o->sphere_size <= 512));
    return ok && (o->reference_width == 0 || (o->reference_width >= 16 &&
                                              o->reference_width <= 4096 &&
                                              o->reference_width % 2 == 0));
}

envl_result envl_preview_write(envl_envmap *map, const envl_preview_options *options,
                               const char *path, FILE *notes, int32_t *width, int32_t *height)
{
    static const envl_preview_options defaults;
    const envl_preview_options *o = options ? options : &defaults;
    if (!map || !path)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_preview_write: NULL argument");
    if (!options_ok(o))
        return envl__fail(ENVL_ERR_ARGUMENT, "preview: an option is out of range "
                          "(envlight.h, envl_preview_options)");
    /* the map's file is not replaced */
    envl_result rc = envl__outputs_of_map(map, NULL, &path, 1);
    if (rc)
        return rc;
    preview_data d;
    float *rgb = NULL;
    int32_t w = 0, h = 0;
    rc = preview_compute(map, o, notes, &d);
    if (!rc)
        rc = preview_compose(map, o, &d, &rgb, &w, &h);
    if (!rc)
        rc = envl_png_save_srgb(path, rgb, w, h);
    else if (rc == ENVL_ERR_MEMORY) /* the picture's own allocations set no message */
        envl__fail(rc, "%s: out of memory", path);
    if (!rc && width)
        *width = w;
    if (!rc && height)
        *height = h;
    free(rgb);
    preview_data_free(&d);
    return rc;
}
