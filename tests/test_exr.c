/* OpenEXR: writer round trips, files written here with the OpenEXR C API for the odd variants
 * (windows, tiles + mip levels, Y only, uint, layers, parts, chromaticities, envmap), every
 * OpenEXR sample under ../shared/data/openexr, damaged and truncated files. */
#include "internal.h"
#include "check.h"

#include <openexr.h>

#include <dirent.h>
#include <fcntl.h>
#include <stdint.h>
#include <unistd.h>

static const envl_limits default_limits = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};

/* File -> image through envl__read_file + envl__read_exr (as the loader does). */
static envl_result read_exr_file(const char *path, const envl_limits *lim, envl_image *img)
{
    uint8_t *data;
    size_t size;
    memset(img, 0, sizeof *img);
    envl_result rc = envl__read_file(path, (size_t)1 << 32, &data, &size);
    if (rc)
        return rc;
    rc = envl__read_exr(data, size, path, lim ? lim : &default_limits, img);
    free(data);
    return rc;
}

static const float *px_at(const envl_image *img, int x, int y)
{
    return img->px + ((size_t)y * (size_t)img->width + (size_t)x) * 3;
}

/* The loader's path, the open file read by offset with its chunks decoded in parallel (1 and 3
 * threads), against the same bytes read from memory (format detection included): the same
 * result code, the same floats bit for bit or the same message. */
static void check_file_reader(const char *path)
{
    uint8_t *data;
    size_t size;
    envl_image m = {0};
    envl_result rc = envl__read_file(path, (size_t)1 << 32, &data, &size);
    if (rc == ENVL_OK) {
        rc = envl__read_image_memory(data, size, path, &default_limits, &m);
        free(data);
    }
    char msg[2048];
    snprintf(msg, sizeof msg, "%s", envl_last_error());
    for (int32_t threads = 1; threads <= 3; threads += 2) {
        envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, NULL, threads};
        envl_image f = {0};
        envl_result frc = envl__read_image_file(path, &lim, &f);
        CHECK(frc == rc);
        if (frc == ENVL_OK && rc == ENVL_OK) {
            CHECK(f.width == m.width && f.height == m.height &&
                  !memcmp(f.px, m.px, sizeof(float) * 3 * (size_t)f.width * f.height));
            CHECK(f.meta.envmap_layout == m.meta.envmap_layout &&
                  f.meta.channels == m.meta.channels);
        } else if (strcmp(msg, envl_last_error())) {
            CHECK(!"the same message from the file as from memory");
            fprintf(stderr, "  memory: %s\n  file:   %s\n", msg, envl_last_error());
        }
        envl__image_free(&f);
    }
    envl__image_free(&m);
}

static float bits_to_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* ---- writing odd variants with the OpenEXR C API ------------------------------------------- */

/* Value of channel c at level-0 pixel (x, y): multiples of 1/8 below 16, exact in half. */
static float test_value(int c, int x, int y, int level)
{
    int v = ((x * 7 + y * 13 + c * 5) % 120 + 120) % 120;
    return (float)v / 8.0f + 100.0f * (float)level;
}

typedef struct test_part {
    const char *name;             /* part name (NULL: unnamed single part) */
    int tiled;                    /* 0 scanline, 1 tiled */
    exr_tile_level_mode_t levels; /* tiled: one level / mip / rip */
    int tile_w, tile_h;
    exr_attr_box2i_t dw, disp;
    int nch;
    const char *ch[4];            /* channel names, any order (the library sorts them) */
    exr_pixel_type_t type[4];
    int value_index[4];           /* test_value's c for each channel */
    exr_compression_t comp;
    int envmap;                   /* -1 none, else exr_envmap_t */
    const float *chroma;          /* 8 floats or NULL */
} test_part;

/* Writes each chunk from a planar buffer holding test_value (float / uint per channel). */
static int write_chunk(exr_context_t f, int p, const test_part *tp, exr_encode_pipeline_t *enc,
                       int *enc_ready, const exr_chunk_info_t *ci, int64_t x0, int64_t y0,
                       int level)
{
    exr_result_t rc = *enc_ready ? exr_encoding_update(f, p, ci, enc)
                                 : exr_encoding_initialize(f, p, ci, enc);
    if (rc)
        return rc;
    *enc_ready = 1;
    size_t n = (size_t)ci->width * (size_t)ci->height;
    uint32_t *buf = malloc(n * 4 * (size_t)enc->channel_count);
    for (int c = 0; c < enc->channel_count; c++) {
        exr_coding_channel_info_t *ec = &enc->channels[c];
        int k = 0;
        while (k < tp->nch && strcmp(tp->ch[k], ec->channel_name))
            k++;
        uint32_t *plane = buf + n * (size_t)c;
        for (int y = 0; y < ci->height; y++)
            for (int x = 0; x < ci->width; x++) {
                int ax = (int)(x0 + x), ay = (int)(y0 + y);
                float v = test_value(tp->value_index[k], ax, ay, level);
                if (tp->type[k] == EXR_PIXEL_UINT)
                    plane[(size_t)y * ci->width + x] = (uint32_t)(ax * 1000 + ay * 3 + 7);
                else
                    memcpy(&plane[(size_t)y * ci->width + x], &v, 4);
            }
        ec->encode_from_ptr = (const uint8_t *)plane;
        ec->user_pixel_stride = 4;
        ec->user_line_stride = 4 * ci->width;
        ec->user_bytes_per_element = 4;
        ec->user_data_type = tp->type[k] == EXR_PIXEL_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
    }
    rc = exr_encoding_choose_default_routines(f, p, enc);
    if (!rc)
        rc = exr_encoding_run(f, p, enc);
    free(buf);
    return rc;
}

static int write_test_file(const char *path, const test_part *parts, int nparts)
{
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_result_t rc = exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc)
        return rc;
    for (int i = 0; i < nparts && !rc; i++) {
        const test_part *tp = &parts[i];
        int p;
        rc = exr_add_part(f, tp->name, tp->tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &p);
        exr_attr_v2f_t swc = {.x = 0, .y = 0};
        if (!rc)
            rc = exr_initialize_required_attr(f, p, &tp->disp, &tp->dw, 1.0f, &swc, 1.0f,
                                              EXR_LINEORDER_INCREASING_Y, tp->comp);
        for (int c = 0; c < tp->nch && !rc; c++)
            rc = exr_add_channel(f, p, tp->ch[c], tp->type[c], EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
        if (!rc && tp->tiled)
            rc = exr_set_tile_descriptor(f, p, (uint32_t)tp->tile_w, (uint32_t)tp->tile_h,
                                         tp->levels, EXR_TILE_ROUND_DOWN);
        if (!rc && tp->envmap >= 0)
            rc = exr_attr_set_envmap(f, p, "envmap", (exr_envmap_t)tp->envmap);
        if (!rc && tp->chroma) {
            const float *c = tp->chroma;
            exr_attr_chromaticities_t chr = {c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]};
            rc = exr_attr_set_chromaticities(f, p, "chromaticities", &chr);
        }
    }
    if (!rc)
        rc = exr_write_header(f);
    for (int p = 0; p < nparts && !rc; p++) {
        const test_part *tp = &parts[p];
        exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
        int enc_ready = 0;
        exr_chunk_info_t ci;
        if (!tp->tiled) {
            int32_t lines;
            rc = exr_get_scanlines_per_chunk(f, p, &lines);
            for (int y = tp->dw.min.y; !rc && y <= tp->dw.max.y; y += lines) {
                rc = exr_write_scanline_chunk_info(f, p, y, &ci);
                if (!rc)
                    rc = write_chunk(f, p, tp, &enc, &enc_ready, &ci, tp->dw.min.x, y, 0);
            }
        } else {
            int32_t nlx = 1, nly = 1;
            rc = exr_get_tile_levels(f, p, &nlx, &nly);
            for (int ly = 0; !rc && ly < nly; ly++)
                for (int lx = 0; !rc && lx < nlx; lx++) {
                    if (tp->levels == EXR_TILE_MIPMAP_LEVELS && lx != ly)
                        continue;
                    int32_t lw, lh;
                    rc = exr_get_level_sizes(f, p, lx, ly, &lw, &lh);
                    for (int ty = 0; !rc && ty * tp->tile_h < lh; ty++)
                        for (int tx = 0; !rc && tx * tp->tile_w < lw; tx++) {
                            rc = exr_write_tile_chunk_info(f, p, tx, ty, lx, ly, &ci);
                            if (!rc)
                                rc = write_chunk(f, p, tp, &enc, &enc_ready, &ci,
                                                 tp->dw.min.x + tx * tp->tile_w,
                                                 tp->dw.min.y + ty * tp->tile_h,
                                                 lx > ly ? lx : ly);
                        }
                }
        }
        if (enc_ready)
            exr_encoding_destroy(f, &enc);
    }
    exr_result_t frc = exr_finish(&f);
    return rc ? rc : frc;
}

