/* Prefiltered maps: analytic answers (constant, linear in z), a single bright pixel, roughness 0
 * and 1, tiny inputs, the BRDF table's endpoints, the glossy error against the brute-force
 * reference, requests that compute only what they need, exports (RGBM atlas round trip, a
 * failed export leaving files as they were), determinism across thread counts. */
#include "internal.h"
#include "check.h"
#include "error_measure.h"
#include "prefilter_impl.h"

#include <dirent.h>
#include <time.h>
#include <unistd.h>


static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* A W x H map of f(d) per channel: c0 + c1 * d[axis] (for z, each pixel's exact mean). */
static envl_envmap *make_map(int32_t w, int32_t h, const double c0[3], double c1, int axis)
{
    float *px = malloc(sizeof(float) * 3 * (size_t)w * h);
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            /* z: the row's mean (its z-midpoint), so pixels hold exact averages of L */
            if (axis == 2)
                d[2] = 0.5 * (sin(M_PI * (0.5 - (double)r / h)) +
                              sin(M_PI * (0.5 - (double)(r + 1) / h)));
            for (int k = 0; k < 3; k++)
                px[3 * ((size_t)r * w + c) + k] = (float)(c0[k] + c1 * d[axis]);
        }
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    free(px);
    return m;
}

static double energy(const float *px, int32_t w, int32_t h, int k)
{
    double e = 0;
    for (int32_t r = 0; r < h; r++) {
        double s = 0;
        for (int32_t c = 0; c < w; c++)
            s += px[3 * ((size_t)r * w + c) + k];
        e += s * envl_latlong_solid_angle(w, h, r);
    }
    return e;
}

static int all_finite(const float *px, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(px[i]) || px[i] < 0)
            return 0;
    return 1;
}

/* Constant radiance: every specular level (filtered and plain) is the constant, the
 * irradiance map is pi L by every method (the exact sum over pixel centres carries the
 * midpoint rule's error, ~h^2 / 24 relative with h = pi / 32: 2e-3 bound). */
static void test_constant(void)
{
    const double L[3] = {0.5, 1.0, 2.0};
    envl_envmap *m = make_map(64, 32, L, 0, 2);
    for (int un = 0; un < 2; un++) {
        for (int method = 0; method < ENVL_IRRADIANCE_COUNT; method++) {
            envl_request q = {.specular_chain = 1, .irradiance_map = 1};
            q.prefilter = (envl_prefilter_options){.width = 64, .samples = 32, .unfiltered = un,
                                                   .irradiance_method = method,
                                                   .irradiance_width = 16};
            envl_products *p = NULL;
            CHECK_OK(envl_compute(m, &q, &p));
            if (!p)
                continue;
            CHECK(envl_products_level_count(p) == ENVL_DEFAULT_LEVELS);
            for (int32_t i = 0; i < envl_products_level_count(p); i++) {
                envl_level l;
                CHECK_OK(envl_products_level(p, i, &l));
                CHECK_NEAR(l.roughness, (double)i / (ENVL_DEFAULT_LEVELS - 1), 1e-15);
                double worst = 0;
                for (size_t t = 0; t < (size_t)l.width * l.height; t++)
                    for (int k = 0; k < 3; k++)
                        worst = fmax(worst, fabs(l.rgb[3 * t + k] / L[k] - 1));
                CHECK_NEAR(worst, 0, 1e-5); /* float rounding of normalised weights */
            }
            envl_irradiance_map irr;
            CHECK_OK(envl_products_irradiance(p, &irr));
            double tol = method == ENVL_IRRADIANCE_SH ? 1e-6 : 2e-3;
            for (int32_t t = 0; t < irr.width * irr.height; t++)
                for (int k = 0; k < 3; k++)
                    CHECK_REL(irr.rgb[3 * t + k], M_PI * L[k], tol);
            envl_products_free(p);
        }
    }
    /* The brute-force reference of a constant is the constant. */
    double d[3] = {0.3, -0.4, sqrt(1 - 0.25)}, ref[3];
    CHECK_OK(envl_prefilter_reference(m, 0.37, 1, d, ref));
    CHECK_REL(ref[1], 1.0, 1e-12);
    envl_envmap_free(m);
}

/* L = a + b z: SH irradiance = pi a + (2 pi / 3) b n_z (exact); specular at roughness 1 (D
 * constant, the cosine-weighted hemisphere) = a + (2 / 3) b R_z. */
static void test_linear(void)
{
    const double a[3] = {1, 1, 1};
    const double b = 0.5;
    envl_envmap *m = make_map(128, 64, a, b, 2);
    envl_request q = {.irradiance_map = 1, .n_roughness = 1, .roughness = (double[]){1.0}};
    q.prefilter = (envl_prefilter_options){.irradiance_method = ENVL_IRRADIANCE_SH,
                                           .irradiance_width = 32, .width = 32, .min_width = 32,
                                           .samples = 1024};
    envl_products *p = NULL;
    CHECK_OK(envl_compute(m, &q, &p));
    envl_irradiance_map irr;
    CHECK_OK(envl_products_irradiance(p, &irr));
    double worst = 0, worst_spec = 0;
    for (int32_t r = 0; r < irr.height; r++)
        for (int32_t c = 0; c < irr.width; c++) {
            double n[3];
            envl_latlong_direction(irr.width, irr.height, c, r, n);
            double e = M_PI * a[0] + 2 * M_PI / 3 * b * n[2];
            worst = fmax(worst, fabs(irr.rgb[3 * (r * irr.width + c)] - e) / e);
        }
    /* The map is piecewise constant over pixels: its SH differ from those of a + b z by the
     * variance of z within a row, (pi / 64)^2 / 12 ~ 2e-4 relative at most. */
    CHECK_NEAR(worst, 0, 5e-4);
    envl_level l;
    CHECK_OK(envl_products_level(p, 0, &l));
    CHECK_NEAR(l.roughness, 1.0, 0);
    for (int32_t r = 0; r < l.height; r++)
        for (int32_t c = 0; c < l.width; c++) {
            double d[3];
            envl_latlong_direction(l.width, l.height, c, r, d);
            double e = a[0] + 2.0 / 3.0 * b * d[2];
            worst_spec = fmax(worst_spec, fabs(l.rgb[3 * (r * l.width + c)] - e) / e);
        }
    /* With 1024 samples a sample's footprint is ~0.16 rad tall: it reads the 32- and 16-row
     * levels. Rows are interpolated linearly in the row coordinate, so z = cos(colatitude)
     * (the row means at the nodes) is off by at most a^2 / 8 + a^2 / 24 = a^2 / 6 at a = pi / 16:
     * 0.0032 of b, 0.0048 of the smallest value a - 2 b / 3; the 1024-point quadrature of the
     * cosine lobe adds ~1e-4. */
    printf("linear in z: SH irradiance max rel error %.2g, roughness-1 level %.2g\n", worst,
           worst_spec);
    CHECK_NEAR(worst_spec, 0, 5e-3);
    /* The reference agrees with the analytic P to the midpoint rule's accuracy. */
    double d[3] = {0.6, 0, 0.8}, ref[3];
    CHECK_OK(envl_prefilter_reference(m, 1.0, 1, d, ref));
    CHECK_REL(ref[0], a[0] + 2.0 / 3.0 * b * 0.8, 1e-3);
    envl_products_free(p);
    envl_envmap_free(m);
}

