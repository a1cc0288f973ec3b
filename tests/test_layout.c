/* Layout conversions (src/layout.c): guessing, orientation of every layout, area-weighted
 * accuracy against analytic scenes, round trips, cube-face continuity, OpenEXR envmaps.
 *
 * The test renders scenes into every layout with its own pixel -> direction functions, written
 * from the documented formulas (the comment block of layout.c, docs/design.md, OpenEXR's
 * ImfEnvmap.cpp), not through the library.
 *
 * Error bounds. The scene is f(d) = k + b.d + d^T A d per channel. Along any great circle
 * parametrised by angle, f'' = 2 q^T A q - 2 p^T A p - b.p (p the point, q the unit tangent), so
 * |f''| <= K = 2 (lambda_max(A) - lambda_min(A)) + |b|, and the tangential gradient is at most
 * G = (lambda_max - lambda_min) + |b|. Worst channel below: K = 4.56, G = 2.56.
 * An image of a layout is f sampled at pixel centres. Its bilinear reconstruction errs by at
 * most (1/8)(max|f_xx| + max|f_yy|) (pixel units), and along an image line f_xx = f''(v)^2 +
 * (grad f).acc with v the angle per pixel and acc the map's acceleration; the library then
 * averages the reconstruction over the output footprint with a midpoint rule of at least 2 x 2
 * equal-solid-angle cells, whose error is at most (1/24) per axis of (cell size)^2 |f''| plus the
 * footprint mean's own distance from the centre value (same form, footprint size). Each check
 * below states which of these terms it uses. */
#include "check.h"
#include "internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ---- the analytic scene ---- */
static const double K_F = 4.56, G_F = 2.56;

static void scene(const double d[3], double out[3])
{
    double x = d[0], y = d[1], z = d[2];
    out[0] = 1.0 + 0.5 * x + 0.25 * y + 2.0 * z * z;
    out[1] = 1.5 - 0.3 * x + 0.6 * y + 0.4 * z + 0.5 * x * y;
    out[2] = 2.0 + 0.2 * x - 0.4 * y - 0.7 * z + 1.0 * x * x;
}
/* integral over the sphere: 4 pi k + (4 pi / 3) trace(A) */
static void scene_power(double p[3])
{
    p[0] = 4 * PI * 1.0 + 4 * PI / 3 * 2.0;
    p[1] = 4 * PI * 1.5;
    p[2] = 4 * PI * 2.0 + 4 * PI / 3 * 1.0;
}

