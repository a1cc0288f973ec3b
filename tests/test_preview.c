/* envlight preview (src/export/preview.c): the tone curves and the sRGB encoding against their
 * formulas, the picture's size, a constant map rendering every reference sphere at L, a
 * one-bright-pixel map lighting the spheres brightest where n points at it; what the picture
 * tells: each method only in the rows it serves, the light counts the methods returned, the
 * error on the displayed values (bounded for a sun in the mirror), and stderr's notes holding
 * the picture's own texts; the public entry (envl_preview_write) refusing bad options. */
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
    /* docs/methods.md, "Preview": width 80 + 5 (S + 24) + 8;
     * height 66 + (width - 16) / 2 + 4 (S + 28). */
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
    envl_preview_options o = {.sphere_size = 48, .tonemap = ENVL_PREVIEW_TONEMAP_REINHARD,
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
    envl_preview_options o = {.sphere_size = S, .median_count = 4, .fit_count = 1};
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

/* preview.h's picture error written out: display luminance of each pixel, then docs/design.md's
 * relative RMS over the disc's pixels. */
static double shown_y(const envl_preview_options *o, double ev, const double *p)
{
    double d[3];
    for (int k = 0; k < 3; k++) {
        double x = exp2(ev) * p[k];
        d[k] = o->tonemap == ENVL_PREVIEW_TONEMAP_REINHARD ? preview_reinhard(x) : preview_aces(x);
    }
    return 0.2126 * d[0] + 0.7152 * d[1] + 0.0722 * d[2];
}

static double picture_error(const envl_preview_options *o, const preview_data *d, int row, int col)
{
    const int32_t S = d->size;
    double se = 0, sr = 0;
    int n = 0;
    for (int32_t j = 0; j < S; j++)
        for (int32_t i = 0; i < S; i++) {
            double nn[3];
            if (!preview_sphere_normal(S, d->view, i, j, nn))
                continue;
            size_t at = 3 * ((size_t)j * S + i);
            double ya = shown_y(o, d->exposure_ev, d->sphere[row][col] + at);
            double yr = shown_y(o, d->exposure_ev, d->sphere[row][0] + at);
            se += (ya - yr) * (ya - yr);
            sr += yr;
            n++;
        }
    return sqrt(se / n) / (sr / n);
}

/* Which cells are drawn: the reference and the prefiltered maps everywhere, lights in the
 * diffuse and glossy rows, SH in the diffuse row. A cell not served holds no sphere and no
 * error, and the picture leaves its disc empty (background) with the note in its middle; every
 * served cell's error is the formula above (same sums, so equal to rounding). */
static void check_cells(const envl_preview_options *o, const envl_envmap *m, const preview_data *d)
{
    static const int served[PREVIEW_ROWS][PREVIEW_COLS] = {
        {1, 1, 1, 1, 1}, {1, 1, 1, 0, 1}, {1, 1, 1, 0, 1}, {1, 0, 0, 0, 1}};
    const int32_t S = d->size;
    float *rgb = NULL;
    int32_t w, h;
    CHECK_OK(preview_compose(m, o, d, &rgb, &w, &h));
    for (int r = 0; r < PREVIEW_ROWS; r++)
        for (int c = 0; c < PREVIEW_COLS; c++) {
            CHECK(preview_serves(r, c) == served[r][c] && d->served[r][c] == served[r][c]);
            if (c == 0)
                continue;
            if (served[r][c]) {
                CHECK_NEAR(d->error[r][c], picture_error(o, d, r, c), 1e-12);
                continue;
            }
            CHECK(d->error[r][c] == -1);
            int lit = 0;
            for (int32_t i = 0; i < 3 * S * S; i++)
                lit += d->sphere[r][c][i] != 0;
            CHECK(lit == 0);
            int32_t x0, y0;
            preview_sphere_origin(S, r, c, &x0, &y0);
            const float *px = rgb ? rgb + 3 * ((size_t)(y0 + S / 6) * w + x0 + S / 2) : NULL;
            CHECK(px && px[0] == 0.012f && px[1] == 0.012f && px[2] == 0.012f);
            char t0[32], t1[32];
            preview_cell_text(o, d, r, c, 0, t0, sizeof t0);
            preview_cell_text(o, d, r, c, 1, t1, sizeof t1);
            CHECK(!strcmp(t0, c == 3 ? "SH:" : "lights:"));
            CHECK(!strcmp(t1, c == 3 ? "diffuse only" : "no mirror"));
        }
    free(rgb);
}

/* A sun in the mirror. Constant sky L = 1 (128 x 64) and one pixel of 10^4 at (47, 31), whose
 * reflection lands near the ball's centre (it is 0.035 rad from v, 0.4 sphere pixel). The
 * reference's residual keeps that pixel at luminance T = 50 x the mean (146; the library's
 * split) and deposits the excess (L - T) dw into the sphere pixel reflecting its centre; the
 * prefiltered mirror level (the map area-resampled to 512: each map pixel 4 x 4 texels) spreads
 * it over the bilinear support of those texels, 5 texels = 0.061 rad, looked up at 16 points
 * per sphere pixel. Near the centre R turns by 2 / sqrt(1 - r^2) >= 2 times the screen offset,
 * so a sphere pixel spans >= 2 (2 / S) = 0.083 rad of R > 0.061: the sun region, the residual's
 * pixel at T and the deposit meet at most 2 x 2 sphere pixels (where the pixel was 0 before the
 * residual kept T, the same 2 x 2: the bound holds either way). Everywhere
 * else both spheres are L (the level's area weights: float rounding, 1e-6). So with displayed
 * luminance Y in [0, 1] (Reinhard, EV 0: Y(L) = 0.5), the error is at most
 * sqrt((4 + N (1e-6)^2) / N) / (0.5 (N - 4) / N) over the N disc pixels. (The radiance measure
 * gave thousands of percent here: the sun's pixel is ~3500 where the sky is 1.) */
static void test_mirror_sun(void)
{
    const int32_t W = 128, H = 64, S = 48;
    float *px = malloc(sizeof(float) * W * H * 3);
    for (int i = 0; i < W * H * 3; i++)
        px[i] = 1;
    for (int k = 0; k < 3; k++)
        px[3 * (31 * W + 47) + k] = 1e4f;
    envl_envmap *m = map_from(px, W, H);
    free(px);
    envl_preview_options o = {.sphere_size = S, .tonemap = ENVL_PREVIEW_TONEMAP_REINHARD,
                              .exposure_set = 1, .exposure_ev = 0, .median_count = 4,
                              .fit_count = 1, .reference_width = 64};
    preview_data d;
    CHECK_OK(preview_compute(m, &o, NULL, &d));
    int n = 0;
    for (int32_t j = 0; j < S; j++)
        for (int32_t i = 0; i < S; i++) {
            double nn[3];
            n += preview_sphere_normal(S, d.view, i, j, nn);
        }
    double bound = sqrt((4 + n * 1e-12) / n) / (0.5 * (n - 4) / n);
    CHECK(d.error[3][4] >= 0 && d.error[3][4] <= bound);
    check_cells(&o, m, &d);
    preview_data_free(&d);
    envl_envmap_free(m);
}

/* preview_compute with its notes written to the file `name` under the test folder, read back
 * into notes (size bytes, NUL-terminated). */
static void compute_with_notes(envl_envmap *m, const envl_preview_options *o, const char *name,
                               preview_data *d, char *notes, size_t size)
{
    FILE *f = fopen(tmp_path(name), "w+");
    CHECK(f != NULL);
    CHECK_OK(preview_compute(m, o, f, d));
    notes[0] = 0;
    if (f) {
        rewind(f);
        notes[fread(notes, 1, size - 1, f)] = 0;
        fclose(f);
    }
}

/* The built-in sky at 128 wide, -k 6, --diffuse oren-nayar: the fit stops at fewer lights
 * (docs/methods.md, "Lights"), and the header, the legend's count and stderr say how many it
 * returned; stderr's notes are printed once everything is computed and hold, per column, the
 * very texts under its spheres (no -100 % for an error not yet set) and docs/design.md's diffuse
 * error. */
static void test_counts_and_notes(void)
{
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 128}, &m));
    envl_preview_options o = {.sphere_size = 48, .fit_count = 6, .median_count = 8,
                              .reference_width = 64, .diffuse = ENVL_PREVIEW_DIFFUSE_OREN_NAYAR};
    preview_data d;
    char notes[8192];
    compute_with_notes(m, &o, "preview_notes.txt", &d, notes, sizeof notes);
    CHECK(d.fit_lights == envl_lights_count(d.fit) && d.fit_lights < 6);
    CHECK(d.median_lights == envl_lights_count(d.median) && d.median_lights == 8);
    char h[32], want[64];
    preview_column_head(&d, 2, 0, h, sizeof h);
    snprintf(want, sizeof want, "fit %d light%s", (int)d.fit_lights, d.fit_lights == 1 ? "" : "s");
    CHECK(!strcmp(h, want));
    preview_column_head(&d, 1, 1, h, sizeof h);
    CHECK(!strcmp(h, "8 lights"));
    preview_defaults(&o);
    for (int c = 1; c < PREVIEW_COLS; c++) {
        char h0[32], h1[32], head[96], t[32], cell[96];
        preview_column_head(&d, c, 0, h0, sizeof h0);
        preview_column_head(&d, c, 1, h1, sizeof h1);
        snprintf(head, sizeof head, "envlight preview: %s %s:", h0, h1);
        const char *line = strstr(notes, head), *end = line ? strchr(line, '\n') : NULL;
        CHECK(line && end);
        if (!line || !end)
            continue;
        char buf[1024];
        snprintf(buf, sizeof buf, "%.*s", (int)(end - line), line);
        for (int r = 0; r < PREVIEW_ROWS; r++) {
            preview_cell_text(&o, &d, r, c, 0, t, sizeof t);
            if (r == 0)
                snprintf(cell, sizeof cell, " diffuse %s ", t);
            else if (r < 3)
                snprintf(cell, sizeof cell, " glossy %.2f %s ", o.roughness[r - 1], t);
            else
                snprintf(cell, sizeof cell, " mirror %s ", t);
            CHECK((strstr(buf, cell) != NULL) == (d.served[r][c] != 0));
        }
        CHECK(d.diffuse_error[c] >= 0);
        snprintf(cell, sizeof cell, "docs/design.md diffuse error %.3f %%", 100 * d.diffuse_error[c]);
        CHECK(strstr(buf, cell) != NULL);
    }
    CHECK(!strstr(notes, "-100") && !strstr(notes, "n/a"));
    preview_data_free(&d);
    envl_envmap_free(m);
}

