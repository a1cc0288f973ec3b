/* Spherical harmonics: the basis against docs/design.md's formulas, A_l, the white furnace, a
 * linear sky, windows, artist forms, and a single bright pixel. */
#include "internal.h"
#include "sh_basis.h"
#include "check.h"

static const double PI = 3.14159265358979323846;

/* docs/design.md's l <= 2 basis (Ramamoorthi & Hanrahan 2001), and orthonormality at higher order
 * by quadrature. */
static void test_basis(void)
{
    double y[81];
    for (int i = 0; i < 20; i++) {
        double d[3];
        envl_fibonacci_direction(i * 37, 1024, d);
        double x = d[0], yy = d[1], z = d[2];
        envl_sh_basis(2, d, y);
        const double expect[9] = {0.282095, 0.488603 * yy, 0.488603 * z, 0.488603 * x,
                                  1.092548 * x * yy, 1.092548 * yy * z,
                                  0.315392 * (3 * z * z - 1), 1.092548 * x * z,
                                  0.546274 * (x * x - yy * yy)};
        for (int k = 0; k < 9; k++)
            CHECK_NEAR(y[k], expect[k], 1e-6); /* docs/design.md's constants have 6 digits */
    }
    /* Orthonormality of order 8 over a fine lat-long quadrature (pixel centres, 512 x 256):
     * <Y_i, Y_j> = delta_ij to O(h^2) with h = pi/256. */
    const int w = 512, h = 256, n = 81;
    double *gram = calloc(n * n, sizeof(double));
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            envl_sh_basis(8, d, y);
            double om = envl_latlong_solid_angle(w, h, r);
            for (int i = 0; i < n; i++)
                for (int j = 0; j <= i; j++)
                    gram[i * n + j] += y[i] * y[j] * om;
        }
    double worst = 0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j <= i; j++)
            worst = fmax(worst, fabs(gram[i * n + j] - (i == j)));
    CHECK(worst < 2e-3); /* 8^2 h^2 / 2 ~ 5e-3 bound for band 8 */
    free(gram);
}

/* A_l: pi, 2pi/3, pi/4, 0, -pi/24, 0, pi/64 (Ramamoorthi & Hanrahan 2001, eq. 9). */
static void test_cosine_lobe(void)
{
    CHECK_NEAR(envl_sh_cosine_lobe(0), PI, 1e-15);
    CHECK_NEAR(envl_sh_cosine_lobe(1), 2 * PI / 3, 1e-15);
    CHECK_NEAR(envl_sh_cosine_lobe(2), PI / 4, 1e-15);
    CHECK_NEAR(envl_sh_cosine_lobe(3), 0, 0);
    CHECK_NEAR(envl_sh_cosine_lobe(4), -PI / 24, 1e-15);
    CHECK_NEAR(envl_sh_cosine_lobe(5), 0, 0);
    CHECK_NEAR(envl_sh_cosine_lobe(6), PI / 64, 1e-15);
    /* no band below 0 (A_-2 was infinite, A_-1 0 by the odd rule) */
    CHECK(envl_sh_cosine_lobe(-1) == 0 && envl_sh_cosine_lobe(-2) == 0);
}

static envl_envmap *constant_map(int w, int h, float v)
{
    float *px = malloc(sizeof(float) * w * h * 3);
    for (int i = 0; i < w * h * 3; i++)
        px[i] = v;
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    free(px);
    return m;
}

/* White furnace: L00 = 2 sqrt(pi) L exactly, every other coefficient below 1e-6 of it, any
 * order; irradiance pi L everywhere. The error measure compares with the integrator, exact
 * but on each normal's horizon, where pixels are sliced in azimuth only: relative error at
 * most 4 (h/S)^2, h the column's angular width, S = clamp(h / 0.25 degree, 4, 256) slices. */