/* ---- docs/design.md canonical lat-long, written here independently ---- */
static void ll_dir(int w, int h, double c, double r, double d[3])
{
    double u = (c + 0.5) / w, v = (r + 0.5) / h;
    double phi = PI * (1 - 2 * u), th = PI * (0.5 - v);
    d[0] = cos(th) * cos(phi), d[1] = cos(th) * sin(phi), d[2] = sin(th);
}
/* pixel (centre on integers) of a direction */
static void ll_pix(int w, int h, const double d[3], double *c, double *r)
{
    double phi = atan2(d[1], d[0]), th = asin(fmax(-1, fmin(1, d[2])));
    *c = (1 - phi / PI) / 2 * w - 0.5;
    *r = (0.5 - th / PI) * h - 0.5;
}
static void unit(double d[3])
{
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    d[0] /= l, d[1] /= l, d[2] /= l;
}
static double angle_between(const double a[3], const double b[3])
{
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    return atan2(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
                 a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
}

/* ---- layouts, from the documented formulas ---- */
typedef struct face { double c[3], rt[3], up[3]; } face;
static const face FRONT = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
static const face BACK = {{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
static const face LEFT = {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}};
static const face RIGHT = {{0, -1, 0}, {-1, 0, 0}, {0, 0, 1}};
static const face TOP = {{0, 0, 1}, {0, -1, 0}, {-1, 0, 0}};
static const face BOTTOM = {{0, 0, -1}, {0, -1, 0}, {1, 0, 0}};
static const face BACK_V = {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};

/* face in cell (col, row) of a cross/strip, NULL if empty */
static const face *cell_face(int layout, int col, int row)
{
    static const face *hcross[3][4] = {{NULL, &TOP, NULL, NULL},
                                       {&LEFT, &FRONT, &RIGHT, &BACK},
                                       {NULL, &BOTTOM, NULL, NULL}};
    static const face *vcross[4][3] = {
        {NULL, &TOP, NULL}, {&LEFT, &FRONT, &RIGHT}, {NULL, &BOTTOM, NULL}, {NULL, &BACK_V, NULL}};
    static const face *strip[6] = {&FRONT, &BACK, &LEFT, &RIGHT, &TOP, &BOTTOM};
    switch (layout) {
    case ENVL_LAYOUT_CROSS_H: return hcross[row][col];
    case ENVL_LAYOUT_CROSS_V: return vcross[row][col];
    case ENVL_LAYOUT_STRIP_H: return strip[col];
    default: return strip[row];
    }
}

static void layout_size(int layout, int size, int *w, int *h)
{
    switch (layout) {
    case ENVL_LAYOUT_CROSS_H: *w = 4 * size, *h = 3 * size; break;
    case ENVL_LAYOUT_CROSS_V: *w = 3 * size, *h = 4 * size; break;
    case ENVL_LAYOUT_STRIP_H: *w = 6 * size, *h = size; break;
    case ENVL_LAYOUT_STRIP_V: case ENVL_LAYOUT_EXR_CUBE: *w = size, *h = 6 * size; break;
    case ENVL_LAYOUT_EXR_LATLONG: *w = size, *h = size / 2; break;
    default: *w = *h = size; break;
    }
}

/* OpenEXR cube, face f (+X,-X,+Y,-Y,+Z,-Z of OpenEXR), local pixel (px, py) -> direction in
 * OpenEXR's frame; derived by inverting ImfEnvmap.cpp's CubeMap::pixelPosition and applying
 * CubeMap::direction. */
static void exr_cube_dir_exr(int f, int n, double px, double py, double e[3])
{
    double m = n - 1, a = 2 * px / m - 1, b = 2 * py / m - 1; /* -1..1 across, down */
    switch (f) {
    case 0: e[0] = 1, e[1] = -b, e[2] = a; break;
    case 1: e[0] = -1, e[1] = -b, e[2] = -a; break;
    case 2: e[0] = a, e[1] = 1, e[2] = -b; break;
    case 3: e[0] = a, e[1] = -1, e[2] = b; break;
    case 4: e[0] = -a, e[1] = -b, e[2] = 1; break;
    default: e[0] = a, e[1] = -b, e[2] = -1; break;
    }
}
/* ImfEnvmap.cpp's CubeMap::faceAndPixelPosition + pixelPosition, transcribed: OpenEXR
 * direction -> face and local pixel (used to check the inversion above). */
static void exr_cube_pix(int n, const double e[3], int *fc, double *px, double *py)
{
    double ax = fabs(e[0]), ay = fabs(e[1]), az = fabs(e[2]), m = n - 1, pifx, pify;
    if (ax >= ay && ax >= az) {
        pifx = (e[1] / ax + 1) / 2 * m, pify = (e[2] / ax + 1) / 2 * m;
        *fc = e[0] > 0 ? 0 : 1;
    } else if (ay >= az) {
        pifx = (e[0] / ay + 1) / 2 * m, pify = (e[2] / ay + 1) / 2 * m;
        *fc = e[1] > 0 ? 2 : 3;
    } else {
        pifx = (e[0] / az + 1) / 2 * m, pify = (e[1] / az + 1) / 2 * m;
        *fc = e[2] > 0 ? 4 : 5;
    }
    switch (*fc) {
    case 0: *px = pify, *py = m - pifx; break;
    case 1: *px = m - pify, *py = m - pifx; break;
    case 2: *px = pifx, *py = m - pify; break;
    case 3: *px = pifx, *py = pify; break;
    case 4: *px = m - pifx, *py = m - pify; break;
    default: *px = pifx, *py = m - pify; break;
    }
}

/* Direction of the centre of pixel (i, j) of a w x h image in `layout`; 0 if not covered. */
static int test_dir(int layout, int w, int h, int i, int j, double d[3])
{
    switch (layout) {
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: {
        double rad = 0.5 * (w < h ? w : h);
        double x = (i + 0.5 - 0.5 * w) / rad, y = (0.5 * h - (j + 0.5)) / rad;
        double r = hypot(x, y);
        if (r > 1)
            return 0;
        double img[3];
        if (layout == ENVL_LAYOUT_ANGULAR) {
            double a = atan2(y, x);
            img[0] = sin(PI * r) * cos(a), img[1] = sin(PI * r) * sin(a), img[2] = -cos(PI * r);
        } else { /* reflect the view (0,0,-1) about n = (x, y, sqrt(1-r^2)) */
            double n[3] = {x, y, sqrt(fmax(0, 1 - r * r))}, vn = -n[2];
            double v[3] = {0, 0, -1};
            for (int k = 0; k < 3; k++)
                img[k] = v[k] - 2 * vn * n[k];
        }
        d[0] = -img[2], d[1] = -img[0], d[2] = img[1];
        return 1;
    }
    case ENVL_LAYOUT_EXR_LATLONG: {
        double lat = -PI * ((double)j / (h - 1) - 0.5), lon = -2 * PI * ((double)i / (w - 1) - 0.5);
        double e[3] = {sin(lon) * cos(lat), sin(lat), cos(lon) * cos(lat)};
        d[0] = e[2], d[1] = e[0], d[2] = e[1];
        return 1;
    }
    case ENVL_LAYOUT_EXR_CUBE: {
        int n = w, f = j / n;
        double e[3];
        exr_cube_dir_exr(f, n, i, j - f * n, e);
        d[0] = e[2], d[1] = e[0], d[2] = e[1];
        unit(d);
        return 1;
    }
    default: {
        int cols = layout == ENVL_LAYOUT_CROSS_H ? 4 : layout == ENVL_LAYOUT_CROSS_V ? 3
                       : layout == ENVL_LAYOUT_STRIP_H ? 6 : 1;
        int n = w / cols, col = i / n, row = j / n;
        const face *f = cell_face(layout, col, row);
        if (!f)
            return 0;
        double s = 2 * (i - col * n + 0.5) / n - 1, t = 1 - 2 * (j - row * n + 0.5) / n;
        for (int k = 0; k < 3; k++)
            d[k] = f->c[k] + s * f->rt[k] + t * f->up[k];
        unit(d);
        return 1;
    }
    }
}

typedef void (*scene_fn)(const double d[3], double out[3]);

static envl_image render(int layout, int size, scene_fn fn)
{
    envl_image img = {0};
    int w, h;
    layout_size(layout, size, &w, &h);
    if (envl__image_alloc(&img, w, h, NULL, "test") != ENVL_OK)
        abort();
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            double d[3], v[3];
            if (!test_dir(layout, w, h, i, j, d))
                continue;
            fn(d, v);
            for (int k = 0; k < 3; k++)
                img.px[3 * ((size_t)j * w + i) + k] = (float)v[k];
        }
    return img;
}

static envl_image render_latlong(int w, scene_fn fn)
{
    envl_image img = {0};
    int h = w / 2;
    if (envl__image_alloc(&img, w, h, NULL, "test") != ENVL_OK)
        abort();
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            double d[3], v[3];
            ll_dir(w, h, i, j, d);
            fn(d, v);
            for (int k = 0; k < 3; k++)
                img.px[3 * ((size_t)j * w + i) + k] = (float)v[k];
        }
    return img;
}

/* Exact-enough mean of fn over the footprint of lat-long pixel (c, r): 32 x 32 equal-area
 * midpoint cells (error ~ K (size/32)^2 / 24, negligible here). */
