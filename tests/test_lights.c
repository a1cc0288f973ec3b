/* Lights: energy bookkeeping, analytic hard cases (constant, one bright pixel, seam, pole,
 * black, tiny maps), determinism across thread counts, a huge map for SAT precision, and the
 * sun method (the built-in sky's sun, no sun, two suns and the count). */
#include "lights_impl.h"
#include "check.h"

static const double PI = 3.14159265358979323846;

static envl_envmap *map_of(const float *px, int w, int h, int threads)
{
    envl_envmap *m = NULL;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG, .threads = threads};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
    return m;
}

static float *filled(int w, int h, float v)
{
    float *px = malloc(sizeof(float) * (size_t)w * h * 3);
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        px[i] = v;
    return px;
}

static double residual_power(const envl_lights *ls, const envl_envmap *m, int k)
{
    const float *r = envl_lights_residual(ls);
    double p = 0;
    for (int y = 0; y < envl_envmap_height(m); y++) {
        double row = 0;
        for (int x = 0; x < envl_envmap_width(m); x++)
            row += r[3 * ((size_t)y * envl_envmap_width(m) + x) + k];
        p += row * envl_envmap_solid_angle(m, y);
    }
    return p;
}

/* Lights + residual = the map's power: the sum of the lights' rgb plus the residual map's own
 * integral, both computed independently of the summary's bookkeeping. Relative 1e-6 (float
 * residual pixels). */
static void check_energy(const envl_lights *ls, const envl_envmap *m)
{
    envl_lights_summary s;
    CHECK_OK(envl_lights_get_summary(ls, &s));
    for (int k = 0; k < 3; k++) {
        double lights = 0;
        for (int i = 0; i < s.count; i++) {
            envl_light l;
            envl_lights_get(ls, i, &l);
            lights += l.rgb[k];
            CHECK(l.rgb[k] >= 0);
            CHECK_NEAR(l.direction[0] * l.direction[0] + l.direction[1] * l.direction[1] +
                       l.direction[2] * l.direction[2], 1.0, 1e-12);
            CHECK(l.angle >= 0 && l.angle <= PI);
        }
        CHECK_REL(lights + residual_power(ls, m, k), s.power[k], 1e-6);
    }
}

/* Constant environment: every method's lights + residual hold the exact power 4 pi L; the fit
 * reproduces the irradiance pi L (order-0 remainder) to 1e-6. */
static void test_constant(void)
{
    float *px = filled(128, 64, 2.0f);
    envl_envmap *m = map_of(px, 128, 64, 0);
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        envl_lights *ls;
        envl_lights_options o = {.method = method, .count = 8, .measure = 1};
        CHECK_OK(envl_lights_compute(m, &o, &ls));
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        CHECK_REL(s.power[1], 4 * PI * 2.0, 1e-12);
        check_energy(ls, m);
        if (method == ENVL_METHOD_FIT)
            CHECK(s.diffuse_error < 1e-6);
        else if (method == ENVL_METHOD_SUN)
            CHECK(s.count == 0); /* no sun (test_sun_none) */
        else
            CHECK_REL(s.lights_power[0], 4 * PI * 2.0, 1e-12); /* cuts take everything */
        envl_lights_free(ls);
    }
    envl_envmap_free(m);
    free(px);
}

/* One bright pixel (1e6 over a sky of 1e-3): one light points at it within the pixel's angular
 * size and carries its energy to 1e-6 relative; nothing is NaN. */
static void test_one_bright_pixel(void)
{
    const int w = 256, h = 128, c0 = 77, r0 = 40;
    float *px = filled(w, h, 1e-3f);
    for (int k = 0; k < 3; k++)
        px[3 * (r0 * w + c0) + k] = 1e6f;
    envl_envmap *m = map_of(px, w, h, 0);
    double d0[3];
    envl_envmap_direction(m, c0, r0, d0);
    double spot = (1e6 - 1e-3) * envl_envmap_solid_angle(m, r0); /* above the sky */
    double pixel_angle = PI / h; /* angular height of a pixel, >= its width here */
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        envl_lights *ls;
        envl_lights_options o = {.method = method, .count = method == ENVL_METHOD_FIT ? 4 : 64, .measure = 1};
        CHECK_OK(envl_lights_compute(m, &o, &ls));
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        CHECK(isfinite(s.diffuse_error));
        int best = -1;
        double best_rgb = -1;
        for (int i = 0; i < s.count; i++) {
            envl_light l;
            envl_lights_get(ls, i, &l);
            for (int k = 0; k < 3; k++)
                CHECK(isfinite(l.rgb[k]) && isfinite(l.direction[k]));
            if (l.rgb[1] > best_rgb) {
                best_rgb = l.rgb[1];
                best = i;
            }
        }
        envl_light l;
        CHECK_OK(envl_lights_get(ls, best, &l));
        double dot = l.direction[0] * d0[0] + l.direction[1] * d0[1] + l.direction[2] * d0[2];
        CHECK(acos(fmin(1.0, dot)) <= pixel_angle);
        /* The light holds the spot plus the sky of its region (1e-3 x its solid angle); the
         * spot's energy to 1e-6. The fit matches irradiance, and a pixel's lobe differs from a
         * point light's by O(h^2) (h: the pixel's angular size), which the fit may give to the
         * remainder: there, h^2. */
        double tol = method == ENVL_METHOD_FIT ? pixel_angle * pixel_angle : 1e-6;
        if (method == ENVL_METHOD_SUN) {
            /* the sun takes the pixel's excess over the threshold T = 50 x the mean luminance,
             * and its solid angle is the pixel's */
            double T = 50.0 * envl_luminance(s.power[0], s.power[1], s.power[2]) / (4 * PI);
            CHECK(s.count == 1);
            CHECK_REL(l.rgb[1], (1e6 - T) * envl_envmap_solid_angle(m, r0), 1e-9);
            CHECK_REL(l.solid_angle, envl_envmap_solid_angle(m, r0), 1e-12);
        } else {
            CHECK_NEAR(l.rgb[1] - 1e-3 * l.solid_angle, spot, tol * spot);
        }
        check_energy(ls, m);
        envl_lights_free(ls);
    }
    envl_envmap_free(m);
    free(px);
}

/* A sun on the seam (azimuth 180 degrees) and at the pole. Median cut splits a dominant sun
 * into equal-energy pieces, as it should; the seam must not cut it otherwise: the lights
 * within (sun radius + one pixel) of the sun hold all its light (luminance 12), and the error
 * is no worse than with the sun in the middle of the map (azimuth 0, same elevation). */
