/* The exact integrator against analytic irradiance, the error measure, and the tree-summed
 * reference against the exact integrator (its oracle). */
#include "internal.h"
#include "check.h"
#include "error_measure.h"

#include <dirent.h>

static const double PI = 3.14159265358979323846;

/* A lat-long map whose pixel (c, r) holds a + b z (z at the pixel centre), per channel. */
static envl_envmap *linear_z_map(int w, int h, const double a[3], const double b[3], int threads)
{
    float *px = malloc(sizeof(float) * w * h * 3);
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            for (int k = 0; k < 3; k++)
                px[3 * (r * w + c) + k] = (float)(a[k] + b[k] * d[2]);
        }
    envl_envmap *m = NULL;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
    free(px);
    return m;
}

/* Irradiance of L = a + b z is pi a + (2 pi / 3) b n_z (Ramamoorthi & Hanrahan 2001: the
 * clamped cosine passes band 0 with A0 = pi and band 1 with A1 = 2 pi / 3).
 * The map holds a + b z at each pixel's centre, constant over the pixel: against the
 * continuous a + b z that is off by O(h^2) (h = pi/H) of the radiance scale |a| + |b|, so the
 * tolerance is 4 pi h^2 (|a| + |b|). */
static void test_linear_sky(void)
{
    const int w = 512, h = 256;
    const double a[3] = {1.0, 0.5, 2.0}, b[3] = {0.5, -0.25, 1.5};
    envl_envmap *m = linear_z_map(w, h, a, b, 0);
    double step = PI / h, tol = 4 * PI * step * step * 3.5;
    double normals[6 * 3], e[6 * 3];
    for (int i = 0; i < 6; i++)
        envl_fibonacci_direction(i * 170, 1024, normals + 3 * i);
    CHECK_OK(envl_irradiance_exact(m, 6, normals, e));
    for (int i = 0; i < 6; i++)
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(e[3 * i + k], PI * a[k] + 2 * PI / 3 * b[k] * normals[3 * i + 2], tol);
    envl_envmap_free(m);
}

/* Constant radiance 1: E = pi for every normal, including the poles and the seam. The
 * integrator is exact for wholly lit pixels (closed-form moments) and exact in elevation on
 * the horizon of n, where it takes S = 6 azimuth slices per pixel here (1.4 degrees / 0.25):
 * the slices' midpoint error sums to at most 4 pi (h/S)^2, h = 2 pi / W. */
static void test_constant(void)
{
    const double one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
    envl_envmap *m = linear_z_map(256, 128, one, zero, 0);
    const double normals[] = {0, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 0, 0, 1, 0, 0.6, 0, 0.8};
    double e[18];
    CHECK_OK(envl_irradiance_exact(m, 6, normals, e));
    double step = 2 * PI / 256 / 6;
    for (int i = 0; i < 18; i++)
        CHECK_NEAR(e[i], PI, 4 * PI * step * step);
    envl_envmap_free(m);
}

/* Pixels wider than tall (a map narrower than twice its height) are integrated the other way
 * round (issue 30, 4.4: a map one pixel wide took 256 azimuth slices of every pixel for every
 * normal, 70 s for the reference of a 1 x 16384 map): exact in azimuth, in slices of elevation
 * at most delta = 0.25 degrees high. Their midpoints miss the integrand cos t I(t) (I the
 * exact azimuth integral, |I| <= dphi |L|, its second derivative at most 4 dphi |L|) by at
 * most delta^3 / 24 x 4 dphi |L| a slice; over the sphere's pi / delta x 2 pi / dphi slices
 * that is pi^2 delta^2 / 3 |L|: 4 pi delta^2 |L| bounds it. Checked on constant maps (E = pi)
 * at every 16th of the 1024 normals and the poles, on a linear z map one pixel wide (pi a +
 * 2 pi / 3 b n_z, within that plus test_linear_sky's 4 pi h^2 (|a| + |b|)), and against the same
 * function split into narrow pixels (each pixel into 64 columns), integrated the usual way: the
 * two within the sum of both slicings' bounds (azimuth slices d: 4 pi d^2 |L|). */