/* The library's split written out from sun_split.c's rule, as the oracle: T = 50 x the mean
 * luminance, or, when more than 4096 pixels are above it, the 4097th brightest luminance (as a
 * float); the pixels above T, at most 4096 in row-major order, keep rgb T / Y in the residual
 * (a float), and the excess E = (L - L T / Y) dw is a point at the pixel's centre. */
typedef struct oracle_split {
    float *res;
    int32_t n;
    double d[4096][3], e[4096][3];
} oracle_split;

static int cmp_down(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x > y ? -1 : x < y;
}

static void split_oracle(const envl_envmap *m, oracle_split *o)
{
    int32_t w = envl_envmap_width(m), h = envl_envmap_height(m);
    const float *px = envl_envmap_pixels(m);
    size_t npx = (size_t)w * h, count = 0;
    float *y = malloc(sizeof(float) * npx);
    envl_info info;
    envl_envmap_info(m, &info);
    double T = 50 * envl_luminance(info.power[0], info.power[1], info.power[2]) / (4 * PI);
    for (size_t i = 0; i < npx; i++) {
        double l = envl_luminance(px[3 * i], px[3 * i + 1], px[3 * i + 2]);
        if (l > T)
            y[count++] = (float)l;
    }
    if (count > 4096) {
        qsort(y, count, sizeof(float), cmp_down);
        T = y[4096];
    }
    free(y);
    o->res = malloc(sizeof(float) * 3 * npx);
    memcpy(o->res, px, sizeof(float) * 3 * npx);
    o->n = 0;
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w && o->n < 4096; c++) {
            float *p = o->res + 3 * ((size_t)r * w + c);
            double l = envl_luminance(p[0], p[1], p[2]), f = T / l;
            if (!(l > T))
                continue;
            for (int k = 0; k < 3; k++) {
                double keep = p[k] * f;
                o->e[o->n][k] = (p[k] - keep) * envl_envmap_solid_angle(m, r);
                p[k] = (float)keep;
            }
            envl_envmap_direction(m, c, r, o->d[o->n++]);
        }
}