static void check_furnace(envl_envmap *m, double value)
{
    double hdeg = 360.0 / envl_envmap_width(m);
    double sub = fmin(256, fmax(4, ceil(hdeg / 0.25)));
    double hs = hdeg / sub * PI / 180;
    envl_sh *sh;
    CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = 8, .measure = 1}, &sh));
    const double *c = envl_sh_radiance(sh);
    for (int ch = 0; ch < 3; ch++) {
        CHECK_REL(c[ch], 2 * sqrt(PI) * value, 1e-12);
        for (int i = 1; i < 81; i++)
            CHECK(fabs(c[3 * i + ch]) <= 1e-6 * c[ch]);
    }
    envl_sh_summary s;
    envl_sh_get_summary(sh, &s);
    CHECK(s.diffuse_error <= 4 * hs * hs);
    CHECK_REL(s.ambient[0], PI * value, 1e-12);
    CHECK_REL(s.hemi_sky[1], PI * value, 1e-9);
    CHECK_REL(s.hemi_ground[1], PI * value, 1e-9);
    envl_sh_free(sh);
}

static void test_furnace(void)
{
    envl_envmap *m = constant_map(256, 128, 1.0f);
    check_furnace(m, 1.0);
    envl_envmap_free(m);
    m = constant_map(3, 1, 2.5f);
    check_furnace(m, 2.5);
    envl_envmap_free(m);
    /* the real files, when present */
    const char *files[] = {"synthetic/white128.hdr", "synthetic/pi128.hdr"};
    for (int i = 0; i < 2; i++) {
        const char *p = shared_data(files[i]);
        if (!p)
            continue;
        CHECK_OK(envl_envmap_load(p, &(envl_load_options){.layout = 1}, &m));
        envl_info info;
        envl_envmap_info(m, &info);
        check_furnace(m, info.max[0]); /* constant: its max is its value */
        envl_envmap_free(m);
    }
}

/* L = a + b z (z of the pixel centre): R00 = 2 sqrt(pi) a, R10 = b sqrt(4 pi / 3) up to the
 * map's O(h^2); irradiance pi a + (2 pi / 3) b n_z. */
static void test_linear_z(void)
{
    const int w = 256, h = 128;
    float *px = malloc(sizeof(float) * w * h * 3);
    const double a = 1.5, b = 0.75;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            for (int k = 0; k < 3; k++)
                px[3 * (r * w + c) + k] = (float)(a + b * d[2]);
        }
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    envl_sh *sh;
    CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = 2, .measure = 1}, &sh));
    const double *c = envl_sh_radiance(sh), hh = PI / h, tol = 2 * hh * hh * (a + b);
    CHECK_NEAR(c[0], 2 * sqrt(PI) * a, tol);
    CHECK_NEAR(c[3 * 2], b * sqrt(4 * PI / 3), tol);
    for (int i = 1; i < 9; i++)
        if (i != 2)
            CHECK_NEAR(c[3 * i], 0, tol);
    double normals[6] = {0, 0, 1, 0.6, 0, -0.8}, e[6];
    CHECK_OK(envl_sh_eval_irradiance(sh, 2, normals, e));
    CHECK_NEAR(e[0], PI * a + 2 * PI / 3 * b, 4 * tol);
    CHECK_NEAR(e[3], PI * a - 0.8 * 2 * PI / 3 * b, 4 * tol);
    envl_sh_summary s;
    envl_sh_get_summary(sh, &s);
    /* artist forms: ambient pi a, dz = (2 pi / 3) b; hemispheric axis +Z */
    CHECK_NEAR(s.ambient[0], PI * a, 4 * tol);
    CHECK_NEAR(s.deltas[2][0], 2 * PI / 3 * b, 4 * tol);
    CHECK_NEAR(s.hemi_axis[2], 1.0, 1e-9);
    CHECK_NEAR(s.hemi_sky[0], PI * a + 2 * PI / 3 * b, 4 * tol);
    CHECK_NEAR(s.hemi_ground[0], PI * a - 2 * PI / 3 * b, 4 * tol);
    envl_sh_free(sh);
    envl_envmap_free(m);
    free(px);
}

