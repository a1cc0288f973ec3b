/* DWAA / DWAB files, decoded through the OpenEXR C++ library (src/io/exr_dwa.cpp). DWA is lossy,
 * but decoding is deterministic: OpenImageIO's oiiotool reads with the same libOpenEXR-3_1
 * (Debian 12), so its float copy of a DWA file (-d float, no compression, read back here by
 * OpenEXRCore) must hold exactly our floats, bit for bit. Checked on the OpenEXR test files, on
 * Blender's world HDRIs (DWAB, Debian's blender-data) and on small files oiiotool writes here
 * (tiled, a data window inside the display window, a layer, Y, two parts); truncated and
 * damaged DWA files fail with ENVL_ERR_FORMAT and a message, never a crash. Skips (with a
 * message) what is absent. */
#include "internal.h"
#include "check.h"

#include <openexr.h>

#include <dirent.h>
#include <fcntl.h>
#include <stdint.h>
#include <unistd.h>

#define BLENDER_WORLDS "/usr/share/blender/datafiles/studiolights/world"

static int compared; /* files compared with oiiotool's decode */
/* Under Valgrind's memcheck (30-50x slower; scripts/valgrind.sh sets it): two of Blender's
 * worlds, every 4th prefix, no flipped bytes (test_damaged); the plain and ASan runs check all. */
static int thin;

/* The file through the loader's own reader (content detection, then envl__read_exr). */
static envl_result read_exr_file(const char *path, const char *part, int64_t max_pixels,
                                 envl_image *img)
{
    envl_limits lim = {max_pixels ? max_pixels : ENVL_DEFAULT_MAX_PIXELS, part, 0};
    return envl__read_image_file(path, &lim, img);
}

static int have_oiiotool(void)
{
    static int have = -1;
    if (have < 0) {
        have = system("command -v oiiotool >/dev/null 2>&1") == 0;
        if (!have)
            printf("SKIP: oiiotool absent (Debian: openimageio-tools): no reference decode\n");
    }
    return have;
}

/* Compression of part `part` (by index) of a file, through OpenEXRCore; -1 if unreadable. */
static int compression_of(const char *path, int part)
{
    exr_context_t f = NULL;
    exr_compression_t c = EXR_COMPRESSION_NONE;
    int ok = exr_start_read(&f, path, NULL) == EXR_ERR_SUCCESS &&
             exr_get_compression(f, part, &c) == EXR_ERR_SUCCESS;
    exr_finish(&f);
    return ok ? (int)c : -1;
}

/* Reads the DWA file `path` (part `part`, NULL: our default choice; `index`: its number) and
 * oiiotool's float copy of the same part; every value must be the same float. */
static void compare_with_oiiotool(const char *path, const char *part, int index)
{
    int c = compression_of(path, index);
    CHECK(c == EXR_COMPRESSION_DWAA || c == EXR_COMPRESSION_DWAB);
    if (c != EXR_COMPRESSION_DWAA && c != EXR_COMPRESSION_DWAB)
        fprintf(stderr, "  %s part %d: compression %d, not DWA\n", path, index, c);
    const char *ref = tmp_path("reference.exr");
    char sub[128] = "";
    if (part)
        snprintf(sub, sizeof sub, "--subimage '%s'", part);
    if (run_command("oiiotool '%s' %s -d float --compression none -o '%s'", path, sub, ref) != 0) {
        CHECK(!"oiiotool's float copy");
        return;
    }
    envl_image a, b;
    CHECK_OK(read_exr_file(path, part, 0, &a));
    CHECK_OK(read_exr_file(ref, NULL, 0, &b));
    if (a.px && b.px) {
        CHECK(a.width == b.width && a.height == b.height);
        CHECK(a.meta.channels == b.meta.channels);
        size_t n = (size_t)a.width * a.height * 3, differ = 0, nonzero = 0;
        for (size_t i = 0; a.width == b.width && a.height == b.height && i < n; i++) {
            uint32_t ua, ub;
            memcpy(&ua, &a.px[i], 4);
            memcpy(&ub, &b.px[i], 4);
            differ += ua != ub && !(isnan(a.px[i]) && isnan(b.px[i]));
            nonzero += a.px[i] != 0.0f;
        }
        CHECK(differ == 0);
        CHECK(nonzero > 0); /* the test images are not black */
        if (differ)
            fprintf(stderr, "  %s: %zu of %zu values differ from oiiotool's decode\n", path,
                    differ, n);
        compared++;
    }
    envl__image_free(&a);
    envl__image_free(&b);
}