static double seam_error(double elevation, double azimuth, int method)
{
    envl_sky_options so = {.sun_elevation_degrees = elevation, .sun_elevation_is_set = 1,
                           .sun_azimuth_degrees = azimuth, .width = 512};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_lights *ls;
    envl_lights_options o = {.method = method, .count = 16, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    envl_lights_free(ls);
    envl_envmap_free(m);
    return s.diffuse_error;
}

static void test_seam_and_pole(double elevation, double azimuth)
{
    envl_sky_options so = {.sun_elevation_degrees = elevation, .sun_elevation_is_set = 1,
                           .sun_azimuth_degrees = azimuth, .width = 512};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    double el = elevation * PI / 180, az = azimuth * PI / 180;
    double sun[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)};
    static const int cuts[] = {ENVL_METHOD_MEDIAN, ENVL_METHOD_VARIANCE};
    for (int c = 0; c < 2; c++) {
        int method = cuts[c];
        envl_lights *ls;
        envl_lights_options o = {.method = method, .count = 16, .measure = 1};
        CHECK_OK(envl_lights_compute(m, &o, &ls));
        double near = 0, reach = 0.265 * PI / 180 + PI / 256;
        for (int i = 0; i < envl_lights_count(ls); i++) {
            envl_light l;
            envl_lights_get(ls, i, &l);
            double dot = l.direction[0] * sun[0] + l.direction[1] * sun[1] +
                         l.direction[2] * sun[2];
            if (acos(fmin(1.0, dot)) <= reach)
                near += envl_luminance(l.rgb[0], l.rgb[1], l.rgb[2]);
        }
        CHECK(near >= 12.0);
        check_energy(ls, m);
        if (elevation < 90)
            CHECK(seam_error(elevation, azimuth, method) <=
                  1.2 * seam_error(elevation, 0, method));
        envl_lights_free(ls);
    }
    envl_envmap_free(m);
}

/* A black map: no lights, "no light", zero error, nothing divides by zero. */
static void test_black(void)
{
    float *px = filled(64, 32, 0.0f);
    envl_envmap *m = map_of(px, 64, 32, 0);
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        envl_lights *ls;
        envl_lights_options o = {.method = method, .measure = 1};
        CHECK_OK(envl_lights_compute(m, &o, &ls));
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        CHECK(s.no_light == 1 && s.count == 0);
        CHECK(s.diffuse_error == 0.0);
        CHECK(s.lights_power[0] == 0.0 && s.residual_power[0] == 0.0);
        envl_lights_free(ls);
    }
    envl_envmap_free(m);
    free(px);
}

/* 1x1, 2x1, 8192x1 maps, and more lights asked than there are pixels. */
static void test_tiny(void)
{
    const int sizes[][2] = {{1, 1}, {2, 1}, {8192, 1}, {3, 2}};
    for (size_t s = 0; s < 4; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        float *px = filled(w, h, 1.0f);
        px[0] = 5.0f;
        envl_envmap *m = map_of(px, w, h, 0);
        for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
            envl_lights *ls;
            int n = method == ENVL_METHOD_FIT ? 32 : 20000;
            envl_lights_options o = {.method = method, .count = n, .measure = 1};
            CHECK_OK(envl_lights_compute(m, &o, &ls));
            int count = envl_lights_count(ls);
            if (method != ENVL_METHOD_FIT && method != ENVL_METHOD_SUN)
                CHECK(count == (w * h < n ? w * h : n)); /* one light per pixel at most */
            check_energy(ls, m);
            envl_lights_free(ls);
        }
        envl_envmap_free(m);
        free(px);
    }
}

/* Same output at 1 and 4 threads, bit for bit. */
static void test_deterministic(void)
{
    envl_sky_options so = {.width = 256};
    envl_envmap *sky;
    CHECK_OK(envl_envmap_sky(&so, &sky));
    envl_envmap *a = map_of(envl_envmap_pixels(sky), 256, 128, 1);
    envl_envmap *b = map_of(envl_envmap_pixels(sky), 256, 128, 4);
    for (int method = 0; method < ENVL_METHOD_COUNT; method++) {
        envl_lights *la, *lb;
        envl_lights_options o = {.method = method, .count = 8, .measure = 1};
        CHECK_OK(envl_lights_compute(a, &o, &la));
        CHECK_OK(envl_lights_compute(b, &o, &lb));
        CHECK(envl_lights_count(la) == envl_lights_count(lb));
        for (int i = 0; i < envl_lights_count(la); i++) {
            envl_light x, y;
            envl_lights_get(la, i, &x);
            envl_lights_get(lb, i, &y);
            CHECK(memcmp(&x, &y, sizeof x) == 0);
        }
        envl_lights_summary sa, sb;
        envl_lights_get_summary(la, &sa);
        envl_lights_get_summary(lb, &sb);
        CHECK(sa.diffuse_error == sb.diffuse_error);
        envl_lights_free(la);
        envl_lights_free(lb);
    }
    envl_envmap_free(a);
    envl_envmap_free(b);
    envl_envmap_free(sky);
}

/* Median cut of a 16384 x 8192 uniform sky with one small light: the energy median of a
 * region is found from differences of SAT entries that are each ~ the whole map's energy
 * (4 pi). A float table (24-bit mantissa) would lose the ~1e-7 of one pixel; the double table
 * must isolate the light: the light holding it points at its pixel and holds its energy. */
static void test_sat_precision(void)
{
    const int w = 16384, h = 8192, c0 = 12345, r0 = 2345;
    float *px = filled(w, h, 1.0f);
    for (int k = 0; k < 3; k++)
        px[3 * ((size_t)r0 * w + c0) + k] = 101.0f; /* 100 pixels' worth above the sky */
    envl_envmap *m = map_of(px, w, h, 0);
    free(px);
    envl_lights *ls;
    envl_lights_options o = {.method = ENVL_METHOD_MEDIAN, .count = 1 << 14, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    double d0[3];
    envl_envmap_direction(m, c0, r0, d0);
    double omega = envl_envmap_solid_angle(m, r0);
    /* Median cut makes equal-energy regions: 4 pi / 16384 each (~800 pixels). The region with
     * the light holds it (100 omega) plus sky; its centroid is pulled towards the light. */
    int found = 0;
    for (int i = 0; i < envl_lights_count(ls); i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        if (l.rect[0] <= c0 && c0 < l.rect[2] && l.rect[1] <= r0 && r0 < l.rect[3]) {
            found++;
            /* its rgb: the sky over its solid angle plus the light's excess, exactly */
            CHECK_REL(l.rgb[1], l.solid_angle + 100.0 * omega, 1e-9);
        }
    }
    CHECK(found == 1);
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    /* Equal energies: every region's luminance energy is within one strip of the mean. */
    double mean = s.power[1] / envl_lights_count(ls), worst = 0;
    for (int i = 0; i < envl_lights_count(ls); i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        worst = fmax(worst, fabs(l.rgb[1] - mean) / mean);
    }
    printf("SAT precision: %d lights, worst region energy off the mean by %.3g\n",
           envl_lights_count(ls), worst);
    /* Measured: 0.015 with the double table, 0.029 with a float one. */
    CHECK(worst < 0.02);
    /* The region table, where it is hardest: small rectangles at the far corner, whose
     * table entries are ~ 4 pi while the rectangle holds ~3e-6 (one within a block: direct
     * sums; one across three blocks: four table entries and two ragged ends). Each entry is a
     * double sum of 8192 rows: rounding at most 8192 x 2^-53 x 4 pi = 1.1e-11, i.e. 3.4e-6 of
     * such a rectangle in the worst case; a float table (2^-24 x 4 pi = 7.5e-7 per entry)
     * would be off by ~100 %. Within a block the sums are float: 2^-24 relative. */
    const float *px2 = envl_envmap_pixels(m);
    for (int t = 0; t < 6; t++) {
        int x0 = t < 4 ? w - 7 - 3 * t : w - 70 - 5 * t, x1 = t < 4 ? w - 3 * t : w - 3 - t;
        int y0 = h - 5 - t, y1 = h - t;
        double direct = 0;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                const float *p = px2 + 3 * ((size_t)y * w + x);
                direct += envl_luminance(p[0], p[1], p[2]) * envl_envmap_solid_angle(m, y);
            }
        CHECK_REL(envl__rect_energy(m, x0, x1, y0, y1), direct, 1e-5);
    }
    envl_lights_free(ls);
    envl_envmap_free(m);
}

