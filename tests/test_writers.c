/* Writers under injected write failures (issue 19). Each writer is first run once to count its
 * write steps (envl__io_calls: create, each write, close, rename); then, for every N in
 * 1 .. that count, the N-th step fails as on a full disk (envl__io_fail_at = N, ENOSPC) and the
 * writer must return ENVL_ERR_IO with a message naming the target and the cause, leave the
 * file that was there byte-identical, and leave no temporary file in the folder. Exhaustive
 * over the steps: the fuzz over write calls (fuzz/fuzz_writers.c draws them at random). */
#include "internal.h"
#include "check.h"

#include <dirent.h>
#include <unistd.h>

enum { W_EXR_FLOAT, W_EXR_HALF, W_HDR, W_PFM, W_PNG_RGBM, W_PNG_SRGB, W_TEXT, W_COUNT };
static const char *const kind_name[W_COUNT] = {"exr-float", "exr-half", "hdr", "pfm",
                                               "png-rgbm", "png-srgb", "json"};
static const char *const kind_ext[W_COUNT] = {"exr", "exr", "hdr", "pfm", "png", "png", "json"};

static envl_result write_one(int kind, const char *path, const float *rgb, int32_t w, int32_t h)
{
    envl_save_options half = {.pixel_type = ENVL_PIXEL_HALF};
    char text[256];
    int n;
    switch (kind) {
    case W_EXR_HALF: return envl_image_save(path, rgb, w, h, &half);
    case W_PNG_RGBM: return envl_png_save_rgbm(path, rgb, w, h, ENVL_RGBM_RANGE);
    case W_PNG_SRGB: return envl_png_save_srgb(path, rgb, w, h);
    case W_TEXT:
        n = snprintf(text, sizeof text, "{\"width\": %d, \"height\": %d, \"first\": %.9g}\n",
                     (int)w, (int)h, rgb[0]);
        return envl_file_write_atomic(path, text, (size_t)n);
    default: return envl_image_save(path, rgb, w, h, NULL); /* format from the extension */
    }
}

/* The file's bytes (malloc'd, *size set), or NULL if it cannot be read. */
static uint8_t *slurp(const char *path, size_t *size)
{
    uint8_t *data;
    return envl__read_file(path, (size_t)1 << 26, &data, size) ? NULL : data;
}

/* Entries of `dir` other than "." and "..", and other than `keep` (NULL: none kept). */
static int other_entries(const char *dir, const char *keep)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    while (d && (e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && (!keep || strcmp(e->d_name, keep))) {
            fprintf(stderr, "  left in %s: %s\n", dir, e->d_name);
            n++;
        }
    if (d)
        closedir(d);
    return n;
}

/* Write steps of a good write (the hook off). */
static int64_t count_steps(int kind, const char *path, const float *rgb, int32_t w, int32_t h)
{
    envl__io_fail_at = 0;
    int64_t before = envl__io_calls;
    CHECK_OK(write_one(kind, path, rgb, w, h));
    return envl__io_calls - before;
}

