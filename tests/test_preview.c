/* envlight preview (src/preview.c): the tone curves and the sRGB encoding against their
 * formulas, the picture's size, a constant map rendering every reference sphere at L, and a
 * one-bright-pixel map lighting the spheres brightest where n points at it. */
#include "internal.h"
#include "check.h"
#include "preview.h"

static const double PI = 3.14159265358979323846;

/* IEC 61966-2-1 sRGB OETF. */
static double srgb(double v)
{
    v = v > 0 ? (v < 1 ? v : 1) : 0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
}

/* Narkowicz 2015: x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clamped to [0, 1]; Reinhard
 * x / (1 + x). The same formula in the same order of operations: equal to rounding. */
static void test_tone_curves(void)
{
    const double xs[] = {1e-6, 0.01, 0.18, 0.5, 0.8, 1, 2, 7.5};
    for (int i = 0; i < 8; i++) {
        double x = xs[i], aces = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
        CHECK_NEAR(preview_aces(x), fmin(aces, 1), 1e-15);
        CHECK_NEAR(preview_reinhard(x), x / (1 + x), 1e-15);
    }
    CHECK(preview_aces(0) == 0 && preview_aces(-1) == 0 && preview_aces(NAN) == 0);
    CHECK(preview_aces(1e9) == 1); /* the fit passes 1 near x = 10.2 and is clamped */
    CHECK(preview_reinhard(0) == 0 && preview_reinhard(-3) == 0);
    CHECK(preview_reinhard(INFINITY) == 1);
}

/* The PNG path the preview writes through (envl_png_save_srgb) encodes round(255 OETF(v)). */
static void test_srgb_png(void)
{
    const float v[8 * 3] = {0, 0.001f, 0.0031308f, 0.01f, 0.18f, 0.5f, 1, 2,
                            0.02f, 0.04f, 0.1f, 0.2f, 0.3f, 0.6f, 0.9f, 0.99f,
                            -1, 0.05f, 0.25f, 0.35f, 0.45f, 0.7f, 0.75f, 0.95f};
    const char *path = tmp_path("preview_srgb.png");
    CHECK_OK(envl_png_save_srgb(path, v, 8, 1));
    int32_t w, h, ch;
    uint8_t *px = NULL;
    CHECK_OK(envl__png_read(path, &w, &h, &ch, &px));
    CHECK(w == 8 && h == 1 && ch == 3);
    for (int i = 0; px && i < 24; i++)
        CHECK_NEAR(px[i], floor(255 * srgb(v[i]) + 0.5), 0);
    free(px);
}

static void test_layout(void)
{
    /* README: width 80 + 5 (S + 24) + 8; height 66 + (width - 16) / 2 + 4 (S + 28). */
    for (int32_t s = 48; s <= 160; s += 16) {
        int32_t w, h, x, y;
        preview_layout(s, &w, &h);
        CHECK(w == 88 + 5 * (s + 24));
        CHECK(h == 66 + (w - 16) / 2 + 4 * (s + 28));
        preview_sphere_origin(s, 3, 4, &x, &y); /* the last sphere lies inside the picture */
        CHECK(x + s <= w && y + s + 21 <= h);
    }
}

static envl_envmap *map_from(const float *px, int32_t w, int32_t h)
{
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    return m;
}

/* Constant radiance L: every reference sphere is L. Diffuse: E / pi with the exact integrator,
 * whose only error is its horizon slices' midpoint rule, at most 4 pi (h / sub)^2 L in E
 * (tests/test_irradiance.c), h = 2 pi / W, sub = ceil(360 / W / 0.25) = 23 for W = 64. Glossy
 * and mirror: P(R) is a weighted mean of equal values: L to rounding. Through the PNG with
 * exposure 0 and Reinhard: round(255 OETF(L / (1 + L))), +-1 for the float rounding at the
 * half-way points of the quantiser. */