static void footprint_mean(scene_fn fn, int w, int h, int c, int r, double out[3])
{
    const int n = 32;
    double zt = sin(PI * (0.5 - (double)r / h)), zb = sin(PI * (0.5 - (double)(r + 1) / h));
    out[0] = out[1] = out[2] = 0;
    for (int b = 0; b < n; b++) {
        double z = zt + (zb - zt) * (b + 0.5) / n, cz = sqrt(fmax(0, 1 - z * z));
        for (int a = 0; a < n; a++) {
            double phi = PI * (1 - 2 * (c + (a + 0.5) / n) / w);
            double d[3] = {cz * cos(phi), cz * sin(phi), z}, v[3];
            fn(d, v);
            for (int k = 0; k < 3; k++)
                out[k] += v[k] / (n * n);
        }
    }
}

static const int ALL_LAYOUTS[] = {ENVL_LAYOUT_ANGULAR,  ENVL_LAYOUT_MIRRORBALL,
                                  ENVL_LAYOUT_CROSS_V,  ENVL_LAYOUT_CROSS_H,
                                  ENVL_LAYOUT_STRIP_H,  ENVL_LAYOUT_STRIP_V,
                                  ENVL_LAYOUT_EXR_LATLONG, ENVL_LAYOUT_EXR_CUBE};
#define N_LAYOUTS ((int)(sizeof ALL_LAYOUTS / sizeof ALL_LAYOUTS[0]))

/* Test sizes: faces of 32, probes of 128 px, OpenEXR lat-long 128 wide. */
static int test_size(int layout)
{
    switch (layout) {
    case ENVL_LAYOUT_ANGULAR: case ENVL_LAYOUT_MIRRORBALL: case ENVL_LAYOUT_EXR_LATLONG:
        return 128;
    default: return 32;
    }
}

/* ---- tests ---- */

static void test_guess(void)
{
    struct { int w, h, meta, want; } cases[] = {
        {512, 256, 0, ENVL_LAYOUT_LATLONG},    {1000, 1000, 0, ENVL_LAYOUT_ANGULAR},
        {8, 8, 0, ENVL_LAYOUT_ANGULAR},        {4, 4, 0, ENVL_LAYOUT_LATLONG},
        {768, 1024, 0, ENVL_LAYOUT_CROSS_V},   {1024, 768, 0, ENVL_LAYOUT_CROSS_H},
        {1536, 256, 0, ENVL_LAYOUT_STRIP_H},   {256, 1536, 0, ENVL_LAYOUT_STRIP_V},
        {1, 1, 0, ENVL_LAYOUT_LATLONG},        {8192, 1, 0, ENVL_LAYOUT_LATLONG},
        {300, 200, 0, ENVL_LAYOUT_LATLONG},    {2, 1, 0, ENVL_LAYOUT_LATLONG},
        {512, 3072, ENVL_LAYOUT_EXR_CUBE, ENVL_LAYOUT_EXR_CUBE},
        {1024, 512, ENVL_LAYOUT_EXR_LATLONG, ENVL_LAYOUT_EXR_LATLONG},
        {256, 1536, ENVL_LAYOUT_EXR_CUBE, ENVL_LAYOUT_EXR_CUBE}, /* metadata beats the strip */
        {512, 512, ENVL_LAYOUT_EXR_LATLONG, ENVL_LAYOUT_EXR_LATLONG},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        envl_image img = {.width = cases[k].w, .height = cases[k].h};
        img.meta.envmap_layout = cases[k].meta;
        int32_t got = envl__guess_layout(&img);
        if (got != cases[k].want)
            fprintf(stderr, "guess %dx%d meta %d: got %s want %s\n", cases[k].w, cases[k].h,
                    cases[k].meta, envl_layout_name(got), envl_layout_name(cases[k].want));
        CHECK(got == cases[k].want);
    }
    /* default widths */
    envl_image a = {.width = 1000, .height = 1000}, c = {.width = 96, .height = 128},
               e = {.width = 512, .height = 3072}, l = {.width = 1024, .height = 512};
    CHECK(envl__default_latlong_width(&a, ENVL_LAYOUT_ANGULAR) == 2000);
    CHECK(envl__default_latlong_width(&a, ENVL_LAYOUT_MIRRORBALL) == 2000);
    CHECK(envl__default_latlong_width(&c, ENVL_LAYOUT_CROSS_V) == 128);
    CHECK(envl__default_latlong_width(&e, ENVL_LAYOUT_EXR_CUBE) == 2048);
    CHECK(envl__default_latlong_width(&l, ENVL_LAYOUT_EXR_LATLONG) == 1024);
    CHECK(envl__default_latlong_width(&l, ENVL_LAYOUT_LATLONG) == 1024);
}

/* Our transcription of OpenEXR's dir -> pixel inverts our pixel -> dir for every face. */
static void test_exr_cube_formulas(void)
{
    const int n = 16;
    double worst = 0;
    int bad_face = 0;
    for (int f = 0; f < 6; f++)
        for (int py = 0; py < n; py++)
            for (int px = 0; px < n; px++) {
                double e[3], x, y;
                int g;
                exr_cube_dir_exr(f, n, px, py, e);
                exr_cube_pix(n, e, &g, &x, &y);
                /* edge pixels are shared by two faces: compare positions only off the edges */
                if (px > 0 && px < n - 1 && py > 0 && py < n - 1) {
                    bad_face += g != f;
                    worst = fmax(worst, fmax(fabs(x - px), fabs(y - py)));
                }
            }
    CHECK(bad_face == 0);
    CHECK_NEAR(worst, 0, 1e-9);
}

/* ---- error bounds (see the top of the file) ---- */

/* The rim direction of a probe (the angular map's rim is backward, the mirror ball's forward)
 * and the angle around it where the reconstruction drops taps outside the disc or, for the
 * mirror ball, has no pixel centre at all: two rings of pixels plus the blind cap. */
