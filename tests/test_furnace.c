/* The white furnace at every size (issue 30, 4.5): a constant map prefilters to that constant,
 * every texel of every level, whatever the map's shape. The GGX sums (the levels' cell pyramid,
 * the glossy reference) take each pixel as a point at its centre; a map one pixel wide put all
 * those points on one meridian, and texels facing away from it saw none: 0, the others scaled
 * up to keep the energy (1x8: texels 0 and 1.07, stated glossy error 8-11 %, nothing said).
 * A map whose pixels are too coarse for that (fewer than 16 columns, or wider than tall) is
 * now prefiltered from a copy with each pixel split evenly (the same function), which the
 * products' summary reports. Checked on 1x1 .. 7x100 maps and on the 1x16384 and 16384x1
 * extremes: every texel L within 2e-6 relative (float sums), the irradiance map pi L (exact;
 * the default split method within its promise, ENVL_SPLIT_RELATIVE), every
 * stated error within 2e-6 (the diffuse one within the reference's tolerance when the tree
 * sums it); an elevation ramp one pixel wide gives the levels of its split copy. */
#include "error_measure.h"
#include "check.h"

static envl_envmap *constant(int32_t w, int32_t h, const float rgb[3])
{
    float *px = malloc(sizeof(float) * 3 * (size_t)w * h);
    for (size_t i = 0; i < (size_t)w * h; i++)
        for (int k = 0; k < 3; k++)
            px[3 * i + k] = rgb[k];
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &m));
    free(px);
    return m;
}

/* Every value of n RGB texels within rel of rgb; the worst relative deviation returned. */
static double worst(const float *v, size_t n, const float rgb[3])
{
    double e = 0;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            e = fmax(e, fabs(v[3 * i + k] - rgb[k]) / rgb[k]);
    return e;
}

static void furnace(int32_t w, int32_t h, int coarse)
{
    const float rgb[3] = {1.0f, 0.37f, 2.5f};
    envl_envmap *m = constant(w, h, rgb);
    /* the irradiance map by the exact integrator, exact for a constant map; the default
     * (split) is checked below against its promise */
    envl_request q = {.irradiance_map = 1, .specular_chain = 1, .measure = 1,
                      .prefilter = {.levels = 4, .width = 64, .irradiance_width = 32,
                                    .irradiance_method = ENVL_IRRADIANCE_EXACT}};
    envl_products *p = NULL;
    CHECK_OK(envl_compute(m, &q, &p));
    if (!p) {
        envl_envmap_free(m);
        return;
    }
    envl_products_summary s;
    envl_products_get_summary(p, &s);
    double e = 0, err = 0;
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        e = fmax(e, worst(l.rgb, (size_t)l.width * l.height, rgb));
        err = fmax(err, l.glossy_error);
    }
    envl_irradiance_map irr;
    CHECK_OK(envl_products_irradiance(p, &irr));
    const float e_rgb[3] = {(float)(ENVL_PI * rgb[0]), (float)(ENVL_PI * rgb[1]),
                            (float)(ENVL_PI * rgb[2])};
    double ei = worst(irr.rgb, (size_t)irr.width * irr.height, e_rgb);
    printf("%5d x %-5d levels within %.2g, irradiance %.2g, errors %.2g; prefiltered as %d x %d\n",
           (int)w, (int)h, e, ei, fmax(err, irr.diffuse_error), (int)s.prefiltered_width,
           (int)s.prefiltered_height);
    CHECK(e <= 2e-6);
    CHECK(ei <= 2e-6);
    /* the glossy reference of a constant map is exact (a ratio of the same sums); the diffuse
     * one above 256 x 128 pixels is the tree's, within ENVL_REFERENCE_TOLERANCE of the mean */
    CHECK(err <= 2e-6);
    CHECK(irr.diffuse_error <= 2e-6 + ((int64_t)s.prefiltered_width * s.prefiltered_height >
                                               256 * 128
                                           ? ENVL_REFERENCE_TOLERANCE
                                           : 0));
    /* the summary says when the map was split first (and into what), and only then */
    if (coarse == 1) /* split: k x j pixels each, at least 64 x 32, aspect within [1/2, 2] */
        CHECK(s.prefiltered_width >= 64 && s.prefiltered_width % w == 0 &&
              s.prefiltered_height >= 32 && s.prefiltered_height % h == 0 &&
              s.prefiltered_width >= s.prefiltered_height &&
              s.prefiltered_width <= 4 * s.prefiltered_height);
    else if (coarse == 2) /* splitting would pass 1024 x 512: resampled to it */
        CHECK(s.prefiltered_width == 1024 && s.prefiltered_height == 512);
    else
        CHECK(s.prefiltered_width == w && s.prefiltered_height == h);
    /* the default irradiance method, split: every texel within ENVL_SPLIT_RELATIVE of pi L */
    envl_request qs = {.irradiance_map = 1,
                       .prefilter = {.irradiance_width = 32,
                                     .irradiance_method = ENVL_IRRADIANCE_SPLIT}};
    envl_products *ps = NULL;
    CHECK_OK(envl_compute(m, &qs, &ps));
    envl_irradiance_map irs;
    if (ps && envl_products_irradiance(ps, &irs) == ENVL_OK)
        CHECK(worst(irs.rgb, (size_t)irs.width * irs.height, e_rgb) <= ENVL_SPLIT_RELATIVE);
    else
        CHECK(0);
    envl_products_free(ps);
    /* one level on its own */
    float *lv = NULL;
    envl_level st;
    CHECK_OK(envl_prefilter_specular(m, 0.4, 32, NULL, &lv, &st));
    CHECK(lv && worst(lv, 32 * 16, rgb) <= 2e-6);
    envl_free(lv);
    envl_products_free(p);
    envl_envmap_free(m);
}