/* One bright pixel (1e6 over 1e-3): no NaN; order 2 rings to negative irradiance; auto finds
 * the least window that removes it; hann and lanczos factors as defined. */
static void test_bright_pixel_windows(void)
{
    const int w = 256, h = 128;
    float *px = malloc(sizeof(float) * w * h * 3);
    for (int i = 0; i < w * h * 3; i++)
        px[i] = 1e-3f;
    for (int k = 0; k < 3; k++)
        px[3 * (40 * w + 77) + k] = 1e6f;
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    for (int order = 1; order <= 8; order++) {
        envl_sh *none, *autow, *hannw, *lanc;
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = order, .window = ENVL_WINDOW_NONE, .measure = 1}, &none));
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = order, .window = ENVL_WINDOW_AUTO, .measure = 1}, &autow));
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = order, .window = ENVL_WINDOW_HANN, .measure = 1}, &hannw));
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = order, .window = ENVL_WINDOW_LANCZOS, .measure = 1}, &lanc));
        envl_sh_summary sn, sa;
        envl_sh_get_summary(none, &sn);
        envl_sh_get_summary(autow, &sa);
        CHECK(isfinite(sn.diffuse_error) && isfinite(sa.diffuse_error));
        CHECK(sa.min_irradiance >= 0);
        if (sn.min_irradiance >= 0) {
            CHECK(sa.window_width == 0); /* nothing to fix: no window */
        } else {
            CHECK(sa.window_width > 0); /* narrower than order + 1 = harder than Hann */
            /* least windowing: a slightly wider window (weaker) rings again */
            double wd = sa.window_width * 1.01;
            const double *raw = envl_sh_radiance(none);
            double d[3], y[81], worst = INFINITY;
            for (int i = 0; i < 4096; i++) {
                envl_fibonacci_direction(i, 4096, d);
                envl_sh_basis(order, d, y);
                double e = 0;
                for (int l = 0; l <= order; l++)
                    for (int mm = -l; mm <= l; mm++) {
                        int j = l * (l + 1) + mm;
                        double f = 0.5 * (1 + cos(PI * l / wd));
                        e += envl_sh_cosine_lobe(l) * f * y[j] *
                             envl__lum(raw[3 * j], raw[3 * j + 1], raw[3 * j + 2]);
                    }
                worst = fmin(worst, e);
            }
            CHECK(worst < 0);
        }
        const double *fh = envl_sh_window_factors(hannw), *fl = envl_sh_window_factors(lanc);
        for (int l = 0; l <= order; l++) {
            double x = PI * l / (order + 1);
            CHECK_NEAR(fh[l], 0.5 * (1 + cos(x)), 1e-15);
            CHECK_NEAR(fl[l], l ? sin(x) / x : 1.0, 1e-15);
        }
        envl_sh_free(none);
        envl_sh_free(autow);
        envl_sh_free(hannw);
        envl_sh_free(lanc);
    }
    envl_envmap_free(m);
    free(px);
}

/* Pixels near FLT_MAX (issue 19): a float lane of the projection summed 8 of them and
 * overflowed to inf / NaN. A map with a few 3e38 pixels over 1 is exactly 1024 times the same
 * map divided by 1024 (whose sums stay far from FLT_MAX): the power-of-two scaling is exact,
 * so the coefficients agree bit for bit; a constant 3e38 gives L00 = 2 sqrt(pi) 3e38. */
