/* No output replaces an input or another output of the same call (issue 30, 4.1):
 * envl_outputs_check itself (the same device and inode when the files exist: hard and symbolic
 * links; else the same normalised path: ./, ../, //, a folder that does not exist yet), and
 * every library writer that knows its input refusing to write over it or over its other
 * output: envl_envmap_save, envl_pov_include_write (the include, its default sky image
 * OUT_sky.hdr, sky_image, the scene), envl_gltf_export, envl_preview_write and
 * envl_products_export (a file of the set named like the input). Each refusal is
 * ENVL_ERR_ARGUMENT naming the file, and the input keeps its bytes. tests/cli_same_file.sh
 * runs the same through the command line. */
#include "internal.h"
#include "check.h"

#include <unistd.h>

static uint8_t *slurp(const char *path, size_t *size)
{
    uint8_t *data;
    return envl__read_file(path, (size_t)1 << 26, &data, size) ? NULL : data;
}

/* `call` must be refused naming `named`, and `path` keep the bytes it had. */
#define CHECK_REFUSED(call, named, path)                                                       \
    do {                                                                                       \
        size_t n0_, n1_;                                                                       \
        uint8_t *before_ = slurp(path, &n0_);                                                  \
        CHECK_RC(call, ENVL_ERR_ARGUMENT);                                                     \
        CHECK(strstr(envl_last_error(), named) != NULL);                                       \
        CHECK(strstr(envl_last_error(), "the same file as") != NULL);                          \
        uint8_t *after_ = slurp(path, &n1_);                                                   \
        CHECK(before_ && after_ && n0_ == n1_ && memcmp(before_, after_, n0_) == 0);           \
        free(before_);                                                                         \
        free(after_);                                                                          \
    } while (0)

static void check_names(void)
{
    char m[4096], hard[4096], soft[4096], dotted[4096], other[4096], absent[4096];
    snprintf(m, sizeof m, "%s", tmp_path("m.hdr"));
    snprintf(hard, sizeof hard, "%s", tmp_path("hard.hdr"));
    snprintf(soft, sizeof soft, "%s", tmp_path("soft.hdr"));
    snprintf(dotted, sizeof dotted, "%s/./no-such-folder/..//m.hdr", ENVL_TEST_TMP);
    snprintf(other, sizeof other, "%s", tmp_path("other.hdr"));
    snprintf(absent, sizeof absent, "%s/new/../new/x.exr", ENVL_TEST_TMP);
    unlink(hard);
    unlink(soft);
    CHECK(link(m, hard) == 0);
    CHECK(symlink(m, soft) == 0);
    const char *in[1] = {m};
    /* the same file by device and inode, or by normalised path */
    const char *same[] = {m, hard, soft, dotted};
    for (int i = 0; i < 4; i++) {
        CHECK_RC(envl_outputs_check(in, 1, &same[i], 1), ENVL_ERR_ARGUMENT);
        CHECK(strstr(envl_last_error(), "the same file as the input") != NULL);
    }
    /* two outputs that do not exist yet, spelled differently */
    char x[4096];
    snprintf(x, sizeof x, "%s/new/x.exr", ENVL_TEST_TMP);
    const char *two[2] = {x, absent};
    CHECK_RC(envl_outputs_check(NULL, 0, two, 2), ENVL_ERR_ARGUMENT);
    CHECK(strstr(envl_last_error(), "the same file as the output") != NULL);
    /* relative against absolute */
    char cwd[4096];
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    CHECK(chdir(ENVL_TEST_TMP) == 0);
    const char *rel[1] = {"./m.hdr"};
    CHECK_RC(envl_outputs_check(in, 1, rel, 1), ENVL_ERR_ARGUMENT);
    CHECK(chdir(cwd) == 0);
    /* not the same: other names, NULL and empty names skipped, inputs among themselves */
    const char *fine[4] = {other, NULL, "", x};
    CHECK_OK(envl_outputs_check(in, 1, fine, 4));
    const char *inputs[2] = {m, hard};
    CHECK_OK(envl_outputs_check(inputs, 2, NULL, 0));
    CHECK_RC(envl_outputs_check(NULL, 1, NULL, 0), ENVL_ERR_ARGUMENT);
}

/* A scratch path that stays (tmp_path's buffers are reused). */
static const char *keep(char buf[4096], const char *name)
{
    snprintf(buf, 4096, "%s", tmp_path(name));
    return buf;
}

/* Copies file `from` to `to`. */
static void copy(const char *from, const char *to)
{
    size_t n;
    uint8_t *bytes = slurp(from, &n);
    CHECK(bytes && envl_file_write_atomic(to, bytes, n) == ENVL_OK);
    free(bytes);
}