/* One pixel of 1e6 over 1e-3: everything finite. The unfiltered baseline's levels are scaled
 * to the map's integral of L dw (to 1e-4); a filtered level holds P(R) at each texel, unscaled:
 * its texel sum is what energy_scale reports (to 1e-5: the sums round in float), within 15 %
 * of the map's (the 1e6 pixel's lobe at roughness 0.05 is narrower than a texel). */
static void test_bright_pixel(void)
{
    int32_t w = 128, h = 64;
    float *px = malloc(sizeof(float) * 3 * w * h);
    for (int32_t i = 0; i < 3 * w * h; i++)
        px[i] = 1e-3f;
    for (int k = 0; k < 3; k++)
        px[3 * (21 * w + 40) + k] = 1e6f;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    double ein = energy(envl_envmap_pixels(m), w, h, 1);
    for (int un = 0; un < 2; un++) {
        envl_request q = {.specular_chain = 1, .irradiance_map = 1, .diffuse = 1,
                          .n_roughness = 2, .roughness = (double[]){0.05, 0.4}};
        q.prefilter = (envl_prefilter_options){.width = 128, .samples = 64, .unfiltered = un};
        envl_products *p = NULL;
        CHECK_OK(envl_compute(m, &q, &p));
        CHECK(envl_products_level_count(p) == ENVL_DEFAULT_LEVELS + 1); /* 0.4 is in it */
        for (int32_t i = 0; i < envl_products_level_count(p); i++) {
            envl_level l;
            envl_products_level(p, i, &l);
            CHECK(all_finite(l.rgb, (size_t)l.width * l.height * 3));
            if (un || l.roughness == 0) {
                CHECK_REL(energy(l.rgb, l.width, l.height, 1), ein, 1e-4);
            } else {
                CHECK_REL(energy(l.rgb, l.width, l.height, 1), l.energy_scale * ein, 1e-5);
                CHECK_NEAR(l.energy_scale, 1.0, 0.15);
            }
        }
        envl_irradiance_map irr;
        CHECK_OK(envl_products_irradiance(p, &irr));
        CHECK(all_finite(irr.rgb, (size_t)irr.width * irr.height * 3));
        envl_products_free(p);
    }
    free(px);
    envl_envmap_free(m);
}

/* Roughness 0 is the map resampled by area, bit for bit; roughness 1 and a one-level chain. */
static void test_endpoints(void)
{
    envl_sky_options so = {.width = 256};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_prefilter_options po = {.width = 64};
    float *lev, *ref;
    envl_level st;
    CHECK_OK(envl_prefilter_specular(m, 0.0, 0, &po, &lev, &st));
    CHECK(st.width == 64 && st.height == 32 && st.samples == 0);
    CHECK_OK(envl__latlong_resample(envl_envmap_pixels(m), 256, 128, 64, 32, 0.0, &ref));
    CHECK(memcmp(lev, ref, sizeof(float) * 3 * 64 * 32) == 0);
    envl_free(lev);
    free(ref);
    CHECK_OK(envl_prefilter_specular(m, 1.0, 0, &po, &lev, &st));
    CHECK(st.width == 64 && st.alpha == 1.0); /* the minimum width, 64, caps the halving */
    CHECK(all_finite(lev, 3 * 64 * 32));
    envl_free(lev);
    CHECK(envl_prefilter_level_width(&(envl_prefilter_options){.levels = 6}, 0.4) == 128);
    CHECK(envl_prefilter_level_width(&(envl_prefilter_options){.levels = 6}, 0.39) == 256);
    CHECK(envl_prefilter_level_width(NULL, 1.0) == 64);
    envl_request q = {.specular_chain = 1};
    q.prefilter.levels = 1;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    CHECK(envl_products_level_count(p) == 1);
    envl_products_free(p);
    CHECK_RC(envl_prefilter_specular(m, 1.5, 0, &po, &lev, &st), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_prefilter_specular(m, NAN, 0, &po, &lev, &st), ENVL_ERR_ARGUMENT);
    envl_envmap_free(m);
}

/* 1 x 1, 2 x 1 and 4 x 2 inputs: finite products. A 1 x 1 map is one pixel, constant L over
 * the sphere, so every level is L (the white furnace). The GGX sums take each pixel as a point
 * at its centre, and this one's, +X, left half the texels with no pixel in front: they were 0
 * and the others 2 L (issue 30, 4.5); a map that coarse is now prefiltered from a copy with
 * each pixel split (tests/test_furnace.c has every shape). */