static void test_huge_values(void)
{
    const int w = 256, h = 128;
    float *px = malloc(sizeof(float) * w * h * 3), *small = malloc(sizeof(float) * w * h * 3);
    for (int i = 0; i < w * h * 3; i++)
        px[i] = 1.0f;
    for (int j = 0; j < 40; j++) /* a cluster: one block of 8 x 5 pixels */
        for (int k = 0; k < 3; k++)
            px[3 * ((30 + j / 8) * w + 100 + j % 8) + k] = 3e38f;
    for (int i = 0; i < w * h * 3; i++)
        small[i] = px[i] / 1024.0f;
    envl_envmap *m, *ms;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    CHECK_OK(envl_envmap_from_pixels(small, w, h, 3, &lo, &ms));
    envl_sh *a = NULL, *b = NULL;
    CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = 4, .measure = 1}, &a));
    CHECK_OK(envl_sh_compute(ms, &(envl_sh_options){.order = 4, .measure = 1}, &b));
    if (a && b) {
        const double *ra = envl_sh_radiance(a), *rb = envl_sh_radiance(b);
        for (int i = 0; i < 25 * 3; i++) {
            CHECK(isfinite(ra[i]));
            CHECK_NEAR(ra[i], 1024.0 * rb[i], 0);
        }
        envl_sh_summary s;
        envl_sh_get_summary(a, &s);
        CHECK(isfinite(s.diffuse_error) && isfinite(s.hemi_sky[0]) && isfinite(s.hemi_ground[0]));
    }
    envl_sh_free(a);
    envl_sh_free(b);
    envl_envmap_free(m);
    envl_envmap_free(ms);
    for (int i = 0; i < w * h * 3; i++)
        px[i] = 3e38f;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = 2, .measure = 1}, &a));
    if (a) {
        /* a float lane adds 8 equal terms: 7 roundings, relative 7 u = 7 x 2^-24 = 4.2e-7
         * (blocks and rows add in double); the diffuse error, at most that much again from
         * the same rounding in bands 1-2: 2 x 7 u */
        const double u = ldexp(1.0, -24);
        CHECK_REL(envl_sh_radiance(a)[0], 2 * sqrt(PI) * (double)3e38f, 7 * u);
        envl_sh_summary s;
        envl_sh_get_summary(a, &s);
        CHECK_NEAR(s.diffuse_error, 0, 14 * u);
    }
    envl_sh_free(a);
    envl_envmap_free(m);
    free(px);
    free(small);
}

/* Negative light (issue 19). The auto window keeps every channel >= 0 (a blue spike over a
 * yellow map rings in blue while the luminance stays positive), and the hemispheric pair is
 * never negative: where the plain linear fit (ambient -+ c1) has a negative end, the pair is
 * the best fit with both ends >= 0, c0 = c1 = (3 ambient + |c1|) / 4 (sh.c's hemi_pair). */
static void test_never_negative(void)
{
    const int w = 128, h = 64;
    float *px = malloc(sizeof(float) * w * h * 3);
    for (int i = 0; i < w * h; i++) {
        px[3 * i] = px[3 * i + 1] = 1.0f;
        px[3 * i + 2] = 0.01f;
    }
    px[3 * (20 * w + 40) + 2] = 2e4f;
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    for (int win = 0; win < 2; win++) {
        envl_sh *sh;
        int32_t window = win ? ENVL_WINDOW_AUTO : ENVL_WINDOW_NONE;
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = 2, .window = window, .measure = 1}, &sh));
        envl_sh_summary s;
        envl_sh_get_summary(sh, &s);
        double least = INFINITY, d[3], e[3];
        for (int i = 0; i < 4096; i++) {
            envl_fibonacci_direction(i, 4096, d);
            envl_sh_eval_irradiance(sh, 1, d, e);
            least = fmin(least, fmin(e[0], fmin(e[1], e[2])));
        }
        if (win) {
            CHECK(least >= 0);
            CHECK(s.window_width > 0);
        } else {
            CHECK(least < 0);             /* the map does ring: the test means something */
            CHECK(s.min_irradiance >= 0); /* ... in blue only: luminance stays positive */
        }
        int clamped = 0;
        for (int ch = 0; ch < 3; ch++) {
            CHECK(s.hemi_sky[ch] >= 0 && s.hemi_ground[ch] >= 0);
            double c1 = 0;
            for (int a = 0; a < 3; a++)
                c1 += s.deltas[a][ch] * s.hemi_axis[a];
            double a0 = s.ambient[ch];
            if (a0 - fabs(c1) < 0) {
                clamped++;
                double lit = (3 * a0 + fabs(c1)) / 2, tol = 1e-12 * lit;
                CHECK_NEAR(c1 > 0 ? s.hemi_sky[ch] : s.hemi_ground[ch], lit, tol);
                CHECK_NEAR(c1 > 0 ? s.hemi_ground[ch] : s.hemi_sky[ch], 0, 0);
            } else {
                CHECK_NEAR(s.hemi_sky[ch], a0 + c1, 1e-12 * (a0 + fabs(c1)));
                CHECK_NEAR(s.hemi_ground[ch], a0 - c1, 1e-12 * (a0 + fabs(c1)));
            }
        }
        CHECK(clamped > 0); /* the blue spike's plain fit has a negative end */
        envl_sh_free(sh);
    }
    envl_envmap_free(m);
    free(px);
}