static void check_writers(void)
{
    char b_m[4096], b_hard[4096], b_glb[4096], b_env[4096], b_psky[4096], b_scene[4096];
    char b_dir[4096];
    const char *m = keep(b_m, "m.hdr");
    envl_envmap *map;
    CHECK_OK(envl_envmap_load(m, NULL, &map));
    envl_save_options hdr = {.format = "hdr"};
    CHECK_REFUSED(envl_envmap_save(map, m, &hdr), "m.hdr", m);
    CHECK_REFUSED(envl_envmap_save(map, keep(b_hard, "hard.hdr"), &hdr), "hard.hdr", m);
    /* glTF: an input named .glb (read by its content) */
    const char *glb = keep(b_glb, "m.glb");
    copy(m, glb);
    envl_envmap *glb_map;
    CHECK_OK(envl_envmap_load(glb, NULL, &glb_map));
    envl_gltf_options go = {.face_size = 16, .mips = 2};
    CHECK_REFUSED(envl_gltf_export(glb_map, glb, &go, NULL), "m.glb", glb);
    envl_envmap_free(glb_map);
    envl_preview_options po = {.sphere_size = 48, .reference_width = 16};
    CHECK_REFUSED(envl_preview_write(map, &po, m, NULL, NULL, NULL), "m.hdr", m);
    /* the POV-Ray include: over the map, its default sky image the map, sky_image the include
     * or the map, the include over the scene */
    envl_pov_options pov = {.recipe = ENVL_POV_RECIPE_SH, .recipe_is_set = 1};
    envl_pov_result res;
    CHECK_REFUSED(envl_pov_include_write(map, &pov, m, &res), "m.hdr", m);
    envl_pov_result_free(&res);
    envl_envmap *probe;
    const char *p_sky = keep(b_psky, "p_sky.hdr");
    envl_load_options angular = {.layout = ENVL_LAYOUT_ANGULAR};
    CHECK_OK(envl_envmap_load(p_sky, &angular, &probe));
    envl_pov_options sky = pov;
    sky.sky = 1;
    CHECK_REFUSED(envl_pov_include_write(probe, &sky, tmp_path("p.inc"), &res), "p_sky.hdr",
                  p_sky);
    CHECK(strstr(envl_last_error(), "the sky image, named after the include") != NULL);
    envl_pov_result_free(&res);
    CHECK(access(tmp_path("p.inc"), F_OK) != 0);
    /* a lat-long .hdr serves as its own sky, but not as the residual's */
    const char *env_sky = keep(b_env, "env_sky.hdr");
    copy(m, env_sky);
    envl_envmap *env;
    CHECK_OK(envl_envmap_load(env_sky, NULL, &env));
    envl_pov_options residual = pov;
    residual.sky_residual = 1;
    CHECK_REFUSED(envl_pov_include_write(env, &residual, tmp_path("env.inc"), &res),
                  "env_sky.hdr", env_sky);
    envl_pov_result_free(&res);
    envl_envmap_free(env);
    envl_pov_options named = sky;
    named.sky_image = tmp_path("e.inc");
    CHECK_RC(envl_pov_include_write(map, &named, tmp_path("e.inc"), &res), ENVL_ERR_ARGUMENT);
    CHECK(strstr(envl_last_error(), "the same file as the output") != NULL);
    envl_pov_result_free(&res);
    CHECK(access(tmp_path("e.inc"), F_OK) != 0);
    named.sky_image = m;
    CHECK_REFUSED(envl_pov_include_write(map, &named, tmp_path("e.inc"), &res), "m.hdr", m);
    envl_pov_result_free(&res);
    const char *scene = keep(b_scene, "s.pov");
    CHECK_OK(envl_file_write_atomic(scene, "sphere { <0, 1, 0>, 1 }\n", 24));
    envl_pov_options with_scene = pov;
    with_scene.scene_path = scene;
    CHECK_REFUSED(envl_pov_include_write(map, &with_scene, scene, &res), "s.pov", scene);
    envl_pov_result_free(&res);
    /* not refused: the include elsewhere, the map's own .hdr as the sky as it is */
    CHECK_OK(envl_pov_include_write(map, &sky, tmp_path("m.inc"), &res));
    CHECK(res.sky_file && strstr(res.sky_file, "m.hdr") != NULL);
    envl_pov_result_free(&res);
    envl_envmap_free(probe);
    envl_envmap_free(map);

    /* the prefiltered set: its irradiance.hdr is the input */
    const char *dir = keep(b_dir, "set");
    mkdir(dir, 0755);
    char in[4096];
    snprintf(in, sizeof in, "%s/irradiance.hdr", dir);
    copy(m, in);
    CHECK_OK(envl_envmap_load(in, NULL, &map));
    envl_request q = {.irradiance_map = 1, .prefilter = {.irradiance_width = 16}};
    envl_products *p;
    CHECK_OK(envl_compute(map, &q, &p));
    envl_export_options eo = {.format = "hdr"};
    CHECK_REFUSED(envl_products_export(p, dir, &eo), "irradiance.hdr", in);
    CHECK(access(tmp_path("set/prefilter.json"), F_OK) != 0);
    eo.format = "pfm";
    CHECK_OK(envl_products_export(p, dir, &eo));
    envl_products_free(p);
    envl_envmap_free(map);
}

int main(void)
{
    /* what an earlier run may have left */
    const char *left[] = {"p.inc", "e.inc", "env.inc", "m.inc", "set/prefilter.json"};
    for (int i = 0; i < 5; i++)
        unlink(tmp_path(left[i]));
    /* a 64 x 32 sky as m.hdr, and a 32 x 32 angular probe of it as p_sky.hdr */
    envl_sky_options so = {.width = 64};
    envl_envmap *sky;
    CHECK_OK(envl_envmap_sky(&so, &sky));
    CHECK_OK(envl_envmap_save(sky, tmp_path("m.hdr"), NULL));
    float *px;
    int32_t w, h;
    CHECK_OK(envl_envmap_to_layout(sky, ENVL_LAYOUT_ANGULAR, 32, &px, &w, &h));
    CHECK_OK(envl_image_save(tmp_path("p_sky.hdr"), px, w, h, NULL));
    envl_free(px);
    envl_envmap_free(sky);
    check_names();
    check_writers();
    return check_report("test_same_file");
}