static void test_writer(int kind, const float *rgb, int32_t w, int32_t h)
{
    char dir[4096], path[4200], name[64], scratch[4200];
    snprintf(dir, sizeof dir, "%s", tmp_path(kind_name[kind]));
    mkdir(dir, 0755);
    snprintf(name, sizeof name, "out.%s", kind_ext[kind]);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    snprintf(scratch, sizeof scratch, "%s.count.%s", dir, kind_ext[kind]);
    unlink(path);

    int64_t steps = count_steps(kind, scratch, rgb, w, h);
    /* create, at least one write, close, rename (atomic: the temporary file + rename) */
    CHECK(steps >= 4);
    CHECK(count_steps(kind, scratch, rgb, w, h) == steps); /* the same steps every time */
    unlink(scratch);

    static const char old[] = "the file that was there before\n";
    CHECK_OK(envl_file_write_atomic(path, old, sizeof old - 1));
    int failures = check_failures_;
    for (int64_t k = 1; k <= steps; k++) {
        envl__io_calls = 0;
        envl__io_fail_at = k;
        envl_result rc = write_one(kind, path, rgb, w, h);
        envl__io_fail_at = 0;
        const char *msg = envl_last_error();
        CHECK_RC(rc, ENVL_ERR_IO);
        CHECK(strstr(msg, path) == msg);  /* names the target first */
        CHECK(!strstr(msg, ".tmp-"));     /* and not the temporary file as well */
        CHECK(strstr(msg, "No space left on device") != NULL);
        size_t size = 0;
        uint8_t *now = slurp(path, &size);
        CHECK(now && size == sizeof old - 1 && !memcmp(now, old, size));
        free(now);
        CHECK(other_entries(dir, name) == 0);
        if (check_failures_ != failures) {
            fprintf(stderr, "%s: step %lld of %lld failed: %s\n", kind_name[kind], (long long)k,
                    (long long)steps, msg);
            break; /* one report per writer */
        }
    }
    /* One step past the last: nothing fails, the file is replaced. */
    envl__io_calls = 0;
    envl__io_fail_at = steps + 1;
    CHECK_OK(write_one(kind, path, rgb, w, h));
    envl__io_fail_at = 0;
    size_t size = 0;
    uint8_t *now = slurp(path, &size);
    CHECK(now && !(size == sizeof old - 1 && !memcmp(now, old, size)));
    free(now);
    CHECK(other_entries(dir, name) == 0);
    printf("%s: %lld write steps, each made to fail\n", kind_name[kind], (long long)steps);
}

/* The folder of prefiltered maps (envl_products_export, what `prefilter -o DIR` writes): every
 * file of the export written before must stay as it was. Its final renames are prefilter.c's
 * own (not counted); every write before them is. */
#define MAX_FILES 16
typedef struct snapshot {
    int n;
    char name[MAX_FILES][256];
    uint8_t *data[MAX_FILES];
    size_t size[MAX_FILES];
} snapshot;

static void take(const char *dir, snapshot *s)
{
    memset(s, 0, sizeof *s);
    DIR *d = opendir(dir);
    struct dirent *e;
    while (d && (e = readdir(d)) && s->n < MAX_FILES) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        char path[4400];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        snprintf(s->name[s->n], sizeof s->name[0], "%s", e->d_name);
        s->data[s->n] = slurp(path, &s->size[s->n]);
        s->n++;
    }
    if (d)
        closedir(d);
}

static bool same(const snapshot *a, const snapshot *b)
{
    if (a->n != b->n)
        return false;
    for (int i = 0; i < a->n; i++) {
        int j = 0;
        while (j < b->n && strcmp(a->name[i], b->name[j]))
            j++;
        if (j == b->n || !a->data[i] || !b->data[j] || a->size[i] != b->size[j] ||
            memcmp(a->data[i], b->data[j], a->size[i]))
            return false;
    }
    return true;
}

static void drop(snapshot *s)
{
    for (int i = 0; i < s->n; i++)
        free(s->data[i]);
}