/* Same coefficients at 1 and 4 threads, bit for bit. */
static void test_threads(void)
{
    envl_envmap *sky;
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 256}, &sky));
    const float *p = envl_envmap_pixels(sky);
    envl_envmap *a, *b;
    CHECK_OK(envl_envmap_from_pixels(p, 256, 128, 3, &(envl_load_options){1, .threads = 1}, &a));
    CHECK_OK(envl_envmap_from_pixels(p, 256, 128, 3, &(envl_load_options){1, .threads = 4}, &b));
    envl_sh *sa, *sb;
    CHECK_OK(envl_sh_compute(a, &(envl_sh_options){.order = 8, .measure = 1}, &sa));
    CHECK_OK(envl_sh_compute(b, &(envl_sh_options){.order = 8, .measure = 1}, &sb));
    CHECK(memcmp(envl_sh_radiance(sa), envl_sh_radiance(sb), sizeof(double) * 81 * 3) == 0);
    envl_sh_free(sa);
    envl_sh_free(sb);
    envl_envmap_free(a);
    envl_envmap_free(b);
    envl_envmap_free(sky);
}

/* SH orders in options (docs/design.md, "Spherical harmonics"): the field holds the order, 0
 * (and NULL options) means the default 2, ENVL_ORDER_0 the order 0, whose one coefficient on a
 * constant map L is 2 sqrt(pi) L (Y00 = 1 / (2 sqrt(pi)) integrated over 4 pi). The request's
 * diffuse SH reads its sh_order the same way; orders outside 0..32 are refused. */
static void test_orders(void)
{
    envl_envmap *m = constant_map(64, 32, 1.5f);
    static const struct { int32_t field, order; } cases[] = {
        {0, 2}, {ENVL_ORDER_0, 0}, {1, 1}, {5, 5}, {32, 32}};
    for (int i = 0; i < 5; i++) {
        envl_sh *sh;
        CHECK_OK(envl_sh_compute(m, &(envl_sh_options){.order = cases[i].field, .measure = 1}, &sh));
        envl_sh_summary s;
        envl_sh_get_summary(sh, &s);
        CHECK(s.order == cases[i].order);
        CHECK_REL(envl_sh_radiance(sh)[1], 2 * sqrt(PI) * 1.5, 1e-12);
        envl_sh_free(sh);
    }
    envl_sh *sh;
    CHECK_OK(envl_sh_compute(m, NULL, &sh));
    envl_sh_summary s;
    envl_sh_get_summary(sh, &s);
    CHECK(s.order == ENVL_DEFAULT_ORDER);
    envl_sh_free(sh);
    CHECK_RC(envl_sh_compute(m, &(envl_sh_options){.order = 33, .measure = 1}, &sh), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_sh_compute(m, &(envl_sh_options){.order = -1, .measure = 1}, &sh), ENVL_ERR_ARGUMENT);
    envl_products *p;
    CHECK_OK(envl_compute(m, &(envl_request){.diffuse = 1, .sh_order = ENVL_ORDER_0}, &p));
    envl_sh_get_summary(envl_products_sh(p), &s);
    CHECK(s.order == 0);
    envl_products_free(p);
    envl_envmap_free(m);
}

