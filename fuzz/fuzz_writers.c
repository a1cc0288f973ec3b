/* libFuzzer target for the writers (issue 19): the input chooses a writer (EXR float / half,
 * Radiance, PFM, PNG RGBM / sRGB, a text file through envl_file_write_atomic), a small image
 * and its pixels (raw floats: NaN, Inf and negatives included), and which write step fails
 * (envl__io_fail_at, internal.h). Over an existing file, the write must then either fail with
 * ENVL_ERR_IO, a message naming the file and "No space left on device", the old file
 * byte-identical and no temporary file, or, when the step is past its last one, succeed and
 * replace the file. Input: kind, width - 1, height - 1, failing step - 1, then pixel bytes.
 * tests/test_writers.c runs every step of one image per writer. */
#include "internal.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { W_EXR_FLOAT, W_EXR_HALF, W_HDR, W_PFM, W_PNG_RGBM, W_PNG_SRGB, W_TEXT, W_COUNT };
static const char *const kind_ext[W_COUNT] = {"exr", "exr", "hdr", "pfm", "png", "png", "json"};
static const char old[] = "the file that was there before\n";
static char dir[64] = "";

static void cleanup(void)
{
    if (!dir[0])
        return;
    DIR *d = opendir(dir);
    struct dirent *e;
    char path[512];
    while (d && (e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            unlink(path);
        }
    if (d)
        closedir(d);
    rmdir(dir);
}

static void check(bool ok, const char *what, int kind, int64_t step)
{
    if (ok)
        return;
    fprintf(stderr, "fuzz_writers: %s (writer %d, step %lld: %s)\n", what, kind, (long long)step,
            envl_last_error());
    abort();
}

/* Entries of dir other than "." "..", and `keep`. */
static int others(const char *keep)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    while (d && (e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && strcmp(e->d_name, keep)) {
            fprintf(stderr, "fuzz_writers: left in %s: %s\n", dir, e->d_name);
            n++;
        }
    if (d)
        closedir(d);
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 4)
        return 0;
    if (!dir[0]) {
        /* In memory where there is a tmpfs: a rename over a file on ext4 waits for its data. */
        snprintf(dir, sizeof dir, "/dev/shm/envl-fuzz-writers-XXXXXX");
        if (!mkdtemp(dir)) {
            snprintf(dir, sizeof dir, "/tmp/envl-fuzz-writers-XXXXXX");
            if (!mkdtemp(dir))
                abort();
        }
        atexit(cleanup);
    }
    int kind = data[0] % W_COUNT;
    int32_t w = 1 + data[1] % 24, h = 1 + data[2] % 24;
    int64_t step = 1 + data[3] % 64;
    size_t n = (size_t)w * h * 3;
    float *rgb = calloc(n, sizeof(float));
    if (!rgb)
        return 0;
    memcpy(rgb, data + 4, size - 4 < n * 4 ? size - 4 : n * 4);
    char name[16], path[128];
    snprintf(name, sizeof name, "out.%s", kind_ext[kind]);
    snprintf(path, sizeof path, "%s/%s", dir, name);
    envl__io_fail_at = 0;
    check(!envl_file_write_atomic(path, old, sizeof old - 1), "cannot write the old file", kind, 0);

    envl__io_calls = 0;
    envl__io_fail_at = step;
    envl_result rc;
    char text[128];
    switch (kind) {
    case W_EXR_HALF:
        rc = envl_image_save(path, rgb, w, h, &(envl_save_options){.pixel_type = ENVL_PIXEL_HALF});
        break;
    case W_PNG_RGBM: rc = envl_png_save_rgbm(path, rgb, w, h, ENVL_RGBM_RANGE); break;
    case W_PNG_SRGB: rc = envl_png_save_srgb(path, rgb, w, h); break;
    case W_TEXT:
        rc = envl_file_write_atomic(path, text, (size_t)snprintf(text, sizeof text,
                                    "{\"first\": %.9g}\n", rgb[0]));
        break;
    default: rc = envl_image_save(path, rgb, w, h, NULL); break;
    }
    envl__io_fail_at = 0;
    bool failed = envl__io_calls >= step; /* the step was reached, so it failed */
    /* .hdr refuses, before any write step, a pixel RGBE cannot hold (NaN, Inf, >= 2^127, < 0) */
    bool unholdable = false;
    for (size_t i = 0; kind == W_HDR && i < n; i++)
        unholdable |= !(rgb[i] >= 0.0f && rgb[i] < 0x1p127f);
    free(rgb);

    uint8_t *now = NULL;
    size_t now_size = 0;
    bool unchanged = !envl__read_file(path, 1 << 24, &now, &now_size) &&
                     now_size == sizeof old - 1 && !memcmp(now, old, now_size);
    free(now);
    if (unholdable) {
        check(rc == ENVL_ERR_NONFINITE && envl__io_calls == 0,
              ".hdr must refuse what RGBE cannot hold before writing", kind, step);
        check(unchanged, "the old file changed", kind, step);
    } else if (failed) {
        const char *msg = envl_last_error();
        check(rc == ENVL_ERR_IO, "a failed write step must give ENVL_ERR_IO", kind, step);
        check(strstr(msg, path) == msg, "the message must name the file first", kind, step);
        check(strstr(msg, "No space left on device") != NULL, "the message must say why", kind,
              step);
        check(unchanged, "the old file changed", kind, step);
    } else {
        check(rc == ENVL_OK, "a write with no failing step failed", kind, step);
        check(!unchanged, "the file was not replaced", kind, step);
    }
    check(others(name) == 0, "a temporary file was left", kind, step);
    unlink(path);
    return 0;
}