/* A map one pixel wide is prefiltered as its copy with each pixel split: the very levels of
 * that copy given as a map (64 x 36 for 1 x 12), and each texel a weighted mean of the map's
 * values (within [min, max] / energy_scale, the level's renormalisation), never 0. */
static void ramp_one_wide(void)
{
    enum { H = 12, K = 64, J = 3 };
    static float px[3 * H], split[3 * K * H * J];
    for (int r = 0; r < H; r++)
        px[3 * r] = px[3 * r + 1] = px[3 * r + 2] = 0.2f + r;
    for (int r = 0; r < H * J; r++)
        for (int c = 0; c < K; c++)
            for (int k = 0; k < 3; k++)
                split[3 * (r * K + c) + k] = px[3 * (r / J)];
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m, *ms;
    CHECK_OK(envl_envmap_from_pixels(px, 1, H, 3, &lo, &m));
    CHECK_OK(envl_envmap_from_pixels(split, K, H * J, 3, &lo, &ms));
    envl_request q = {.specular_chain = 1, .measure = 1, .prefilter = {.levels = 4, .width = 64}};
    envl_products *p, *ps;
    CHECK_OK(envl_compute(m, &q, &p));
    CHECK_OK(envl_compute(ms, &q, &ps));
    int same = 1, inside = 1;
    double err = 0;
    for (int32_t i = 0; p && ps && i < envl_products_level_count(p); i++) {
        envl_level l, ls;
        envl_products_level(p, i, &l);
        envl_products_level(ps, i, &ls);
        size_t n = 3 * (size_t)l.width * l.height;
        same &= l.width == ls.width && memcmp(l.rgb, ls.rgb, sizeof(float) * n) == 0 &&
                l.glossy_error == ls.glossy_error;
        for (size_t k = 0; k < n; k++)
            inside &= l.rgb[k] >= 0.2 / l.energy_scale * (1 - 1e-6) &&
                      l.rgb[k] <= (0.2 + H - 1) / l.energy_scale * (1 + 1e-6);
        err = fmax(err, l.glossy_error);
    }
    printf("1 x %d ramp: the levels of its %d x %d split: %s; within the values' range: %s; "
           "glossy error %.2g\n", H, K, H * J, same ? "yes" : "no", inside ? "yes" : "no", err);
    CHECK(same);
    CHECK(inside);
    envl_products_free(p);
    envl_products_free(ps);
    envl_envmap_free(m);
    envl_envmap_free(ms);
}

int main(void)
{
    static const int32_t sizes[][3] = {
        /* w, h, coarse: 0 as it is, 1 split first, 2 resampled to 1024 x 512 first */
        {1, 1, 1},  {1, 2, 1},  {1, 8, 1},   {1, 15, 1}, {2, 1, 1},    {2, 2, 1},
        {3, 7, 1},  {4, 2, 1},  {8, 4, 1},   {15, 8, 1}, {7, 100, 1},  {1, 64, 1},
        {64, 1, 1}, {40, 3, 1}, {16, 8, 0},  {64, 32, 0}, {48, 12, 0}, {24, 20, 0},
        {1, 16384, 2}, {16384, 1, 2}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        furnace(sizes[i][0], sizes[i][1], sizes[i][2]);
    ramp_one_wide();
    return check_report("test_furnace");
}