/* A fitted light's size is the uniform disc with its spread: a uniform disc of angular radius
 * rho (1000 over a sky of 1e-4) gives a light of solid angle 2 pi (1 - cos rho). Tolerance: the
 * disc is drawn with pixels of 0.176 degrees, its edge is off by at most half a diagonal,
 * 0.124 degrees, i.e. 2 x 0.124 / 3 = 8.3 % of the solid angle. */
static void test_fit_light_size(void)
{
    const int w = 2048, h = 1024;
    const double rho = 3.0 * PI / 180.0, axis[3] = {0.6, 0.0, 0.8};
    float *px = filled(w, h, 1e-4f);
    envl_envmap *m0 = map_of(px, w, h, 0);
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double d[3];
            envl_envmap_direction(m0, c, r, d);
            if (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2] >= cos(rho))
                for (int k = 0; k < 3; k++)
                    px[3 * ((size_t)r * w + c) + k] = 1000.0f;
        }
    envl_envmap_free(m0);
    envl_envmap *m = map_of(px, w, h, 0);
    envl_lights *ls;
    envl_lights_options o = {.method = ENVL_METHOD_FIT, .count = 1, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    envl_light l;
    CHECK_OK(envl_lights_get(ls, 0, &l));
    double disc = 2.0 * PI * (1.0 - cos(rho));
    printf("fit light of a 3-degree disc: solid angle %.6g (disc %.6g), angle %.3f degrees\n",
           l.solid_angle, disc, l.angle * 180.0 / PI);
    CHECK_REL(l.solid_angle, disc, 0.083);
    CHECK_REL(l.angle, 2.0 * rho, 0.042); /* the square root of the solid angle's bound */
    /* skip_residual: the same lights and error, no residual (a map wider than the fit's
     * 1024-wide copy: the cones' search starts from the copy's rings) */
    envl_lights *lk;
    o.skip_residual = 1;
    CHECK_OK(envl_lights_compute(m, &o, &lk));
    envl_light l2;
    CHECK_OK(envl_lights_get(lk, 0, &l2));
    CHECK(memcmp(&l, &l2, sizeof l) == 0);
    envl_lights_summary s1, s2;
    envl_lights_get_summary(ls, &s1);
    envl_lights_get_summary(lk, &s2);
    CHECK(s1.count == s2.count && s1.diffuse_error == s2.diffuse_error);
    CHECK(memcmp(s1.residual_power, s2.residual_power, sizeof s1.residual_power) == 0);
    CHECK(envl_lights_residual(ls) != NULL);
    CHECK(envl_lights_residual(lk) == NULL);
    CHECK(strstr(envl_last_error(), "skip_residual") != NULL);
    envl_lights_free(lk);
    envl_lights_free(ls);
    envl_envmap_free(m);
    free(px);
}

/* Lights alone (no remainder) on a constant map: the unconstrained fit would want lights far
 * brighter than the sky around them; each is held at its 45-degree cone's power instead (it
 * used to return no light at all). The cone of a constant map holds 2 pi (1 - cos 45) L,
 * drawn with pixels of 1.4 degrees: edge off by half a diagonal, 1 degree of 45, about
 * 2 x 1/45 = 4.4 % of the cap's power at most. */
static void test_fit_lights_alone(void)
{
    const int w = 256, h = 128;
    float *px = filled(w, h, 2.0f);
    envl_envmap *m = map_of(px, w, h, 0);
    envl_lights *ls;
    envl_lights_options o = {.method = ENVL_METHOD_FIT, .count = 4, .remainder_order = ENVL_REMAINDER_NONE, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    printf("fit, lights alone, constant map: %d lights, error %.4f\n", (int)s.count,
           s.diffuse_error);
    CHECK(s.count >= 1);
    CHECK(s.diffuse_error < 1.0); /* no light at all is 100 % off */
    double cap = 2.0 * PI * (1.0 - cos(PI / 4)) * 2.0;
    for (int i = 0; i < s.count; i++) {
        envl_light l;
        envl_lights_get(ls, i, &l);
        CHECK(l.rgb[1] > 0 && l.rgb[1] <= cap * 1.044);
    }
    envl_lights_free(ls);
    envl_envmap_free(m);
    free(px);
}

/* The region table against brute force: random rectangles (wrapping across the seam too) of a
 * random map whose width is no multiple of the block, every sum to 1e-9 relative (double sums
 * in another order: ~1e-13; the direction sums within a block are float: each product and
 * weight rounded, 2 x 2^-24, and eight adds a lane, 8 x 2^-24, of the block's sum of Y, so
 * at most 10 x 2^-24 = 6e-7 of the rectangle's energy, asserted 1e-6); and the median
 * column, which must be where the running energy first reaches half. */
static void test_region_table(void)
{
    const int w = 333, h = 97;
    float *px = malloc(sizeof(float) * 3 * w * h);
    uint32_t seed = 7;
    for (int i = 0; i < 3 * w * h; i++) {
        seed = seed * 1664525u + 1013904223u;
        px[i] = (float)((seed >> 8) / 16777216.0 * (i % 31 == 0 ? 1000.0 : 1.0));
    }
    envl_envmap *m = map_of(px, w, h, 0);
    CHECK_OK(envl__region_table(m));
    for (int t = 0; t < 400; t++) {
        seed = seed * 1664525u + 1013904223u;
        int x0 = (int)(seed % w), wd = 1 + (int)((seed >> 9) % w);
        seed = seed * 1664525u + 1013904223u;
        int y0 = (int)(seed % h), y1 = y0 + 1 + (int)((seed >> 9) % (h - y0));
        int x1 = x0 + wd;
        double direct[6] = {0, 0, 0, 0, 0, 0}, got[6];
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                const float *p = px + 3 * ((size_t)y * w + x % w);
                double om = envl_envmap_solid_angle(m, y), d[3];
                envl_envmap_direction(m, x % w, y, d);
                double e = envl_luminance(p[0], p[1], p[2]) * om;
                for (int k = 0; k < 3; k++) {
                    direct[k] += p[k] * om;
                    direct[3 + k] += e * d[k];
                }
            }
        envl__rect_sums(m, x0, x1, y0, y1, got);
        double energy = envl_luminance(direct[0], direct[1], direct[2]);
        for (int k = 0; k < 3; k++) {
            CHECK_REL(got[k], direct[k], 1e-9);
            /* the direction sums are those of the pixels' centres, as the table's */
            CHECK(fabs(got[3 + k] - direct[3 + k]) <= 1e-6 * energy);
        }
        CHECK_REL(envl__rect_energy(m, x0, x1, y0, y1), energy, 1e-9);
        if (wd >= 2) {
            double left, half = 0.5 * energy, *cols = malloc(sizeof(double) * wd);
            int s = envl__median_column(m, x0, x1, y0, y1, half, &left);
            envl__column_energies(m, x0, x1, y0, y1, cols);
            /* F(s) = energy([x0, s)); the exact rule: the smallest s in [x0 + 1, x1 - 1] with
             * F(s) >= half (else x1 - 1), or s - 1 if that is as close to half */
            double *F = malloc(sizeof(double) * (wd + 1));
            F[0] = 0;
            for (int c = 0; c < wd; c++)
                F[c + 1] = F[c] + cols[c];
            int want = wd - 1;
            for (int k = 1; k <= wd - 1; k++)
                if (F[k] >= half) {
                    want = k;
                    break;
                }
            if (want > 1 && fabs(F[want - 1] - half) <= fabs(F[want] - half))
                want--;
            CHECK(s >= x0 + 1 && s <= x1 - 1);
            /* the same split, or one exactly as good up to rounding (a tie) */
            CHECK(s - x0 == want ||
                  fabs(fabs(F[s - x0] - half) - fabs(F[want] - half)) <= 1e-9 * energy);
            CHECK(fabs(left - F[s - x0]) <= 1e-9 * energy);
            free(F);
            free(cols);
        }
    }
    envl_envmap_free(m);
    free(px);
}