static void test_export(const char *format)
{
    envl_envmap *m1, *m2;
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 32}, &m1));
    CHECK_OK(envl_envmap_sky(&(envl_sky_options){.width = 32, .sun_elevation_degrees = 60,
                                                 .sun_elevation_is_set = 1}, &m2));
    envl_request q = {.specular_chain = 1, .irradiance_map = 1, .brdf_lut = 1};
    q.prefilter = (envl_prefilter_options){.levels = 2, .width = 16, .min_width = 2,
                                           .samples = 4, .irradiance_width = 16, .threads = 1};
    q.brdf = (envl_brdf_options){.size = 8, .samples = 16, .threads = 1};
    envl_products *p1, *p2;
    CHECK_OK(envl_compute(m1, &q, &p1));
    CHECK_OK(envl_compute(m2, &q, &p2));
    char dir[4096], count_dir[4200];
    snprintf(dir, sizeof dir, "%s", tmp_path(format));
    snprintf(count_dir, sizeof count_dir, "%s.count", dir);
    mkdir(dir, 0755);
    mkdir(count_dir, 0755);
    envl_export_options eo = {.format = format};
    /* ktx2: one file per map (irradiance, the chain, the BRDF table), cube faces of the glTF
     * frame only */
    int ktx2 = !strcmp(format, "ktx2");
    int files = ktx2 ? 4 : 5;
    if (ktx2) {
        CHECK_RC(envl_products_export(p1, count_dir, &eo), ENVL_ERR_ARGUMENT);
        eo.layout = ENVL_EXPORT_CUBE;
        CHECK_RC(envl_products_export(p1, count_dir, &eo), ENVL_ERR_ARGUMENT); /* Blender's */
        eo.frame = ENVL_FRAME_GLTF;
    }

    envl__io_fail_at = 0;
    /* counted over a folder that holds the 5 files already, as `dir` will: replacing a file
     * takes one step more than writing a new one (its old file is linked aside first) */
    CHECK_OK(envl_products_export(p1, count_dir, &eo));
    int64_t before = envl__io_calls;
    CHECK_OK(envl_products_export(p2, count_dir, &eo));
    int64_t steps = envl__io_calls - before;
    /* irradiance, 2 levels (ktx2: one file), the BRDF table, the JSON: 5 steps each at least */
    CHECK(steps >= files * 5);
    CHECK_OK(envl_products_export(p1, dir, &eo));
    snapshot old, now;
    take(dir, &old);
    CHECK(old.n == files);
    int failures = check_failures_;
    for (int64_t k = 1; k <= steps; k++) {
        envl__io_calls = 0;
        envl__io_fail_at = k;
        envl_result rc = envl_products_export(p2, dir, &eo);
        envl__io_fail_at = 0;
        const char *msg = envl_last_error();
        CHECK_RC(rc, ENVL_ERR_IO);
        CHECK(strstr(msg, dir) == msg);
        CHECK(!strstr(msg, ".tmp-") && !strstr(msg, "/.envl-")); /* the file, not its temporary */
        CHECK(strstr(msg, "No space left on device") != NULL);
        take(dir, &now);
        CHECK(same(&old, &now)); /* also: no temporary file */
        drop(&now);
        if (check_failures_ != failures) {
            fprintf(stderr, "export %s: step %lld of %lld failed: %s\n", format, (long long)k,
                    (long long)steps, msg);
            break;
        }
    }
    envl__io_fail_at = steps + 1;
    envl__io_calls = 0;
    CHECK_OK(envl_products_export(p2, dir, &eo));
    envl__io_fail_at = 0;
    take(dir, &now);
    CHECK(now.n == files && !same(&old, &now));
    drop(&now);
    drop(&old);
    printf("export %s: %lld write steps, each made to fail\n", format, (long long)steps);
    envl_products_free(p1);
    envl_products_free(p2);
    envl_envmap_free(m1);
    envl_envmap_free(m2);
}

int main(void)
{
    CHECK(envl__io_fail_at == 0); /* off unless a test sets it */
    /* 37 x 40: three 16-line ZIP chunks in EXR, RLE scanlines in Radiance; values over the
     * range a map holds, with a negative, a NaN and an infinity (EXR and PFM keep them, PNG
     * clamps them, .hdr refuses them). */
    enum { W = 37, H = 40 };
    static float rgb[W * H * 3];
    for (int i = 0; i < W * H * 3; i++)
        rgb[i] = (float)((i % 97) * 0.37 + (i % 5) * 1e3 * (i % 11 == 0));
    rgb[5] = -2.0f;
    rgb[7] = NAN;
    rgb[11] = INFINITY;
    /* .hdr refuses those three (test_hdr): its copy holds 0, 1e30 and 0 there */
    static float rgbe_ok[W * H * 3];
    memcpy(rgbe_ok, rgb, sizeof rgb);
    rgbe_ok[5] = 0.0f, rgbe_ok[7] = 1e30f, rgbe_ok[11] = 0.0f;
    for (int k = 0; k < W_COUNT; k++)
        test_writer(k, strcmp(kind_ext[k], "hdr") ? rgb : rgbe_ok, W, H);
    test_export("exr");
    test_export("rgbm-png");
    test_export("ktx2");
    return check_report("test_writers");
}