static void test_tiny(void)
{
    static const int32_t sizes[3][2] = {{1, 1}, {2, 1}, {4, 2}};
    for (int s = 0; s < 3; s++) {
        int32_t w = sizes[s][0], h = sizes[s][1];
        float px[3 * 8];
        for (int i = 0; i < 3 * w * h; i++)
            px[i] = (float)(1 + i % 5);
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
        envl_envmap *m;
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
        envl_request q = {.specular_chain = 1, .irradiance_map = 1, .diffuse = 1, .mirror = 1};
        q.prefilter = (envl_prefilter_options){.width = 16, .min_width = 4, .samples = 16,
                                               .irradiance_width = 8};
        envl_products *p = NULL;
        CHECK_OK(envl_compute(m, &q, &p));
        for (int32_t i = 0; p && i < envl_products_level_count(p); i++) {
            envl_level l;
            envl_products_level(p, i, &l);
            CHECK(all_finite(l.rgb, (size_t)l.width * l.height * 3));
            if (w == 1)
                for (int32_t r = 0; r < l.height; r++)
                    for (int32_t c = 0; c < l.width; c++) {
                        CHECK_NEAR(l.rgb[3 * ((size_t)r * l.width + c) + 2], 3.0, 6e-5);
                    }
        }
        envl_products_free(p);
        envl_envmap_free(m);
    }
}

/* int over the NoV = 1 lobe as a 1D integral in t = N.h (Simpson, 20000 intervals): the
 * albedo (F = 1) and the Fresnel part (Fc = (1 - t)^5). l = reflect(N, h): NoL = 2t^2 - 1,
 * dl = 4 t dh, G2 = G1(l) (Lambda(v) = 0). */
static void brdf_nov1(double rough, double *albedo, double *bias)
{
    double a = rough * rough, a2 = a * a;
    double lo = sqrt(0.5), hi = 1.0;
    int n = 20000;
    double sa = 0, sb = 0;
    for (int i = 0; i <= n; i++) {
        double t = lo + (hi - lo) * i / n;
        double nol = 2 * t * t - 1;
        double q = t * t * (a2 - 1) + 1;
        double D = a2 / (M_PI * q * q);
        double g1 = nol > 0 ? 2 * nol / (nol + sqrt(a2 + (1 - a2) * nol * nol)) : 0;
        double f = 2 * M_PI * D * t * g1 * t / (4 * t) * 4 / 4; /* D G1 / (4 NoL NoV) NoL dl */
        /* D G1 / 4 over l = D G1 / 4 * 4 t per unit h, h measure 2 pi dt: 2 pi D G1 t */
        f = 2 * M_PI * D * g1 * t;
        double wgt = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
        sa += wgt * f;
        sb += wgt * f * pow(1 - t, 5);
    }
    *albedo = sa * (hi - lo) / n / 3;
    *bias = sb * (hi - lo) / n / 3;
}

static void test_brdf(void)
{
    double ab[2];
    /* Roughness 0: every sample is h = N, weight exactly 1. */
    for (double nov = 0.05; nov <= 1.0; nov += 0.15) {
        CHECK_OK(envl_brdf_eval(nov, 0.0, 256, ab));
        CHECK_NEAR(ab[0] + ab[1], 1.0, 1e-12);
        CHECK_NEAR(ab[1], pow(1 - nov, 5), 1e-12);
    }
    /* NoV = 1: roughness 1 in closed form, 1 - ln 2; others by the 1D integral. The
     * Hammersley estimate with 65536 points is good to ~1e-4 here. */
    CHECK_OK(envl_brdf_eval(1.0, 1.0, 65536, ab));
    CHECK_NEAR(ab[0] + ab[1], 1 - log(2.0), 1e-4);
    for (double r = 0.25; r <= 1.0; r += 0.25) {
        double alb, bias;
        brdf_nov1(r, &alb, &bias);
        CHECK_OK(envl_brdf_eval(1.0, r, 65536, ab));
        CHECK_NEAR(ab[0] + ab[1], alb, 2e-4);
        CHECK_NEAR(ab[1], bias, 2e-4);
        if (r == 1.0)
            CHECK_NEAR(alb, 1 - log(2.0), 1e-9);
    }
    /* The table: 32 x 32, first row (roughness 1/64) A + B ~ 1, last column ~ NoV = 1. */
    float *t, *tm;
    int32_t s;
    envl_brdf_options bo = {.size = 32, .samples = 2048};
    CHECK_OK(envl_brdf_lut(&bo, &t, &s));
    CHECK(s == 32);
    for (int32_t c = 0; c < s; c++)
        CHECK_NEAR(t[2 * c] + t[2 * c + 1], 1.0, 2e-3);
    double alb, bias;
    brdf_nov1((s - 0.5) / s, &alb, &bias);
    CHECK_NEAR(t[2 * ((s - 1) * s + s - 1)] + t[2 * ((s - 1) * s + s - 1) + 1], alb, 5e-3);
    bo.multiscatter = 1;
    CHECK_OK(envl_brdf_lut(&bo, &tm, &s));
    for (int32_t i = 0; i < s * s; i++) {
        CHECK_NEAR(tm[2 * i], t[2 * i + 1], 1e-7);                /* B */
        CHECK_NEAR(tm[2 * i + 1], t[2 * i] + t[2 * i + 1], 1e-6); /* A + B */
    }
    envl_free(t);
    envl_free(tm);
    CHECK_RC(envl_brdf_eval(1.5, 0.5, 0, ab), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_brdf_lut(&(envl_brdf_options){.size = -1}, &t, &s), ENVL_ERR_ARGUMENT);
}

/* docs/design.md's glossy error on a small smooth map (the 512 x 256 sky with its sun turned down
 * to nearly nothing), base 256 wide, 256 samples. */
