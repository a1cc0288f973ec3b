/* PNG output through libpng: RGBM (RGBA8) for HDR maps, sRGB RGB8 for the BRDF table. Encoded
 * in memory, then written atomically. A small reader (RGB8 / RGBA8) serves the tests. */
#include "internal.h"

#include <math.h>
#ifndef ENVL_NO_PNG
#include <png.h>
#endif
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

/* RGBM, range M: a = ceil(255 * min(max(r, g, b) / M, 1)) / 255, rgb8 = round(255 c / (M a))
 * (clamped to 255). Using the ceiling for a keeps rgb8 <= 255, so only values above M clamp. */
void envl_rgbm_encode(const float rgb[3], double range, uint8_t out[4])
{
    double c[3];
    double m = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = isfinite(rgb[k]) && rgb[k] > 0 ? fmin(rgb[k], range) : 0.0;
        m = fmax(m, c[k]);
    }
    double a = ceil(255.0 * fmin(m / range, 1.0) - 1e-9);
    if (a < 1) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    if (a > 255)
        a = 255;
    for (int k = 0; k < 3; k++) {
        double v = floor(255.0 * 255.0 * c[k] / (range * a) + 0.5);
        out[k] = (uint8_t)(v > 255 ? 255 : v < 0 ? 0 : v);
    }
    out[3] = (uint8_t)a;
}

void envl_rgbm_decode(const uint8_t in[4], double range, float rgb[3])
{
    for (int k = 0; k < 3; k++)
        rgb[k] = (float)(range * (in[k] / 255.0) * (in[3] / 255.0));
}

/* RGBD (Babylon.js's packing, which EXT_lights_image_based names for its PNG faces; its shader
 * helperFunctions toRGBD / fromRGBD): D = clamp(floor(max(255 / max(r, g, b), 1)) / 255, 0, 1),
 * rgb8 = round(255 (c D)^(1 / 2.2)), a8 = round(255 D); decode c = (rgb8 / 255)^2.2 / (a8 / 255).
 * Values above 255 clamp; below 1, D = 1 and the bytes are plain gamma 2.2. */
void envl_rgbd_encode(const float rgb[3], uint8_t out[4])
{
    double c[3], m = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = isfinite(rgb[k]) && rgb[k] > 0 ? rgb[k] : 0.0;
        m = fmax(m, c[k]);
    }
    double d = m > 0 ? floor(fmax(255.0 / m, 1.0)) : 255.0;
    d = fmin(d, 255.0);
    for (int k = 0; k < 3; k++) {
        double v = floor(255.0 * pow(fmin(c[k] * d / 255.0, 1.0), 1.0 / 2.2) + 0.5);
        out[k] = (uint8_t)(v > 255 ? 255 : v);
    }
    out[3] = (uint8_t)d;
}

void envl_rgbd_decode(const uint8_t in[4], float rgb[3])
{
    double d = (in[3] ? in[3] : 1) / 255.0;
    for (int k = 0; k < 3; k++)
        rgb[k] = (float)(pow(in[k] / 255.0, 2.2) / d);
}

#ifdef ENVL_NO_PNG
/* Built without libpng: the encoders below refuse (envl__format_built says why). */
envl_result envl__png_encode(const char *what, const uint8_t *px, int32_t w, int32_t h,
                             int channels, int srgb, uint8_t **out, size_t *size)
{
    (void)px, (void)w, (void)h, (void)channels, (void)srgb, (void)out, (void)size;
    return envl__format_built(what, "png");
}

static envl_result png_write(const char *path, const uint8_t *px, int32_t w, int32_t h,
                             int channels, int srgb)
{
    return envl__format_built(path, "png");
}
#else
typedef struct membuf {
    uint8_t *data;
    size_t size, cap;
    int failed;
} membuf;

static void write_cb(png_structp png, png_bytep data, png_size_t n)
{
    membuf *b = png_get_io_ptr(png);
    if (b->failed)
        return;
    if (b->size + n > b->cap) {
        size_t cap = b->cap ? b->cap : 65536;
        while (cap < b->size + n)
            cap *= 2;
        uint8_t *p = realloc(b->data, cap);
        if (!p) {
            b->failed = 1;
            return;
        }
        b->data = p;
        b->cap = cap;
    }
    memcpy(b->data + b->size, data, n);
    b->size += n;
}

static void flush_cb(png_structp png) { (void)png; }

static void error_cb(png_structp png, png_const_charp msg)
{
    envl__fail(ENVL_ERR_IO, "libpng: %s", msg);
    png_longjmp(png, 1);
}

