/* Every failing library call frees what it allocated, and sizes are checked in 64 bits before
 * they are multiplied (issue 30, 4.8 and 4.9).
 *
 * Each scenario makes envl_* calls fail in a different place: bad arguments, a file cut short,
 * a map whose products overflow the float range (a specular level, the irradiance map, SH,
 * lights, the POV-Ray include, glTF), a cancel from the progress callback at every step, a
 * write step failing (the fault hook of io.c) in every exporter, layout sizes whose sides do
 * not fit 32 bits. The expected result code is checked, and then the memory: a scenario run a
 * third time must leave exactly as many bytes in use (glibc's mallinfo2, all arenas, heap and
 * mmap) as after its second run (the first fills the caches that live for the process: a
 * thread's buffers, libraries' pools). A leak on an error path grows it every run. Under
 * AddressSanitizer (CI's build-asan) mallinfo2 says nothing, and LeakSanitizer's report at
 * exit fails the test instead; under memcheck (ENVL_UNDER_MEMCHECK) each scenario runs once
 * and memcheck's leak check is the check. */
#include "internal.h"
#include "check.h"
#include "clock.h"

#include <float.h>
#include <malloc.h>
#include <stdint.h>
#include <unistd.h>

static size_t bytes_in_use(void)
{
    struct mallinfo2 mi = mallinfo2();
    return mi.uordblks + mi.hblkhd;
}

/* Runs `scenario` three times: the bytes in use after the second and third runs agree. */
static void leak_free(const char *name, void (*scenario)(void))
{
    if (getenv("ENVL_UNDER_MEMCHECK")) { /* memcheck's leak check is the check: run it once */
        scenario();
        return;
    }
    double t0 = envl__seconds();
    scenario();
    if (getenv("ENVL_TEST_TIMES"))
        fprintf(stderr, "%s: %.2f s a run\n", name, envl__seconds() - t0);
    scenario();
    size_t before = bytes_in_use();
    scenario();
    size_t after = bytes_in_use();
    check_count_++;
    if (after != before) {
        check_failures_++;
        fprintf(stderr, "%s: a failing run leaves %lld more bytes in use\n", name,
                (long long)after - (long long)before);
    }
}

static envl_envmap *small_sky(int32_t width)
{
    envl_sky_options so = {.width = width};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_sky(&so, &m));
    return m;
}

/* A 64 x 32 map of `value` everywhere (FLT_MAX, 3e38: products overflow the float range). */
static envl_envmap *uniform(float value)
{
    static float px[64 * 32 * 3];
    for (int i = 0; i < 64 * 32 * 3; i++)
        px[i] = value;
    envl_envmap *m = NULL;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, 64, 32, 3, &lo, &m));
    return m;
}

/* A folder of this test's own for the exports. */
static const char *out_dir(void)
{
    static char dir[4096];
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "%s", tmp_path("error_paths"));
        mkdir(dir, 0755);
    }
    return dir;
}

/* ---- item 9: layout sizes ---- */
static void layout_sizes(void)
{
    envl_envmap *m = small_sky(32);
    static const int32_t layouts[] = {ENVL_LAYOUT_LATLONG, ENVL_LAYOUT_ANGULAR,
                                      ENVL_LAYOUT_MIRRORBALL, ENVL_LAYOUT_CROSS_V,
                                      ENVL_LAYOUT_CROSS_H, ENVL_LAYOUT_STRIP_H,
                                      ENVL_LAYOUT_STRIP_V, ENVL_LAYOUT_EXR_LATLONG,
                                      ENVL_LAYOUT_EXR_CUBE};
    for (size_t i = 0; i < sizeof layouts / sizeof layouts[0]; i++) {
        int32_t l = layouts[i];
        /* a side beyond 32 bits (cross 3 x 2^30 wide, strips 6 x): an argument no image can
         * have; the sides fit but the pixels are too many: the size limit */
        int sides_overflow = l == ENVL_LAYOUT_CROSS_V || l == ENVL_LAYOUT_CROSS_H ||
                             l == ENVL_LAYOUT_STRIP_H || l == ENVL_LAYOUT_STRIP_V ||
                             l == ENVL_LAYOUT_EXR_CUBE;
        const int32_t sizes[] = {1 << 30, INT32_MAX, 1 << 20};
        for (int k = 0; k < 3; k++) {
            float *px = (float *)&m; /* must come back NULL */
            int32_t w = -1, h = -1;
            envl_result want = k < 2 && sides_overflow ? ENVL_ERR_ARGUMENT : ENVL_ERR_LIMIT;
            CHECK_RC(envl_envmap_to_layout(m, l, sizes[k], &px, &w, &h), want);
            CHECK(px == NULL);
            if (want == ENVL_ERR_ARGUMENT)
                CHECK(strstr(envl_last_error(), "does not fit") != NULL);
        }
    }
    envl_envmap_free(m);
}