/* The glTF frame: vectors turned as Blender's glTF exporter turns them, and SH coefficients
 * turned exactly at any order: for random coefficients c, sum c'_i Y_i(T d) = sum c_i Y_i(d)
 * at random d. Tolerance 1e-9 of sum |c_i|: each band's matrix sums (L + 1)(2 L + 2) terms
 * of at most |Y|^2 <= (2 L + 1) / 4 pi, and the check (L + 1)^2 more, each rounded by 2^-53:
 * below 1e-10 at L = 32. */
static void test_frames(void)
{
    CHECK(envl_frame_from_name("gltf") == ENVL_FRAME_GLTF);
    CHECK(envl_frame_from_name("blender") == ENVL_FRAME_BLENDER);
    CHECK(envl_frame_from_name("unity") == -1 && envl_frame_name(7) == NULL);
    const double up[3] = {0, 0, 1}, y[3] = {0, 1, 0}, x[3] = {1, 0, 0};
    double v[3];
    envl_frame_vector(ENVL_FRAME_GLTF, up, v);
    CHECK(v[0] == 0 && v[1] == 1 && v[2] == 0); /* up is +Y */
    envl_frame_vector(ENVL_FRAME_GLTF, y, v);
    CHECK(v[0] == 0 && v[1] == 0 && v[2] == -1); /* Blender's +Y (left of the map's centre) */
    envl_frame_vector(ENVL_FRAME_GLTF, x, v);
    CHECK(v[0] == 1 && v[1] == 0 && v[2] == 0);
    const int orders[] = {0, 1, 2, 3, 8, 16, 32};
    uint32_t seed = 7;
    for (size_t t = 0; t < sizeof orders / sizeof orders[0]; t++) {
        int L = orders[t], n = envl_sh_count(L);
        double *c = malloc(sizeof(double) * 3 * n), *g = malloc(sizeof(double) * 3 * n);
        double *y0 = malloc(sizeof(double) * n), *y1 = malloc(sizeof(double) * n), scale = 0;
        for (int i = 0; i < 3 * n; i++) {
            seed = seed * 1664525u + 1013904223u;
            c[i] = (seed >> 8) / 8388608.0 - 1.0;
            scale += fabs(c[i]);
        }
        CHECK_OK(envl_sh_to_frame(ENVL_FRAME_GLTF, L, 3, c, g));
        double worst = 0;
        for (int k = 0; k < 200; k++) {
            double d[3], td[3];
            envl_fibonacci_direction(k, 200, d);
            envl_frame_vector(ENVL_FRAME_GLTF, d, td);
            envl_sh_eval(L, d, y0);
            envl_sh_eval(L, td, y1);
            for (int ch = 0; ch < 3; ch++) {
                double a = 0, b = 0;
                for (int i = 0; i < n; i++)
                    a += c[3 * i + ch] * y0[i], b += g[3 * i + ch] * y1[i];
                worst = fmax(worst, fabs(a - b) / scale);
            }
        }
        printf("SH to the glTF frame, order %d: worst |difference| %.2e of sum |c|\n", L, worst);
        CHECK(worst <= 1e-9);
        /* the canonical frame: the identity, to the quadrature's rounding (as above) */
        CHECK_OK(envl_sh_to_frame(ENVL_FRAME_BLENDER, L, 3, c, g));
        for (int i = 0; i < 3 * n; i++)
            CHECK_NEAR(g[i], c[i], 1e-10);
        free(c), free(g), free(y0), free(y1);
    }
    CHECK(envl_sh_to_frame(5, 2, 3, v, v) == ENVL_ERR_ARGUMENT);
}

int main(void)
{
    test_basis();
    test_orders();
    test_cosine_lobe();
    test_furnace();
    test_linear_z();
    test_bright_pixel_windows();
    test_huge_values();
    test_never_negative();
    test_threads();
    test_frames();
    return check_report("test_sh");
}