static void test_wide_pixels(void)
{
    const double delta = 0.25 * PI / 180;
    double normals[66 * 3];
    for (int i = 0; i < 64; i++)
        envl_fibonacci_direction(16 * i, 1024, normals + 3 * i);
    const double poles[6] = {0, 0, 1, 0, 0, -1};
    memcpy(normals + 3 * 64, poles, sizeof poles);
    double e[66 * 3], e2[66 * 3];
    const double one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
    static const int sizes[4][2] = {{1, 16}, {1, 512}, {3, 40}, {5, 64}};
    for (int s = 0; s < 4; s++) {
        envl_envmap *m = linear_z_map(sizes[s][0], sizes[s][1], one, zero, 0);
        CHECK_OK(envl_irradiance_exact(m, 66, normals, e));
        double worst = 0;
        for (int i = 0; i < 66 * 3; i++)
            worst = fmax(worst, fabs(e[i] - PI));
        printf("  constant %d x %d: worst |E - pi| %.2e (bound %.2e)\n", sizes[s][0],
               sizes[s][1], worst, 4 * PI * delta * delta);
        CHECK(worst <= 4 * PI * delta * delta);
        envl_envmap_free(m);
    }
    const double a[3] = {1.0, 0.5, 2.0}, b[3] = {0.5, -0.25, 1.5};
    envl_envmap *m = linear_z_map(1, 512, a, b, 0);
    CHECK_OK(envl_irradiance_exact(m, 66, normals, e));
    double h = PI / 512;
    for (int i = 0; i < 66; i++)
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(e[3 * i + k], PI * a[k] + 2 * PI / 3 * b[k] * normals[3 * i + 2],
                       4 * PI * (h * h + delta * delta) * (fabs(a[k]) + fabs(b[k])));
    envl_envmap_free(m);
    /* 4 x 64 of values in [0, 1] against its 256 x 64 split */
    enum { W = 4, H = 64, K = 64 };
    static float px[3 * W * H], split[3 * W * K * H];
    for (int i = 0; i < 3 * W * H; i++)
        px[i] = (float)((i * 7919) % 101) / 100.0f;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W * K; c++)
            for (int k = 0; k < 3; k++)
                split[3 * (r * W * K + c) + k] = px[3 * (r * W + c / K) + k];
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *wide, *narrow;
    CHECK_OK(envl_envmap_from_pixels(px, W, H, 3, &lo, &wide));
    CHECK_OK(envl_envmap_from_pixels(split, W * K, H, 3, &lo, &narrow));
    CHECK_OK(envl_irradiance_exact(wide, 66, normals, e));
    CHECK_OK(envl_irradiance_exact(narrow, 66, normals, e2));
    double d = 2 * PI / (W * K) / 6; /* the split's azimuth slices: 360 / 256 / 0.25 -> 6 */
    double worst = 0;
    for (int i = 0; i < 66 * 3; i++)
        worst = fmax(worst, fabs(e[i] - e2[i]));
    printf("  4 x 64 against its 256 x 64 split: worst difference %.2e (bound %.2e)\n", worst,
           4 * PI * (delta * delta + d * d));
    CHECK(worst <= 4 * PI * (delta * delta + d * d));
    envl_envmap_free(wide);
    envl_envmap_free(narrow);
    /* the cost: across the horizon a pixel 1 x 2048 is 0.09 degrees high, one slice (it took
     * 256 for every pixel: 360 / 0.25 azimuth slices, capped), so at most a slice a pixel a
     * normal (on one thread: the counter is the thread's) */
    m = linear_z_map(1, 2048, one, zero, 1);
    envl__horizon_slices = 0;
    CHECK_OK(envl_irradiance_exact(m, 16, normals, e));
    printf("  1 x 2048: %.2f slices a pixel a normal\n", envl__horizon_slices / (2048.0 * 16));
    CHECK(envl__horizon_slices <= 2048 * 16);
    envl_envmap_free(m);
}