/* The variance cut's marginals from block sums (cut_marginals.c) against the pixels' own sums,
 * on a map whose sides are no multiple of the block (ragged blocks at the edges), regions that
 * wrap across the seam, and a window of the map's rows (the other rows black). Both are sums of
 * n >= 0 terms in double, in different orders: each within n u of the sum of the terms'
 * magnitudes (u = 2^-53), so they differ by at most 2 n u x the energy (|cos|, |sin| <= 1). */
static void check_marginals(const envl_envmap *m, const cut_marginals *t, int x0, int x1, int y0,
                            int y1)
{
    int w = x1 - x0, h = y1 - y0, W = m->width, ya = y0, yb = y1;
    if (m->window) {
        ya = ya < m->row0 ? m->row0 : ya;
        yb = yb > m->row1 ? m->row1 : yb;
    }
    double *col = calloc(3 * (size_t)w, sizeof(double)), *row = calloc(3 * (size_t)h,
                                                                       sizeof(double));
    double *dc = calloc(3 * (size_t)w, sizeof(double)), *dr = calloc(3 * (size_t)h,
                                                                     sizeof(double));
    region r = {x0, x1, y0, y1, 0, 0};
    envl__cut_marginals_of(m, t, &r, col, row);
    for (int y = ya; y < yb; y++)
        for (int x = x0; x < x1; x++) {
            int c = x % W;
            const float *p = m->px + 3 * ((size_t)y * W + c);
            double d[3];
            envl_envmap_direction(m, c, y, d);
            double e = envl_luminance(p[0], p[1], p[2]) * envl_envmap_solid_angle(m, y);
            double ct = sqrt(d[0] * d[0] + d[1] * d[1]);
            double *a = dc + 3 * (x - x0), *b = dr + 3 * (y - y0);
            a[0] += e, a[1] += e * ct, a[2] += e * d[2];
            b[0] += e, b[1] += e * d[0] / ct, b[2] += e * d[1] / ct;
        }
    /* the direction's terms from the test's own trigonometry: 1e-15 of each */
    for (int i = 0; i < 3 * w; i++)
        CHECK(fabs(col[i] - dc[i]) <= (2.0 * h * 0x1p-53 + 1e-15) * dc[3 * (i / 3)] + 1e-300);
    for (int j = 0; j < 3 * h; j++)
        CHECK(fabs(row[j] - dr[j]) <= (2.0 * w * 0x1p-53 + 1e-15) * dr[3 * (j / 3)] + 1e-300);
    free(col);
    free(row);
    free(dc);
    free(dr);
}

static void test_cut_marginals(void)
{
    const int w = 333, h = 197; /* 5 blocks of 64 and 13 columns; 3 of 64 rows and 5 */
    float *px = malloc(sizeof(float) * 3 * w * h);
    uint32_t seed = 11;
    for (int i = 0; i < 3 * w * h; i++) {
        seed = seed * 1664525u + 1013904223u;
        px[i] = (float)((seed >> 8) / 16777216.0 * (i % 29 == 0 ? 1e4 : 1.0));
    }
    envl_envmap *m = map_of(px, w, h, 0), *half = NULL;
    CHECK_OK(envl__envmap_window(m, 70, 160, &half));
    envl_envmap *maps[2] = {m, half};
    for (int k = 0; k < 2; k++) {
        cut_marginals t;
        CHECK_OK(envl__cut_marginals_build(maps[k], &t));
        check_marginals(maps[k], &t, 0, w, 0, h);          /* the whole map */
        check_marginals(maps[k], &t, 64, 128, 64, 128);    /* exactly one block */
        check_marginals(maps[k], &t, 300, 300 + w, 0, h);  /* across the seam */
        for (int n = 0; n < 200; n++) {
            seed = seed * 1664525u + 1013904223u;
            int x0 = (int)(seed % w), wd = 1 + (int)((seed >> 9) % w);
            seed = seed * 1664525u + 1013904223u;
            int y0 = (int)(seed % h), y1 = y0 + 1 + (int)((seed >> 9) % (h - y0));
            check_marginals(maps[k], &t, x0, x0 + wd, y0, y1);
        }
        envl__cut_marginals_free(&t);
    }
    envl_envmap_free(half);
    envl_envmap_free(m);
    free(px);
}

/* ---- sun: the map's suns split off exactly ---- */

static int cmp_float_desc(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x > y ? -1 : x < y;
}

/* The split's threshold, computed here from its definition: 50 x the mean luminance, raised to
 * the luminance of the 4097th brightest pixel when more than 4096 are above it. */
static double split_threshold(const envl_envmap *m)
{
    envl_info info;
    envl_envmap_info(m, &info);
    double T = 50.0 * envl_luminance(info.power[0], info.power[1], info.power[2]) / (4 * PI);
    const float *px = envl_envmap_pixels(m);
    size_t n = (size_t)envl_envmap_width(m) * envl_envmap_height(m), count = 0;
    float *y = malloc(sizeof(float) * n);
    for (size_t i = 0; i < n; i++) {
        double l = envl_luminance(px[3 * i], px[3 * i + 1], px[3 * i + 2]);
        if (l > T)
            y[count++] = (float)l;
    }
    if (count > 4096) {
        qsort(y, count, sizeof(float), cmp_float_desc);
        T = y[4096];
    }
    free(y);
    return T;
}

/* Lights + residual = the map, per channel to 1e-9: the summary's bookkeeping, and the sum of
 * the lights' rgb plus the residual map's own integral (the residual's float pixels round
 * only the few split pixels, at the threshold). */