static void warning_cb(png_structp png, png_const_charp msg) { (void)png, (void)msg; }

/* Encodes 8-bit pixels (channels 3 or 4) into memory (*out malloc'd); `what` names the output
 * in messages. */
envl_result envl__png_encode(const char *what, const uint8_t *px, int32_t w, int32_t h,
                             int channels, int srgb, uint8_t **out, size_t *size)
{
    membuf buf = {0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, error_cb, warning_cb);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot start the PNG encoder", what);
    }
    png_bytep *rows = malloc(sizeof(png_bytep) * (size_t)h);
    if (!rows) {
        png_destroy_write_struct(&png, &info);
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", what);
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(rows);
        free(buf.data);
        return envl__fail_prefix(ENVL_ERR_IO, what);
    }
    png_set_write_fn(png, &buf, write_cb, flush_cb);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8,
                 channels == 4 ? PNG_COLOR_TYPE_RGBA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* RGBM / RGBD data carries no colour chunk: its bytes are code values, not display colour. */
    if (srgb)
        png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    for (int32_t r = 0; r < h; r++)
        rows[r] = (png_bytep)(px + (size_t)r * w * channels);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    free(rows);
    if (buf.failed) {
        free(buf.data);
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory while encoding", what);
    }
    *out = buf.data;
    *size = buf.size;
    return ENVL_OK;
}

/* Encodes and writes the file atomically. */
static envl_result png_write(const char *path, const uint8_t *px, int32_t w, int32_t h,
                             int channels, int srgb)
{
    uint8_t *data;
    size_t size;
    envl_result rc = envl__png_encode(path, px, w, h, channels, srgb, &data, &size);
    if (rc)
        return rc;
    rc = envl_file_write_atomic(path, data, size);
    free(data);
    return rc;
}

#endif /* ENVL_NO_PNG */

static envl_result check_args(const char *path, const float *rgb, int32_t w, int32_t h)
{
    if (!path || !rgb || w <= 0 || h <= 0 || w > (1 << 20) || h > (1 << 20) ||
        (int64_t)w * h > ENVL_DEFAULT_MAX_PIXELS)
        return envl__fail(ENVL_ERR_ARGUMENT, "png: need a path, pixels and a sane size");
    return ENVL_OK;
}

envl_result envl_png_save_rgbm(const char *path, const float *rgb, int32_t w, int32_t h,
                               double range)
{
    envl_result rc = check_args(path, rgb, w, h);
    if (rc)
        return rc;
    if (!(range > 0))
        range = ENVL_RGBM_RANGE;
    size_t n = (size_t)w * h;
    uint8_t *px = malloc(4 * n);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    for (size_t i = 0; i < n; i++)
        envl_rgbm_encode(rgb + 3 * i, range, px + 4 * i);
    rc = png_write(path, px, w, h, 4, 0);
    free(px);
    return rc;
}

static double srgb_oetf(double v)
{
    v = v > 0 ? (v < 1 ? v : 1) : 0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

envl_result envl_png_save_srgb(const char *path, const float *rgb, int32_t w, int32_t h)
{
    envl_result rc = check_args(path, rgb, w, h);
    if (rc)
        return rc;
    size_t n = (size_t)w * h * 3;
    uint8_t *px = malloc(n);
    if (!px)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    for (size_t i = 0; i < n; i++)
        px[i] = (uint8_t)floor(255.0 * srgb_oetf(isfinite(rgb[i]) ? rgb[i] : 0) + 0.5);
    rc = png_write(path, px, w, h, 3, 1);
    free(px);
    return rc;
}

/* Reads an 8-bit RGB / RGBA PNG (for the tests; declared in internal.h). */
envl_result envl__png_read(const char *path, int32_t *w, int32_t *h, int32_t *channels,
                           uint8_t **px)
{
#ifdef ENVL_NO_PNG
    return envl__format_built(path, "png");
#else
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return envl__fail(ENVL_ERR_FORMAT, "%s: %s", path, img.message);
    int ch = (img.format & PNG_FORMAT_FLAG_ALPHA) ? 4 : 3;
    img.format = ch == 4 ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
    uint8_t *p = malloc(PNG_IMAGE_SIZE(img));
    if (!p) {
        png_image_free(&img);
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    }
    if (!png_image_finish_read(&img, NULL, p, 0, NULL)) {
        free(p);
        return envl__fail(ENVL_ERR_FORMAT, "%s: %s", path, img.message);
    }
    *w = (int32_t)img.width;
    *h = (int32_t)img.height;
    *channels = ch;
    *px = p;
    return ENVL_OK;
#endif
}
