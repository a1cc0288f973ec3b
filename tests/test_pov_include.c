/* The POV-Ray include in the library (pov_ambient.c, pov_include.c): the ridge functions
 * reproduce any irradiance SH up to order 8; the hemispheric form is sh.c's pair; the include
 * is written atomically (every write step made to fail leaves the old file); its result
 * agrees with its text. Renders are in tests/py_pov.py, the command line in tests/cli_pov.sh. */
#include "envlight.h"
#include "internal.h"
#include "pov_ambient.h"
#include "sh_forms.h"
#include "check.h"

#include <stdint.h>
#include <unistd.h>

/* A fixed pseudo-random number in [-1, 1). */
static double noise(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) / 8388608.0 - 1;
}

/* sum_k sum_l C[k][l] P_l(d_k . n) equals sum_j c_j Y_j(n) (the addition theorem). */
static void test_ridge_from_sh(void)
{
    uint32_t seed = 7;
    for (int order = 0; order <= ENVL_POV_MAX_ORDER; order++) {
        double sh[(ENVL_POV_MAX_ORDER + 1) * (ENVL_POV_MAX_ORDER + 1) * 3];
        int n = (order + 1) * (order + 1);
        for (int j = 0; j < 3 * n; j++)
            sh[j] = noise(&seed);
        pov_ridge r;
        double dev = pov_ridge_from_sh(order, sh, &r);
        CHECK(dev >= 0 && dev < 1e-9);
        CHECK(r.terms == (order == 0 ? 1 : 2 * order + 5) && r.order == order);
        double worst = 0;
        for (int i = 0; i < 200; i++) {
            double d[3] = {noise(&seed), noise(&seed), noise(&seed)};
            double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            double y[(ENVL_POV_MAX_ORDER + 1) * (ENVL_POV_MAX_ORDER + 1)], a[3] = {0, 0, 0}, b[3];
            for (int k = 0; k < 3; k++)
                d[k] /= len;
            envl_sh_basis(order, d, y);
            for (int j = 0; j < n; j++)
                for (int ch = 0; ch < 3; ch++)
                    a[ch] += sh[3 * j + ch] * y[j];
            pov_ridge_eval(&r, d, b);
            for (int ch = 0; ch < 3; ch++)
                worst = fmax(worst, fabs(a[ch] - b[ch]));
        }
        CHECK(worst < 1e-9);
    }
    double bad[3] = {0, 0, 0};
    pov_ridge r;
    CHECK(pov_ridge_from_sh(ENVL_POV_MAX_ORDER + 1, bad, &r) < 0);
}

/* The hemispheric ambient is envl_sh_summary's pair, one ridge term: E(+axis) = sky,
 * E(-axis) = ground, linear in axis . n between. */
static void test_hemi_is_the_sh_pair(void)
{
    envl_sky_options so = {.width = 128};
    envl_envmap *map;
    CHECK_OK(envl_envmap_sky(&so, &map));
    envl_sh_options sho = {.order = 2, .window = ENVL_WINDOW_AUTO};
    envl_sh *sh;
    CHECK_OK(envl_sh_compute(map, &sho, &sh));
    envl_sh_summary s;
    CHECK_OK(envl_sh_get_summary(sh, &s));
    double axis[3], sky[3], ground[3], amb[3], deltas[3][3];
    envl__sh_artist_forms(2, envl_sh_irradiance(sh), amb, deltas, axis, sky, ground);
    for (int k = 0; k < 3; k++) {
        CHECK(axis[k] == s.hemi_axis[k] && sky[k] == s.hemi_sky[k]);
        CHECK(ground[k] == s.hemi_ground[k] && amb[k] == s.ambient[k]);
        for (int ch = 0; ch < 3; ch++)
            CHECK(deltas[k][ch] == s.deltas[k][ch]);
    }
    pov_ridge r;
    pov_ridge_from_hemi(axis, sky, ground, &r);
    double up[3], down[3], minus[3] = {-axis[0], -axis[1], -axis[2]};
    pov_ridge_eval(&r, axis, up);
    pov_ridge_eval(&r, minus, down);
    /* perpendicular to the axis (axis x e, e the world axis least along it): the mean */
    int e = fabs(axis[0]) < fabs(axis[1]) ? (fabs(axis[0]) < fabs(axis[2]) ? 0 : 2)
                                          : (fabs(axis[1]) < fabs(axis[2]) ? 1 : 2);
    double side[3] = {e == 0 ? 0 : e == 1 ? -axis[2] : axis[1],
                      e == 1 ? 0 : e == 0 ? axis[2] : -axis[0],
                      e == 2 ? 0 : e == 0 ? -axis[1] : axis[0]}, mid[3];
    double len = sqrt(side[0] * side[0] + side[1] * side[1] + side[2] * side[2]);
    for (int k = 0; k < 3; k++)
        side[k] /= len;
    pov_ridge_eval(&r, side, mid);
    for (int ch = 0; ch < 3; ch++) {
        CHECK_NEAR(mid[ch], 0.5 * (sky[ch] + ground[ch]), 1e-12 * fabs(sky[ch]) + 1e-15);
        CHECK_NEAR(up[ch], sky[ch], 1e-12 * fabs(sky[ch]) + 1e-15);
        CHECK_NEAR(down[ch], ground[ch], 1e-12 * fabs(sky[ch]) + 1e-15);
        CHECK(sky[ch] >= 0 && ground[ch] >= 0);
    }
    int negative;
    CHECK(pov_ridge_least(&r, &negative) >= 0 && negative == 0);
    envl_sh_free(sh);
    envl_envmap_free(map);
}