static void test_glossy_error(void)
{
    envl_sky_options so = {.width = 512, .sun_irradiance = 1e-6};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    const double rs[5] = {0.1, 0.25, 0.5, 0.75, 1.0};
    envl_request q = {.n_roughness = 5, .roughness = rs, .measure = 1};
    q.prefilter.width = 256;
    q.prefilter.samples = 256;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    for (int i = 0; i < 5; i++) {
        envl_level l;
        CHECK_OK(envl_products_level(p, i, &l));
        double e2;
        CHECK_OK(envl_glossy_error(m, l.roughness, l.rgb, l.width, l.height, &e2));
        CHECK_NEAR(e2, l.glossy_error, 1e-12);
        printf("smooth sky: roughness %.2f %d x %d glossy error %.3f %%\n", l.roughness,
               (int)l.width, (int)l.height, 100 * l.glossy_error);
        /* docs/design.md's target is 1 %. At roughness 0.1 the lobe (~1 degree) is narrower than
         * the map's pixels (0.7 degrees) are apart, so the reference itself is a pixelated
         * picture of the horizon: 2 % there. */
        CHECK(l.glossy_error >= 0 && l.glossy_error <= (l.roughness < 0.2 ? 0.02 : 0.01));
    }
    envl_products_free(p);
    envl_envmap_free(m);
}

/* Requests: roughness 0.4 alone computes one level and one pyramid, no SH, no irradiance;
 * the pyramid is cached for the next request; everything takes longer. */
static void test_request(void)
{
    envl_sky_options so = {.width = 512};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_request one = {.n_roughness = 1, .roughness = (double[]){0.4}};
    double t0 = now();
    envl_products *p;
    CHECK_OK(envl_compute(m, &one, &p));
    double t_one = now() - t0;
    envl_products_summary s;
    CHECK_OK(envl_products_get_summary(p, &s));
    CHECK(s.specular_levels == 1 && s.pyramids_built == 1 && s.sh_projections == 0);
    CHECK(s.irradiance_maps == 0 && s.lights_computed == 0 && s.brdf_tables == 0);
    CHECK(envl_products_level_count(p) == 1 && envl_products_find_level(p, 0.4) == 0);
    envl_irradiance_map irr;
    CHECK_RC(envl_products_irradiance(p, &irr), ENVL_ERR_ARGUMENT);
    CHECK(envl_products_sh(p) == NULL && envl_products_lights(p) == NULL);
    CHECK(envl_products_brdf(p, NULL, NULL) == NULL);
    envl_products_free(p);
    /* Mirror only: no pyramid at all. */
    envl_envmap_drop_mips(m);
    envl_request mir = {.mirror = 1};
    CHECK_OK(envl_compute(m, &mir, &p));
    envl_products_get_summary(p, &s);
    CHECK(s.pyramids_built == 0 && s.pyramid_levels == 0 && s.specular_levels == 1);
    envl_products_free(p);
    /* Everything: one SH projection shared by diffuse and an SH irradiance map; mirror and the
     * chain's roughness 0 and 0.4 are not computed twice. */
    envl_request all = {.diffuse = 1, .irradiance_map = 1, .mirror = 1, .shadows = 1,
                        .specular_chain = 1, .n_roughness = 2,
                        .roughness = (double[]){0.4, 0.25}, .brdf_lut = 1};
    all.prefilter.irradiance_method = ENVL_IRRADIANCE_SH;
    all.brdf.size = 64;
    t0 = now();
    CHECK_OK(envl_compute(m, &all, &p));
    double t_all = now() - t0;
    envl_products_get_summary(p, &s);
    CHECK(s.sh_projections == 1 && s.pyramids_built == 1 && s.irradiance_maps == 1);
    CHECK(s.lights_computed == 1 && s.brdf_tables == 1);
    CHECK(s.specular_levels == ENVL_DEFAULT_LEVELS + 1); /* the chain + 0.25 */
    CHECK(envl_products_sh(p) != NULL && envl_products_lights(p) != NULL);
    printf("request timing: roughness 0.4 alone %.3f s, everything %.3f s (ratio %.1f)\n",
           t_one, t_all, t_all / t_one);
    CHECK(t_one < t_all);
    envl_products_free(p);
    envl_envmap_free(m);
}

/* Same output for 1, 2 and 3 threads: the level's texels, and the cell pyramid under them,
 * which each map builds with its own thread count (its level-L split moves with it). */
static void test_threads(void)
{
    envl_sky_options so = {.width = 512};
    envl_envmap *sky;
    CHECK_OK(envl_envmap_sky(&so, &sky));
    float *lv[3];
    for (int t = 0; t < 3; t++) {
        envl_envmap *m;
        CHECK_OK(envl_envmap_from_pixels(envl_envmap_pixels(sky), 512, 256, 3,
                                         &(envl_load_options){.threads = t + 1}, &m));
        envl_level st;
        CHECK_OK(envl_prefilter_specular(m, 0.3, 64, &(envl_prefilter_options){.threads = t + 1},
                                         &lv[t], &st));
        envl_envmap_free(m);
    }
    CHECK(memcmp(lv[0], lv[1], sizeof(float) * 3 * 64 * 32) == 0);
    CHECK(memcmp(lv[0], lv[2], sizeof(float) * 3 * 64 * 32) == 0);
    for (int t = 0; t < 3; t++)
        envl_free(lv[t]);
    envl_envmap_free(sky);
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

static int count_temporaries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += strncmp(e->d_name, ".envl-", 6) == 0;
    if (d)
        closedir(d);
    return n;
}