static int probe_rim(int layout, int size, double dir[3], double *cap)
{
    double R = 0.5 * size;
    if (layout == ENVL_LAYOUT_ANGULAR) {
        dir[0] = -1, dir[1] = 0, dir[2] = 0;
        *cap = PI * 2.0 / R; /* radius linear in angle: pi/R per pixel */
        return 1;
    }
    if (layout == ENVL_LAYOUT_MIRRORBALL) {
        dir[0] = 1, dir[1] = 0, dir[2] = 0;
        /* point at normalized radius r sees 2 acos(r) away from forward */
        *cap = 2 * acos((R - 2.0) / R);
        return 1;
    }
    return 0;
}

/* Bilinear reconstruction error of the scene sampled in `layout`, (1/8)(max|f_xx| + max|f_yy|)
 * in pixel units:
 *  - our cubes: image lines of a face are great circles (lines of a plane through the centre),
 *    speed sqrt(1+t^2)/(1+s^2+t^2) <= 1 rad per unit of s, its derivative <= 0.65; the step is
 *    2/N: f_xx <= (2/N)^2 (K + 0.65 G), same for y;
 *  - OpenEXR cube: the same with step 2/(N-1);
 *  - OpenEXR lat-long: rows are circles of latitude (speed cos(lat) <= 1, acceleration along
 *    the sphere sin cos <= 1/2): f_xx <= (2 pi/(W-1))^2 (K + G/2); columns are meridians:
 *    f_yy <= (pi/(H-1))^2 K;
 *  - probes: the map's acceleration varies over the disc, so max |f_xx| is measured as the
 *    largest second difference of f over pixel triples inside the disc (f_xx at some point
 *    between them; the scene is smooth enough that the maximum over a pixel differs from the
 *    second difference by a few per cent, covered by a factor 1.25). */
static double recon_bound(int layout, int size)
{
    double n = size;
    switch (layout) {
    case ENVL_LAYOUT_EXR_CUBE: n = size - 1; /* fall through */
    case ENVL_LAYOUT_CROSS_V: case ENVL_LAYOUT_CROSS_H: case ENVL_LAYOUT_STRIP_H:
    case ENVL_LAYOUT_STRIP_V:
        return 0.125 * 2 * (2 / n) * (2 / n) * (K_F + 0.65 * G_F);
    case ENVL_LAYOUT_EXR_LATLONG: {
        int w = size, h = size / 2;
        double hx = 2 * PI / (w - 1), hy = PI / (h - 1);
        return 0.125 * (hx * hx * (K_F + G_F / 2) + hy * hy * K_F);
    }
    default: break;
    }
    int w = size, h = size;
    double m[2] = {0, 0};
    for (int j = 1; j < h - 1; j++)
        for (int i = 1; i < w - 1; i++)
            for (int ax = 0; ax < 2; ax++) {
                double d0[3], d1[3], d2[3], f0[3], f1[3], f2[3];
                int di = ax == 0, dj = ax == 1;
                if (!test_dir(layout, w, h, i - di, j - dj, d0) ||
                    !test_dir(layout, w, h, i, j, d1) ||
                    !test_dir(layout, w, h, i + di, j + dj, d2))
                    continue;
                scene(d0, f0), scene(d1, f1), scene(d2, f2);
                for (int k = 0; k < 3; k++)
                    m[ax] = fmax(m[ax], fabs(f0[k] - 2 * f1[k] + f2[k]));
            }
    return 0.125 * 1.25 * (m[0] + m[1]);
}

/* The library's midpoint rule over >= 2 x 2 equal-solid-angle cells of an output lat-long pixel
 * against the footprint's exact mean: (1/24) per axis of (cell angle)^2 |f''| with cells at most
 * half the pixel (pi/H high, at most pi/H wide away from the poles); f'' in (azimuth, z)
 * coordinates is bounded by K + G (the circle-of-latitude term). */
static double quad_bound(int H)
{
    double cell = 0.5 * PI / H;
    return 2.0 / 24 * cell * cell * (K_F + G_F);
}

/* Analytic scene rendered into each layout -> lat-long: every output pixel against the exact
 * mean of f over its footprint, and the power against the analytic integral. */
static void test_accuracy(void)
{
    const int W = 128, H = 64;
    double ref_power[3];
    scene_power(ref_power);
    for (int li = 0; li < N_LAYOUTS; li++) {
        int layout = ALL_LAYOUTS[li], size = test_size(layout);
        envl_image src = render(layout, size, scene), ll = {0};
        CHECK_OK(envl__layout_to_latlong(&src, layout, W, &ll));
        if (!ll.px) {
            envl__image_free(&src);
            continue;
        }
        CHECK(ll.width == W && ll.height == H);
        double rim_dir[3], cap = 0;
        int probe = probe_rim(layout, size, rim_dir, &cap);
        double bound = recon_bound(layout, size) + quad_bound(H);
        /* near a probe's rim: first order, G times the cap plus the output pixel's diagonal */
        double rim_bound = G_F * (cap + 1.5 * PI / H);
        double worst = 0, worst_rim = 0, err_power = 0, power[3] = {0, 0, 0}, rim_omega = 0;
        for (int r = 0; r < H; r++) {
            double dw = envl_latlong_solid_angle(W, H, r);
            for (int c = 0; c < W; c++) {
                double ref[3], d[3];
                footprint_mean(scene, W, H, c, r, ref);
                ll_dir(W, H, c, r, d);
                int in_rim = probe && angle_between(d, rim_dir) < cap + 1.5 * PI / H;
                rim_omega += in_rim ? dw : 0;
                const float *o = ll.px + 3 * ((size_t)r * W + c);
                for (int k = 0; k < 3; k++) {
                    double e = fabs(o[k] - ref[k]);
                    if (in_rim)
                        worst_rim = fmax(worst_rim, e);
                    else
                        worst = fmax(worst, e);
                    power[k] += o[k] * dw;
                }
            }
        }
        printf("  %-12s max |out - footprint mean| %.2e (bound %.2e), near the rim %.2e "
               "(bound %.2e)\n",
               envl_layout_name(layout), worst, bound, worst_rim, rim_bound);
        CHECK(worst <= bound);
        CHECK(worst_rim <= rim_bound);
        /* power: the footprint means integrate to the exact power; the error is at most the
         * pointwise bounds integrated (plus the reference quadrature, ~1e-6) */
        err_power = 4 * PI * bound + rim_omega * rim_bound + 1e-4;
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(power[k], ref_power[k], err_power);
        envl__image_free(&src);
        envl__image_free(&ll);
    }
}