static void check_sun_energy(const envl_lights *ls, const envl_envmap *m)
{
    envl_lights_summary s;
    CHECK_OK(envl_lights_get_summary(ls, &s));
    CHECK(s.method == ENVL_METHOD_SUN && s.remainder_order == -1);
    CHECK(envl_lights_remainder(ls, NULL) == NULL);
    for (int k = 0; k < 3; k++) {
        double lights = 0;
        for (int i = 0; i < s.count; i++) {
            envl_light l;
            envl_lights_get(ls, i, &l);
            lights += l.rgb[k];
        }
        CHECK_REL(lights, s.lights_power[k], 1e-12);
        CHECK_REL(s.lights_power[k] + s.residual_power[k], s.power[k], 1e-9);
        CHECK_REL(lights + residual_power(ls, m, k), s.power[k], 1e-9);
    }
}

static double max_luminance(const float *px, size_t n)
{
    double y = 0;
    for (size_t i = 0; i < n; i++)
        y = fmax(y, envl_luminance(px[3 * i], px[3 * i + 1], px[3 * i + 2]));
    return y;
}

static double angle_between(const double a[3], const double b[3])
{
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return acos(fmax(-1.0, fmin(1.0, d)));
}

/* The built-in sky (a 0.53-degree sun): exactly one sun light, within 0.3 degrees of the sky's
 * sun and about its size, carrying what the residual lost; the residual has no pixel above
 * the split's threshold; the error (lights + the residual's exact irradiance) is small. */
static void test_sun_sky(void)
{
    const double el_deg = 35, az_deg = 30;
    envl_sky_options so = {.sun_elevation_degrees = el_deg, .sun_elevation_is_set = 1,
                           .sun_azimuth_degrees = az_deg};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    double el = el_deg * PI / 180, az = az_deg * PI / 180;
    double sun[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)};
    envl_lights *ls;
    envl_lights_options o = {.method = ENVL_METHOD_SUN, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    envl_lights_summary s;
    CHECK_OK(envl_lights_get_summary(ls, &s));
    CHECK(s.count == 1 && envl_lights_count(ls) == 1);
    envl_light l;
    CHECK_OK(envl_lights_get(ls, 0, &l));
    printf("sun method, built-in sky: %d light, %.4f degrees off the sun, angle %.3f degrees, "
           "rgb %.5g %.5g %.5g, diffuse error %.3g\n", (int)s.count,
           angle_between(l.direction, sun) * 180 / PI, l.angle * 180 / PI, l.rgb[0], l.rgb[1],
           l.rgb[2], s.diffuse_error);
    CHECK(angle_between(l.direction, sun) <= 0.3 * PI / 180);
    /* the disc of the same spread as the sun's pixels: the sun, blurred by pixels of 0.35
     * degrees */
    CHECK(l.angle > 0.2 * PI / 180 && l.angle < 1.5 * PI / 180);
    /* its rectangle holds the sun's pixel */
    double u = 0.5 - atan2(sun[1], sun[0]) / (2 * PI), v = 0.5 - el / PI;
    int cx = (int)(u * envl_envmap_width(m)), cy = (int)(v * envl_envmap_height(m));
    CHECK(l.rect[0] <= cx && cx < l.rect[2] && l.rect[1] <= cy && cy < l.rect[3]);
    check_sun_energy(ls, m);
    /* the sun holds most of the sky's light (irradiance 12 of the sun disc) */
    CHECK(envl_luminance(l.rgb[0], l.rgb[1], l.rgb[2]) > 11.0);
    double T = split_threshold(m);
    size_t n = (size_t)envl_envmap_width(m) * envl_envmap_height(m);
    CHECK(max_luminance(envl_lights_residual(ls), n) <= T * (1 + 1e-6));
    CHECK(max_luminance(envl_envmap_pixels(m), n) > T);
    CHECK(s.diffuse_error >= 0 && s.diffuse_error < 1e-3);
    envl_lights_free(ls);
    envl_envmap_free(m);

    /* 2048 wide (the error's reference resampled to 1024): skip_residual keeps no residual,
     * the same light and error bit for bit */
    so.width = 2048;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_lights *lk;
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    o.skip_residual = 1;
    CHECK_OK(envl_lights_compute(m, &o, &lk));
    envl_light l2;
    envl_lights_summary s2;
    CHECK_OK(envl_lights_get(ls, 0, &l));
    CHECK_OK(envl_lights_get(lk, 0, &l2));
    CHECK(!memcmp(&l, &l2, sizeof l));
    CHECK_OK(envl_lights_get_summary(ls, &s));
    CHECK_OK(envl_lights_get_summary(lk, &s2));
    CHECK(s.diffuse_error == s2.diffuse_error && s.diffuse_error > 0);
    CHECK(envl_lights_residual(lk) == NULL);
    envl_lights_free(lk);
    envl_lights_free(ls);
    envl_envmap_free(m);

    /* 256 x 128 (the reference is the brute force, envl_irradiance_exact): the error is the
     * lights' irradiance + the residual's exact irradiance against the map's, both brute
     * force here; the library adds the patched pixels' change to the map's (linear in the
     * pixels, each pixel integrated as envl_irradiance_exact does): equal to rounding */
    so.width = 256;
    o.skip_residual = 0;
    CHECK_OK(envl_envmap_sky(&so, &m));
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    CHECK_OK(envl_lights_get_summary(ls, &s));
    CHECK(s.count == 1);
    const float *res = envl_lights_residual(ls);
    envl_envmap *rm;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK(res && !envl_envmap_from_pixels(res, 256, 128, 3, &lo, &rm));
    double *dirs = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    double *e = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    double *ex = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    double *eres = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
    for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
        envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, dirs + 3 * i);
    CHECK_OK(envl_irradiance_exact(m, ENVL_ERROR_NORMALS, dirs, ex));
    CHECK_OK(envl_irradiance_exact(rm, ENVL_ERROR_NORMALS, dirs, eres));
    CHECK_OK(envl_lights_irradiance(ls, ENVL_ERROR_NORMALS, dirs, e));
    for (int32_t i = 0; i < 3 * ENVL_ERROR_NORMALS; i++)
        e[i] += eres[i];
    double brute = envl_relative_rms_luminance(ENVL_ERROR_NORMALS, e, ex);
    printf("sun method, sky 256 x 128: diffuse error %.9g, brute force %.9g\n", s.diffuse_error,
           brute);
    /* the difference is E's rounding (~1e-16 of E) over the error's own size (~1e-5 of E) */
    CHECK(brute > 0 && fabs(s.diffuse_error - brute) <= 1e-9 * brute);
    free(dirs);
    free(e);
    free(ex);
    free(eres);
    envl_envmap_free(rm);
    envl_lights_free(ls);
    envl_envmap_free(m);
}

/* No sun: a constant map (nothing above the threshold), and a bright patch 20 degrees wide (a
 * window, no sun: too wide): no light, the residual is the map bit for bit, zero error (the
 * residual's irradiance is the map's); not "no light" (the map is not black). */
