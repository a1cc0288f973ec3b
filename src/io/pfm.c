/* Portable float map (PFM): "PF" (RGB) or "Pf" (grey), width, height, a scale whose sign
 * gives the byte order (negative: little-endian) — its magnitude is ignored, as most readers
 * do — then one whitespace byte and raw 32-bit floats, rows from the BOTTOM of the image up. */
#include "internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Next whitespace-separated token of the header: [*pos, end); returns its length (0 = none).
 * Tokens are short; anything longer than 63 bytes is malformed. */
static size_t header_token(const uint8_t *data, size_t size, size_t *pos, char tok[64])
{
    size_t i = *pos;
    while (i < size && (data[i] == ' ' || data[i] == '\t' || data[i] == '\r' || data[i] == '\n'))
        i++;
    size_t n = 0;
    while (i < size && !(data[i] == ' ' || data[i] == '\t' || data[i] == '\r' || data[i] == '\n')) {
        if (n >= 63)
            return 0;
        tok[n++] = (char)data[i++];
    }
    tok[n] = '\0';
    *pos = i;
    return n;
}

/* The header token as a message may show it (a terminal must not receive escape sequences):
 * its first 32 bytes, printable ASCII as is, other bytes as \xHH, "..." when longer. */
static void printable(const char *tok, char out[4 * 32 + 4])
{
    size_t o = 0, i = 0;
    for (; tok[i] && i < 32; i++) {
        unsigned char c = (unsigned char)tok[i];
        if (c >= 0x20 && c < 0x7f && c != '\\')
            out[o++] = (char)c;
        else
            o += (size_t)snprintf(out + o, 5, "\\x%02x", c);
    }
    if (tok[i])
        memcpy(out + o, "...", 3), o += 3;
    out[o] = '\0';
}

static int parse_int(const char *s, long *v)
{
    char *end;
    errno = 0;
    *v = strtol(s, &end, 10);
    return *s && !*end && errno == 0;
}

static float read_float(const uint8_t *p, int little)
{
    uint32_t u = little ? (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                              (uint32_t)p[3] << 24
                        : (uint32_t)p[3] | (uint32_t)p[2] << 8 | (uint32_t)p[1] << 16 |
                              (uint32_t)p[0] << 24;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

envl_result envl__read_pfm(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{
    memset(out, 0, sizeof *out);
    char tok[64];
    size_t pos = 0;
    if (!header_token(data, size, &pos, tok) || (strcmp(tok, "PF") && strcmp(tok, "Pf")))
        return envl__fail(ENVL_ERR_FORMAT, "%s: not a PFM file (expected \"PF\" or \"Pf\")",
                          name);
    int channels = tok[1] == 'F' ? 3 : 1;
    long w, h;
    if (!header_token(data, size, &pos, tok) || !parse_int(tok, &w) ||
        !header_token(data, size, &pos, tok) || !parse_int(tok, &h))
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM header: expected width and height near "
                          "byte %zu", name, pos);
    if (w <= 0 || h <= 0 || w > INT32_MAX || h > INT32_MAX)
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM size %ld x %ld: both must be at least 1",
                          name, w, h);
    if (!header_token(data, size, &pos, tok))
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM header: expected the scale at byte %zu",
                          name, pos);
    char *end;
    double scale = strtod(tok, &end);
    if (*end || !isfinite(scale) || scale == 0.0) {
        char shown[4 * 32 + 4];
        printable(tok, shown);
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM scale '%s' must be a non-zero number", name,
                          shown);
    }
    if (pos >= size || !(data[pos] == '\n' || data[pos] == ' ' || data[pos] == '\r' ||
                         data[pos] == '\t'))
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM header: expected one whitespace byte after "
                          "the scale at byte %zu", name, pos);
    pos++;
    /* Check the size against the limit and the bytes present before allocating. */
    envl_limits deflim = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};
    const envl_limits *l = lim ? lim : &deflim;
    int64_t max = l->max_pixels > 0 ? l->max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    if ((int64_t)w * h > max)
        return envl__fail(ENVL_ERR_LIMIT, "%s: image size %ld x %ld exceeds the limit of %lld "
                          "pixels", name, w, h, (long long)max);
    uint64_t need = (uint64_t)w * (uint64_t)h * (uint64_t)channels * 4u;
    if (size - pos < need)
        return envl__fail(ENVL_ERR_FORMAT, "%s: PFM data truncated: %zu bytes after the header at "
                          "byte %zu, %llu expected", name, size - pos, pos,
                          (unsigned long long)need);
    envl_result rc = envl__image_alloc(out, (int32_t)w, (int32_t)h, l, name);
    if (rc)
        return rc;
    int little = scale < 0;
    const uint8_t *p = data + pos;
    for (long r = h - 1; r >= 0; r--) /* bottom row first */
        for (long c = 0; c < w; c++) {
            float *q = out->px + 3 * ((size_t)r * w + c);
            if (channels == 3) {
                q[0] = read_float(p, little);
                q[1] = read_float(p + 4, little);
                q[2] = read_float(p + 8, little);
                p += 12;
            } else {
                q[0] = q[1] = q[2] = read_float(p, little);
                p += 4;
            }
        }
    snprintf(out->meta.format, sizeof out->meta.format, "pfm");
    out->meta.channels = channels;
    out->meta.exposure = 1.0;
    return ENVL_OK;
}

envl_result envl__write_pfm(const char *path, const float *rgb, int32_t w, int32_t h)
{
    uint8_t *row = malloc((size_t)w * 12);
    if (!row)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    FILE *f = envl__io_fault() ? NULL : fopen(path, "wb");
    if (!f) {
        int err = errno;
        free(row);
        return envl__fail(ENVL_ERR_IO, "%s: cannot write: %s", path, strerror(err));
    }
    int err = 0;
    errno = 0;
    if (envl__io_fault() || fprintf(f, "PF\n%d %d\n-1.0\n", (int)w, (int)h) < 0)
        err = errno ? errno : EIO;
    for (int32_t r = h - 1; r >= 0 && !err; r--) {
        const float *s = rgb + (size_t)r * w * 3;
        for (size_t i = 0; i < (size_t)w * 3; i++) {
            uint32_t u;
            memcpy(&u, &s[i], 4);
            row[4 * i] = (uint8_t)u;
            row[4 * i + 1] = (uint8_t)(u >> 8);
            row[4 * i + 2] = (uint8_t)(u >> 16);
            row[4 * i + 3] = (uint8_t)(u >> 24);
        }
        errno = 0;
        if (envl__io_fault() || fwrite(row, 12, (size_t)w, f) != (size_t)w)
            err = errno ? errno : EIO;
    }
    free(row);
    return envl__close_written(f, path, err);
}