/* GGX's w(u) = u / q^2, q = ((1 + u) / 2)(alpha^2 - 1) + 1 (docs/design.md, "Error measures"). */
static double ggx_lobe(double u, double a2)
{
    double q = 0.5 * (1 + u) * (a2 - 1) + 1;
    return u > 0 ? u / (q * q) : 0;
}

/* Where the lobes matter: a 512 x 256 map, a dim sky (0.05) and 4608 coloured pixels of
 * luminance 83..166 in the top 9 rows (0.038 sr, so 50 x the mean luminance is 21.4: all 4608
 * above it, more than the 4096 the split takes). The reference's diffuse (Lambert) and GGX
 * glossy rows must be the residual as the library makes it, resampled as the preview resamples
 * it (the same call), summed exactly (envl_irradiance_exact, envl_prefilter_reference) + the
 * points analytically: E max(0, n.l) / pi, E w(R.l) / N(alpha). The oracle's T, residual, E
 * and l are the library's bit for bit (the same expressions on the same floats), so only the
 * order of the operations differs: n = 4097 non-negative terms summed, relative error at most
 * n 2^-53 each way (Higham 2002, 4.2), 2 x 4097 x 1.1e-16 = 9.1e-13 < 1e-12. The notes count
 * the 4096 points. */
static void test_split_reference(void)
{
    const int32_t W = 512, H = 256, S = 48;
    float *px = malloc(sizeof(float) * W * H * 3);
    for (int32_t i = 0; i < W * H; i++) {
        double v = i < 9 * W ? 100 * (1 + (double)(i * 7919 % (9 * W)) / (9 * W)) : 0.05;
        px[3 * i] = (float)v, px[3 * i + 1] = (float)(0.8 * v), px[3 * i + 2] = (float)(0.6 * v);
    }
    envl_envmap *m = map_from(px, W, H);
    free(px);
    oracle_split *os = malloc(sizeof *os);
    split_oracle(m, os);
    CHECK(os->n == 4096);
    envl_envmap *rest = NULL;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .width = 64};
    CHECK_OK(envl_envmap_from_pixels(os->res, W, H, 3, &lo, &rest));
    envl_preview_options o = {.sphere_size = S, .median_count = 4, .fit_count = 1,
                              .reference_width = 64};
    preview_data d;
    char notes[8192];
    compute_with_notes(m, &o, "preview_split_notes.txt", &d, notes, sizeof notes);
    CHECK(strstr(notes, "references on a 64-wide copy + 4096 points") != NULL);
    preview_defaults(&o);
    for (int32_t j = 0; j < S; j++)
        for (int32_t i = 0; i < S; i++) {
            double n[3], R[3], e[3], g[2][3];
            if (!preview_sphere_normal(S, d.view, i, j, n))
                continue;
            double nv = n[0] * d.view[0] + n[1] * d.view[1] + n[2] * d.view[2];
            for (int k = 0; k < 3; k++)
                R[k] = 2 * nv * n[k] - d.view[k];
            CHECK_OK(envl_irradiance_exact(rest, 1, n, e));
            for (int row = 1; row <= 2; row++)
                CHECK_OK(envl_prefilter_reference(rest, o.roughness[row - 1], 1, R, g[row - 1]));
            for (int k = 0; k < 3; k++)
                e[k] /= PI;
            for (int32_t q = 0; q < os->n; q++) {
                const double *l = os->d[q];
                double nl = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
                double rl = R[0] * l[0] + R[1] * l[1] + R[2] * l[2];
                for (int row = 1; row <= 2; row++) {
                    double a = o.roughness[row - 1] * o.roughness[row - 1];
                    double wl = ggx_lobe(rl, a * a) / envl_ggx_lobe_norm(a);
                    for (int k = 0; k < 3; k++)
                        g[row - 1][k] += os->e[q][k] * wl;
                }
                for (int k = 0; k < 3; k++)
                    e[k] += os->e[q][k] * fmax(0, nl) / PI;
            }
            for (int k = 0; k < 3; k++) {
                size_t at = 3 * ((size_t)j * S + i) + k;
                CHECK_REL(d.sphere[0][0][at], e[k], 1e-12);
                CHECK_REL(d.sphere[1][0][at], g[0][k], 1e-12);
                CHECK_REL(d.sphere[2][0][at], g[1][k], 1e-12);
            }
        }
    free(os->res);
    free(os);
    preview_data_free(&d);
    envl_envmap_free(rest);
    envl_envmap_free(m);
}