/* A bright spot rendered into a layout lands within one output pixel of docs/design.md's pixel
 * (and its centre less than one pixel-angle, pi/H, from the spot's direction). */
static double spot_dir_[3];
static void spot(const double d[3], double out[3])
{
    const double sigma = 4.0 * PI / 180;
    double a = angle_between(d, spot_dir_);
    double v = exp(-0.5 * (a / sigma) * (a / sigma));
    out[0] = out[1] = out[2] = v;
}
static void dir_from_degrees(double az, double el, double d[3])
{
    az *= PI / 180, el *= PI / 180;
    d[0] = cos(el) * cos(az), d[1] = cos(el) * sin(az), d[2] = sin(el);
}

static void check_spot(int layout, int size, const double dir[3], const char *label)
{
    const int W = 256, H = 128;
    memcpy(spot_dir_, dir, sizeof spot_dir_);
    envl_image src = render(layout, size, spot), ll = {0};
    CHECK_OK(envl__layout_to_latlong(&src, layout, W, &ll));
    if (!ll.px) {
        envl__image_free(&src);
        return;
    }
    /* the spot's centre: solid-angle weighted centroid of the pixels above a fifth of the
     * peak (weights L - peak/5), a sub-pixel estimate that ties cannot move */
    float peak = 0;
    for (int k = 0; k < W * H; k++)
        peak = fmaxf(peak, ll.px[3 * k]);
    double m[3] = {0, 0, 0};
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++) {
            double wgt = ll.px[3 * (r * W + c)] - 0.2 * peak, d[3];
            if (wgt <= 0)
                continue;
            wgt *= envl_latlong_solid_angle(W, H, r);
            ll_dir(W, H, c, r, d);
            for (int k = 0; k < 3; k++)
                m[k] += wgt * d[k];
        }
    unit(m);
    double gc, gr, ec, er;
    ll_pix(W, H, m, &gc, &gr);
    ll_pix(W, H, dir, &ec, &er);
    double dc = fabs(gc - ec);
    dc = fmin(dc, W - dc);
    int pole = fabs(dir[2]) > 0.999; /* at a pole any column is right */
    double ang = angle_between(m, dir);
    int ok = (pole || dc <= 1.0) && fabs(gr - er) <= 1.0 && ang < PI / H;
    if (!ok)
        fprintf(stderr, "spot %s in %s: at (%.2f, %.2f), expected (%.2f, %.2f), %.4f rad off\n",
                label, envl_layout_name(layout), gc, gr, ec, er, ang);
    CHECK(ok);
    envl__image_free(&src);
    envl__image_free(&ll);
}