/* RGBM atlas round trip (layout and quantisation); a failed export changes nothing. */
static void test_export(void)
{
    envl_sky_options so = {.width = 256};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_request q = {.specular_chain = 1, .irradiance_map = 1, .brdf_lut = 1};
    q.prefilter = (envl_prefilter_options){.width = 64, .min_width = 2, .samples = 32};
    q.brdf.size = 16;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    const char *dir = tmp_path("atlas");
    mkdir(dir, 0755);
    envl_export_options eo = {.format = "rgbm-png", .layout = ENVL_EXPORT_ATLAS};
    CHECK_OK(envl_products_export(p, dir, &eo));
    char path[4200];
    snprintf(path, sizeof path, "%s/specular_atlas.png", dir);
    int32_t w, h, ch;
    uint8_t *px = NULL;
    CHECK_OK(envl__png_read(path, &w, &h, &ch, &px));
    CHECK(w == 64 && h == 64 && ch == 4);
    for (int32_t k = 0; px && k < ENVL_DEFAULT_LEVELS; k++) {
        envl_level l;
        envl_products_level(p, k, &l);
        CHECK(l.width == (64 >> k)); /* min_width 2: the chain halves all the way */
        int32_t y0 = 64 >> (k + 1);
        double worst = 0;
        for (int32_t r = 0; r < l.height; r++)
            for (int32_t c = 0; c < l.width; c++) {
                const uint8_t *e = px + 4 * ((size_t)(y0 + r) * w + c);
                float dec[3];
                envl_rgbm_decode(e, ENVL_RGBM_RANGE, dec);
                for (int i = 0; i < 3; i++) {
                    double v = fmin(l.rgb[3 * ((size_t)r * l.width + c) + i], 6.0);
                    /* rounding of rgb8: half a step of 6 a / 255 */
                    double tol = 0.5 * 6.0 * (e[3] / 255.0) / 255.0 + 1e-6;
                    worst = fmax(worst, fabs(dec[i] - v) / tol);
                }
            }
        CHECK(worst <= 1.0);
    }
    /* The rows above the last slot are unused (zero). */
    for (int32_t i = 0; px && i < 4 * w * (64 >> ENVL_DEFAULT_LEVELS); i++)
        CHECK(px[i] == 0);
    free(px);
    snprintf(path, sizeof path, "%s/brdf_lut.png", dir);
    CHECK_OK(envl__png_read(path, &w, &h, &ch, &px));
    CHECK(w == 16 && h == 16 && ch == 3);
    free(px);
    snprintf(path, sizeof path, "%s/prefilter.json", dir);
    long json_size = file_size(path);
    CHECK(json_size > 100);
    envl_products_free(p);

    /* An export that fails part-way (6 levels cannot fit an atlas 16 wide) leaves the files
     * of the successful one as they were and no temporaries. */
    q.prefilter.width = 16;
    CHECK_OK(envl_compute(m, &q, &p));
    snprintf(path, sizeof path, "%s/irradiance.png", dir);
    long irr_size = file_size(path);
    CHECK(irr_size > 0);
    CHECK_RC(envl_products_export(p, dir, &eo), ENVL_ERR_ARGUMENT);
    CHECK(file_size(path) == irr_size);
    snprintf(path, sizeof path, "%s/prefilter.json", dir);
    CHECK(file_size(path) == json_size);
    CHECK(count_temporaries(dir) == 0);
    /* Lat-long EXR and cube faces. */
    CHECK_OK(envl_products_export(p, dir, &(envl_export_options){.layout = ENVL_EXPORT_CUBE}));
    snprintf(path, sizeof path, "%s/specular_00_nz.exr", dir);
    CHECK(file_size(path) > 0);
    CHECK_RC(envl_products_export(p, dir, &(envl_export_options){.format = "tiff"}),
             ENVL_ERR_ARGUMENT);
    envl_products_free(p);
    envl_envmap_free(m);
}

static void test_rgbm(void)
{
    float in[3] = {5.0f, 0.5f, 0.0f}, out[3];
    uint8_t e[4];
    envl_rgbm_encode(in, 6.0, e);
    CHECK(e[3] == 213); /* ceil(255 * 5 / 6) */
    envl_rgbm_decode(e, 6.0, out);
    CHECK_NEAR(out[0], 5.0, 0.5 * 6 * 213 / 255.0 / 255.0);
    CHECK_NEAR(out[1], 0.5, 0.5 * 6 * 213 / 255.0 / 255.0);
    float big[3] = {100, 100, 100}, zero[3] = {0, 0, 0};
    envl_rgbm_encode(big, 6.0, e);
    CHECK(e[0] == 255 && e[3] == 255);
    envl_rgbm_encode(zero, 6.0, e);
    CHECK(e[0] == 0 && e[3] == 0);
}


/* N(alpha) in closed form against a midpoint sum of 2 pi int_0^1 u / (A + B u)^2 du, and its
 * limit pi at alpha = 1 (the series branch) from both sides. */
static void test_lobe_norm(void)
{
    const double as[6] = {0.01, 0.0625, 0.25, 0.5625, 0.999, 1.0};
    for (int i = 0; i < 6; i++) {
        double a2 = as[i] * as[i], A = 0.5 * (1 + a2), B = 0.5 * (a2 - 1), s = 0;
        int n = 2000000;
        for (int k = 0; k < n; k++) {
            double u = (k + 0.5) / n, q = A + B * u;
            s += u / (q * q);
        }
        s *= 2 * M_PI / n;
        CHECK_REL(envl_ggx_lobe_norm(as[i]), s, 1e-6);
    }
    CHECK_REL(envl_ggx_lobe_norm(1.0), M_PI, 1e-12);
    CHECK_REL(envl_ggx_lobe_norm(0.999995), envl_ggx_lobe_norm(1.000005), 1e-4);
}

/* One bright pixel (1e4 over 1) is split into a point lobe: every level matches the brute-force
 * reference at the output texel centres. Tolerance: the lobe is evaluated at the texel centre
 * exactly as the reference sums it (the pixel's excess times w), the residual is a constant
 * (exact), so what remains is the reference's discrete normaliser against N(alpha) (a midpoint
 * sum of a lobe >= 4 pixels wide: < 1e-3) and the energy rescaling of the lobe part (the sum of
 * w over the output grid, ~1e-3): 1 % of the peak, relative to each texel's value + 1e-2 of
 * the peak's value for far texels. */