/* The reference at 1024 normals is the same at 1 and 4 threads, bit for bit. */
static void test_threads_deterministic(void)
{
    const double a[3] = {1, 2, 3}, b[3] = {3, 2, 1};
    envl_envmap *m1 = linear_z_map(128, 64, a, b, 1), *m4 = linear_z_map(128, 64, a, b, 4);
    const double *r1, *r4;
    CHECK_OK(envl_envmap_reference_irradiance(m1, &r1));
    CHECK_OK(envl_envmap_reference_irradiance(m4, &r4));
    CHECK(memcmp(r1, r4, sizeof(double) * 3 * ENVL_ERROR_NORMALS) == 0);
    const double *again;
    CHECK_OK(envl_envmap_reference_irradiance(m1, &again));
    CHECK(again == r1); /* cached, computed once */
    envl_envmap_free(m1);
    envl_envmap_free(m4);
}

/* Fibonacci points are unit vectors spread evenly: their mean is ~0 and mean z^2 is 1/3. */
static void test_fibonacci(void)
{
    double sum[3] = {0, 0, 0}, z2 = 0;
    for (int i = 0; i < 1024; i++) {
        double d[3];
        envl_fibonacci_direction(i, 1024, d);
        CHECK_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-12);
        for (int k = 0; k < 3; k++)
            sum[k] += d[k];
        z2 += d[2] * d[2];
    }
    /* z_i = 1 - (2i+1)/n sums to exactly 0; x, y sums are bounded by the golden-angle
     * equidistribution (small compared with n). */
    CHECK_NEAR(sum[2], 0, 1e-9);
    /* no such point: i outside 0..n-1, or n < 1 (n = 0 divided by zero) */
    const int32_t bad[4][2] = {{0, 0}, {0, -3}, {-1, 8}, {8, 8}};
    for (int b = 0; b < 4; b++) {
        double d[3] = {9, 9, 9};
        envl_fibonacci_direction(bad[b][0], bad[b][1], d);
        CHECK(d[0] == 0 && d[1] == 0 && d[2] == 0);
    }
    CHECK_NEAR(sum[0] / 1024, 0, 0.01);
    CHECK_NEAR(sum[1] / 1024, 0, 0.01);
    /* mean of z^2 over the midpoints (2i+1)/n - 1: exactly 1/3 - 1/(3 n^2) */
    CHECK_NEAR(z2 / 1024, 1.0 / 3 - 1.0 / (3.0 * 1024 * 1024), 1e-12);
}

/* The error measure: relative RMS of luminance; zero for equal inputs, exact for a scale. */
static void test_error_measure(void)
{
    double e[6] = {1, 1, 1, 3, 3, 3}, a[6] = {1.1, 1.1, 1.1, 3.3, 3.3, 3.3};
    CHECK_NEAR(envl_relative_rms_luminance(2, e, e), 0, 0);
    /* diffs 0.1 and 0.3: rms = sqrt((0.01 + 0.09)/2), mean |Ye| = 2 */
    CHECK_NEAR(envl_relative_rms_luminance(2, a, e), sqrt(0.05) / 2, 1e-12);
    double z[6] = {0};
    CHECK_NEAR(envl_relative_rms_luminance(2, z, z), 0, 0); /* black map: no division by 0 */
    CHECK(isinf(envl_relative_rms_luminance(2, e, z)));
}