/* ---- item 8: failing calls free what they allocated ---- */

static void bad_loads(void)
{
    envl_envmap *m = (envl_envmap *)1;
    CHECK_RC(envl_envmap_load(tmp_path("no-such-file.hdr"), NULL, &m), ENVL_ERR_IO);
    CHECK(m == NULL);
    /* a .hdr cut short: every prefix of a small file */
    envl_envmap *sky = small_sky(16);
    static char hdr[4096], prefix[4096];
    snprintf(hdr, sizeof hdr, "%s", tmp_path("cut.hdr"));
    snprintf(prefix, sizeof prefix, "%s", tmp_path("cut_prefix.hdr"));
    CHECK_OK(envl_envmap_save(sky, hdr, NULL));
    envl_envmap_free(sky);
    uint8_t *data;
    size_t size;
    CHECK_OK(envl__read_file(hdr, 1 << 20, &data, &size));
    for (size_t n = 1; n < size; n += 7) {
        CHECK_OK(envl_file_write_atomic(prefix, data, n));
        CHECK(envl_envmap_load(prefix, NULL, &m) != ENVL_OK);
    }
    free(data);
    envl_load_options bad = {.layout = 99};
    CHECK_RC(envl_envmap_load(hdr, &bad, &m), ENVL_ERR_ARGUMENT);
    envl_load_options wide = {.width = 1 << 30};
    CHECK_RC(envl_envmap_load(hdr, &wide, &m), ENVL_ERR_LIMIT);
    float nan_px[3 * 8 * 4];
    for (int i = 0; i < 3 * 8 * 4; i++)
        nan_px[i] = i == 5 ? NAN : 1.0f;
    envl_load_options strict = {.strict = 1};
    CHECK_RC(envl_envmap_from_pixels(nan_px, 8, 4, 3, &strict, &m), ENVL_ERR_NONFINITE);
    CHECK_RC(envl_envmap_from_pixels(nan_px, 8, 4, 2, NULL, &m), ENVL_ERR_ARGUMENT);
}

static void overflowing_products(void)
{
    /* a specular level of roughness 0.1 over FLT_MAX everywhere overflows (request.c's error
     * path leaked it) */
    envl_envmap *m = uniform(FLT_MAX);
    double r = 0.1;
    envl_request one = {.n_roughness = 1, .roughness = &r, .prefilter = {.width = 64}};
    envl_products *p = (envl_products *)&one;
    CHECK_RC(envl_compute(m, &one, &p), ENVL_ERR_NONFINITE);
    CHECK(p == NULL && strstr(envl_last_error(), "specular level of roughness 0.1 overflows"));
    envl_request chain = {.specular_chain = 1, .n_roughness = 1, .roughness = &r,
                          .prefilter = {.levels = 3, .width = 64}};
    CHECK_RC(envl_compute(m, &chain, &p), ENVL_ERR_NONFINITE);
    float *level = (float *)&one;
    envl_level st;
    CHECK_RC(envl_prefilter_specular(m, 0.1, 64, NULL, &level, &st), ENVL_ERR_NONFINITE);
    CHECK(level == NULL);
    envl_envmap_free(m);
    /* 3e38 everywhere: the irradiance (pi x 3e38) overflows; whatever fails frees */
    m = uniform(3e38f);
    envl_request irr = {.irradiance_map = 1, .diffuse = 1, .shadows = 1,
                        .prefilter = {.irradiance_width = 16}};
    CHECK_RC(envl_compute(m, &irr, &p), ENVL_ERR_NONFINITE);
    CHECK(p == NULL);
    envl_pov_result res;
    envl_pov_options po = {.recipe = ENVL_POV_RECIPE_IMAGE_RADIOSITY, .recipe_is_set = 1};
    if (envl_pov_include_write(m, &po, tmp_path("overflow.inc"), &res) == ENVL_OK)
        unlink(tmp_path("overflow.inc"));
    envl_pov_result_free(&res);
    envl_gltf_options go = {.face_size = 16, .mips = 2, .measure = 1};
    if (envl_gltf_export(m, tmp_path("overflow.glb"), &go, NULL) == ENVL_OK)
        unlink(tmp_path("overflow.glb"));
    envl_envmap_free(m);
}