static void test_point_lobe(void)
{
    int32_t w = 256, h = 128;
    float *px = malloc(sizeof(float) * 3 * w * h);
    for (int32_t i = 0; i < 3 * w * h; i++)
        px[i] = 1.0f;
    for (int k = 0; k < 3; k++)
        px[3 * (40 * w + 70) + k] = k == 0 ? 1e4f : 5e3f;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    const double rs[3] = {0.5, 0.75, 1.0};
    for (int i = 0; i < 3; i++) {
        float *rgb;
        envl_level st;
        envl_prefilter_options po = {.width = 64, .samples = 64};
        CHECK_OK(envl_prefilter_specular(m, rs[i], 0, &po, &rgb, &st));
        int32_t lw = st.width, lh = st.height;
        double *d = malloc(sizeof(double) * 3 * lw * lh), *ref = malloc(sizeof(double) * 3 * lw * lh);
        for (int32_t r = 0; r < lh; r++)
            for (int32_t c = 0; c < lw; c++)
                envl_latlong_direction(lw, lh, c, r, d + 3 * (r * lw + c));
        CHECK_OK(envl_prefilter_reference(m, rs[i], lw * lh, d, ref));
        double peak = 0, worst = 0;
        for (int32_t t = 0; t < lw * lh; t++)
            peak = fmax(peak, ref[3 * t]);
        for (int32_t t = 0; t < lw * lh; t++)
            for (int k = 0; k < 3; k++) {
                double e = fabs(rgb[3 * t + k] - ref[3 * t + k]) / (ref[3 * t + k] + 1e-2 * peak);
                worst = fmax(worst, e);
            }
        printf("one bright pixel: roughness %.2f %d x %d worst error %.4f %% (peak %.1f)\n",
               rs[i], (int)lw, (int)lh, 100 * worst, peak);
        CHECK(worst < 0.01);
        free(d), free(ref), free(rgb);
    }
    free(px);
    envl_envmap_free(m);
}

/* A sun map (the built-in sky, 1024 x 512, base level 512 wide), the sun baked into the levels
 * as point lobes: the glossy error at the five roughness values is printed; where the issue's
 * 1 % target is met (0.5, 0.75 and 1.0) it is asserted. 0.1 and 0.25 are limited by the level's
 * resolution (the lobe is a few texels wide; 0.26 % at 0.1 with a 2048-wide level): reported,
 * not asserted here (see test_sun_lights). */
static void test_sun_glossy(void)
{
    envl_sky_options so = {.width = 1024};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    const double rs[5] = {0.1, 0.25, 0.5, 0.75, 1.0};
    envl_request q = {.n_roughness = 5, .roughness = rs, .measure = 1};
    q.prefilter.width = 512;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    for (int i = 0; i < 5; i++) {
        envl_level l;
        CHECK_OK(envl_products_level(p, i, &l));
        printf("sun sky: roughness %.2f %d x %d glossy error %.3f %% energy_scale %.4f\n",
               l.roughness, (int)l.width, (int)l.height, 100 * l.glossy_error, l.energy_scale);
        CHECK(l.glossy_error >= 0 && isfinite(l.glossy_error));
        if (l.roughness >= 0.5)
            CHECK(l.glossy_error <= 0.01);
    }
    int32_t n;
    CHECK(envl_products_sun_lights(p, &n) == NULL && n == 0); /* not asked */
    envl_products_free(p);
    envl_envmap_free(m);
}

/* The target: a 2048 x 1024 sun map, 6-level default sizes (512 wide at roughness 0.1),
 * glossy error at most 1 % at 0.1, 0.25, 0.5, 0.75 and 1.0 with the sun as a light (its disc
 * added analytically, as a renderer adds a sun lamp). The light: one, towards the sky's sun
 * (elevation 35, azimuth 0) to 0.05 degrees (the centroid of a 0.53-degree disc of 0.18-degree
 * pixels, symmetric about it); energy: level of roughness 1 (its texel sum: energy_scale x the
 * residual's, in luminance, to 1e-5, float sums of 2M pixels ~1e-6 each) + the light's rgb =
 * the map's power, to energy_scale's distance from 1 (the texel grid's quadrature of the level)
 * plus 1e-5;
 * the irradiance map of the residual + the light's cosine within 0.2 % (the resampled method's
 * ~1e-3). */
static void test_sun_lights(void)
{
    envl_sky_options so = {.width = 2048};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    const double rs[5] = {0.1, 0.25, 0.5, 0.75, 1.0};
    envl_request q = {.n_roughness = 5, .roughness = rs, .measure = 1, .irradiance_map = 1};
    q.prefilter.sun_lights = 1;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    int32_t n;
    const envl_light *sun = envl_products_sun_lights(p, &n);
    CHECK(n == 1 && sun);
    if (n == 1 && sun) {
        double e = 35 * M_PI / 180, want[3] = {cos(e), 0, sin(e)};
        double dot = want[0] * sun->direction[0] + want[1] * sun->direction[1] +
                     want[2] * sun->direction[2];
        printf("sun light: %.3f deg off, rgb %.4f %.4f %.4f, angle %.3f deg\n",
               acos(fmin(1, dot)) * 180 / M_PI, sun->rgb[0], sun->rgb[1], sun->rgb[2],
               sun->angle * 180 / M_PI);
        CHECK(acos(fmin(1, dot)) * 180 / M_PI < 0.05);
        CHECK(sun->angle * 180 / M_PI > 0.4 && sun->angle * 180 / M_PI < 0.8);
        envl_info info;
        envl_envmap_info(m, &info);
        envl_level l;
        CHECK_OK(envl_products_level(p, 4, &l));
        double el[3], y_power = envl_luminance(info.power[0], info.power[1], info.power[2]);
        for (int k = 0; k < 3; k++)
            el[k] = energy(l.rgb, l.width, l.height, k);
        CHECK_REL(envl_luminance(el[0], el[1], el[2]),
                  l.energy_scale * (y_power - envl_luminance(sun->rgb[0], sun->rgb[1],
                                                             sun->rgb[2])), 1e-5);
        for (int k = 0; k < 3; k++)
            CHECK_REL(el[k] + sun->rgb[k], info.power[k], fabs(l.energy_scale - 1) + 1e-5);
    }
    for (int i = 0; i < 5; i++) {
        envl_level l;
        CHECK_OK(envl_products_level(p, i, &l));
        printf("sun sky 2048, sun light: roughness %.2f %d x %d samples %d glossy error %.3f %%\n",
               l.roughness, (int)l.width, (int)l.height, (int)l.samples, 100 * l.glossy_error);
        CHECK(l.glossy_error >= 0 && l.glossy_error <= 0.01);
    }
    envl_irradiance_map irr;
    CHECK_OK(envl_products_irradiance(p, &irr));
    printf("sun sky 2048, sun light: irradiance diffuse error %.3f %%\n", 100 * irr.diffuse_error);
    CHECK(irr.diffuse_error >= 0 && irr.diffuse_error <= 0.002);
    envl_products_free(p);
    /* the unfiltered baseline samples the map as it is: no sun lights there */
    q.prefilter.unfiltered = 1;
    q.measure = 0;
    CHECK(envl_compute(m, &q, &p) == ENVL_ERR_ARGUMENT);
    envl_envmap_free(m);
}