static void test_openexr_samples(void)
{
    static const char *files[] = {"comp_dwaa_v1.exr", "comp_dwaa_v2.exr", "comp_dwab_v1.exr",
                                  "comp_dwab_v2.exr"};
    for (int i = 0; i < 4; i++) {
        char rel[128];
        snprintf(rel, sizeof rel, "openexr/OpenEXRTest/%s", files[i]);
        const char *path = shared_data(rel);
        if (!path)
            continue;
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, 0, &img));
        CHECK(img.width == 587 && img.height == 675 && img.meta.channels == 4); /* RGBA */
        envl__image_free(&img);
        if (have_oiiotool())
            compare_with_oiiotool(path, NULL, 0);
    }
}

static void test_blender_worlds(void)
{
    DIR *d = opendir(BLENDER_WORLDS);
    if (!d) {
        printf("SKIP: %s absent (Debian: blender-data): Blender's DWAB worlds not tested\n",
               BLENDER_WORLDS);
        return;
    }
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".exr"))
            continue;
        if (thin && n == 2)
            break;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", BLENDER_WORLDS, e->d_name);
        CHECK(compression_of(path, 0) == EXR_COMPRESSION_DWAB);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, 0, &img));
        CHECK(img.width == 2 * img.height && img.meta.channels == 3); /* lat-long RGB */
        envl__image_free(&img);
        if (have_oiiotool())
            compare_with_oiiotool(path, NULL, 0);
        n++;
    }
    closedir(d);
    CHECK(n >= 1);
}

/* Small DWA files written by oiiotool from comp_dwab_v1.exr / comp_dwaa_v1.exr. */
static void test_written_by_oiiotool(void)
{
    const char *src = shared_data("openexr/OpenEXRTest/comp_dwab_v1.exr");
    const char *src2 = shared_data("openexr/OpenEXRTest/comp_dwaa_v1.exr");
    if (!src || !src2 || !have_oiiotool())
        return;
    const char *path = tmp_path("written.exr");
    /* scanlines, 64 x 40 */
    if (!run_command("oiiotool '%s' --cut 64x40+100+200 --origin +0+0 --compression dwaa "
                     "-o '%s'", src, path))
        compare_with_oiiotool(path, NULL, 0);
    /* tiles of 32 x 32 over 70 x 45 pixels (partial tiles), data window at (100, 200) */
    if (!run_command("oiiotool '%s' --cut 70x45+100+200 --tile 32 32 --compression dwab "
                     "-o '%s'", src, path)) {
        compare_with_oiiotool(path, NULL, 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, 0, &img));
        CHECK(img.width == 70 && img.height == 45);
        envl__image_free(&img);
    }
    /* data window 100 x 80 at (10, 20) inside the 587 x 675 display window: zero around it */
    if (!run_command("oiiotool '%s' --crop 100x80+10+20 --compression dwaa -o '%s'", src, path)) {
        compare_with_oiiotool(path, NULL, 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, 0, &img));
        if (img.px) {
            CHECK(img.width == 587 && img.height == 675);
            CHECK(img.px[0] == 0.0f && img.px[3 * (size_t)(21 * 587 + 11)] != 0.0f);
        }
        envl__image_free(&img);
    }
    /* a layer: left.R, left.G, left.B */
    if (!run_command("oiiotool '%s' --cut 64x40 --ch R,G,B --chnames left.R,left.G,left.B "
             "--compression dwab -o '%s'", src2, path))
        compare_with_oiiotool(path, NULL, 0);
    /* Y and A (oiiotool writes one channel alone with ZIP): grey */
    if (!run_command("oiiotool '%s' --cut 64x40 --ch G,A --chnames Y,A --compression dwaa "
                     "-o '%s'", src2, path)) {
        compare_with_oiiotool(path, NULL, 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, 0, &img));
        if (img.px)
            CHECK(img.meta.channels == 2 && img.px[0] == img.px[1] && img.px[1] == img.px[2]);
        envl__image_free(&img);
    }
    /* two parts, "first" (R, G, B, A) and "second" (left.*): by default the first */
    if (!run_command("oiiotool '%s' --cut 64x40+100+200 --origin +0+0 --attrib "
                     "oiio:subimagename first '%s' --cut 64x40 --ch R,G,B --chnames "
                     "left.R,left.G,left.B --attrib oiio:subimagename second --siappend "
                     "--compression dwab -o '%s'", src, src2, path)) {
        compare_with_oiiotool(path, "first", 0);
        compare_with_oiiotool(path, "second", 1);
        envl_image a, b;
        CHECK_OK(read_exr_file(path, NULL, 0, &a));
        CHECK_OK(read_exr_file(path, "first", 0, &b));
        CHECK(a.px && b.px && !memcmp(a.px, b.px, (size_t)64 * 40 * 3 * sizeof(float)));
        envl__image_free(&a);
        envl__image_free(&b);
        CHECK_RC(read_exr_file(path, "third", 0, &a), ENVL_ERR_ARGUMENT);
        CHECK(strstr(envl_last_error(), "'third'") && strstr(envl_last_error(), "'second'"));
    }
    /* the pixel limit applies before anything is decoded */
    if (!run_command("oiiotool '%s' --cut 64x40+100+200 --origin +0+0 --compression dwaa "
                     "-o '%s'", src, path)) {
        envl_image img;
        CHECK_RC(read_exr_file(path, NULL, 64 * 40 - 1, &img), ENVL_ERR_LIMIT);
        CHECK(img.px == NULL && strstr(envl_last_error(), "written.exr"));
        CHECK_OK(read_exr_file(path, NULL, 64 * 40, &img));
        envl__image_free(&img);
    }
}