/* The tree-summed irradiance (error_measure.h) against envl_irradiance_exact at 1024 normals:
 * every value within its own stated bound, and every bound within the promised tolerance x the
 * mean irradiance of its channel. Besides the bound, the two differ by
 *   - rounding (the same products summed in other orders): 1e-12 of the mean;
 *   - the oracle's own slices: it integrates the pixels within a half-diagonal of the horizon
 *     over `sub` slices in azimuth (irradiance.c), the tree a wholly lit one in closed form. On
 *     a lit pixel the slice midpoints miss A(phi) = nx cos phi + ny sin phi (|A''| <= 1) by at
 *     most dphi d^2 / 24 (d = dphi / sub), times I_r <= sin t1 - sin t0: at most L dw d^2 / 24
 *     a pixel, so at most d^2 / 24 of the power S = 4 x the mean of E: d^2 / 6 of the mean. */
static void check_fast(envl_envmap *m, const char *name)
{
    const int n = ENVL_ERROR_NORMALS;
    double *nrm = malloc(sizeof(double) * 3 * n), *ex = malloc(sizeof(double) * 3 * n);
    double *fa = malloc(sizeof(double) * 3 * n), *bd = malloc(sizeof(double) * 3 * n);
    for (int i = 0; i < n; i++)
        envl_fibonacci_direction(i, n, nrm + 3 * i);
    CHECK_OK(envl_irradiance_exact(m, n, nrm, ex));
    CHECK_OK(envl__irradiance_fast(m, n, nrm, ENVL_REFERENCE_TOLERANCE, fa, bd));
    double mean[3] = {0, 0, 0}, worst = 0;
    for (int i = 0; i < 3 * n; i++)
        mean[i % 3] += ex[i] / n;
    double slice = 2 * PI / envl_envmap_width(m) / 4; /* sub >= 4 (irradiance.c's SUB_MIN) */
    int outside = 0, over = 0;
    for (int i = 0; i < 3 * n; i++) {
        double scale = mean[i % 3];
        outside += !(fabs(fa[i] - ex[i]) <= bd[i] + (slice * slice / 6 + 1e-12) * scale);
        over += !(bd[i] <= ENVL_REFERENCE_TOLERANCE * scale * (1 + 1e-12));
        if (scale > 0)
            worst = fmax(worst, fabs(fa[i] - ex[i]) / scale);
    }
    printf("  %-28s worst |fast - exact| / mean E %.2e, %d outside their bound\n", name,
           worst, outside);
    CHECK(outside == 0);
    CHECK(over == 0);
    free(nrm), free(ex), free(fa), free(bd);
}

/* check(map, its file name) on every map of ../shared/data/latlong_hdri, read `width` wide (0:
 * its own size); skipped when the folder is absent, and under memcheck (the brute force's
 * time: 30-50x slower there, which scripts/valgrind.sh says; the plain and ASan runs check
 * them). */
static void for_each_map(int32_t width, void (*check)(envl_envmap *, const char *))
{
    if (getenv("ENVL_UNDER_MEMCHECK")) {
        printf("  skipped the maps under memcheck (the plain and ASan runs check them)\n");
        return;
    }
    const char *dir = ENVL_SHARED_DATA "/latlong_hdri";
    DIR *d = opendir(dir);
    if (!d) {
        printf("  skipped the maps: %s is absent\n", dir);
        return;
    }
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".hdr"))
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        envl_load_options o = {.width = width};
        envl_envmap *m;
        CHECK_OK(envl_envmap_load(path, &o, &m));
        check(m, e->d_name);
        envl_envmap_free(m);
    }
    closedir(d);
}

static void test_fast_reference(void)
{
    /* the built-in sky (a sun of 0.5 degrees), a lone bright pixel on the equator, a constant */
    envl_envmap *m;
    envl_sky_options so = {.width = 512};
    CHECK_OK(envl_envmap_sky(&so, &m));
    check_fast(m, "built-in sky 512");
    envl_envmap_free(m);
    double a[3] = {1, 2, 3}, b[3] = {0, 0, 0};
    m = linear_z_map(256, 128, a, b, 0);
    check_fast(m, "constant 256");
    envl_envmap_free(m);
    float *px = calloc(256 * 128 * 3, sizeof(float));
    for (int k = 0; k < 3; k++)
        px[3 * (64 * 256 + 100) + k] = 1e6f, px[3 * (10 * 256 + 7) + k] = 1.0f;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, 256, 128, 3, &lo, &m));
    free(px);
    check_fast(m, "one bright pixel 256");
    envl_envmap_free(m);
    /* every map of ../shared/data/latlong_hdri, read at 512 x 256 */
    for_each_map(512, check_fast);
}