static void test_sun_none(void)
{
    const int w = 256, h = 128;
    for (int t = 0; t < 2; t++) {
        float *px = filled(w, h, 2.0f);
        if (t == 1)
            for (int r = 40; r < 54; r++)
                for (int c = 100; c < 114; c++)
                    for (int k = 0; k < 3; k++)
                        px[3 * (r * w + c) + k] = 5000.0f;
        envl_envmap *m = map_of(px, w, h, 0);
        CHECK(t == 0 || max_luminance(px, (size_t)w * h) > split_threshold(m));
        envl_lights *ls;
        envl_lights_options o = {.method = ENVL_METHOD_SUN, .measure = 1};
        CHECK_OK(envl_lights_compute(m, &o, &ls));
        envl_lights_summary s;
        CHECK_OK(envl_lights_get_summary(ls, &s));
        CHECK(s.count == 0 && envl_lights_count(ls) == 0 && s.no_light == 0);
        CHECK(memcmp(envl_lights_residual(ls), envl_envmap_pixels(m),
                     sizeof(float) * 3 * w * h) == 0);
        CHECK(s.lights_power[0] == 0 && s.lights_power[1] == 0 && s.lights_power[2] == 0);
        CHECK(s.diffuse_error == 0.0);
        check_sun_energy(ls, m);
        envl_lights_free(ls);
        envl_envmap_free(m);
        free(px);
    }
}

/* Paints a disc of radius rho about d with radiance v. */
static void paint_disc(float *px, const envl_envmap *m, const double d[3], double rho, float v)
{
    int w = envl_envmap_width(m), h = envl_envmap_height(m);
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double e[3];
            envl_envmap_direction(m, c, r, e);
            if (e[0] * d[0] + e[1] * d[1] + e[2] * d[2] >= cos(rho))
                for (int k = 0; k < 3; k++)
                    px[3 * ((size_t)r * w + c) + k] = v;
        }
}

static void dir_of(double el_deg, double az_deg, double d[3])
{
    double el = el_deg * PI / 180, az = az_deg * PI / 180;
    d[0] = cos(el) * cos(az), d[1] = cos(el) * sin(az), d[2] = sin(el);
}

/* Two suns (3-degree discs, 1e4 and 5e3 over a sky of 0.1), the brighter on the seam: both as
 * lights, brightest first; count = 1 keeps the brighter, and the residual keeps the other's
 * pixels at their full value while the kept sun's are at the threshold. */
static void test_sun_count(void)
{
    const int w = 512, h = 256;
    const double rho = 1.5 * PI / 180;
    double a[3], b[3];
    dir_of(30, 180, a);   /* on the seam: its pixels at both ends of the rows */
    dir_of(20, -70, b);
    float *px = filled(w, h, 0.1f);
    envl_envmap *m0 = map_of(px, w, h, 0);
    paint_disc(px, m0, a, rho, 1e4f);
    paint_disc(px, m0, b, rho, 5e3f);
    envl_envmap_free(m0);
    envl_envmap *m = map_of(px, w, h, 0);
    double T = split_threshold(m);
    size_t n = (size_t)w * h;
    envl_lights *ls;
    envl_lights_options o = {.method = ENVL_METHOD_SUN, .measure = 1};
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    CHECK(envl_lights_count(ls) == 2);
    if (envl_lights_count(ls) == 2) {
        envl_light la, lb;
        envl_lights_get(ls, 0, &la);
        envl_lights_get(ls, 1, &lb);
        CHECK(angle_between(la.direction, a) < 0.2 * PI / 180);
        CHECK(angle_between(lb.direction, b) < 0.2 * PI / 180);
        /* each holds its disc's excess over the threshold, (v - T) omega a pixel */
        double ea = 0, eb = 0;
        for (int r = 0; r < h; r++)
            for (int c = 0; c < w; c++) {
                double d[3];
                envl_envmap_direction(m, c, r, d);
                if (angle_between(d, a) <= rho)
                    ea += (1e4 - T) * envl_envmap_solid_angle(m, r);
                else if (angle_between(d, b) <= rho)
                    eb += (5e3 - T) * envl_envmap_solid_angle(m, r);
            }
        CHECK_REL(la.rgb[1], ea, 1e-9);
        CHECK_REL(lb.rgb[1], eb, 1e-9);
        /* the sun on the seam: its rectangle wraps (x1 past the width) and is narrow */
        CHECK(la.rect[0] < w && la.rect[2] > w && la.rect[2] - la.rect[0] < 16);
        CHECK(lb.rect[2] <= w && lb.rect[2] - lb.rect[0] < 16);
    }
    check_sun_energy(ls, m);
    CHECK(max_luminance(envl_lights_residual(ls), n) <= T * (1 + 1e-6));
    envl_lights_free(ls);

    o.count = 1;
    CHECK_OK(envl_lights_compute(m, &o, &ls));
    envl_lights_summary s;
    CHECK_OK(envl_lights_get_summary(ls, &s));
    CHECK(s.count == 1);
    envl_light l;
    CHECK_OK(envl_lights_get(ls, 0, &l));
    CHECK(angle_between(l.direction, a) < 0.2 * PI / 180);
    check_sun_energy(ls, m);
    const float *res = envl_lights_residual(ls), *map = envl_envmap_pixels(m);
    int in_a = 0, in_b = 0, b_kept = 1, a_cut = 1, others_kept = 1;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            size_t i = (size_t)r * w + c;
            double d[3];
            envl_envmap_direction(m, c, r, d);
            int same = memcmp(res + 3 * i, map + 3 * i, sizeof(float) * 3) == 0;
            double y = envl_luminance(res[3 * i], res[3 * i + 1], res[3 * i + 2]);
            if (angle_between(d, b) <= rho) {
                in_b++;
                b_kept &= same && map[3 * i + 1] == 5e3f;
            } else if (angle_between(d, a) <= rho) {
                in_a++;
                a_cut &= fabs(y - T) <= 1e-6 * T;
            } else {
                others_kept &= same;
            }
        }
    CHECK(in_a > 10 && in_b > 10);
    CHECK(b_kept);
    CHECK(a_cut);
    CHECK(others_kept);
    /* what the light holds is what the residual lost at the kept sun's pixels */
    double lost = 0;
    for (int r = 0; r < h; r++) {
        double row = 0;
        for (int c = 0; c < w; c++) {
            size_t i = (size_t)r * w + c;
            row += (double)map[3 * i + 1] - res[3 * i + 1];
        }
        lost += row * envl_envmap_solid_angle(m, r);
    }
    CHECK_REL(l.rgb[1], lost, 1e-9);
    /* The error is the lights' (points for 3-degree discs) against what they took: the
     * residual's irradiance is exact, so the sun left in it adds none. */
    envl_lights_summary s2;
    envl_lights *both;
    o.count = 2;
    CHECK_OK(envl_lights_compute(m, &o, &both));
    CHECK_OK(envl_lights_get_summary(both, &s2));
    CHECK(s2.count == 2);
    CHECK(s.diffuse_error > 0 && s.diffuse_error < 2e-3);
    CHECK(s2.diffuse_error > 0 && s2.diffuse_error < 2e-3);
    printf("sun method, two suns: error %.3g with both, %.3g with the brighter only\n",
           s2.diffuse_error, s.diffuse_error);
    envl_lights_free(both);
    envl_lights_free(ls);
    envl_envmap_free(m);
    free(px);
}

/* ---- the fit's residual (envl__take_cones) against the plain algorithm ---- */