static void test_constant_map(void)
{
    const float L = 0.7f;
    float *px = malloc(sizeof(float) * 64 * 32 * 3);
    for (int i = 0; i < 64 * 32 * 3; i++)
        px[i] = L;
    envl_envmap *m = map_from(px, 64, 32);
    free(px);
    preview_options o = {.sphere_size = 48, .tonemap = PREVIEW_TONEMAP_REINHARD,
                         .exposure_set = 1, .exposure_ev = 0, .title = "constant"};
    preview_data d;
    CHECK_OK(preview_compute(m, &o, NULL, &d));
    double step = 2 * PI / 64 / 23, tol_diffuse = 4 * step * step * L;
    int inside = 0;
    for (int32_t j = 0; j < 48; j++)
        for (int32_t i = 0; i < 48; i++) {
            double n[3];
            if (!preview_sphere_normal(48, d.view, i, j, n))
                continue;
            inside++;
            for (int k = 0; k < 3; k++) {
                size_t at = 3 * ((size_t)j * 48 + i) + k;
                CHECK_NEAR(d.sphere[0][0][at], L, tol_diffuse);
                CHECK_NEAR(d.sphere[1][0][at], L, 1e-12);
                CHECK_NEAR(d.sphere[2][0][at], L, 1e-12);
                CHECK_NEAR(d.sphere[3][0][at], L, 1e-6); /* float pixels averaged */
            }
        }
    /* The disc holds pi 24^2 pixels to within its perimeter. */
    CHECK_NEAR(inside, PI * 24 * 24, 2 * PI * 24);
    float *rgb = NULL;
    int32_t w, h;
    CHECK_OK(preview_compose(m, &o, &d, &rgb, &w, &h));
    const char *path = tmp_path("preview_constant.png");
    CHECK_OK(envl_png_save_srgb(path, rgb, w, h));
    uint8_t *png = NULL;
    int32_t pw, ph, ch;
    CHECK_OK(envl__png_read(path, &pw, &ph, &ch, &png));
    CHECK(pw == w && ph == h && ch == 3);
    double expect = floor(255 * srgb(L / (1 + L)) + 0.5);
    int32_t x0, y0;
    preview_sphere_origin(48, 0, 0, &x0, &y0);
    for (int32_t j = 0; png && j < 48; j++)
        for (int32_t i = 0; i < 48; i++) {
            double n[3];
            if (preview_sphere_normal(48, d.view, i, j, n))
                for (int k = 0; k < 3; k++)
                    CHECK_NEAR(png[3 * ((size_t)(y0 + j) * w + x0 + i) + k], expect, 1);
        }
    free(png);
    free(rgb);
    preview_data_free(&d);
    envl_envmap_free(m);
}

/* One bright pixel: the median cut sphere (lights) and the reference sphere are brightest at
 * the pixel whose normal is nearest the light; nearest means within half a pixel diagonal of
 * the normals' spacing, 2 / S / cos(t) at angle t from the view (t ~ 20 degrees here), so the
 * bound used is one full spacing. */
static void test_one_bright_pixel(void)
{
    const int32_t W = 128, H = 64, S = 64;
    float *px = calloc((size_t)W * H * 3, sizeof(float));
    /* azimuth ~45 degrees (u = 0.375), elevation ~20 degrees (v = 0.389) */
    int32_t c = 48, r = 24;
    for (int k = 0; k < 3; k++)
        px[3 * (r * W + c) + k] = 1000;
    envl_envmap *m = map_from(px, W, H);
    free(px);
    double l[3];
    envl_envmap_direction(m, c, r, l);
    preview_options o = {.sphere_size = S, .median_count = 4, .fit_count = 1};
    preview_data d;
    CHECK_OK(preview_compute(m, &o, NULL, &d));
    for (int col = 0; col <= 1; col++) {
        double best = -1, bn[3] = {0, 0, 0};
        for (int32_t j = 0; j < S; j++)
            for (int32_t i = 0; i < S; i++) {
                double n[3];
                if (!preview_sphere_normal(S, d.view, i, j, n))
                    continue;
                const double *p = d.sphere[0][col] + 3 * ((size_t)j * S + i);
                double y = envl_luminance(p[0], p[1], p[2]);
                if (y > best)
                    best = y, memcpy(bn, n, sizeof bn);
            }
        double t = acos(fmin(1, d.view[0] * l[0] + d.view[1] * l[1] + d.view[2] * l[2]));
        CHECK(best > 0);
        CHECK_NEAR(acos(fmin(1, bn[0] * l[0] + bn[1] * l[1] + bn[2] * l[2])), 0,
                   2.0 / S / cos(t));
    }
    preview_data_free(&d);
    envl_envmap_free(m);
}

int main(void)
{
    mkdir(ENVL_TEST_TMP, 0777);
    test_tone_curves();
    test_srgb_png();
    test_layout();
    test_constant_map();
    test_one_bright_pixel();
    return check_report("test_preview");
}