/* The split irradiance map on cube faces wider than 32 (irradiance_map.c reads the rest from
 * faces of 32 texels where its bound allows, else sums it at the texel): on maps with no pixel
 * above the split's threshold (the rest is the map, not resampled) every checked
 * texel of a 128-texel face is within ENVL_SPLIT_RELATIVE x max(E, the floor) of
 * envl_irradiance_exact, per channel (the oracle's own slices: 1e-6 of that, see check_fast).
 * The maps: sharp-edged softboxes at 2/3 of the threshold (kinks along their horizons, what
 * the 32-texel faces read bilinearly miss by up to 4.6 % of a dark texel), a black ground
 * under a bright sky (the horizon's kink across every face), and a linear sky (smooth). And
 * with pixels far above it next to a pole (split off and added per texel, each pixel
 * integrated exactly): a 128 x 64 map's top row at 4000 x the rest, a 64 x 32 map's one bottom
 * pixel at 2e5 x; summed at the pixels' centres they were 1.9 % and more off near their
 * horizons (a polar pixel's light sits a good part of its height off its centre). And the
 * built-in sky and every map of ../shared/data/latlong_hdri at 1024 x 512: with the rest area-averaged to 256 wide
 * and the faces' corners read from the coarse faces, adams_place_bridge_1k was 0.58 % off at
 * one texel, studio_small_03_1k 0.52 % at 12. */
static void check_split_faces(envl_envmap *m, const char *name)
{
    const int32_t face = 128, w = 6 * face, stride = 37;
    envl_request q = {.irradiance_map = 1,
                      .prefilter = {.irradiance_width = 4 * face,
                                    .irradiance_method = ENVL_IRRADIANCE_SPLIT,
                                    .layout = ENVL_EXPORT_CUBE}};
    envl_products *p = NULL;
    envl_irradiance_map irr;
    CHECK_OK(envl_compute(m, &q, &p));
    CHECK_OK(envl_products_irradiance(p, &irr));
    CHECK(irr.width == w && irr.height == face && irr.layout == ENVL_LAYOUT_STRIP_H);
    /* every stride-th texel, and the 3 x 3 texels at each corner of each face (read from
     * two face edges at once where the coarse faces are interpolated) */
    int32_t n = w * face / stride, at = 0;
    int32_t *texel = malloc(sizeof(int32_t) * (n + 6 * 4 * 9));
    for (int32_t i = 0; i < n; i++)
        texel[at++] = i * stride;
    for (int32_t f = 0; f < 6; f++)
        for (int32_t corner = 0; corner < 4; corner++)
            for (int32_t k = 0; k < 9; k++) {
                int32_t c = corner & 1 ? face - 1 - k % 3 : k % 3;
                int32_t r = corner & 2 ? face - 1 - k / 3 : k / 3;
                texel[at++] = r * w + f * face + c;
            }
    n = at;
    double *d = malloc(sizeof(double) * 3 * n), *ex = malloc(sizeof(double) * 3 * n);
    for (int32_t i = 0; i < n; i++)
        envl__texel_direction(ENVL_LAYOUT_STRIP_H, w, face, texel[i] % w, texel[i] / w,
                              d + 3 * i);
    CHECK_OK(envl_irradiance_exact(m, n, d, ex));
    double worst = 0, *power;
    envl_info info;
    CHECK_OK(envl_envmap_info(m, &info));
    power = info.power;
    int outside = 0;
    for (int32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double floor = ENVL_TEXEL_DARK * power[k] / 4, ref = fmax(ex[3 * i + k], floor);
            double e = fabs(irr.rgb[3 * (size_t)texel[i] + k] - ex[3 * i + k]) / ref;
            worst = fmax(worst, e);
            outside += !(e <= ENVL_SPLIT_RELATIVE * (1 + 1e-6));
        }
    printf("  %-28s 128-texel faces: worst %.3f %% of max(E, floor) (promise %.1f %%), %d "
           "outside\n", name, 100 * worst, 100 * ENVL_SPLIT_RELATIVE, outside);
    CHECK(outside == 0);
    free(texel), free(d), free(ex);
    envl_products_free(p);
}