static exr_attr_box2i_t box(int x0, int y0, int x1, int y1)
{
    exr_attr_box2i_t b = {.min = {.x = x0, .y = y0}, .max = {.x = x1, .y = y1}};
    return b;
}

/* Display window (and data window) of part `part` of a file, through the C API. */
static int header_windows(const char *path, int part, exr_attr_box2i_t *disp,
                          exr_attr_box2i_t *dw)
{
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.flags = EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
    if (exr_start_read(&f, path, &init))
        return -1;
    int rc = exr_get_display_window(f, part, disp) || exr_get_data_window(f, part, dw);
    exr_finish(&f);
    return rc;
}

/* ---- writer round trips -------------------------------------------------------------------- */

static float *pattern(int w, int h, unsigned seed)
{
    float *px = malloc((size_t)w * h * 3 * sizeof(float));
    for (size_t i = 0; i < (size_t)w * h * 3; i++) {
        seed = seed * 1664525u + 1013904223u;
        px[i] = (float)(seed >> 8) / (float)(1u << 24) * 50.0f - 5.0f; /* [-5, 45) */
    }
    px[0] = 1e6f;
    if ((size_t)w * h * 3 > 2) {
        px[1] = 1e-30f;
        px[2] = 0.0f;
    }
    return px;
}

static void test_round_trip_float(void)
{
    const int sizes[3][2] = {{1, 1}, {3, 2}, {257, 129}};
    for (int s = 0; s < 3; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        float *px = pattern(w, h, 17u + (unsigned)s);
        const char *path = tmp_path("rt_float.exr");
        CHECK_OK(envl__write_exr(path, px, w, h, ENVL_PIXEL_FLOAT, 0));
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        CHECK(img.width == w && img.height == h);
        if (img.px && img.width == w && img.height == h)
            CHECK(memcmp(img.px, px, (size_t)w * h * 3 * sizeof(float)) == 0); /* bit-exact */
        if (img.px)
            CHECK(img.px[0] == 1e6f);
        CHECK(!strcmp(img.meta.format, "exr") && img.meta.channels == 3);
        CHECK(img.meta.envmap_layout == 0 && img.meta.has_primaries == 0);
        CHECK(img.meta.exposure == 1.0);
        envl__image_free(&img);
        free(px);
    }
    /* through the public save (atomic) and the format-detecting reader */
    float one[6] = {1e6f, 1e-30f, -2.5f, 3e38f, 0.0f, 1.0f};
    const char *path = tmp_path("rt_public.exr");
    CHECK_OK(envl_image_save(path, one, 2, 1, NULL));
    envl_image img;
    CHECK_OK(envl__read_image_file(path, &default_limits, &img));
    CHECK(img.width == 2 && img.height == 1 && img.px && memcmp(img.px, one, sizeof one) == 0);
    envl__image_free(&img);
}

static void test_round_trip_half(void)
{
    const int sizes[3][2] = {{1, 1}, {3, 2}, {257, 129}};
    for (int s = 0; s < 3; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        float *px = pattern(w, h, 99u + (unsigned)s);
        size_t n = (size_t)w * h * 3;
        if (n >= 6) {
            px[3] = -1e6f;
            px[4] = NAN;
            px[5] = INFINITY;
        }
        const char *path = tmp_path("rt_half.exr");
        CHECK_OK(envl__write_exr(path, px, w, h, ENVL_PIXEL_HALF, 0));
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        CHECK(img.width == w && img.height == h);
        if (!img.px || img.width != w || img.height != h) {
            free(px);
            continue;
        }
        CHECK(img.px[0] == 65504.0f); /* 1e6 clamps to the largest half */
        if (n >= 6) {
            CHECK(img.px[3] == -65504.0f && img.px[4] == 0.0f && img.px[5] == 65504.0f);
            CHECK(img.px[1] == 0.0f); /* 1e-30 is below the smallest half subnormal (2^-24) */
        }
        int bad = 0, nonfinite = 0;
        for (size_t i = (n >= 6 ? 6 : 1); i < n; i++) {
            /* round to nearest: relative error <= 2^-11 for normal halves */
            if (fabsf(img.px[i] - px[i]) > fabsf(px[i]) * (1.0f / 2048.0f) + 1e-7f)
                bad++;
            if (!isfinite(img.px[i]))
                nonfinite++;
        }
        CHECK(bad == 0 && nonfinite == 0);
        envl__image_free(&img);
        free(px);
    }
}

/* Many small images of low-entropy values: some chunks deflate to exactly their raw size,
 * which the writer must then store raw (or the file is misread). */
static void test_round_trip_small_sizes(void)
{
    int bad = 0, files = 0;
    unsigned seed = 7;
    for (int w = 1; w <= 24; w++)
        for (int h = 1; h <= 3; h++)
            for (int t = 0; t < 2; t++) {
                size_t n = (size_t)w * h * 3;
                float *px = malloc(n * sizeof(float));
                for (size_t i = 0; i < n; i++) {
                    seed = seed * 1664525u + 1013904223u;
                    px[i] = (float)((seed >> 20) % 24) * 0.25f; /* exact in half */
                }
                const char *path = tmp_path("small_rt.exr");
                CHECK_OK(envl__write_exr(path, px, w, h, t ? ENVL_PIXEL_HALF : ENVL_PIXEL_FLOAT, 0));
                envl_image img;
                if (read_exr_file(path, NULL, &img) != ENVL_OK || !img.px ||
                    memcmp(img.px, px, n * sizeof(float)))
                    bad++;
                files++;
                envl__image_free(&img);
                free(px);
            }
    CHECK(files == 144 && bad == 0);
}

static void test_write_errors(void)
{
    float px[3] = {1, 2, 3};
    CHECK_RC(envl__write_exr("/nonexistent-dir/x/out.exr", px, 1, 1, ENVL_PIXEL_FLOAT, 0),
             ENVL_ERR_IO);
    CHECK(strstr(envl_last_error(), "/nonexistent-dir/x/out.exr") != NULL);
    CHECK_RC(envl__write_exr(tmp_path("bad.exr"), px, 0, 1, ENVL_PIXEL_FLOAT, 0), ENVL_ERR_ARGUMENT);
}

/* The envmap attribute (Imf::Envmap: ENVMAP_LATLONG 0, ENVMAP_CUBE 1) as envl_image_save writes
 * it: read back by the library (OpenEXRCore) as written, absent when not asked for; other
 * values refused. */