static void test_orientation(void)
{
    double d[3];
    dir_from_degrees(30, 20, d);
    for (int li = 0; li < N_LAYOUTS; li++)
        check_spot(ALL_LAYOUTS[li], test_size(ALL_LAYOUTS[li]), d, "az 30 el 20");
    /* the probes elsewhere too (not the mirror ball's blind forward cap) */
    dir_from_degrees(135, -40, d);
    check_spot(ENVL_LAYOUT_ANGULAR, 128, d, "az 135 el -40");
    check_spot(ENVL_LAYOUT_MIRRORBALL, 128, d, "az 135 el -40");
    dir_from_degrees(-100, 60, d);
    check_spot(ENVL_LAYOUT_ANGULAR, 128, d, "az -100 el 60");
    check_spot(ENVL_LAYOUT_MIRRORBALL, 128, d, "az -100 el 60");
    /* the six axes in every cube layout: +X at u = 0.5, +Y at u = 0.25, ... */
    static const double axes[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                                      {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    static const char *names[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    static const int cubes[] = {ENVL_LAYOUT_CROSS_V, ENVL_LAYOUT_CROSS_H, ENVL_LAYOUT_STRIP_H,
                                ENVL_LAYOUT_STRIP_V, ENVL_LAYOUT_EXR_CUBE};
    for (int k = 0; k < 5; k++)
        for (int a = 0; a < 6; a++)
            check_spot(cubes[k], 32, axes[a], names[a]);
    /* and where docs/design.md puts them: +X is the centre pixel pair, +Y a quarter from the left */
    double c, r;
    ll_pix(256, 128, axes[0], &c, &r);
    CHECK_NEAR(c, 127.5, 1e-9);
    CHECK_NEAR(r, 63.5, 1e-9);
    ll_pix(256, 128, axes[2], &c, &r);
    CHECK_NEAR(c, 63.5, 1e-9);
    ll_pix(256, 128, axes[3], &c, &r);
    CHECK_NEAR(c, 191.5, 1e-9);
}

/* latlong -> layout agrees with the independent rendering; latlong -> layout -> latlong returns
 * the scene. */
static void test_round_trip(void)
{
    const int W = 128, H = 64;
    envl_image ll = render_latlong(W, scene);
    /* lat-long input reconstruction (bilinear; over the poles the interpolation runs along a
     * great circle too): (1/8)((2 pi/W)^2 (K + G/2) + (pi/H)^2 K) */
    double hx = 2 * PI / W, hy = PI / H;
    double e_ll = 0.125 * (hx * hx * (K_F + G_F / 2) + hy * hy * K_F);
    for (int li = 0; li < N_LAYOUTS; li++) {
        int layout = ALL_LAYOUTS[li], size = test_size(layout);
        envl_image lay = {0}, back = {0}, ref = render(layout, size, scene);
        CHECK_OK(envl__latlong_to_layout(&ll, layout, size, &lay));
        if (!lay.px) {
            envl__image_free(&ref);
            continue;
        }
        CHECK(lay.width == ref.width && lay.height == ref.height);
        /* each layout pixel is the footprint mean (within the midpoint rule) of the
         * reconstruction: |pixel - f(centre)| <= e_ll + (1/24)(K + G) (ax^2 + ay^2), ax, ay
         * the pixel's angular size (cube: 2/N, OpenEXR cube 2/(N-1), angular probe pi/R,
         * OpenEXR lat-long 2 pi/(W-1) and pi/(H-1)). Probe pixels within two pixels of the
         * rim are left out (their footprints are cut by the rim or, for the mirror ball,
         * many degrees wide); outside the disc both must be 0. */
        double ax, ay;
        switch (layout) {
        case ENVL_LAYOUT_EXR_CUBE: ax = ay = 2.0 / (size - 1); break;
        case ENVL_LAYOUT_ANGULAR: ax = ay = PI / (0.5 * size); break;
        case ENVL_LAYOUT_MIRRORBALL: ax = ay = 2.0 / (0.5 * size) * 4; break; /* r <= 1-2/R */
        case ENVL_LAYOUT_EXR_LATLONG: ax = 2 * PI / (size - 1), ay = PI / (size / 2 - 1); break;
        default: ax = ay = 2.0 / size; break;
        }
        double b_pix = e_ll + (K_F + G_F) / 24 * (ax * ax + ay * ay) + 1e-5;
        double worst = 0, outside = 0, R = 0.5 * size;
        int probe = layout == ENVL_LAYOUT_ANGULAR || layout == ENVL_LAYOUT_MIRRORBALL;
        for (int j = 0; j < lay.height; j++)
            for (int i = 0; i < lay.width; i++) {
                const float *p = lay.px + 3 * ((size_t)j * lay.width + i);
                const float *q = ref.px + 3 * ((size_t)j * lay.width + i);
                double dx = i + 0.5 - R, dy = j + 0.5 - R;
                if (probe && dx * dx + dy * dy > R * R) {
                    outside = fmax(outside, fabs(p[0]) + fabs(p[1]) + fabs(p[2]));
                    continue;
                }
                if (probe && sqrt(dx * dx + dy * dy) > R - 2)
                    continue;
                for (int k = 0; k < 3; k++)
                    worst = fmax(worst, fabs(p[k] - q[k]));
            }
        printf("  %-12s latlong->layout vs analytic: max %.2e (bound %.2e)\n",
               envl_layout_name(layout), worst, b_pix);
        CHECK(worst <= b_pix);
        CHECK(outside == 0);

        /* back to lat-long: bounded by the layout's pixel error, its reconstruction and the
         * midpoint rule, against the footprint mean; probe rims as in test_accuracy */
        CHECK_OK(envl__layout_to_latlong(&lay, layout, W, &back));
        if (back.px) {
            double rim_dir[3], cap = 0;
            int pr = probe_rim(layout, size, rim_dir, &cap);
            double bound = b_pix + recon_bound(layout, size) + quad_bound(H);
            double worst2 = 0, mean_err = 0;
            for (int r = 0; r < H; r++)
                for (int c = 0; c < W; c++) {
                    double refv[3], d[3];
                    footprint_mean(scene, W, H, c, r, refv);
                    ll_dir(W, H, c, r, d);
                    const float *o = back.px + 3 * ((size_t)r * W + c);
                    int in_rim = pr && angle_between(d, rim_dir) < cap + 1.5 * PI / H;
                    for (int k = 0; k < 3; k++) {
                        double e = fabs(o[k] - refv[k]);
                        mean_err += e * envl_latlong_solid_angle(W, H, r) / (12 * PI);
                        if (!in_rim)
                            worst2 = fmax(worst2, e);
                    }
                }
            printf("  %-12s round trip: max %.2e (bound %.2e), mean %.2e\n",
                   envl_layout_name(layout), worst2, bound, mean_err);
            CHECK(worst2 <= bound);
            CHECK(mean_err <= bound);
        }
        envl__image_free(&lay);
        envl__image_free(&back);
        envl__image_free(&ref);
    }
    envl__image_free(&ll);
}

/* Neighbouring faces of the crosses share their edges: render a lat-long whose pixels are their
 * own direction (+2, to stay positive) into the cross through the library, decode, and compare
 * the directions of the edge pixels on both sides of every shared edge of the image (and the
 * horizontal cross's wrap-around edge, left face's left edge to back face's right edge). They
 * must be less than two pixel-angles apart: a face edge pixel spans at most (2/N) / 2 rad, so
 * two edge pixel centres of a continuous edge are at most 2/N apart; any wrong orientation puts
 * them tens of degrees apart. */
static void dir_scene(const double d[3], double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = d[k] + 2;
}

static void decode(const envl_image *img, int i, int j, double d[3])
{
    const float *p = img->px + 3 * ((size_t)j * img->width + i);
    for (int k = 0; k < 3; k++)
        d[k] = p[k] - 2;
    unit(d);
}

static void test_continuity(void)
{
    const int n = 32;
    envl_image ll = render_latlong(512, dir_scene);
    const int layouts[2] = {ENVL_LAYOUT_CROSS_V, ENVL_LAYOUT_CROSS_H};
    for (int li = 0; li < 2; li++) {
        int layout = layouts[li];
        envl_image cr = {0};
        CHECK_OK(envl__latlong_to_layout(&ll, layout, n, &cr));
        if (!cr.px)
            continue;
        int cols = cr.width / n, rows = cr.height / n, edges = 0;
        double worst = 0;
        for (int row = 0; row < rows; row++)
            for (int col = 0; col < cols; col++) {
                if (!cell_face(layout, col, row))
                    continue;
                /* right neighbour */
                if (col + 1 < cols && cell_face(layout, col + 1, row)) {
                    edges++;
                    for (int k = 0; k < n; k++) {
                        double a[3], b[3];
                        decode(&cr, col * n + n - 1, row * n + k, a);
                        decode(&cr, (col + 1) * n, row * n + k, b);
                        worst = fmax(worst, angle_between(a, b));
                    }
                }
                /* lower neighbour */
                if (row + 1 < rows && cell_face(layout, col, row + 1)) {
                    edges++;
                    for (int k = 0; k < n; k++) {
                        double a[3], b[3];
                        decode(&cr, col * n + k, row * n + n - 1, a);
                        decode(&cr, col * n + k, (row + 1) * n, b);
                        worst = fmax(worst, angle_between(a, b));
                    }
                }
            }
        if (layout == ENVL_LAYOUT_CROSS_H) {
            edges++;
            for (int k = 0; k < n; k++) {
                double a[3], b[3];
                decode(&cr, 4 * n - 1, n + k, a);
                decode(&cr, 0, n + k, b);
                worst = fmax(worst, angle_between(a, b));
            }
        }
        printf("  %-12s %d shared edges, largest step across an edge %.4f rad (limit %.4f)\n",
               envl_layout_name(layout), edges, worst, 2.0 / n);
        CHECK(edges == (layout == ENVL_LAYOUT_CROSS_V ? 5 : 6));
        CHECK(worst < 2.0 / n);
        envl__image_free(&cr);
    }
    envl__image_free(&ll);
}

/* A scene with structure: smooth base plus three coloured lobes. */
static void lobes(const double d[3], double out[3])
{
    static const double lobe[3][3] = {{0.5, 0.3, 0.81}, {-0.6, 0.7, -0.39}, {0.1, -0.9, 0.42}};
    static const double col[3][3] = {{8, 4, 1}, {1, 6, 2}, {2, 2, 9}};
    const double sigma = 10 * PI / 180;
    for (int k = 0; k < 3; k++)
        out[k] = 0.5 + 0.2 * d[2];
    for (int l = 0; l < 3; l++) {
        double u[3] = {lobe[l][0], lobe[l][1], lobe[l][2]};
        unit(u);
        double a = angle_between(d, u), g = exp(-0.5 * (a / sigma) * (a / sigma));
        for (int k = 0; k < 3; k++)
            out[k] += col[l][k] * g;
    }
}

/* An angular probe and a vertical cross of the same scene agree with the lat-long version.
 * Bound: a lobe's |f''| <= A / sigma^2 (A its peak, 9), so the pointwise reconstruction error
 * is at most (1/4) A (h / sigma)^2 with h the pixel angle (~ 0.012 rad here), about 0.1; the
 * mean absolute difference over the sphere, where the lobes cover a few per cent of it, must be
 * below 1% of the mean radiance. */
static void test_same_scene(void)
{
    const int W = 512, H = 256;
    envl_image ref = render_latlong(W, lobes);
    double mean_ref = 0;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++)
            for (int k = 0; k < 3; k++)
                mean_ref += ref.px[3 * (r * W + c) + k] * envl_latlong_solid_angle(W, H, r) /
                            (12 * PI);
    const int layouts[2] = {ENVL_LAYOUT_ANGULAR, ENVL_LAYOUT_CROSS_V};
    const int sizes[2] = {256, 128};
    for (int li = 0; li < 2; li++) {
        envl_image src = render(layouts[li], sizes[li], lobes), ll = {0};
        CHECK_OK(envl__layout_to_latlong(&src, layouts[li], W, &ll));
        if (ll.px) {
            double mad = 0;
            for (int r = 0; r < H; r++)
                for (int c = 0; c < W; c++)
                    for (int k = 0; k < 3; k++)
                        mad += fabs(ll.px[3 * (r * W + c) + k] - ref.px[3 * (r * W + c) + k]) *
                               envl_latlong_solid_angle(W, H, r) / (12 * PI);
            printf("  %-12s vs lat-long: mean |diff| %.2e, mean radiance %.3f\n",
                   envl_layout_name(layouts[li]), mad, mean_ref);
            CHECK(mad < 0.01 * mean_ref);
        }
        envl__image_free(&src);
        envl__image_free(&ll);
    }
    envl__image_free(&ref);
}

/* OpenEXR's orientation images: the lat-long and the cube must come out the same way round. */
static void test_openexr_files(void)
{
    const char *pl = shared_data("openexr/MultiResolution/OrientationLatLong.exr");
    const char *pc = shared_data("openexr/MultiResolution/OrientationCube.exr");
    if (!pl || !pc)
        return;
    envl_limits lim = {.max_pixels = ENVL_DEFAULT_MAX_PIXELS};
    envl_image il = {0}, ic = {0};
    envl_result rl = envl__read_image_file(pl, &lim, &il);
    envl_result rc = rl == ENVL_OK ? envl__read_image_file(pc, &lim, &ic) : rl;
    if (rl != ENVL_OK || rc != ENVL_OK) {
        printf("SKIP: OpenEXR orientation files not readable yet (%s: %s)\n",
               envl_result_name(rl ? rl : rc), envl_last_error());
        envl__image_free(&il);
        envl__image_free(&ic);
        return;
    }
    CHECK(il.width == 1024 && il.height == 512);
    CHECK(ic.width == 512 && ic.height == 3072);
    CHECK(envl__guess_layout(&il) == ENVL_LAYOUT_EXR_LATLONG);
    CHECK(envl__guess_layout(&ic) == ENVL_LAYOUT_EXR_CUBE);
    const int W = 256, H = 128;
    envl_image a = {0}, b = {0};
    CHECK_OK(envl__layout_to_latlong(&il, ENVL_LAYOUT_EXR_LATLONG, W, &a));
    CHECK_OK(envl__layout_to_latlong(&ic, ENVL_LAYOUT_EXR_CUBE, W, &b));
    if (a.px && b.px) {
        /* luminance correlation, solid-angle weighted */
        double sw = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0, rel = 0;
        for (int r = 0; r < H; r++)
            for (int c = 0; c < W; c++) {
                const float *p = a.px + 3 * (r * W + c), *q = b.px + 3 * (r * W + c);
                double w = envl_latlong_solid_angle(W, H, r);
                double ya = envl_luminance(p[0], p[1], p[2]), yb = envl_luminance(q[0], q[1], q[2]);
                sw += w, sa += w * ya, sb += w * yb, saa += w * ya * ya, sbb += w * yb * yb;
                sab += w * ya * yb;
                rel += w * fabs(ya - yb) / fmax(1e-6, 0.5 * (ya + yb));
            }
        double ma = sa / sw, mb = sb / sw;
        double corr = (sab / sw - ma * mb) /
                      sqrt(fmax(1e-30, (saa / sw - ma * ma) * (sbb / sw - mb * mb)));
        printf("  OpenEXR orientation files: luminance correlation %.4f, mean relative "
               "difference %.4f\n", corr, rel / sw);
        CHECK(corr > 0.9);
        /* the same comparison with the cube turned by a quarter turn about +Z must be worse:
         * the agreement is about orientation, not about the images being alike anywhere */
        double sab2 = 0;
        for (int r = 0; r < H; r++)
            for (int c = 0; c < W; c++) {
                const float *p = a.px + 3 * (r * W + c), *q = b.px + 3 * (r * W + (c + W / 4) % W);
                double w = envl_latlong_solid_angle(W, H, r);
                sab2 += w * envl_luminance(p[0], p[1], p[2]) * envl_luminance(q[0], q[1], q[2]);
            }
        double corr2 = (sab2 / sw - ma * mb) /
                       sqrt(fmax(1e-30, (saa / sw - ma * ma) * (sbb / sw - mb * mb)));
        printf("  ... with the cube turned 90 degrees: correlation %.4f\n", corr2);
        CHECK(corr2 < corr - 0.2);
    }
    envl__image_free(&a);
    envl__image_free(&b);
    envl__image_free(&il);
    envl__image_free(&ic);
}

static void test_errors(void)
{
    envl_image img = {0}, out = {0};
    CHECK_RC(envl__layout_to_latlong(NULL, ENVL_LAYOUT_ANGULAR, 64, &out), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl__latlong_to_layout(NULL, ENVL_LAYOUT_ANGULAR, 64, &out), ENVL_ERR_ARGUMENT);
    if (envl__image_alloc(&img, 4, 4, NULL, "t") != ENVL_OK)
        abort();
    CHECK_RC(envl__layout_to_latlong(&img, ENVL_LAYOUT_ANGULAR, 0, &out), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl__latlong_to_layout(&img, ENVL_LAYOUT_CROSS_V, 0, &out), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl__latlong_to_layout(&img, 99, 8, &out), ENVL_ERR_ARGUMENT);
    /* a 4 x 4 image cannot hold a 6 x 1 strip or an N x 6N cube of whole faces */
    CHECK_RC(envl__layout_to_latlong(&img, ENVL_LAYOUT_STRIP_H, 16, &out), ENVL_ERR_FORMAT);
    CHECK_RC(envl__layout_to_latlong(&img, ENVL_LAYOUT_EXR_CUBE, 16, &out), ENVL_ERR_FORMAT);
    CHECK(out.px == NULL);
    /* odd sizes: a 1-pixel face, a 1 x 1 probe, a 1-wide output */
    CHECK_OK(envl__layout_to_latlong(&img, ENVL_LAYOUT_ANGULAR, 1, &out));
    CHECK(out.width == 1 && out.height == 1);
    envl__image_free(&out);
    envl_image one = {0};
    if (envl__image_alloc(&one, 1, 6, NULL, "t") != ENVL_OK)
        abort();
    for (int k = 0; k < 18; k++)
        one.px[k] = 1.0f;
    CHECK_OK(envl__layout_to_latlong(&one, ENVL_LAYOUT_EXR_CUBE, 8, &out));
    CHECK(out.px && out.px[0] == 1.0f && out.px[3 * 31 + 2] == 1.0f);
    envl__image_free(&out);
    CHECK_OK(envl__layout_to_latlong(&one, ENVL_LAYOUT_STRIP_V, 8, &out));
    CHECK(out.px && out.px[3 * 17 + 1] == 1.0f);
    envl__image_free(&out);
    envl__image_free(&one);
    envl__image_free(&img);
    /* faces that do not fill the image: refused, naming the sizes that would fit (the pixels
     * past the last whole face were ignored, their light lost: a 13 x 10 strip read its top
     * 12 x 2) */
    static const struct { int32_t layout, w, h; const char *fits; } part[] = {
        {ENVL_LAYOUT_STRIP_H, 13, 10, "faces of 2: 12 x 2; of 3: 18 x 3"},
        {ENVL_LAYOUT_STRIP_V, 2, 13, "faces of 2: 2 x 12"},
        {ENVL_LAYOUT_CROSS_V, 7, 7, "faces of 1: 3 x 4; of 2: 6 x 8"},
        {ENVL_LAYOUT_CROSS_H, 9, 6, "faces of 2: 8 x 6"},
        {ENVL_LAYOUT_EXR_CUBE, 4, 25, "N x 6N"},
    };
    for (size_t i = 0; i < sizeof part / sizeof part[0]; i++) {
        envl_image im = {0};
        if (envl__image_alloc(&im, part[i].w, part[i].h, NULL, "t") != ENVL_OK)
            abort();
        CHECK_RC(envl__layout_to_latlong(&im, part[i].layout, 8, &out), ENVL_ERR_FORMAT);
        CHECK(out.px == NULL && strstr(envl_last_error(), part[i].fits));
        envl__image_free(&im);
    }
    /* the same sizes a face larger fill it: read */
    envl_image full = {0};
    if (envl__image_alloc(&full, 12, 9, NULL, "t") != ENVL_OK)
        abort();
    CHECK_OK(envl__layout_to_latlong(&full, ENVL_LAYOUT_CROSS_H, 8, &out));
    envl__image_free(&out);
    envl__image_free(&full);
}

int main(void)
{
    setvbuf(stdout, NULL, _IONBF, 0);
    test_guess();
    test_exr_cube_formulas();
    test_errors();
    test_accuracy();
    test_orientation();
    test_round_trip();
    test_continuity();
    test_same_scene();
    test_openexr_files();
    return check_report("test_layout");
}