/* The fit's take (lights_take.c) on a 300 x 150 map (a sky, noise, three discs), five lights
 * aimed as a fit would: two whose takes overlap (the second takes from what the first left), one
 * on the seam, one near the pole, one below the horizon asking for more than the lower
 * hemisphere holds (taken first, the brightest: its level reaches past the horizon for it).
 * - one thread or three, a residual kept or replayed: the same lights and residual, bit for bit;
 * - lights + residual hold the map's power (check_energy, 1e-6);
 * - every residual pixel is its map pixel times one factor in [0, 1]: its hue is kept. Each
 *   channel is rounded to float once per take (2^-24 relative), so the channels' ratios agree
 *   within 5 x 2^-23 (five takes);
 * - each light takes its target luminance, to the float rounding of the residual (1e-6) (the
 *   one below the horizon too: this checked that it took less, which held by a rounding of
 *   1e-9 at 300 x 150 and not at 2400 x 1200);
 * - the first light (taken second) and the one near the pole, alone in its part of the sky, take
 *   light whose first moment lies along their aim: to the solve's tolerance, 1e-6 radians (its
 *   sine), plus the float rounding (1e-6). (The seam light's disc crosses the horizon, below
 *   which it takes little: its moment stays above its aim.)
 * At 2400 x 1200 with a 256-wide coarse copy, the take goes through every level (the coarse
 * copy, 512 and 1024 wide, the map itself, where finish_lb solves lb from the pixels near the
 * level, or solve_lb where the 1024-wide copy's level is outside its window: both happen
 * here): the same checks but the moment's (aligned on the coarser copies only). */
static void test_take_at(int W, int H)
{
    enum { K = 5 };
    float *px = filled(W, H, 0.0f);
    uint32_t seed = 12345;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++)
            for (int k = 0; k < 3; k++) {
                seed = seed * 1664525u + 1013904223u;
                px[3 * (r * W + c) + k] = (float)(0.2 + 0.1 * k + 0.5 * (H - r) / H +
                                                  0.3 * (seed >> 8) / 16777216.0);
            }
    envl_envmap *m0 = map_of(px, W, H, 1);
    double sun[3], seam[3], pole[3];
    dir_of(20, 30, sun);
    dir_of(5, 179, seam);
    dir_of(86, -40, pole);
    paint_disc(px, m0, sun, 4 * PI / 180, 300.0f);
    paint_disc(px, m0, seam, 6 * PI / 180, 40.0f);
    paint_disc(px, m0, pole, 5 * PI / 180, 20.0f);
    envl_envmap_free(m0);
    envl_envmap *m1 = map_of(px, W, H, 1), *m3 = map_of(px, W, H, 3);
    envl_info info;
    CHECK_OK(envl_envmap_info(m1, &info));
    double below = 0; /* the lower hemisphere's luminance power */
    for (int r = H / 2; r < H; r++)
        for (int c = 0; c < W; c++) {
            const float *p = px + 3 * (r * W + c);
            below += envl_luminance(p[0], p[1], p[2]) * envl_envmap_solid_angle(m1, r);
        }
    const double at[K][2] = {{20, 30}, {24, 40}, {5, 179}, {80, -40}, {-30, -100}};
    const double target[K] = {3.0, 1.6, 1.5, 1.2, 1.05 * below};
    envl_light in[K];
    memset(in, 0, sizeof in);
    for (int i = 0; i < K; i++) {
        dir_of(at[i][0], at[i][1], in[i].direction);
        for (int k = 0; k < 3; k++)
            in[i].rgb[k] = target[i];
    }
    size_t nf = (size_t)W * H * 3;
    float *res[2] = {malloc(sizeof(float) * nf), malloc(sizeof(float) * nf)};
    envl_light got[3][K];
    envl__take takes[3][K];
    envl_envmap *maps[3] = {m1, m3, m1}, *coarse[3] = {m1, m3, m1};
    int levels = W > 1024; /* the fit's coarse copy, 256 wide, and the levels above it */
    if (levels) {
        CHECK_OK(envl__envmap_resampled(px, W, H, 256, 1, &coarse[0]));
        coarse[1] = coarse[2] = coarse[0];
    }
    for (int t = 0; t < 3; t++) {
        if (t < 2)
            memcpy(res[t], px, sizeof(float) * nf);
        memcpy(got[t], in, sizeof in);
        envl_lights ls = {.lights = got[t], .residual = t < 2 ? res[t] : NULL, .width = W,
                          .height = H};
        ls.summary.count = K;
        CHECK_OK(envl__take_lights(maps[t], coarse[t], &ls, takes[t]));
    }
    CHECK(memcmp(got[0], got[1], sizeof got[0]) == 0);
    CHECK(memcmp(takes[0], takes[1], sizeof takes[0]) == 0);
    CHECK(memcmp(res[0], res[1], sizeof(float) * nf) == 0);
    CHECK(memcmp(got[0], got[2], sizeof got[0]) == 0); /* no residual kept: the same lights */
    envl_lights ls = {.lights = got[0], .residual = res[0], .width = W, .height = H};
    ls.summary.count = K;
    for (int k = 0; k < 3; k++)
        ls.summary.power[k] = info.power[k];
    check_energy(&ls, m1);
    double worst_hue = 0;
    int below_zero = 0, above_map = 0;
    for (size_t p = 0; p < nf; p += 3) {
        double f[3];
        for (int k = 0; k < 3; k++) {
            below_zero += res[0][p + k] < 0;
            above_map += res[0][p + k] > px[p + k];
            f[k] = res[0][p + k] / (double)px[p + k];
        }
        worst_hue = fmax(worst_hue, fmax(fabs(f[0] - f[1]), fabs(f[0] - f[2])));
    }
    printf("take: hue kept to %.3g (bound %.3g)\n", worst_hue, 5 * ldexp(1.0, -23));
    CHECK(below_zero == 0 && above_map == 0);
    CHECK(worst_hue <= 5 * ldexp(1.0, -23));
    for (int i = 0; i < K; i++) {
        const envl_light *l = &got[0][i];
        double y = envl_luminance(l->rgb[0], l->rgb[1], l->rgb[2]);
        double *v = takes[0][i].moment, len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        double off = acos(fmin(1.0, (v[0] * l->direction[0] + v[1] * l->direction[1] +
                                     v[2] * l->direction[2]) / len));
        printf("  light %d: target %.4g took %.6g, moment %.3g degrees off its aim, "
               "angle %.2f degrees\n", i, target[i], y, off * 180 / PI, l->angle * 180 / PI);
        CHECK_REL(y, target[i], 1e-6);
        CHECK(memcmp(l->direction, in[i].direction, sizeof l->direction) == 0);
    }
    /* every pixel through every light's final level, brightest first, by brute force: the
     * residual bit for bit (the passes visit only the columns where a level can fall under
     * the row's brightest pixel; a pixel skipped that a level would take differs here) */
    int32_t order[K];
    for (int i = 0; i < K; i++) {
        int at_i = i;
        while (at_i > 0 && target[order[at_i - 1]] < target[i])
            order[at_i] = order[at_i - 1], at_i--;
        order[at_i] = i;
    }
    size_t brute_differ = 0;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++) {
            float v[3];
            memcpy(v, px + 3 * ((size_t)r * W + c), sizeof v);
            double x = m1->row_cos[r] * m1->col_cos[c], y = m1->row_cos[r] * m1->col_sin[c];
            for (int i = 0; i < K; i++) {
                double lam = exp(envl__take_level_log(&takes[0][order[i]], x, y, m1->row_sin[r]));
                double Y = envl__lum(v[0], v[1], v[2]);
                for (int k = 0; Y > lam && k < 3; k++)
                    v[k] = (float)(v[k] * (lam / Y));
            }
            brute_differ += memcmp(v, res[0] + 3 * ((size_t)r * W + c), sizeof v) != 0;
        }
    printf("take: %zu of %d pixels differ from the brute-force levels\n", brute_differ, W * H);
    CHECK(brute_differ == 0);
    for (int i = 0; !levels && i < 4; i += 3) {
        double *v = takes[0][i].moment, len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        const double *l = got[0][i].direction;
        double c = (v[0] * l[0] + v[1] * l[1] + v[2] * l[2]) / len;
        CHECK(sqrt(fmax(0.0, 1.0 - c * c)) <= 2e-6);
    }
    free(res[0]);
    free(res[1]);
    if (levels)
        envl_envmap_free(coarse[0]);
    envl_envmap_free(m1);
    envl_envmap_free(m3);
    free(px);
}