static void bad_arguments(void)
{
    envl_envmap *m = small_sky(32);
    envl_products *p;
    double r = 2;
    envl_request q = {.n_roughness = 1, .roughness = &r};
    CHECK_RC(envl_compute(m, &q, &p), ENVL_ERR_ARGUMENT);
    envl_request order = {.diffuse = 1, .sh_order = 40};
    CHECK_RC(envl_compute(m, &order, &p), ENVL_ERR_ARGUMENT);
    envl_sh *sh;
    envl_sh_options so = {.order = 99};
    CHECK_RC(envl_sh_compute(m, &so, &sh), ENVL_ERR_ARGUMENT);
    envl_lights *ls;
    envl_lights_options lo = {.method = ENVL_METHOD_FIT, .count = 33};
    CHECK_RC(envl_lights_compute(m, &lo, &ls), ENVL_ERR_ARGUMENT);
    envl_pov_result res;
    envl_pov_options po = {.recipe = 99};
    CHECK_RC(envl_pov_include_write(m, &po, NULL, &res), ENVL_ERR_ARGUMENT);
    envl_pov_result_free(&res);
    envl_pov_options no_name = {.sky = 1};
    CHECK_RC(envl_pov_include_write(m, &no_name, NULL, &res), ENVL_ERR_ARGUMENT);
    envl_pov_result_free(&res);
    envl_gltf_options go = {.face_size = 48};
    CHECK_RC(envl_gltf_export(m, tmp_path("bad.glb"), &go, NULL), ENVL_ERR_ARGUMENT);
    envl_preview_options pv = {.sphere_size = 1};
    CHECK_RC(envl_preview_write(m, &pv, tmp_path("bad.png"), NULL, NULL, NULL),
             ENVL_ERR_ARGUMENT);
    envl_envmap *g;
    CHECK_RC(envl_ground_plane_map(m, 2.0, 1, &g, NULL), ENVL_ERR_ARGUMENT);
    float *rg;
    int32_t s;
    envl_brdf_options bo = {.size = -1};
    CHECK(envl_brdf_lut(&bo, &rg, &s) != ENVL_OK);
    envl_request all = {.irradiance_map = 1, .specular_chain = 1, .prefilter = {.width = 64}};
    CHECK_OK(envl_compute(m, &all, &p));
    envl_export_options cross_gltf = {.layout = ENVL_EXPORT_CROSS, .frame = ENVL_FRAME_GLTF};
    CHECK_RC(envl_products_export(p, out_dir(), &cross_gltf), ENVL_ERR_ARGUMENT);
    envl_export_options ktx_latlong = {.format = "ktx2"};
    CHECK_RC(envl_products_export(p, out_dir(), &ktx_latlong), ENVL_ERR_ARGUMENT);
    envl_products_free(p);
    envl_envmap_free(m);
}

static int cancel_at, calls;
static int cancel(void *user, double fraction, const char *stage)
{
    (void)user, (void)fraction, (void)stage;
    return ++calls >= cancel_at;
}

/* A cancel at each progress step of envl_compute, envl_lights_compute, envl_gltf_export and
 * envl_products_export. */
static void cancelled(void)
{
    envl_envmap *m = small_sky(32);
    envl_request q = {.diffuse = 1, .irradiance_map = 1, .specular_chain = 1, .shadows = 1,
                      .brdf_lut = 1, .measure = 1, .prefilter = {.width = 32, .levels = 3},
                      .brdf = {.size = 8, .samples = 16},
                      .lights = {.method = ENVL_METHOD_VARIANCE, .count = 4}};
    envl_set_progress(cancel, NULL);
    for (cancel_at = 1;; cancel_at++) {
        calls = 0;
        envl_products *p;
        envl_result rc = envl_compute(m, &q, &p);
        if (rc == ENVL_OK) {
            envl_export_options eo = {0};
            for (int at = cancel_at;; at++) {
                calls = 0;
                cancel_at = at;
                if (envl_products_export(p, out_dir(), &eo) == ENVL_OK)
                    break;
            }
            envl_products_free(p);
            break;
        }
        CHECK(rc == ENVL_ERR_CANCELLED);
    }
    for (cancel_at = 1;; cancel_at++) {
        calls = 0;
        envl_lights *ls;
        envl_lights_options lo = {.count = 2, .measure = 1};
        if (envl_lights_compute(m, &lo, &ls) == ENVL_OK) {
            envl_lights_free(ls);
            break;
        }
    }
    for (cancel_at = 1;; cancel_at++) {
        calls = 0;
        envl_gltf_options go = {.face_size = 16, .mips = 2, .measure = 1};
        if (envl_gltf_export(m, tmp_path("cancel.glb"), &go, NULL) == ENVL_OK)
            break;
    }
    envl_set_progress(NULL, NULL);
    envl_envmap_free(m);
}