static void test_split_faces(void)
{
    const int32_t w = 64, h = 32;
    float *px = malloc(sizeof(float) * 3 * w * h);
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m;
    for (int variant = 0; variant < 2; variant++) {
        for (int32_t r = 0; r < h; r++)
            for (int32_t c = 0; c < w; c++)
                for (int k = 0; k < 3; k++) /* a sky of 1 (bluer), a ground of 0.05 or black */
                    px[3 * (r * w + c) + k] =
                        r < h / 2 ? 0.8f + 0.1f * k : variant ? 0.0f : 0.05f;
        if (!variant) { /* softboxes of 2 x 2 pixels at 2/3 of the threshold, 50 x the mean */
            double mean = 0;
            for (int32_t i = 0; i < w * h; i++)
                mean += envl__lum(px[3 * i], px[3 * i + 1], px[3 * i + 2]) *
                        envl_latlong_solid_angle(w, h, i / w) / (4 * PI);
            static const int32_t box[5][2] = {{5, 7}, {22, 12}, {37, 17}, {50, 5}, {60, 22}};
            for (int b = 0; b < 5; b++)
                for (int32_t r = box[b][1]; r < box[b][1] + 2; r++)
                    for (int32_t c = box[b][0]; c < box[b][0] + 2; c++)
                        for (int k = 0; k < 3; k++)
                            px[3 * (r * w + c) + k] = (float)(50 * 2 / 3.0 * mean);
        }
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
        check_split_faces(m, variant ? "sky over a black ground" : "softboxes");
        envl_envmap_free(m);
    }
    free(px);
    const double a[3] = {1, 1, 1}, b[3] = {0.9, 0.5, 0.2};
    m = linear_z_map(w, h, a, b, 0);
    check_split_faces(m, "linear sky");
    envl_envmap_free(m);
    for (int variant = 0; variant < 2; variant++) {
        int32_t pw = variant ? 64 : 128, ph = pw / 2;
        float *pp = malloc(sizeof(float) * 3 * pw * ph);
        for (int32_t i = 0; i < 3 * pw * ph; i++)
            pp[i] = 0.5f;
        for (int k = 0; k < 3; k++)
            if (variant)
                pp[3 * ((ph - 1) * pw + 5) + k] = 1e5f;
            else
                for (int32_t c = 0; c < pw; c++)
                    pp[3 * c + k] = 2000.0f;
        CHECK_OK(envl_envmap_from_pixels(pp, pw, ph, 3, &lo, &m));
        check_split_faces(m, variant ? "one bright pixel at a pole" : "bright top row");
        envl_envmap_free(m);
        free(pp);
    }
    /* the built-in sky at its default size (the main job's map: a 0.5-degree sun), and every
     * map of ../shared/data/latlong_hdri at its own size, as a user's 1K map */
    envl_sky_options so = {0};
    CHECK_OK(envl_envmap_sky(&so, &m));
    check_split_faces(m, "built-in sky");
    envl_envmap_free(m);
    for_each_map(0, check_split_faces);
}

int main(void)
{
    test_linear_sky();
    test_constant();
    test_wide_pixels();
    test_threads_deterministic();
    test_fibonacci();
    test_error_measure();
    test_fast_reference();
    test_split_faces();
    return check_report("test_irradiance");
}