static void test_envmap_attribute(void)
{
    float *px = pattern(8, 48, 11);
    const char *path = tmp_path("envmap.exr");
    static const int32_t layouts[3] = {0, ENVL_LAYOUT_EXR_LATLONG, ENVL_LAYOUT_EXR_CUBE};
    for (int i = 0; i < 3; i++) {
        CHECK_OK(envl_image_save(path, px, 8, 48, &(envl_save_options){.envmap = layouts[i]}));
        exr_context_t f = NULL;
        exr_envmap_t env = EXR_ENVMAP_LAST_TYPE;
        exr_result_t rc = exr_start_read(&f, path, NULL);
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_attr_get_envmap(f, 0, "envmap", &env);
        exr_finish(&f);
        CHECK(i == 0 ? rc == EXR_ERR_NO_ATTR_BY_NAME
                     : rc == EXR_ERR_SUCCESS && env == (i == 1 ? EXR_ENVMAP_LATLONG
                                                                : EXR_ENVMAP_CUBE));
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        CHECK(img.meta.envmap_layout == layouts[i]);
        CHECK(img.px && !memcmp(img.px, px, sizeof(float) * 8 * 48 * 3));
        envl__image_free(&img);
    }
    CHECK_RC(envl_image_save(path, px, 8, 48, &(envl_save_options){.envmap = ENVL_LAYOUT_STRIP_V}),
             ENVL_ERR_ARGUMENT);
    CHECK(strstr(envl_last_error(), "envmap") != NULL);
    CHECK_RC(envl__write_exr(path, px, 8, 48, ENVL_PIXEL_FLOAT, -1), ENVL_ERR_ARGUMENT);
    free(px);
}

/* ---- variants written with the C API ------------------------------------------------------- */

#define RGB_HALF(p)                                                                            \
    (p).nch = 3, (p).ch[0] = "R", (p).ch[1] = "G", (p).ch[2] = "B",                            \
    (p).type[0] = (p).type[1] = (p).type[2] = EXR_PIXEL_HALF, (p).value_index[0] = 0,          \
    (p).value_index[1] = 1, (p).value_index[2] = 2

/* Output pixel (x, y) of an image read from a file whose display window starts at (dx, dy):
 * test_value at the absolute position when inside the data window, else 0. */
static int check_window_pixels(const envl_image *img, exr_attr_box2i_t disp, exr_attr_box2i_t dw)
{
    int bad = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            int ax = x + disp.min.x, ay = y + disp.min.y;
            int in = ax >= dw.min.x && ax <= dw.max.x && ay >= dw.min.y && ay <= dw.max.y;
            const float *p = px_at(img, x, y);
            for (int c = 0; c < 3; c++)
                if (p[c] != (in ? test_value(c, ax, ay, 0) : 0.0f))
                    bad++;
        }
    return bad;
}

static void test_windows(void)
{
    /* data window inside the display window; beyond it on every side; disjoint; and both
     * scanline (ZIP, 16-line chunks) and tiled */
    const int cases[5][8] = {
        {2, 1, 5, 3, 0, 0, 7, 4},          /* inside */
        {-2, -1, 40, 37, 0, 0, 7, 4},      /* larger on every side: cropped */
        {-5, 3, 12, 40, 1, -2, 20, 30},    /* partial overlap */
        {0, 0, 9, 9, 20, 20, 24, 22},      /* disjoint: an error (nothing would read but black) */
        {0, 0, 30, 20, 0, 0, 30, 20},      /* equal */
    };
    for (int k = 0; k < 5; k++)
        for (int tiled = 0; tiled < 2; tiled++) {
            const int *c = cases[k];
            test_part tp = {0};
            RGB_HALF(tp);
            tp.dw = box(c[0], c[1], c[2], c[3]);
            tp.disp = box(c[4], c[5], c[6], c[7]);
            tp.comp = tiled ? EXR_COMPRESSION_PIZ : EXR_COMPRESSION_ZIP;
            tp.tiled = tiled, tp.tile_w = 4, tp.tile_h = 3, tp.levels = EXR_TILE_ONE_LEVEL;
            tp.envmap = -1;
            const char *path = tmp_path("windows.exr");
            CHECK(write_test_file(path, &tp, 1) == 0);
            envl_image img;
            if (k == 3) {
                CHECK_RC(read_exr_file(path, NULL, &img), ENVL_ERR_FORMAT);
                CHECK(strstr(envl_last_error(), "windows.exr: the data window (0, 0) - (9, 9) "
                             "lies wholly outside the display window (20, 20) - (24, 22)"));
                CHECK(img.px == NULL);
                continue;
            }
            CHECK_OK(read_exr_file(path, NULL, &img));
            CHECK(img.width == c[6] - c[4] + 1 && img.height == c[7] - c[5] + 1);
            if (img.px)
                CHECK(check_window_pixels(&img, tp.disp, tp.dw) == 0);
            envl__image_free(&img);
        }
}

/* More chunks than one block of the parallel decoder (1024): 2100 one-line ZIPS chunks and 1200
 * tiles of 8 x 8, read from the file at 1 and 3 threads as from memory; then one chunk of the
 * second block damaged (its packed size): the same message, naming that chunk. */