static char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *buf = malloc(1 << 20);
    *size = buf ? fread(buf, 1, 1 << 20, f) : 0;
    fclose(f);
    return buf;
}

/* Every write step of the include (and of its sky image) made to fail leaves the old include
 * byte for byte; the text handed back (no path) is what is written, but the seconds. */
static void test_atomic_and_result(void)
{
    envl_sky_options so = {.width = 64};
    envl_envmap *map;
    CHECK_OK(envl_envmap_sky(&so, &map));
    const char *path = tmp_path("pov_include.inc");
    static const char old[] = "// the include that was there before\n";
    CHECK_OK(envl_file_write_atomic(path, old, sizeof old - 1));
    envl_pov_options o = {.recipe = ENVL_POV_RECIPE_SH, .sky = 1, .command = "test"};
    envl_pov_result res;
    envl__io_fail_at = 0;
    int64_t before = envl__io_calls;
    CHECK_OK(envl_pov_include_write(map, &o, tmp_path("count.inc"), &res));
    int64_t steps = envl__io_calls - before;
    envl_pov_result_free(&res);
    CHECK(steps >= 8); /* the sky image's steps and the include's */
    for (int64_t k = 1; k <= steps; k++) {
        envl__io_calls = 0;
        envl__io_fail_at = k;
        envl_result rc = envl_pov_include_write(map, &o, path, &res);
        envl__io_fail_at = 0;
        CHECK_RC(rc, ENVL_ERR_IO);
        CHECK(res.text == NULL && res.sky_file == NULL);
        envl_pov_result_free(&res);
        size_t size = 0;
        char *now = slurp(path, &size);
        CHECK(now && size == sizeof old - 1 && !memcmp(now, old, size));
        free(now);
    }
    CHECK_OK(envl_pov_include_write(map, &o, path, &res));
    CHECK(res.recipe == ENVL_POV_RECIPE_SH && res.method == ENVL_METHOD_FIT);
    CHECK(res.ambient == ENVL_POV_AMBIENT_SH && res.ambient_order == 2);
    CHECK(res.ambient_terms == 9 && res.ambient_negative == 0 && res.ambient_least > 0);
    CHECK(res.count >= 1 && res.count <= 4 && !res.no_light && !res.bounce);
    CHECK(res.diffuse_error > 0 && res.diffuse_error < 0.01);
    CHECK(res.sky_file && res.sky_file[0] == '/' && access(res.sky_file, R_OK) == 0);
    CHECK(res.text == NULL && res.warnings == NULL);
    CHECK(!strcmp(res.reason, "--recipe"));
    envl_pov_result_free(&res);
    CHECK(res.sky_file == NULL);
    size_t size = 0;
    char *written = slurp(path, &size);
    CHECK(written && strstr(written, "// command: test\n"));
    CHECK(written && strstr(written, "#declare EnvLight_Source = \"sky\";\n"));
    free(written);

    /* no path: the text comes back; a sky then needs sky_image */
    o.sky = 0;
    CHECK_OK(envl_pov_include_write(map, &o, NULL, &res));
    CHECK(res.text && strstr(res.text, "#declare EnvLight_Count = ") && !res.sky_file);
    envl_pov_result_free(&res);
    o.sky = 1;
    CHECK_RC(envl_pov_include_write(map, &o, NULL, &res), ENVL_ERR_ARGUMENT);
    envl_pov_result_free(&res);
    /* a fit of more than 32 lights: refused on the plan, which the result still carries */
    envl_pov_options bad = {.count = 40};
    CHECK_RC(envl_pov_include_write(map, &bad, NULL, &res), ENVL_ERR_ARGUMENT);
    CHECK(res.recipe == ENVL_POV_RECIPE_CUSTOM && res.method == ENVL_METHOD_FIT);
    CHECK(res.count == 40 && !res.text && !res.sky_file);
    envl_pov_result_free(&res);
    /* recipe_is_set: AUTO still picks (a dome, no scene) and the count sizes it */
    bad.recipe_is_set = 1;
    CHECK_OK(envl_pov_include_write(map, &bad, NULL, &res));
    CHECK(res.recipe == ENVL_POV_RECIPE_DOME && res.method == ENVL_METHOD_VARIANCE);
    CHECK(res.count == 40 && res.bounce);
    envl_pov_result_free(&res);
    bad = (envl_pov_options){.method = ENVL_METHOD_SUN, .method_is_set = 1};
    CHECK_RC(envl_pov_include_write(map, &bad, NULL, NULL), ENVL_ERR_ARGUMENT);
    bad = (envl_pov_options){.source = "a\nb"};
    CHECK_RC(envl_pov_include_write(map, &bad, NULL, NULL), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_pov_include_write(NULL, NULL, NULL, NULL), ENVL_ERR_ARGUMENT);
    CHECK(!strcmp(envl_pov_recipe_name(ENVL_POV_RECIPE_DOME_AMBIENT), "dome-ambient"));
    CHECK(envl_pov_recipe_name(ENVL_POV_RECIPE_COUNT) == NULL);
    for (int32_t k = 0; k < ENVL_POV_RECIPE_COUNT; k++)
        CHECK(envl_pov_recipe_from_name(envl_pov_recipe_name(k)) == k);
    CHECK(envl_pov_recipe_from_name("nope") == -1 && envl_pov_recipe_from_name(NULL) == -1);
    envl_envmap_free(map);
}

int main(void)
{
    test_ridge_from_sh();
    test_hemi_is_the_sh_pair();
    test_atomic_and_result();
    return check_report("test_pov_include");
}