/* Prefixes and flipped bytes of a small DWAA file: ENVL_ERR_FORMAT with the file's name (or,
 * for flipped bytes of the lossy data, any pixels); no crash, no output on failure, nothing on
 * stderr. */
static void test_damaged(void)
{
    const char *src = shared_data("openexr/OpenEXRTest/comp_dwaa_v1.exr");
    if (!src || !have_oiiotool())
        return;
    const char *path = tmp_path("damaged.exr");
    if (run_command("oiiotool '%s' --cut 40x70+300+300 --origin +0+0 --compression dwaa "
                    "-o '%s'", src, path))
        return;
    uint8_t *data;
    size_t size;
    CHECK_OK(envl__read_file(path, 1 << 20, &data, &size));
    if (!data)
        return;
    const char *log = tmp_path("dwa_stderr.txt");
    fflush(stderr);
    int saved = dup(2), fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (saved < 0 || fd < 0) {
        free(data);
        return;
    }
    dup2(fd, 2);
    close(fd);
    int wrong = 0, leaked = 0, unnamed = 0, prefixes = 0;
    for (size_t n = 0; n < size; n += n < 512 ? 1 : thin ? 44 : 11) {
        envl_image img;
        envl_result rc = envl__read_exr(data, n, "damaged.exr", NULL, &img);
        prefixes++;
        wrong += rc != ENVL_ERR_FORMAT;
        unnamed += rc && strncmp(envl_last_error(), "damaged.exr: ", 13) != 0;
        leaked += img.px != NULL;
        envl__image_free(&img);
    }
    int bad_code = 0;
    /* Under memcheck the flipped bytes are left out: on some of them OpenEXR 3.1.5's own DWA
     * decoder (libOpenEXR-3_1, inside ScanLineInputFile::readPixels) uses uninitialised values
     * of its own (8 memcheck reports, none in envlight); natively and under ASan they run. */
    for (size_t i = 0; !thin && i < size; i += 5) {
        uint8_t *copy = malloc(size);
        memcpy(copy, data, size);
        copy[i] ^= 0x5a;
        envl_image img;
        envl_result rc = envl__read_exr(copy, size, "flipped.exr", NULL, &img);
        bad_code += !(rc == ENVL_OK || rc == ENVL_ERR_FORMAT || rc == ENVL_ERR_LIMIT ||
                      rc == ENVL_ERR_UNSUPPORTED || rc == ENVL_ERR_MEMORY);
        leaked += rc && img.px != NULL;
        envl__image_free(&img);
        free(copy);
    }
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    struct stat st;
    CHECK(stat(log, &st) == 0 && st.st_size == 0); /* nothing printed on stderr */
    CHECK(prefixes > 512 && wrong == 0 && unnamed == 0 && leaked == 0 && bad_code == 0);
    if (wrong || unnamed)
        fprintf(stderr, "  prefixes: %d not ENVL_ERR_FORMAT, %d without the name\n", wrong,
                unnamed);
    /* the whole file still reads */
    envl_image img;
    CHECK_OK(envl__read_exr(data, size, "damaged.exr", NULL, &img));
    CHECK(img.width == 40 && img.height == 70);
    envl__image_free(&img);
    free(data);
}

int main(void)
{
    thin = getenv("ENVL_UNDER_MEMCHECK") != NULL;
    if (thin)
        printf("  under memcheck: 2 of Blender's worlds, every 4th prefix, no flipped bytes\n");
    test_openexr_samples();
    test_blender_worlds();
    test_written_by_oiiotool();
    test_damaged();
    int rc = check_report("test_exr_dwa");
    if (!rc && compared == 0) {
        printf("SKIP: no DWA file compared with oiiotool's decode\n");
        return 77;
    }
    return rc;
}