static void test_many_chunks(void)
{
    for (int tiled = 0; tiled < 2; tiled++) {
        test_part tp = {.nch = 3, .ch = {"R", "G", "B"},
                        .type = {EXR_PIXEL_HALF, EXR_PIXEL_FLOAT, EXR_PIXEL_HALF},
                        .value_index = {0, 1, 2}, .envmap = -1};
        tp.dw = tp.disp = tiled ? box(0, 0, 319, 239) : box(0, 0, 63, 2099);
        tp.comp = tiled ? EXR_COMPRESSION_PIZ : EXR_COMPRESSION_ZIPS;
        tp.tiled = tiled, tp.tile_w = 8, tp.tile_h = 8, tp.levels = EXR_TILE_ONE_LEVEL;
        const char *path = tmp_path(tiled ? "many_tiles.exr" : "many_lines.exr");
        CHECK(write_test_file(path, &tp, 1) == 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        int wrong = 0;
        for (int y = 0; y < img.height && img.px; y++)
            for (int x = 0; x < img.width; x++)
                for (int c = 0; c < 3; c++)
                    wrong += px_at(&img, x, y)[c] != test_value(c, x, y, 0);
        CHECK(wrong == 0);
        check_file_reader(path);
        envl__image_free(&img);

        /* damage: the packed size of chunk 1500 (tiles: 1100) in its chunk header, made huge */
        int64_t chunk = tiled ? 1100 : 1500;
        exr_context_t f;
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        exr_chunk_info_t ci = {0};
        CHECK(exr_start_read(&f, path, &init) == 0);
        if (tiled)
            CHECK(exr_read_tile_chunk_info(f, 0, (int)(chunk % 40), (int)(chunk / 40), 0, 0,
                                           &ci) == 0);
        else
            CHECK(exr_read_scanline_chunk_info(f, 0, (int)chunk, &ci) == 0);
        exr_finish(&f);
        /* scanline chunk: y (4), size (4), data; tile: tx, ty, lx, ly (16), size (4), data */
        uint64_t at = ci.data_offset - 4;
        int fd = open(path, O_WRONLY);
        const uint8_t ff[4] = {0xff, 0xff, 0xff, 0x0f};
        CHECK(fd >= 0 && pwrite(fd, ff, 4, (off_t)at) == 4);
        close(fd);
        envl_result rc = read_exr_file(path, NULL, &img);
        CHECK(rc != ENVL_OK);
        char msg[2048], want[64];
        snprintf(msg, sizeof msg, "%s", envl_last_error());
        if (tiled)
            snprintf(want, sizeof want, "tile (%d, %d)", (int)(chunk % 40), (int)(chunk / 40));
        else
            snprintf(want, sizeof want, "scanline %d", (int)chunk);
        CHECK(strstr(msg, want) != NULL);
        if (!strstr(msg, want))
            fprintf(stderr, "  %s\n", msg);
        check_file_reader(path);
        envl__image_free(&img);
        remove(path);
    }
}

static void test_tiled_mipmap(void)
{
    /* (rip-mapped files are read the same way, level (0, 0); OpenEXRCore 3.1.5 cannot write
     * them in order, so only mip maps are written here) */
    const exr_tile_level_mode_t modes[1] = {EXR_TILE_MIPMAP_LEVELS};
    for (int m = 0; m < 1; m++) {
        test_part tp = {0};
        RGB_HALF(tp);
        tp.dw = tp.disp = box(0, 0, 36, 22);
        tp.comp = EXR_COMPRESSION_ZIP;
        tp.tiled = 1, tp.tile_w = 8, tp.tile_h = 8, tp.levels = modes[m];
        tp.envmap = -1;
        const char *path = tmp_path("mip.exr");
        CHECK(write_test_file(path, &tp, 1) == 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        CHECK(img.width == 37 && img.height == 23); /* level 0 */
        if (img.px)
            CHECK(check_window_pixels(&img, tp.disp, tp.dw) == 0); /* no +100 of level >= 1 */
        envl__image_free(&img);
    }
}

static void test_luminance_and_uint(void)
{
    /* Y only (float): grey */
    test_part tp = {0};
    tp.nch = 2, tp.ch[0] = "Y", tp.ch[1] = "A";
    tp.type[0] = EXR_PIXEL_FLOAT, tp.type[1] = EXR_PIXEL_HALF;
    tp.value_index[0] = 4, tp.value_index[1] = 0;
    tp.dw = tp.disp = box(0, 0, 9, 4);
    tp.comp = EXR_COMPRESSION_RLE;
    tp.envmap = -1;
    const char *path = tmp_path("y.exr");
    CHECK(write_test_file(path, &tp, 1) == 0);
    envl_image img;
    CHECK_OK(read_exr_file(path, NULL, &img));
    int bad = 0;
    for (int y = 0; img.px && y < 5; y++)
        for (int x = 0; x < 10; x++) {
            const float *p = px_at(&img, x, y);
            float v = test_value(4, x, y, 0);
            bad += p[0] != v || p[1] != v || p[2] != v;
        }
    CHECK(img.px && bad == 0);
    CHECK(img.meta.channels == 2); /* Y + A */
    envl__image_free(&img);

    /* a single uint channel: grey, converted to float */
    test_part tu = {0};
    tu.nch = 1, tu.ch[0] = "id", tu.type[0] = EXR_PIXEL_UINT;
    tu.dw = tu.disp = box(0, 0, 6, 3);
    tu.comp = EXR_COMPRESSION_ZIPS;
    tu.envmap = -1;
    path = tmp_path("uint.exr");
    CHECK(write_test_file(path, &tu, 1) == 0);
    CHECK_OK(read_exr_file(path, NULL, &img));
    bad = 0;
    for (int y = 0; img.px && y < 4; y++)
        for (int x = 0; x < 7; x++) {
            const float *p = px_at(&img, x, y);
            float v = (float)(x * 1000 + y * 3 + 7);
            bad += p[0] != v || p[1] != v || p[2] != v;
        }
    CHECK(img.px && bad == 0 && img.meta.channels == 1);
    envl__image_free(&img);

    /* R half, G float, B uint, uncompressed */
    test_part tm = {0};
    tm.nch = 3, tm.ch[0] = "R", tm.ch[1] = "G", tm.ch[2] = "B";
    tm.type[0] = EXR_PIXEL_HALF, tm.type[1] = EXR_PIXEL_FLOAT, tm.type[2] = EXR_PIXEL_UINT;
    tm.value_index[0] = 0, tm.value_index[1] = 1;
    tm.dw = tm.disp = box(0, 0, 4, 2);
    tm.comp = EXR_COMPRESSION_NONE;
    tm.envmap = -1;
    path = tmp_path("mixed.exr");
    CHECK(write_test_file(path, &tm, 1) == 0);
    CHECK_OK(read_exr_file(path, NULL, &img));
    bad = 0;
    for (int y = 0; img.px && y < 3; y++)
        for (int x = 0; x < 5; x++) {
            const float *p = px_at(&img, x, y);
            bad += p[0] != test_value(0, x, y, 0) || p[1] != test_value(1, x, y, 0) ||
                   p[2] != (float)(x * 1000 + y * 3 + 7);
        }
    CHECK(img.px && bad == 0 && img.meta.channels == 3);
    envl__image_free(&img);
}

/* Float channels keep float precision: 1e6, 3e38 and 1e-30 come back bit-exact. */
static void test_float_range(void)
{
    float px[6] = {1e6f, 3e38f, 1e-30f, -3e38f, bits_to_float(0x00000001u), 65505.0f};
    const char *path = tmp_path("range.exr");
    CHECK_OK(envl__write_exr(path, px, 2, 1, ENVL_PIXEL_FLOAT, 0));
    envl_image img;
    CHECK_OK(read_exr_file(path, NULL, &img));
    CHECK(img.px && memcmp(img.px, px, sizeof px) == 0);
    envl__image_free(&img);
}

static void test_parts_and_layers(void)
{
    /* part 0: depth (Z only), part 1: beauty (RGB), both named */
    test_part tp[2] = {{0}, {0}};
    tp[0].name = "depth";
    tp[0].nch = 1, tp[0].ch[0] = "Z", tp[0].type[0] = EXR_PIXEL_FLOAT, tp[0].value_index[0] = 7;
    tp[1].name = "beauty";
    RGB_HALF(tp[1]);
    for (int i = 0; i < 2; i++) {
        tp[i].dw = tp[i].disp = box(0, 0, 5, 3);
        tp[i].comp = EXR_COMPRESSION_ZIP;
        tp[i].envmap = -1;
    }
    const char *path = tmp_path("parts.exr");
    CHECK(write_test_file(path, tp, 2) == 0);
    envl_image img;
    CHECK_OK(read_exr_file(path, NULL, &img)); /* first part with colour: beauty */
    CHECK(img.px && img.meta.channels == 3 && check_window_pixels(&img, tp[1].disp, tp[1].dw) == 0);
    envl__image_free(&img);

    envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, "depth", 0};
    CHECK_OK(read_exr_file(path, &lim, &img)); /* named: the single channel as grey */
    CHECK(img.px && img.meta.channels == 1);
    if (img.px)
        CHECK(px_at(&img, 3, 2)[0] == test_value(7, 3, 2, 0) &&
              px_at(&img, 3, 2)[2] == test_value(7, 3, 2, 0));
    envl__image_free(&img);

    lim.exr_part = "nope";
    CHECK_RC(read_exr_file(path, &lim, &img), ENVL_ERR_ARGUMENT);
    CHECK(strstr(envl_last_error(), "nope") && strstr(envl_last_error(), "'depth'") &&
          strstr(envl_last_error(), "'beauty'"));
    CHECK(img.px == NULL);

    /* layers: left.* and right.*, no plain R, G, B: the first layer (alphabetical) */
    test_part tl = {0};
    tl.nch = 4, tl.ch[0] = "right.R", tl.ch[1] = "left.R", tl.ch[2] = "left.G";
    tl.ch[3] = "left.B";
    for (int c = 0; c < 4; c++)
        tl.type[c] = EXR_PIXEL_HALF;
    tl.value_index[0] = 9, tl.value_index[1] = 0, tl.value_index[2] = 1, tl.value_index[3] = 2;
    tl.dw = tl.disp = box(0, 0, 7, 2);
    tl.comp = EXR_COMPRESSION_PIZ;
    tl.envmap = -1;
    path = tmp_path("layers.exr");
    CHECK(write_test_file(path, &tl, 1) == 0);
    CHECK_OK(read_exr_file(path, NULL, &img));
    CHECK(img.px && img.meta.channels == 3 && check_window_pixels(&img, tl.disp, tl.dw) == 0);
    envl__image_free(&img);

    /* no colour channel at all, two channels: refused, naming them */
    test_part tn = {0};
    tn.nch = 2, tn.ch[0] = "Z", tn.ch[1] = "depth";
    tn.type[0] = tn.type[1] = EXR_PIXEL_FLOAT;
    tn.dw = tn.disp = box(0, 0, 1, 1);
    tn.envmap = -1;
    path = tmp_path("nocolour.exr");
    CHECK(write_test_file(path, &tn, 1) == 0);
    CHECK_RC(read_exr_file(path, NULL, &img), ENVL_ERR_UNSUPPORTED);
    CHECK(strstr(envl_last_error(), "Z, depth") != NULL);
}

/* Chromaticities: a file holding CIE XYZ (R, G, B = X, Y, Z) converts back to Rec.709. The
 * XYZ of Rec.709 red, green, blue and white (D65, Y = 1) are the columns / row sums of the
 * Rec.709 RGB -> XYZ matrix (IEC 61966-2-1). */
static void test_chromaticities(void)
{
    static const float xyz_chroma[8] = {1, 0, 0, 1, 0, 0, 1.0f / 3, 1.0f / 3};
    const float xyz[4][3] = {{0.4124f, 0.2126f, 0.0193f},
                             {0.3576f, 0.7152f, 0.1192f},
                             {0.1805f, 0.0722f, 0.9505f},
                             {0.9505f, 1.0000f, 1.0890f}};
    const float want[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    test_part tp = {0};
    tp.nch = 3, tp.ch[0] = "R", tp.ch[1] = "G", tp.ch[2] = "B";
    tp.value_index[0] = 0, tp.value_index[1] = 1, tp.value_index[2] = 2;
    tp.type[0] = tp.type[1] = tp.type[2] = EXR_PIXEL_FLOAT;
    tp.dw = tp.disp = box(0, 0, 3, 0);
    tp.comp = EXR_COMPRESSION_NONE;
    tp.envmap = EXR_ENVMAP_LATLONG;
    tp.chroma = xyz_chroma;
    const char *path = tmp_path("xyz_pattern.exr");
    CHECK(write_test_file(path, &tp, 1) == 0);
    envl_image img;
    CHECK_OK(read_exr_file(path, NULL, &img));
    CHECK(img.meta.has_primaries == 1 && img.meta.primaries[0] == 1.0f &&
          img.meta.primaries[3] == 1.0f && img.meta.primaries[6] == 1.0f / 3);
    CHECK(img.meta.envmap_layout == ENVL_LAYOUT_EXR_LATLONG);
    /* the same pixels read as Rec.709 would be test_value; as XYZ they are converted: check
     * the matrix on them against the inverse Rec.709 matrix */
    static const double xyz_to_709[3][3] = {{3.2406, -1.5372, -0.4986},
                                            {-0.9689, 1.8758, 0.0415},
                                            {0.0557, -0.2040, 1.0570}};
    int bad = 0;
    for (int x = 0; img.px && x < 4; x++) {
        const float *p = px_at(&img, x, 0);
        for (int c = 0; c < 3; c++) {
            double e = 0;
            for (int k = 0; k < 3; k++)
                e += xyz_to_709[c][k] * test_value(k, x, 0, 0);
            /* the sRGB matrix is given to 4 digits: 5e-4 relative to the largest input */
            if (fabs(p[c] - e) > 5e-4 * 15 * 3) {
                bad++;
                fprintf(stderr, "xyz pattern %d %d: %g, expected %g\n", x, c, p[c], e);
            }
        }
    }
    CHECK(img.px && bad == 0);
    envl__image_free(&img);

    /* exact primaries: XYZ of Rec.709 red/green/blue/white -> unit RGB */
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    path = tmp_path("xyz_primaries.exr");
    int p = 0;
    int rc = exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &init);
    rc = rc ? rc : exr_add_part(f, NULL, EXR_STORAGE_SCANLINE, &p);
    rc = rc ? rc : exr_initialize_required_attr_simple(f, p, 4, 1, EXR_COMPRESSION_NONE);
    for (int c = 0; c < 3 && !rc; c++)
        rc = exr_add_channel(f, p, c == 0 ? "B" : c == 1 ? "G" : "R", EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LINEAR, 1, 1);
    exr_attr_chromaticities_t chr = {1, 0, 0, 1, 0, 0, 1.0f / 3, 1.0f / 3};
    rc = rc ? rc : exr_attr_set_chromaticities(f, p, "chromaticities", &chr);
    rc = rc ? rc : exr_attr_set_envmap(f, p, "envmap", EXR_ENVMAP_CUBE);
    rc = rc ? rc : exr_write_header(f);
    exr_chunk_info_t ci;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    rc = rc ? rc : exr_write_scanline_chunk_info(f, p, 0, &ci);
    rc = rc ? rc : exr_encoding_initialize(f, p, &ci, &enc);
    for (int c = 0; c < enc.channel_count && !rc; c++) {
        int slot = !strcmp(enc.channels[c].channel_name, "R") ? 0
                   : !strcmp(enc.channels[c].channel_name, "G") ? 1 : 2;
        enc.channels[c].encode_from_ptr = (const uint8_t *)(&xyz[0][0] + slot);
        enc.channels[c].user_pixel_stride = 12;
        enc.channels[c].user_line_stride = 48;
        enc.channels[c].user_data_type = EXR_PIXEL_FLOAT;
        enc.channels[c].user_bytes_per_element = 4;
    }
    rc = rc ? rc : exr_encoding_choose_default_routines(f, p, &enc);
    rc = rc ? rc : exr_encoding_run(f, p, &enc);
    exr_encoding_destroy(f, &enc);
    int frc = exr_finish(&f);
    CHECK(rc == 0 && frc == 0);
    CHECK_OK(read_exr_file(path, NULL, &img));
    CHECK(img.meta.envmap_layout == ENVL_LAYOUT_EXR_CUBE);
    bad = 0;
    for (int x = 0; img.px && x < 4; x++)
        for (int c = 0; c < 3; c++)
            if (fabs(px_at(&img, x, 0)[c] - want[x][c]) > 1e-3) { /* 4-digit matrix entries */
                bad++;
                fprintf(stderr, "xyz pixel %d channel %d: %g, expected %g\n", x, c,
                        px_at(&img, x, 0)[c], want[x][c]);
            }
    CHECK(img.px && bad == 0);
    envl__image_free(&img);
}

/* ---- luminance / chroma written here ---------------------------------------------------------
 * OpenEXRCore 3.1's default packer cannot lay out subsampled channels, so this test packs the
 * chunk itself (the pipeline's convert_and_pack_fn hook): per scanline, per channel in list
 * order (BY, RY, Y), the channel's samples on that line, little-endian half. Values are chosen
 * exactly representable in half. Chroma is linear in x and y at its samples, so the reader's
 * bilinear upsampling must reproduce the same linear function at every pixel between samples
 * and repeat the edge sample beyond the last one. */
static uint16_t exact_half(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    if (f == 0.0f)
        return (uint16_t)(u >> 16);
    uint32_t sign = (u >> 16) & 0x8000u, e = (u >> 23) & 255u, m = u & 0x7fffffu;
    return (uint16_t)(sign | ((e - 112u) << 10) | (m >> 13)); /* normal halves only */
}

static float yc_luma(int x, int y) { return (float)(((x * 3 + y * 5) % 16 + 16) % 16 + 4) / 8.0f; }
static float yc_ry(int x, int y) { return (float)(x + 2 * y) / 256.0f - 0.25f; }
static float yc_by(int x, int y) { return 0.125f - (float)(2 * x - y) / 512.0f; }

static exr_result_t pack_yc(exr_encode_pipeline_t *e)
{
    uint8_t *out = e->packed_buffer;
    int x0 = e->chunk.start_x;
    for (int y = e->chunk.start_y; y < e->chunk.start_y + e->chunk.height; y++)
        for (int c = 0; c < e->channel_count; c++) {
            const exr_coding_channel_info_t *ec = &e->channels[c];
            int s = !strcmp(ec->channel_name, "Y") ? 1 : 2;
            if (((y % s) + s) % s)
                continue;
            int first = x0 % s == 0 ? x0 : x0 + (s - ((x0 % s) + s) % s);
            for (int i = 0; i < ec->width; i++) {
                int x = first + i * s;
                float v = s == 1 ? yc_luma(x, y)
                          : !strcmp(ec->channel_name, "RY") ? yc_ry(x, y) : yc_by(x, y);
                uint16_t h = exact_half(v);
                *out++ = (uint8_t)(h & 255);
                *out++ = (uint8_t)(h >> 8);
            }
        }
    e->packed_bytes = (uint64_t)(out - (uint8_t *)e->packed_buffer);
    return e->packed_bytes == e->chunk.unpacked_size ? EXR_ERR_SUCCESS : EXR_ERR_INCORRECT_CHUNK;
}

static int write_yc_file(const char *path, exr_attr_box2i_t dw, exr_attr_box2i_t disp,
                         exr_compression_t comp)
{
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int p = 0;
    exr_attr_v2f_t swc = {.x = 0, .y = 0};
    exr_result_t rc = exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc)
        return rc;
    rc = exr_add_part(f, NULL, EXR_STORAGE_SCANLINE, &p);
    rc = rc ? rc : exr_initialize_required_attr(f, p, &disp, &dw, 1.0f, &swc, 1.0f,
                                                EXR_LINEORDER_INCREASING_Y, comp);
    rc = rc ? rc : exr_add_channel(f, p, "Y", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    rc = rc ? rc : exr_add_channel(f, p, "RY", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 2, 2);
    rc = rc ? rc : exr_add_channel(f, p, "BY", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 2, 2);
    rc = rc ? rc : exr_write_header(f);
    int32_t lines = 1;
    rc = rc ? rc : exr_get_scanlines_per_chunk(f, p, &lines);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int ready = 0;
    for (int y = dw.min.y; !rc && y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        rc = exr_write_scanline_chunk_info(f, p, y, &ci);
        if (!rc)
            rc = ready ? exr_encoding_update(f, p, &ci, &enc)
                       : exr_encoding_initialize(f, p, &ci, &enc);
        if (rc)
            break;
        ready = 1;
        /* the same samples as planes too: for a chunk with one channel on the line the library
         * may take them straight from the pointer instead of calling the packer */
        uint16_t *planes = calloc((size_t)ci.width * (size_t)ci.height * 3 + 1, 2), *pl = planes;
        for (int c = 0; c < enc.channel_count; c++) {
            const char *cn = enc.channels[c].channel_name;
            int sm = !strcmp(cn, "Y") ? 1 : 2, n = 0;
            enc.channels[c].encode_from_ptr = (const uint8_t *)pl;
            for (int yy = ci.start_y; yy < ci.start_y + ci.height; yy++) {
                if (((yy % sm) + sm) % sm)
                    continue;
                for (int i = 0; i < enc.channels[c].width; i++) {
                    int xx = ci.start_x + i * sm;
                    float v = sm == 1 ? yc_luma(xx, yy) : !strcmp(cn, "RY") ? yc_ry(xx, yy)
                                                                             : yc_by(xx, yy);
                    pl[n++] = exact_half(v);
                }
            }
            pl += n;
            enc.channels[c].user_pixel_stride = 2;
            enc.channels[c].user_line_stride = 2 * enc.channels[c].width;
            enc.channels[c].user_bytes_per_element = 2;
            enc.channels[c].user_data_type = EXR_PIXEL_HALF;
        }
        rc = exr_encoding_choose_default_routines(f, p, &enc);
        enc.convert_and_pack_fn = pack_yc;
        rc = rc ? rc : exr_encoding_run(f, p, &enc);
        free(planes);
    }
    if (ready)
        exr_encoding_destroy(f, &enc);
    exr_result_t frc = exr_finish(&f);
    return rc ? rc : frc;
}

static int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

static void test_luminance_chroma(void)
{
    const int cases[3][8] = {{0, 0, 21, 13, 0, 0, 21, 13},    /* last column / row past the last sample */
                             {-4, -6, 17, 9, -2, -7, 30, 8},  /* windows differ, negative */
                             {2, 2, 41, 39, 0, 0, 43, 41}};   /* 16-line chunks, margins */
    /* (no ZIPS: OpenEXRCore 3.1.5 stores a line whose deflated size equals its raw size as
     * deflated data, which every reader must take for raw -- a writer bug of that version) */
    const exr_compression_t comps[3] = {EXR_COMPRESSION_RLE, EXR_COMPRESSION_NONE,
                                        EXR_COMPRESSION_PIZ};
    for (int k = 0; k < 3; k++) {
        const int *c = cases[k];
        exr_attr_box2i_t dw = box(c[0], c[1], c[2], c[3]), disp = box(c[4], c[5], c[6], c[7]);
        char fname[32];
        snprintf(fname, sizeof fname, "yc%d.exr", k);
        const char *path = tmp_path(fname);
        CHECK(write_yc_file(path, dw, disp, comps[k]) == 0);
        envl_image img;
        CHECK_OK(read_exr_file(path, NULL, &img));
        if (!img.px)
            continue;
        CHECK(img.meta.channels == 3);
        /* samples at even coordinates inside the data window */
        int sx0 = dw.min.x + (dw.min.x & 1), sx1 = dw.max.x - (dw.max.x & 1);
        int sy0 = dw.min.y + (dw.min.y & 1), sy1 = dw.max.y - (dw.max.y & 1);
        int bad = 0;
        for (int y = 0; y < img.height; y++)
            for (int x = 0; x < img.width; x++) {
                int ax = x + disp.min.x, ay = y + disp.min.y;
                const float *p = px_at(&img, x, y);
                double want[3] = {0, 0, 0};
                if (ax >= dw.min.x && ax <= dw.max.x && ay >= dw.min.y && ay <= dw.max.y) {
                    int cx = clampi(ax, sx0, sx1), cy = clampi(ay, sy0, sy1);
                    double yl = yc_luma(ax, ay), ry = yc_ry(cx, cy), by = yc_by(cx, cy);
                    /* RgbaYca: R = (RY + 1) Y, B = (BY + 1) Y, G from Rec.709 weights */
                    want[0] = (ry + 1) * yl;
                    want[2] = (by + 1) * yl;
                    want[1] = (yl - 0.2126 * want[0] - 0.0722 * want[2]) / 0.7152;
                }
                for (int ch = 0; ch < 3; ch++)
                    if (fabs(p[ch] - want[ch]) > 2e-4 * (1 + fabs(want[ch]))) { /* 4-digit yw */
                        if (bad++ < 5)
                            fprintf(stderr, "  yc (%d, %d) ch %d: %g, expected %g\n", ax, ay,
                                    ch, p[ch], want[ch]);
                    }
            }
        CHECK(bad == 0);
        if (bad)
            fprintf(stderr, "  yc case %d: %d values differ\n", k, bad);
        envl__image_free(&img);
    }
}

static void test_limits(void)
{
    test_part tp = {0};
    RGB_HALF(tp);
    tp.dw = tp.disp = box(0, 0, 63, 63);
    tp.comp = EXR_COMPRESSION_ZIP;
    tp.envmap = -1;
    const char *path = tmp_path("limit.exr");
    CHECK(write_test_file(path, &tp, 1) == 0);
    envl_image img;
    envl_limits lim = {4095, NULL, 0};
    CHECK_RC(read_exr_file(path, &lim, &img), ENVL_ERR_LIMIT);
    CHECK(img.px == NULL && strstr(envl_last_error(), "limit.exr") != NULL);
    lim.max_pixels = 4096;
    CHECK_OK(read_exr_file(path, &lim, &img));
    envl__image_free(&img);
    /* a tiny display window over a data window far beyond the limit: refused */
    tp.dw = box(0, 0, 299, 299);
    tp.disp = box(0, 0, 3, 3);
    CHECK(write_test_file(path, &tp, 1) == 0);
    lim.max_pixels = 1000;
    CHECK_RC(read_exr_file(path, &lim, &img), ENVL_ERR_LIMIT);
    CHECK(strstr(envl_last_error(), "data window") != NULL);
}

/* Every prefix of a small valid file fails with ENVL_ERR_FORMAT (never a crash or a leak). */
static void test_truncated(void)
{
    float *px = pattern(33, 17, 5);
    const char *path = tmp_path("small.exr");
    CHECK_OK(envl__write_exr(path, px, 33, 17, ENVL_PIXEL_HALF, 0));
    free(px);
    uint8_t *data;
    size_t size;
    CHECK_OK(envl__read_file(path, 1 << 20, &data, &size));
    if (!data)
        return;
    int wrong = 0, leaked = 0;
    for (size_t n = 0; n < size; n++) {
        envl_image img;
        envl_result rc = envl__read_exr(data, n, "small.exr", &default_limits, &img);
        if (rc != ENVL_ERR_FORMAT) {
            wrong++;
            fprintf(stderr, "prefix %zu of %zu: %s %s\n", n, size, envl_result_name(rc),
                    envl_last_error());
        }
        if (img.px)
            leaked++;
        envl__image_free(&img);
    }
    CHECK(wrong == 0 && leaked == 0);
    /* flipped bytes: whatever the result, no crash and no output on failure */
    for (size_t i = 0; i < size; i += 7) {
        uint8_t *copy = malloc(size);
        memcpy(copy, data, size);
        copy[i] ^= 0x5a;
        envl_image img;
        envl_result rc = envl__read_exr(copy, size, "flipped.exr", &default_limits, &img);
        CHECK(rc == ENVL_OK || rc == ENVL_ERR_FORMAT || rc == ENVL_ERR_LIMIT ||
              rc == ENVL_ERR_UNSUPPORTED || rc == ENVL_ERR_MEMORY);
        if (rc)
            CHECK(img.px == NULL);
        envl__image_free(&img);
        free(copy);
    }
    free(data);
}

/* ---- the OpenEXR samples -------------------------------------------------------------------- */

static int redirect_stderr(const char *file, int *saved)
{
    fflush(stderr);
    *saved = dup(2);
    int fd = open(file, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0 || *saved < 0)
        return -1;
    dup2(fd, 2);
    close(fd);
    return 0;
}

static long restore_stderr(const char *file, int saved)
{
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    struct stat st;
    return stat(file, &st) == 0 ? (long)st.st_size : -1;
}

static void test_damaged(void)
{
    static const char *files[] = {"comp_bad_neg_bounds_pxr24.exr", "comp_bad_pos_bounds_piz.exr",
                                  "comp_bad_pos_bounds_pxr24.exr", "comp_early_eof_piz.exr",
                                  "comp_short_decode_piz.exr", "invalid.exr",
                                  /* chunk table points past the end of its 480 bytes */
                                  "tiled.exr"};
    const char *log = tmp_path("stderr.txt");
    for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
        char rel[128];
        snprintf(rel, sizeof rel, "openexr/OpenEXRTest/%s", files[i]);
        const char *path = shared_data(rel);
        if (!path)
            continue;
        int saved;
        if (redirect_stderr(log, &saved) != 0)
            continue;
        envl_image img;
        envl_result rc = read_exr_file(path, NULL, &img);
        long err_bytes = restore_stderr(log, saved);
        CHECK_RC(rc, ENVL_ERR_FORMAT);
        CHECK(strstr(envl_last_error(), files[i]) != NULL);
        CHECK(strlen(envl_last_error()) > strlen(path) + 10); /* says what the library said */
        CHECK(img.px == NULL);
        CHECK(err_bytes == 0); /* nothing printed on stderr */
        envl__image_free(&img);
    }
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

static int is_damaged(const char *base)
{
    return !strncmp(base, "comp_bad_", 9) || !strcmp(base, "comp_early_eof_piz.exr") ||
           !strcmp(base, "comp_short_decode_piz.exr") || !strcmp(base, "invalid.exr") ||
           !strcmp(base, "tiled.exr");
}

static int sample_count;

static void check_sample(const char *path)
{
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    envl_image img;
    envl_result rc = read_exr_file(path, NULL, &img);
    check_file_reader(path);
    sample_count++;
    if (is_damaged(base)) {
        CHECK_RC(rc, ENVL_ERR_FORMAT);
        return;
    }
    if (!strcmp(base, "11.deep.exr")) {
        CHECK_RC(rc, ENVL_ERR_UNSUPPORTED); /* deep only */
        return;
    }
    exr_attr_box2i_t disp, dw;
    CHECK(header_windows(path, 0, &disp, &dw) == 0);
    int overlap = dw.min.x <= disp.max.x && dw.max.x >= disp.min.x && dw.min.y <= disp.max.y &&
                  dw.max.y >= disp.min.y;
    if (!overlap) { /* nothing displayed (DisplayWindow/t09 - t12): an error, not a black map */
        CHECK_RC(rc, ENVL_ERR_FORMAT);
        CHECK(strstr(envl_last_error(), "lies wholly outside the display window"));
        return;
    }
    CHECK_RC(rc, ENVL_OK); /* DWAA / DWAB too (the C++ library: test_exr_dwa.c) */
    if (rc) {
        fprintf(stderr, "  (%s)\n", path);
        return;
    }
    CHECK(img.width == disp.max.x - disp.min.x + 1 && img.height == disp.max.y - disp.min.y + 1);
    double sum[3] = {0, 0, 0};
    int64_t nonfinite = 0, n = (int64_t)img.width * img.height;
    for (int64_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float v = img.px[3 * i + c];
            if (isfinite(v))
                sum[c] += v;
            else
                nonfinite++;
        }
    int may_be_nonfinite = !strcmp(base, "BrightRingsNanInf.exr") ||
                           !strcmp(base, "AllHalfValues.exr") || !strcmp(base, "comp_b44.exr") ||
                           !strncmp(base, "comp_", 5) || !strncmp(base, "lineOrder_", 10);
    if (!may_be_nonfinite)
        CHECK(nonfinite == 0);
    double lum = 0.2126 * sum[0] + 0.7152 * sum[1] + 0.0722 * sum[2];
    CHECK(isfinite(lum));
    if (!strcmp(base, "v1.7.test.interleaved.exr"))
        CHECK(sum[0] == 0); /* its R channel holds zeros only (checked in the raw bytes) */
    else if (strcmp(base, "comp_b44.exr") && strcmp(base, "AllHalfValues.exr")) {
        CHECK(lum > 0);
        if (!(lum > 0))
            fprintf(stderr, "  %s: luminance sum %g\n", base, lum);
    }
    int want = ends_with(base, "LatLong.exr") ? ENVL_LAYOUT_EXR_LATLONG
               : ends_with(base, "Cube.exr")  ? ENVL_LAYOUT_EXR_CUBE
                                              : 0;
    CHECK(img.meta.envmap_layout == want);
    CHECK(!strcmp(img.meta.format, "exr"));
    if (!strcmp(base, "WideFloatRange.exr")) {
        float mx = 0;
        for (int64_t i = 0; i < 3 * n; i++)
            mx = img.px[i] > mx ? img.px[i] : mx;
        CHECK(nonfinite == 0 && mx > 1e37f); /* float32 data stays float32 */
    }
    if (!strcmp(base, "BrightRingsNanInf.exr"))
        CHECK(nonfinite > 0); /* passed through; the caller sanitises */
    envl__image_free(&img);
}

static void walk(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        struct stat st;
        if (stat(path, &st) != 0)
            continue;
        if (S_ISDIR(st.st_mode))
            walk(path);
        else if (ends_with(e->d_name, ".exr"))
            check_sample(path);
    }
    closedir(d);
}