/* Which split-off groups become sun lights: on a 512 x 256 map of 1, a disc of radius 1.5
 * degrees at 1e3 (a sun: compact, a third of the power), a line 1 pixel tall and 7 wide at 1e3
 * (a window edge, 5 % of the power: its disc of the same spread, 4 degrees across, is about
 * 0.82^2 pi 7^2 / 4 = 26 pixels, more than twice its 7) and one pixel at 200 (above 50x the
 * mean but 0.1 % of the power): exactly one light, at the disc's centre to half a pixel (0.35
 * degree); the rest stays baked, so level power + light = map power, to the level's texel
 * quadrature (energy_scale's distance from 1) plus 1e-5. */
static void test_sun_light_choice(void)
{
    int32_t w = 512, h = 256;
    float *px = malloc(sizeof(float) * 3 * w * h);
    for (int32_t i = 0; i < 3 * w * h; i++)
        px[i] = 1.0f;
    double sun[3];
    envl_latlong_direction(w, h, 100.5, 80.5, sun);
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++) {
            double d[3];
            envl_latlong_direction(w, h, c, r, d);
            double cosd = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
            float v = cosd > cos(1.5 * M_PI / 180) ? 1e3f
                      : r == 150 && c >= 300 && c < 307 ? 1e3f
                      : r == 40 && c == 450 ? 200.0f : 1.0f;
            for (int k = 0; k < 3; k++)
                px[3 * (r * w + c) + k] = v;
        }
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    free(px);
    double r1 = 1.0;
    envl_request q = {.n_roughness = 1, .roughness = &r1};
    q.prefilter.sun_lights = 1;
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    int32_t n;
    const envl_light *l = envl_products_sun_lights(p, &n);
    CHECK(n == 1 && l);
    if (n == 1 && l) {
        double dot = l->direction[0] * sun[0] + l->direction[1] * sun[1] +
                     l->direction[2] * sun[2];
        CHECK(acos(fmin(1, dot)) * 180 / M_PI < 0.35);
        envl_info info;
        envl_envmap_info(m, &info);
        envl_level lv;
        CHECK_OK(envl_products_level(p, 0, &lv));
        CHECK_REL(energy(lv.rgb, lv.width, lv.height, 0) + l->rgb[0], info.power[0],
                  fabs(lv.energy_scale - 1) + 1e-5); /* a grey map: every channel the same */
    }
    envl_products_free(p);
    envl_envmap_free(m);
}

/* Issue 19. A map of 3e38 (finite) has irradiance pi 3e38, beyond a float: envl_compute
 * refuses the irradiance map (ENVL_ERR_NONFINITE, naming the map) instead of returning inf
 * pixels; the specular levels (weighted means of the map) still fit and are finite. A bright
 * pixel over a dim map rings negative in plain order-2 SH: the SH irradiance map (window auto)
 * has no negative pixel. */
static void test_hostile_numbers(void)
{
    const int w = 64, h = 32;
    float *px = malloc(sizeof(float) * w * h * 3);
    for (int i = 0; i < w * h * 3; i++)
        px[i] = 3e38f;
    envl_envmap *m;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    envl_products *p = NULL;
    envl_request q = {.irradiance_map = 1};
    for (int method = 0; method < ENVL_IRRADIANCE_COUNT; method++) {
        q.prefilter.irradiance_method = method;
        CHECK_RC(envl_compute(m, &q, &p), ENVL_ERR_NONFINITE);
        CHECK(p == NULL && strstr(envl_last_error(), "irradiance map overflows the float"));
    }
    envl_request spec = {.n_roughness = 2, .roughness = (double[]){0.0, 0.5}};
    spec.prefilter = (envl_prefilter_options){.width = 64, .min_width = 32, .samples = 16};
    CHECK_OK(envl_compute(m, &spec, &p));
    for (int32_t i = 0; p && i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        for (int32_t k = 0; k < 3 * l.width * l.height; k++)
            CHECK_REL(l.rgb[k], 3e38f, 1e-6); /* a mean of equal floats */
    }
    envl_products_free(p);
    envl_envmap_free(m);

    for (int i = 0; i < w * h * 3; i++)
        px[i] = 0.1f;
    for (int k = 0; k < 3; k++)
        px[3 * (10 * w + 20) + k] = 1e5f;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &(envl_load_options){.layout = 1}, &m));
    q.prefilter = (envl_prefilter_options){.irradiance_method = ENVL_IRRADIANCE_SH,
                                           .irradiance_width = 64};
    q.diffuse = 1; /* shared with the irradiance map */
    CHECK_OK(envl_compute(m, &q, &p));
    envl_irradiance_map irr;
    if (p && envl_products_irradiance(p, &irr) == ENVL_OK) {
        float least = INFINITY;
        for (int32_t k = 0; k < 3 * irr.width * irr.height; k++)
            least = fminf(least, irr.rgb[k]);
        CHECK(least >= 0);
        envl_sh_summary s;
        envl_sh_get_summary(envl_products_sh(p), &s);
        CHECK(s.window == ENVL_WINDOW_AUTO && s.window_width > 0 && s.min_irradiance >= 0);
    }
    envl_products_free(p);
    envl_envmap_free(m);
    free(px);
}