static void test_take(void)
{
    test_take_at(300, 150);
    test_take_at(2400, 1200);
}

/* ---- the fit's bright pixels, chunk by chunk (envl__bright_chunk) ---- */

static int cmp_bright(const void *a, const void *b)
{
    const double *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? 1 : -1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

/* The chunks, one after another, are the positive pixels sorted whole (luminance down, index
 * up on ties), bit for bit: on n pixels spanning 2^-140 .. 2^40 with ties, zeros, negatives,
 * a NaN and an infinity, chunks of at least `least`; returns how many chunks and the first's
 * length. */
static int bright_chunks_match(const float *px, size_t n, size_t least, size_t *first)
{
    double *ref = malloc(sizeof(double) * 2 * n), *got = malloc(sizeof(double) * 2 * n);
    double *chunk = malloc(sizeof(double) * 2 * n);
    size_t m = 0, g = 0, len;
    for (size_t i = 0; i < n; i++) {
        double y = envl__lum(px[3 * i], px[3 * i + 1], px[3 * i + 2]);
        if (y > 0)
            ref[2 * m] = y, ref[2 * m + 1] = (double)i, m++;
    }
    qsort(ref, m, 2 * sizeof(double), cmp_bright);
    int top = INT32_MAX, chunks = 0;
    *first = 0;
    while ((len = envl__bright_chunk(px, n, least, &top, chunk)) > 0) {
        CHECK(g + len <= m);
        if (g + len > m)
            break;
        if (chunks++ == 0)
            *first = len;
        CHECK(len >= least || g + len == m); /* at least `least`, but the last */
        memcpy(got + 2 * g, chunk, sizeof(double) * 2 * len);
        g += len;
    }
    CHECK(g == m);
    CHECK(g == m && memcmp(got, ref, sizeof(double) * 2 * m) == 0);
    free(ref);
    free(got);
    free(chunk);
    return chunks;
}

static void test_bright_chunks(void)
{
    enum { W = 64, H = 32 };
    float *px = filled(W, H, 0.0f);
    uint32_t seed = 99;
    for (int i = 0; i < W * H; i++) {
        seed = seed * 1664525u + 1013904223u;
        float v = ldexpf(1.0f + (seed >> 20) / 4096.0f, (int)(seed >> 8 & 0xff) % 181 - 140);
        int kind = (int)(seed >> 28);
        if (kind == 0)
            v = 0.0f;
        else if (kind == 1)
            v = -v;
        else if (kind == 2)
            v = 0.5f; /* ties */
        for (int k = 0; k < 3; k++)
            px[3 * i + k] = v;
    }
    px[3 * 5] = NAN;
    px[3 * 6] = INFINITY;
    size_t first;
    int chunks = bright_chunks_match(px, (size_t)W * H, 7, &first);
    printf("bright chunks: %d of at least 7 on %d pixels\n", chunks, W * H);
    CHECK(chunks > 10);
    free(px);
    /* a sky brightest at the zenith (1024 x 512 lat-long, y = e^(30 sin elevation)): its
     * brightest 16,384 pixels are within 5 degrees of the pole, where no 64 bright pixels are
     * 2 degrees apart: the fit's scan reads past the first chunk */
    enum { LW = 1024, LH = 512 };
    px = filled(LW, LH, 0.0f);
    for (int r = 0; r < LH; r++)
        for (int c = 0; c < LW; c++)
            for (int k = 0; k < 3; k++)
                px[3 * (r * LW + c) + k] =
                    (float)exp(30.0 * cos(PI * (r + 0.5) / LH)); /* sin elevation */
    chunks = bright_chunks_match(px, (size_t)LW * LH, 16384, &first);
    printf("bright chunks: %d of at least 16384 on the zenith sky, the first %zu pixels\n", chunks,
           first);
    CHECK(chunks > 1 && first < (size_t)LW * LH / 4);
    free(px);
}

/* One default lights method (docs/design.md): zero-initialised options (and NULL) fit at most
 * ENVL_DEFAULT_FIT_LIGHTS lights with an order-2 remainder; ENVL_ORDER_0 asks for a remainder
 * of order 0, ENVL_REMAINDER_NONE for none; a remainder order above 8 is refused. */
static void test_defaults(void)
{
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 256}, &m));
    static const struct { int32_t field, order; } cases[] = {
        {0, 2}, {ENVL_ORDER_0, 0}, {ENVL_REMAINDER_NONE, -1}, {8, 8}};
    for (int i = 0; i < 5; i++) {
        envl_lights *ls;
        envl_lights_options o = {.remainder_order = i < 4 ? cases[i].field : 0, .measure = 1};
        CHECK_OK(envl_lights_compute(m, i < 4 ? &o : NULL, &ls));
        envl_lights_summary s;
        envl_lights_get_summary(ls, &s);
        CHECK(s.method == ENVL_METHOD_FIT);
        CHECK(s.count >= 1 && s.count <= ENVL_DEFAULT_FIT_LIGHTS);
        CHECK(s.remainder_order == (i < 4 ? cases[i].order : ENVL_DEFAULT_ORDER));
        envl_lights_free(ls);
    }
    envl_lights *ls;
    CHECK_RC(envl_lights_compute(m, &(envl_lights_options){.remainder_order = 9, .measure = 1}, &ls),
             ENVL_ERR_ARGUMENT);
    CHECK(!strcmp(envl_method_name(0), "fit"));
    envl_envmap_free(m);
}

int main(void)
{
    test_defaults();
    test_constant();
    test_one_bright_pixel();
    test_seam_and_pole(10, 180);  /* on the seam */
    test_seam_and_pole(90, 0);    /* at the pole */
    test_black();
    test_tiny();
    test_deterministic();
    test_sat_precision();
    test_fit_light_size();
    test_fit_lights_alone();
    test_region_table();
    test_cut_marginals();
    test_sun_sky();
    test_sun_none();
    test_sun_count();
    test_take();
    test_bright_chunks();
    return check_report("test_lights");
}