static void test_all_samples(void)
{
    const char *root = shared_data("openexr");
    if (!root)
        return;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", root);
    walk(dir);
    CHECK(sample_count >= 50);
}

/* a and b read from shared files; NULL (skipped) when absent */
static int read_pair(const char *ra, const char *rb, envl_image *a, envl_image *b)
{
    const char *pa = shared_data(ra), *pb = shared_data(rb);
    memset(a, 0, sizeof *a);
    memset(b, 0, sizeof *b);
    if (!pa || !pb)
        return 0;
    CHECK_OK(read_exr_file(pa, NULL, a));
    CHECK_OK(read_exr_file(pb, NULL, b));
    return a->px && b->px;
}

static void mean_rgb(const envl_image *img, double m[3])
{
    m[0] = m[1] = m[2] = 0;
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            m[c] += img->px[3 * i + c];
    for (int c = 0; c < 3; c++)
        m[c] /= (double)n;
}

static void test_sample_comparisons(void)
{
    envl_image a, b;
    /* lossless compressions decode to identical pixels (comp_none / comp_rle when present) */
    static const char *lossless[] = {"openexr/OpenEXRTest/comp_zip.exr",
                                     "openexr/OpenEXRTest/comp_zips.exr",
                                     "openexr/OpenEXRTest/comp_none.exr",
                                     "openexr/OpenEXRTest/comp_rle.exr"};
    for (int i = 0; i < 4; i++) {
        char p[4096];
        snprintf(p, sizeof p, "%s/%s", ENVL_SHARED_DATA, lossless[i]);
        if (i >= 2 && access(p, R_OK) != 0)
            continue; /* not in every copy of the data */
        if (read_pair("openexr/OpenEXRTest/comp_piz.exr", lossless[i], &a, &b)) {
            CHECK(a.width == b.width && a.height == b.height &&
                  !memcmp(a.px, b.px, (size_t)a.width * a.height * 3 * sizeof(float)));
            CHECK(a.meta.channels == 4); /* RGBA */
        }
        envl__image_free(&a);
        envl__image_free(&b);
    }
    if (read_pair("openexr/OpenEXRTest/lineOrder_increasing.exr",
                  "openexr/OpenEXRTest/lineOrder_decreasing.exr", &a, &b))
        CHECK(a.width == b.width && a.height == b.height &&
              !memcmp(a.px, b.px, (size_t)a.width * a.height * 3 * sizeof(float)));
    envl__image_free(&a);
    envl__image_free(&b);
    /* B44 (lossy, luminance/chroma, one pixel smaller) against the PIZ original: luminance
     * within 5 % for 99 % of the finite pixels */
    if (read_pair("openexr/OpenEXRTest/comp_b44.exr", "openexr/OpenEXRTest/comp_piz.exr", &a,
                  &b)) {
        int64_t n = 0, close = 0;
        for (int y = 0; y < a.height && y < b.height; y++)
            for (int x = 0; x < a.width && x < b.width; x++) {
                const float *p = px_at(&a, x, y), *q = px_at(&b, x, y);
                double ya = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
                double yb = 0.2126 * q[0] + 0.7152 * q[1] + 0.0722 * q[2];
                if (!isfinite(ya) || !isfinite(yb))
                    continue;
                n++;
                close += fabs(ya - yb) <= 0.05 * fabs(yb) + 1e-3;
            }
        CHECK(n > 390000 && close >= 0.99 * (double)n);
        CHECK(a.meta.channels == 3);
    }
    envl__image_free(&a);
    envl__image_free(&b);
    /* DWA (lossy) against the PIZ original: means within 5 % (exactness: test_exr_dwa.c) */
    static const char *dwa[] = {"comp_dwaa_v1.exr", "comp_dwaa_v2.exr", "comp_dwab_v1.exr",
                                "comp_dwab_v2.exr"};
    for (int i = 0; i < 4; i++) {
        char rel[128];
        snprintf(rel, sizeof rel, "openexr/OpenEXRTest/%s", dwa[i]);
        const char *pa = shared_data(rel), *pb = shared_data("openexr/OpenEXRTest/comp_piz.exr");
        if (!pa || !pb)
            continue;
        CHECK_OK(read_exr_file(pa, NULL, &a));
        CHECK_OK(read_exr_file(pb, NULL, &b));
        if (!a.px || !b.px) {
            envl__image_free(&a);
            envl__image_free(&b);
            continue;
        }
        double ma[3], mb[3];
        mean_rgb(&a, ma);
        mean_rgb(&b, mb);
        for (int c = 0; c < 3; c++)
            CHECK_REL(ma[c], mb[c], 0.05);
        envl__image_free(&a);
        envl__image_free(&b);
    }
    /* same pixels, ZIP vs uncompressed */
    if (read_pair("openexr/OpenEXRTest/v1.7.test.1.exr", "openexr/OpenEXRTest/v1.7.test.planar.exr",
                  &a, &b))
        CHECK(a.width == b.width && a.height == b.height &&
              !memcmp(a.px, b.px, (size_t)a.width * a.height * 3 * sizeof(float)));
    envl__image_free(&a);
    envl__image_free(&b);

    /* luminance / chroma and XYZ against the Rec.709 RGB original: means within 2 % */
    static const char *variants[] = {"openexr/Chromaticities/Rec709_YC.exr",
                                     "openexr/Chromaticities/XYZ.exr",
                                     "openexr/Chromaticities/XYZ_YC.exr"};
    for (int i = 0; i < 3; i++) {
        if (read_pair("openexr/Chromaticities/Rec709.exr", variants[i], &a, &b)) {
            double ma[3], mb[3];
            mean_rgb(&a, ma);
            mean_rgb(&b, mb);
            for (int c = 0; c < 3; c++)
                CHECK_REL(mb[c], ma[c], 0.02);
            CHECK(b.meta.channels == 3);
            CHECK(b.meta.has_primaries == (i >= 1));
        }
        envl__image_free(&a);
        envl__image_free(&b);
    }

    /* display windows: t01 holds the 400 x 300 pixels with data = display window at (0, 0);
     * every other tN shows the same data through its own windows, zero outside the data */
    const char *t01 = shared_data("openexr/DisplayWindow/t01.exr");
    if (t01 && read_exr_file(t01, NULL, &a) == ENVL_OK) {
        for (int t = 2; t <= 16; t++) {
            char rel[64];
            snprintf(rel, sizeof rel, "openexr/DisplayWindow/t%02d.exr", t);
            const char *path = shared_data(rel);
            exr_attr_box2i_t disp, dw;
            if (!path || header_windows(path, 0, &disp, &dw) != 0)
                continue;
            if (dw.min.x > disp.max.x || dw.max.x < disp.min.x || dw.min.y > disp.max.y ||
                dw.max.y < disp.min.y) { /* t09 - t12: nothing displayed (check_sample) */
                CHECK_RC(read_exr_file(path, NULL, &b), ENVL_ERR_FORMAT);
                continue;
            }
            CHECK_OK(read_exr_file(path, NULL, &b));
            if (!b.px)
                continue;
            int bad = 0;
            for (int y = 0; y < b.height; y++)
                for (int x = 0; x < b.width; x++) {
                    int ax = x + disp.min.x, ay = y + disp.min.y;
                    int in = ax >= dw.min.x && ax <= dw.max.x && ay >= dw.min.y && ay <= dw.max.y;
                    const float *q = px_at(&b, x, y);
                    const float *p = in ? px_at(&a, ax - dw.min.x, ay - dw.min.y) : NULL;
                    for (int c = 0; c < 3; c++)
                        bad += q[c] != (p ? p[c] : 0.0f);
                }
            CHECK(bad == 0);
            if (bad)
                fprintf(stderr, "  t%02d: %d values differ\n", t, bad);
            envl__image_free(&b);
        }
        envl__image_free(&a);
    }
}

int main(void)
{
    test_round_trip_float();
    test_round_trip_half();
    test_round_trip_small_sizes();
    test_write_errors();
    test_envmap_attribute();
    test_windows();
    test_tiled_mipmap();
    test_many_chunks();
    test_luminance_and_uint();
    test_float_range();
    test_parts_and_layers();
    test_chromaticities();
    test_luminance_chroma();
    test_limits();
    test_truncated();
    test_damaged();
    test_all_samples();
    test_sample_comparisons();
    return check_report("test_exr");
}