/* The public entry refuses options outside the command line's ranges (envlight.h) before any
 * work, and writes nothing. */
/* The map's band at the top of the picture (x from 8, y from 18, (width - 16) & ~1 wide and
 * half as tall; docs/methods.md, "Preview") shows the whole map whatever its aspect: a 3 x 1 map
 * was resampled in proportion, a third as tall as the band, and the band read past its end
 * (a crash); a 64 x 40 map showed its top 80 %. Here the map is A above the equator and B
 * below it (a 3 x 1 map: all A); each band row is A or B by its latitude (the two rows next
 * to the equator apart), Reinhard at exposure 0: every grey pixel of the band is the row's
 * value (the median cut's outlines and the lights' marks drawn over it are cyan, yellow and
 * magenta), and most of the band is grey. */
static void check_band(int32_t mw, int32_t mh)
{
    const float A = 0.9f, B = 0.1f;
    float *px = malloc(sizeof(float) * 3 * (size_t)mw * mh);
    for (int32_t r = 0; r < mh; r++)
        for (int32_t i = 0; i < 3 * mw; i++)
            px[3 * (size_t)r * mw + i] = mh == 1 || 2 * r < mh ? A : B;
    envl_envmap *m = map_from(px, mw, mh);
    free(px);
    envl_preview_options o = {.sphere_size = 48, .tonemap = ENVL_PREVIEW_TONEMAP_REINHARD,
                              .exposure_set = 1, .exposure_ev = 0, .title = "band"};
    preview_data d;
    float *rgb = NULL;
    int32_t w = 0, h = 0;
    CHECK_OK(preview_compute(m, &o, NULL, &d));
    CHECK_OK(preview_compose(m, &o, &d, &rgb, &w, &h));
    int32_t bw = (w - 16) & ~1, bh = bw / 2, grey = 0, wrong = 0;
    for (int32_t y = 0; rgb && y < bh; y++) {
        double f = (y + 0.5) / bh; /* the row's centre, 0 at the top, 1 at the bottom */
        if (mh > 1 && fabs(f - 0.5) < 1.0 / bh)
            continue;
        double L = mh == 1 || f < 0.5 ? A : B, expect = L / (1 + L);
        for (int32_t x = 0; x < bw; x++) {
            const float *c = rgb + 3 * ((size_t)(18 + y) * w + 8 + x);
            if (c[0] != c[1] || c[1] != c[2])
                continue; /* an overlay */
            grey++;
            wrong += !(fabs(c[0] - expect) < 1e-6);
        }
    }
    CHECK(wrong == 0);
    CHECK(grey >= 0.5 * bw * bh);
    free(rgb);
    preview_data_free(&d);
    envl_envmap_free(m);
}

static void test_band_of_any_aspect(void)
{
    check_band(3, 1);
    check_band(64, 40);
    check_band(64, 32);
}

static void test_public_entry(void)
{
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 64}, &m));
    const char *path = tmp_path("preview_refused.png");
    remove(path);
    const envl_preview_options bad[] = {{.sphere_size = 47}, {.reference_width = 19},
                                        {.roughness = {0.5, 0.01}}, {.fit_count = 33},
                                        {.tonemap = 2}, {.exposure_set = 1, .exposure_ev = 65}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        CHECK_RC(envl_preview_write(m, &bad[i], path, NULL, NULL, NULL), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_preview_write(m, NULL, NULL, NULL, NULL, NULL), ENVL_ERR_ARGUMENT);
    struct stat st;
    CHECK(stat(path, &st) != 0);
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
    test_mirror_sun();
    test_counts_and_notes();
    test_split_reference();
    test_band_of_any_aspect();
    test_public_entry();
    return check_report("test_preview");
}