/* The N-th write step fails, for every N, in the exporters that write several files or
 * compute before they write (the single-file writers: tests/test_writers.c). */
static void failing_writes(void)
{
    envl_envmap *m = small_sky(32);
    envl_request q = {.irradiance_map = 1, .specular_chain = 1, .brdf_lut = 1,
                      .prefilter = {.width = 32, .levels = 2}, .brdf = {.size = 8, .samples = 8}};
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    /* every step of two sets (each file's writer steps alike are test_writers'): RGBM PNG
     * and KTX2, the exporter's own paths (its files, the sidecar, keeping and renaming) */
    static const char *formats[] = {"rgbm-png", "ktx2"};
    for (int f = 0; f < 2; f++) {
        envl_export_options eo = {.format = formats[f]};
        if (f == 1)
            eo.layout = ENVL_EXPORT_CUBE, eo.frame = ENVL_FRAME_GLTF;
        for (int64_t at = 1;; at++) {
            envl__io_calls = 0;
            envl__io_fail_at = at;
            envl_result rc = envl_products_export(p, out_dir(), &eo);
            envl__io_fail_at = 0;
            if (rc == ENVL_OK)
                break;
            CHECK(rc == ENVL_ERR_IO);
        }
    }
    envl_products_free(p);
    /* the POV-Ray include (0.2 s to compute): the first, middle and last steps of its sky
     * image and of the include */
    envl_pov_options po = {.method = ENVL_METHOD_VARIANCE, .method_is_set = 1, .count = 4,
                           .sky_residual = 1};
    envl_pov_result res;
    envl__io_calls = 0;
    CHECK_OK(envl_pov_include_write(m, &po, tmp_path("fail.inc"), &res));
    envl_pov_result_free(&res);
    int64_t steps = envl__io_calls;
    const int64_t fail_at[] = {1, steps / 2, steps - 5, steps - 4, steps};
    for (int k = 0; k < 5; k++) {
        envl__io_calls = 0;
        envl__io_fail_at = fail_at[k];
        CHECK_RC(envl_pov_include_write(m, &po, tmp_path("fail.inc"), &res), ENVL_ERR_IO);
        envl__io_fail_at = 0;
        envl_pov_result_free(&res);
    }
    for (int64_t at = 1;; at++) {
        envl_gltf_options go = {.face_size = 16, .mips = 2};
        envl__io_calls = 0;
        envl__io_fail_at = at;
        envl_result rc = envl_gltf_export(m, tmp_path("fail.glb"), &go, NULL);
        envl__io_fail_at = 0;
        if (rc == ENVL_OK)
            break;
        CHECK(rc == ENVL_ERR_IO);
    }
    /* the preview (a second to compute; its PNG's steps are test_writers'): the last step */
    envl_preview_options pv = {.sphere_size = 48, .reference_width = 16, .fit_count = 1};
    envl__io_calls = 0;
    CHECK_OK(envl_preview_write(m, &pv, tmp_path("fail.png"), NULL, NULL, NULL));
    envl__io_fail_at = envl__io_calls;
    envl__io_calls = 0;
    CHECK_RC(envl_preview_write(m, &pv, tmp_path("fail.png"), NULL, NULL, NULL), ENVL_ERR_IO);
    envl__io_fail_at = 0;
    envl_envmap_free(m);
}

int main(int argc, char **argv)
{
    /* glibc's per-thread cache holds freed blocks as in use (mallinfo2 would count them): off,
     * for this process, by its tunable (read at start: the test runs itself again) */
    const char *tunables = getenv("GLIBC_TUNABLES");
    if (argc == 1 && !getenv("ENVL_UNDER_MEMCHECK") &&
        (!tunables || !strstr(tunables, "tcache_count=0"))) {
        setenv("GLIBC_TUNABLES", "glibc.malloc.tcache_count=0", 1);
        char *again[] = {argv[0], "again", NULL};
        execv("/proc/self/exe", again);
    }
    layout_sizes();
    leak_free("layout sizes", layout_sizes);
    leak_free("bad loads", bad_loads);
    leak_free("overflowing products", overflowing_products);
    leak_free("bad arguments", bad_arguments);
    leak_free("cancelled", cancelled);
    leak_free("failing writes", failing_writes);
    return check_report("test_error_paths");
}