/* The glossy measure's reference (a finer cut of the cell pyramid, error_measure.h) within
 * ENVL_GLOSSY_REFERENCE_TOLERANCE relative RMS of the brute force over the measure's 1024
 * directions: on the built-in sky at 2048 (a 0.5-degree sun, the hardest case for a cut) at
 * roughness 0.1-1, and on every map of ../shared/data/latlong_hdri at 0.1 and 0.2, where the
 * cut is hardest (left out under memcheck, as test_irradiance's maps). Measured worst when
 * written: 4.9e-4 (rooitou_park at 0.2); at roughness 1 all below 2e-5. */
static double reference_gap(envl_envmap *m, double r, const double *dirs)
{
    double *a = malloc(sizeof(double) * 3 * 1024), *b = malloc(sizeof(double) * 3 * 1024);
    CHECK_OK(envl_prefilter_reference(m, r, 1024, dirs, a));
    CHECK_OK(envl__glossy_reference(m, NULL, r, 1024, dirs, b));
    double d = envl_relative_rms_luminance(1024, b, a);
    CHECK(d <= ENVL_GLOSSY_REFERENCE_TOLERANCE);
    free(a), free(b);
    return d;
}

static void test_glossy_reference(void)
{
    double *dirs = malloc(sizeof(double) * 3 * 1024);
    for (int i = 0; i < 1024; i++)
        envl_fibonacci_direction(i, 1024, dirs + 3 * i);
    envl_sky_options so = {.width = 2048};
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    const double rs[4] = {0.1, 0.2, 0.5, 1.0};
    printf("glossy reference against the brute force, relative RMS:\n  sky 2048");
    for (int k = 0; k < 4; k++)
        printf("  %.1f: %.1e", rs[k], reference_gap(m, rs[k], dirs));
    printf("\n");
    envl_envmap_free(m);
    const char *dir = ENVL_SHARED_DATA "/latlong_hdri";
    DIR *d = getenv("ENVL_UNDER_MEMCHECK") ? NULL : opendir(dir);
    if (!d)
        printf("  skipped the maps: %s\n", getenv("ENVL_UNDER_MEMCHECK")
                   ? "under memcheck (the plain and ASan runs check them)" : "data absent");
    struct dirent *e;
    while (d && (e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".hdr"))
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        CHECK_OK(envl_envmap_load(path, NULL, &m));
        printf("  %-28s", e->d_name);
        const double mr[2] = {0.1, 0.2};
        for (int k = 0; k < 2; k++)
            printf("  %.1f: %.1e", mr[k], reference_gap(m, mr[k], dirs));
        printf("\n");
        envl_envmap_free(m);
    }
    if (d)
        closedir(d);
    free(dirs);
}

/* The mip pyramid keeps no level wider than 4096 (a 16K map's level 1 would be a quarter of
 * the map again): on a 16384 x 8 map, level 1 (8192 x 4) is not kept and a request for it
 * reads the map; level 2 (4096 x 2) is the map's exact area mean, each of its pixels the mean
 * of 4 x 4 of the map's (the rows' solid angles within the block weigh them); the level count
 * is the whole pyramid's. A request the map itself meets builds nothing. */
static void test_mips_kept(void)
{
    const int32_t w = 16384, h = 8;
    float *px = malloc(sizeof(float) * 3 * (size_t)w * h);
    for (size_t i = 0; i < (size_t)3 * w * h; i++)
        px[i] = (float)((i * 2654435761u) % 1000) / 100.0f;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    envl_image lev;
    CHECK_OK(envl__mip_level_for(m, ENVL_PI / h, &lev)); /* the map's own pixels */
    CHECK(lev.px == m->px && lev.width == w && m->mip_levels == 0);
    CHECK_OK(envl__mip_level_for(m, ENVL_PI / 4, &lev)); /* level 1: not kept */
    CHECK(lev.px == m->px && lev.width == w && m->mip_levels == 15 && m->mip_first == 2);
    CHECK_OK(envl__mip_level_for(m, ENVL_PI / 2, &lev)); /* level 2 */
    CHECK(lev.width == 4096 && lev.height == 2 && lev.px != m->px);
    double worst = 0;
    for (int32_t r = 0; r < 2; r++)
        for (int32_t c = 0; c < 4096; c++)
            for (int ch = 0; ch < 3; ch++) {
                double sum = 0, om = 0;
                for (int32_t y = 4 * r; y < 4 * r + 4; y++)
                    for (int32_t x = 4 * c; x < 4 * c + 4; x++) {
                        double o = envl_latlong_solid_angle(w, h, y);
                        sum += o * px[3 * ((size_t)y * w + x) + ch];
                        om += o;
                    }
                double want = sum / om, got = lev.px[3 * ((size_t)r * 4096 + c) + ch];
                worst = fmax(worst, fabs(got - want) / fmax(want, 1e-30));
            }
    /* two float roundings: the column pass's rows are floats (resample.c), then the mean */
    CHECK(worst <= 2 * 0x1p-24);
    int32_t levels = 0;
    CHECK_OK(envl_envmap_mips(m, &levels));
    CHECK(levels == 15);
    envl_envmap_free(m);
    free(px);
}

int main(void)
{
    test_mips_kept();
    test_hostile_numbers();
    test_constant();
    test_linear();
    test_bright_pixel();
    test_endpoints();
    test_tiny();
    test_brdf();
    test_rgbm();
    test_glossy_error();
    test_glossy_reference();
    test_lobe_norm();
    test_point_lobe();
    test_sun_glossy();
    test_sun_lights();
    test_sun_light_choice();
    test_request();
    test_threads();
    test_export();
    return check_report("test_prefilter");
}
