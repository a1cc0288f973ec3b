/* Radiance picture files (.hdr / .pic): reader and writer.
 *
 * File layout (Radiance's src/common/header.c, resolu.c, color.c):
 *   header   text lines ending in '\n', up to an empty line. The first line is normally the
 *            signature "#?RADIANCE" (or "#?RGBE", or "#?" + any program name); legacy files
 *            have none and start straight with history lines. Lines we read: FORMAT=,
 *            EXPOSURE= (each one multiplies), PRIMARIES= (8 numbers). Others are history.
 *   resolution line  "-Y 512 +X 1024" and its seven siblings (see orientation below).
 *   scanlines        each in one of three codings, which may be mixed within a file:
 *            - adaptive RLE (1991+): bytes 2, 2, hi, lo with (hi << 8 | lo) = scanline length,
 *              8 <= length <= 32767; then the R, G, B and E planes one after the other, each a
 *              sequence of (count > 128: a run of count - 128 copies of the next byte) or
 *              (1 <= count <= 128: count literal bytes);
 *            - old RLE: 4-byte pixels, where a pixel (1, 1, 1, n) repeats the previous pixel
 *              n << shift times, shift starting at 0 and growing by 8 for each consecutive
 *              marker (Radiance's oldreadcolrs);
 *            - flat: 4-byte pixels (old RLE without markers).
 *   pixel value  (m + 0.5) * 2^(e - 136) for e > 0, else 0 (Radiance's colr_color).
 *
 * Everything read is distrusted: the header claims are checked against the limits and the
 * bytes present before anything is allocated, every run against what is left of its scanline
 * and of the buffer; failures name the file, the byte offset and what was expected.
 */
#include "internal.h"
#include "color.h"
#include "envmap_impl.h" /* envl__threads */

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HDR_MINELEN 8      /* adaptive RLE only for scanlines of 8 ..  */
#define HDR_MAXELEN 0x7fff /* .. 32767 pixels (Radiance's MINELEN / MAXELEN) */
#define HDR_MINRUN 4       /* writer: shortest run written as a run */

/* ---- colour: XYZE -> RGB ----------------------------------------------------------------
 *
 * What `ra_xyze -r` does (Radiance src/px/ra_xyze.c): rgb = compxyz2rgbWBmat(prims) * xyz,
 * then clipgamut(rgb, bright(rgb), CGAMUT_LOWER, black, white).
 *
 * compxyz2rgbmat (src/common/spec_rgb.c) is the inverse of the RGB -> XYZ matrix M whose
 * column i is S_i (x_i/y_i, 1, z_i/y_i), z = 1 - x - y, with S solving
 * M (1,1,1) = W = (x_w/y_w, 1, z_w/y_w): RGB white maps to the white point at Y = 1.
 * Radiance's default primaries (STDPRIMS, color.h): R (0.640, 0.330), G (0.290, 0.600),
 * B (0.150, 0.060), white (1/3, 1/3) (equal energy, "xyneu").
 * compxyz2rgbWBmat adds, when the white is not equal-energy, a von Kries adaptation from
 * equal-energy white to the primaries' white in Radiance's "Sharp" cone space:
 * WB = ivk * diag(vk W2 / vk W1) * vk, rgb = M^-1 WB xyz, with Radiance's vkmat / ivkmat.
 * The primaries are the file's PRIMARIES line when it has a usable one (all-zero, as written
 * by Photoshop, counts as none), else the defaults.
 * clipgamut with lower = black, upper = white and only the lower limit: brt = bright(rgb)
 * (Radiance's luminance of RGB for the default primaries, the Y row of M_std); if brt < 0 the
 * pixel becomes black, else the colour is desaturated towards the grey (brt, brt, brt) just
 * far enough that no channel is negative: rgb = v rgb + (1 - v) brt, v = min over negative
 * channels of brt / (brt - c). Brightness is preserved (the Y row sums to 1). */

static const double hdr_std_prims[8] = {0.640, 0.330, 0.290, 0.600, 0.150, 0.060,
                                        1.0 / 3.0, 1.0 / 3.0};
static const double hdr_vkmat[3][3] = {{1.2694, -0.0988, -0.1706},
                                       {-0.8364, 1.8006, 0.0357},
                                       {0.0297, -0.0315, 1.0018}};
static const double hdr_ivkmat[3][3] = {{0.8156, 0.0472, 0.1372},
                                        {0.3791, 0.5769, 0.0440},
                                        {-0.0123, 0.0167, 0.9955}};

/* XYZ of chromaticity (x, y) at Y = 1. */
static int white_xyz(double x, double y, double w[3])
{
    if (!(y > 1e-9) || !(x > 1e-9) || !(x + y < 1.0))
        return 0;
    w[0] = x / y;
    w[1] = 1.0;
    w[2] = (1.0 - x - y) / y;
    return 1;
}

/* ra_xyze -r's matrix for primaries p; 0 if they do not span a colour space. */
static int xyz_to_rgb_matrix(const double p[8], double out[3][3])
{
    double m[3][3];
    if (!envl__rgb_to_xyz_matrix(p, m) || !envl__invert3(m, out))
        return 0;
    if (fabs(p[6] - 1.0 / 3.0) > 1e-4 || fabs(p[7] - 1.0 / 3.0) > 1e-4) {
        double w1[3] = {0}, w2[3] = {0}, c1[3], c2[3], d[3][3] = {{0}};
        white_xyz(1.0 / 3.0, 1.0 / 3.0, w1);
        white_xyz(p[6], p[7], w2);
        for (int i = 0; i < 3; i++) {
            c1[i] = hdr_vkmat[i][0] * w1[0] + hdr_vkmat[i][1] * w1[1] + hdr_vkmat[i][2] * w1[2];
            c2[i] = hdr_vkmat[i][0] * w2[0] + hdr_vkmat[i][1] * w2[1] + hdr_vkmat[i][2] * w2[2];
            if (!(fabs(c1[i]) > 1e-9))
                return 0;
            d[i][i] = c2[i] / c1[i];
        }
        double wb[3][3];
        envl__mul3(hdr_ivkmat, d, wb);
        envl__mul3(wb, hdr_vkmat, wb);
        envl__mul3(out, wb, out);
    }
    return 1;
}

static void xyz_image_to_rgb(float *px, size_t n, const double mat[3][3])
{
    double mstd[3][3];
    envl__rgb_to_xyz_matrix(hdr_std_prims, mstd); /* cannot fail */
    const double bf[3] = {mstd[1][0], mstd[1][1], mstd[1][2]}; /* Radiance's CIE_rf/gf/bf */
    for (size_t i = 0; i < n; i++, px += 3) {
        double x = px[0], y = px[1], z = px[2], c[3];
        for (int k = 0; k < 3; k++)
            c[k] = mat[k][0] * x + mat[k][1] * y + mat[k][2] * z;
        double brt = bf[0] * c[0] + bf[1] * c[1] + bf[2] * c[2];
        if (brt < 0.0) {
            c[0] = c[1] = c[2] = 0.0;
        } else {
            double v = 1.0;
            for (int k = 0; k < 3; k++)
                if (c[k] < 0.0) {
                    double t = brt / (brt - c[k]);
                    if (t < v)
                        v = t;
                }
            if (v < 1.0)
                for (int k = 0; k < 3; k++) {
                    c[k] = v * c[k] + (1.0 - v) * brt;
                    if (c[k] < 0.0) /* rounding */
                        c[k] = 0.0;
                }
        }
        px[0] = (float)c[0];
        px[1] = (float)c[1];
        px[2] = (float)c[2];
    }
}

/* ---- reader -------------------------------------------------------------------------------- */

/* A window on the file: its bytes [base, base + size) at data (all of it when the file is in
 * memory; a few MiB of it when it is read from disk). Messages give file offsets. */
typedef struct hdr_reader {
    const uint8_t *data;
    size_t size;
    uint64_t base;
    const char *name;
} hdr_reader;

static int is_text_byte(uint8_t c)
{
    return c >= 0x20 ? c != 0x7f : (c == '\t' || c == '\r');
}

/* Copies line [b, e) without a trailing '\r' into buf (NUL-terminated); 0 if too long. */
static int copy_line(const uint8_t *b, const uint8_t *e, char *buf, size_t cap)
{
    if (e > b && e[-1] == '\r')
        e--;
    size_t n = (size_t)(e - b);
    if (n >= cap)
        return 0;
    memcpy(buf, b, n);
    buf[n] = '\0';
    return 1;
}

/* Parses `count` blank-separated numbers at the start of s. What follows them is ignored,
 * as Radiance's exposval / primsval (atof, sscanf) do. */
static int parse_numbers(const char *s, double *v, int count)
{
    for (int i = 0; i < count; i++) {
        char *end;
        errno = 0;
        v[i] = strtod(s, &end);
        if (end == s || errno == ERANGE || !isfinite(v[i]))
            return 0;
        if (*end && *end != ' ' && *end != '\t')
            return 0; /* "1.5x" is not a number */
        s = end;
    }
    return 1;
}

/* One axis field of the resolution line: sign, letter, blanks, decimal count. Returns the
 * position after it or NULL. Counts beyond 2^40 saturate (they are refused as too large). */
static const char *parse_axis(const char *s, char *sign, char *axis, int64_t *count)
{
    if ((s[0] != '+' && s[0] != '-') || (s[1] != 'X' && s[1] != 'Y'))
        return NULL;
    *sign = s[0];
    *axis = s[1];
    s += 2;
    if (*s != ' ' && *s != '\t')
        return NULL;
    while (*s == ' ' || *s == '\t')
        s++;
    int neg = 0;
    if (*s == '-' || *s == '+')
        neg = *s++ == '-';
    if (*s < '0' || *s > '9')
        return NULL;
    int64_t v = 0;
    while (*s >= '0' && *s <= '9') {
        if (v < ((int64_t)1 << 40))
            v = v * 10 + (*s - '0');
        s++;
    }
    *count = neg ? -v : v;
    return s;
}

/* Decodes one scanline of `len` pixels starting at *pos into the planes r, g, b, e; with
 * planes NULL it only checks the scanline and finds where it ends. `scan` is the scanline's
 * index in file order (for messages). */
static envl_result read_scanline(const hdr_reader *rd, size_t *pos, int32_t len, int32_t scan,
                                 uint8_t *const *planes)
{
    const uint8_t *d = rd->data;
    size_t p = *pos, size = rd->size;
    size_t at = (size_t)rd->base; /* file offset of d[0], for messages */
    if (len >= HDR_MINELEN && len <= HDR_MAXELEN && size - p >= 4 && d[p] == 2 &&
        d[p + 1] == 2 && !(d[p + 2] & 0x80)) {
        /* adaptive RLE */
        int32_t claimed = (int32_t)d[p + 2] << 8 | d[p + 3];
        if (claimed != len)
            return envl__fail(ENVL_ERR_FORMAT,
                              "%s: scanline %d at byte %zu: run-length header claims %d "
                              "pixels, the scanline has %d",
                              rd->name, (int)scan, at + p, (int)claimed, (int)len);
        p += 4;
        for (int c = 0; c < 4; c++) {
            uint8_t *q = planes ? planes[c] : NULL;
            int32_t j = 0;
            while (j < len) {
                if (p >= size)
                    return envl__fail(ENVL_ERR_FORMAT,
                                      "%s: truncated in scanline %d at byte %zu: expected a "
                                      "run-length code for pixel %d of component %d",
                                      rd->name, (int)scan, at + p, (int)j, c);
                unsigned code = d[p];
                if (code > 128) {
                    int32_t n = (int32_t)code - 128;
                    if (n > len - j)
                        return envl__fail(ENVL_ERR_FORMAT,
                                          "%s: RLE run of %d at byte %zu overruns the %d-pixel "
                                          "scanline %d (component %d, %d pixels left)",
                                          rd->name, (int)n, at + p, (int)len, (int)scan, c,
                                          (int)(len - j));
                    if (size - p < 2)
                        return envl__fail(ENVL_ERR_FORMAT,
                                          "%s: truncated in scanline %d at byte %zu: expected "
                                          "the value of a run",
                                          rd->name, (int)scan, at + p + 1);
                    if (q)
                        memset(q + j, d[p + 1], (size_t)n);
                    j += n;
                    p += 2;
                } else {
                    int32_t n = (int32_t)code;
                    if (n == 0)
                        return envl__fail(ENVL_ERR_FORMAT,
                                          "%s: zero-length RLE literal at byte %zu in scanline "
                                          "%d (component %d)",
                                          rd->name, at + p, (int)scan, c);
                    if (n > len - j)
                        return envl__fail(ENVL_ERR_FORMAT,
                                          "%s: RLE literal of %d at byte %zu overruns the "
                                          "%d-pixel scanline %d (component %d, %d pixels left)",
                                          rd->name, (int)n, at + p, (int)len, (int)scan, c,
                                          (int)(len - j));
                    p++;
                    if (size - p < (size_t)n)
                        return envl__fail(ENVL_ERR_FORMAT,
                                          "%s: truncated in scanline %d at byte %zu: expected "
                                          "%d more bytes, %zu left",
                                          rd->name, (int)scan, at + p, (int)n, size - p);
                    if (q)
                        memcpy(q + j, d + p, (size_t)n);
                    j += n;
                    p += (size_t)n;
                }
            }
        }
        *pos = p;
        return ENVL_OK;
    }
    /* old RLE / flat */
    uint8_t *r = planes ? planes[0] : NULL, *g = planes ? planes[1] : NULL,
            *b = planes ? planes[2] : NULL, *e = planes ? planes[3] : NULL;
    int32_t j = 0;
    unsigned shift = 0;
    while (j < len) {
        if (size - p < 4)
            return envl__fail(ENVL_ERR_FORMAT,
                              "%s: truncated in scanline %d at byte %zu: expected 4 bytes for "
                              "pixel %d, %zu left",
                              rd->name, (int)scan, at + p, (int)j, size - p);
        const uint8_t *s = d + p;
        if (s[0] == 1 && s[1] == 1 && s[2] == 1) {
            if (j == 0)
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: old-style repeat marker at byte %zu starts scanline %d: "
                                  "there is no previous pixel to repeat",
                                  rd->name, at + p, (int)scan);
            /* shift is capped at 40: any non-zero count << 40 exceeds every scanline. */
            uint64_t n = (uint64_t)s[3] << shift;
            if (n > (uint64_t)(len - j))
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: old-style run of %llu at byte %zu overruns the %d-pixel "
                                  "scanline %d (%d pixels left)",
                                  rd->name, (unsigned long long)n, at + p, (int)len, (int)scan,
                                  (int)(len - j));
            if (n && r) {
                memset(r + j, r[j - 1], (size_t)n);
                memset(g + j, g[j - 1], (size_t)n);
                memset(b + j, b[j - 1], (size_t)n);
                memset(e + j, e[j - 1], (size_t)n);
            }
            j += (int32_t)n;
            if (shift < 40)
                shift += 8;
        } else {
            if (r) {
                r[j] = s[0];
                g[j] = s[1];
                b[j] = s[2];
                e[j] = s[3];
            }
            j++;
            shift = 0;
        }
        p += 4;
    }
    *pos = p;
    return ENVL_OK;
}

/* Reads the header and the resolution line. On success *pos is the first pixel byte. */
typedef struct hdr_header {
    int xyze;
    double exposure;
    int has_primaries_line;   /* a PRIMARIES line was read (even all-zero) */
    double primaries[8];
    int ymajor, xdecr, ydecr;
    int64_t xres, yres;
} hdr_header;

static envl_result read_header(const hdr_reader *rd, size_t *pos, hdr_header *hd)
{
    const uint8_t *d = rd->data;
    size_t size = rd->size, p = 0;
    memset(hd, 0, sizeof *hd);
    hd->exposure = 1.0;
    if (size == 0)
        return envl__fail(ENVL_ERR_FORMAT, "%s: empty file: not a Radiance file", rd->name);
    int signature = size >= 2 && d[0] == '#' && d[1] == '?';
    int line_no = 0;
    char buf[512];
    for (;;) {
        const uint8_t *nl = p < size ? memchr(d + p, '\n', size - p) : NULL;
        size_t end = nl ? (size_t)(nl - d) : size;
        for (size_t i = p; i < end; i++)
            if (!is_text_byte(d[i])) {
                if (!signature)
                    return envl__fail(ENVL_ERR_FORMAT,
                                      "%s: not a Radiance file: byte 0x%02x at byte %zu in what "
                                      "would be its header (no \"#?RADIANCE\" signature)",
                                      rd->name, d[i], i);
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: header line %d contains the binary byte 0x%02x at byte "
                                  "%zu: expected text up to an empty line",
                                  rd->name, line_no + 1, d[i], i);
            }
        if (!nl) {
            if (!signature)
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: not a Radiance file: no \"#?RADIANCE\" signature and no "
                                  "empty line ending a header in its %zu bytes",
                                  rd->name, size);
            return envl__fail(ENVL_ERR_FORMAT,
                              "%s: truncated in the header at byte %zu: expected the empty line "
                              "that ends it",
                              rd->name, size);
        }
        line_no++;
        const uint8_t *lb = d + p, *le = d + end;
        size_t line_start = p;
        p = end + 1;
        if (le == lb || (le - lb == 1 && lb[0] == '\r'))
            break; /* end of header */
        if (le - lb >= 7 && !memcmp(lb, "FORMAT=", 7)) {
            if (!copy_line(lb + 7, le, buf, sizeof buf))
                return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: FORMAT line at byte %zu too long",
                                  rd->name, line_start);
            char *s = buf;
            while (*s == ' ' || *s == '\t')
                s++;
            size_t n = strcspn(s, " \t");
            if (n == 15 && !memcmp(s, "32-bit_rle_rgbe", 15))
                hd->xyze = 0;
            else if (n == 15 && !memcmp(s, "32-bit_rle_xyze", 15))
                hd->xyze = 1;
            else
                return envl__fail(ENVL_ERR_UNSUPPORTED,
                                  "%s: FORMAT=%.*s at byte %zu: only 32-bit_rle_rgbe and "
                                  "32-bit_rle_xyze are supported",
                                  rd->name, (int)(n > 64 ? 64 : n), s, line_start);
        } else if (le - lb >= 9 && !memcmp(lb, "EXPOSURE=", 9)) {
            double v;
            if (!copy_line(lb + 9, le, buf, sizeof buf) || !parse_numbers(buf, &v, 1) ||
                !(v > 0.0))
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: header line %d at byte %zu: expected EXPOSURE= and one "
                                  "positive number",
                                  rd->name, line_no, line_start);
            hd->exposure *= v;
            if (!isfinite(hd->exposure) || !(hd->exposure > 0.0))
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: header line %d at byte %zu: the product of the EXPOSURE "
                                  "values is out of range",
                                  rd->name, line_no, line_start);
        } else if (le - lb >= 10 && !memcmp(lb, "PRIMARIES=", 10)) {
            if (!copy_line(lb + 10, le, buf, sizeof buf) ||
                !parse_numbers(buf, hd->primaries, 8))
                return envl__fail(ENVL_ERR_FORMAT,
                                  "%s: header line %d at byte %zu: expected PRIMARIES= and 8 "
                                  "numbers (xy of red, green, blue, white)",
                                  rd->name, line_no, line_start);
            hd->has_primaries_line = 1;
        }
    }
    /* resolution line */
    size_t rstart = p;
    const uint8_t *nl = p < size ? memchr(d + p, '\n', size - p) : NULL;
    if (!nl) {
        if (!signature && size - p > 64)
            return envl__fail(ENVL_ERR_FORMAT,
                              "%s: not a Radiance file: no resolution line after the header "
                              "at byte %zu",
                              rd->name, p);
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: truncated at byte %zu: expected a resolution line such as "
                          "\"-Y 512 +X 1024\" ending in a newline",
                          rd->name, size);
    }
    char sa, aa, sb, ab;
    int64_t na, nb;
    const char *s = NULL;
    if (copy_line(d + p, nl, buf, 128)) {
        s = parse_axis(buf, &sa, &aa, &na);
        if (s && (*s == ' ' || *s == '\t')) {
            while (*s == ' ' || *s == '\t')
                s++;
            s = parse_axis(s, &sb, &ab, &nb);
        } else {
            s = NULL;
        }
        if (s) {
            while (*s == ' ' || *s == '\t')
                s++;
            if (*s || aa == ab)
                s = NULL;
        }
    }
    if (!s) {
        if (!signature)
            return envl__fail(ENVL_ERR_FORMAT,
                              "%s: not a Radiance file: expected a resolution line such as "
                              "\"-Y 512 +X 1024\" at byte %zu",
                              rd->name, rstart);
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: bad resolution line at byte %zu: expected \"-Y <height> +X "
                          "<width>\" or one of its orientation variants",
                          rd->name, rstart);
    }
    *pos = (size_t)(nl - d) + 1;
    hd->ymajor = aa == 'Y';
    int64_t nx = hd->ymajor ? nb : na, ny = hd->ymajor ? na : nb;
    char sx = hd->ymajor ? sb : sa, sy = hd->ymajor ? sa : sb;
    hd->xdecr = sx == '-';
    hd->ydecr = sy == '-';
    hd->xres = nx;
    hd->yres = ny;
    if (nx <= 0 || ny <= 0)
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: resolution line at byte %zu gives %lld x %lld pixels: both must "
                          "be at least 1",
                          rd->name, rstart, (long long)nx, (long long)ny);
    return ENVL_OK;
}

/* Where the reader takes the file's bytes from: the whole file in memory (tests, fuzzers), or
 * an open file read by offset in windows (envl__read_hdr_file: no copy of the whole file). */
typedef struct hdr_source {
    const uint8_t *mem;       /* the whole file, or NULL: read from `file` */
    const envl_infile *file;
    uint64_t size;
    const char *name;
} hdr_source;

#define HDR_WINDOW ((size_t)4 << 20) /* pass 1 reads the file in windows of 4 MiB .. */
#define HDR_BATCH ((size_t)1 << 20)  /* .. pass 2 in batches of scanlines of about 1 MiB */

/* rd = the file's bytes [off, off + n) (fewer at its end; in memory always all of them up to
 * the end, as a view). From a file they are read into *buf, grown to n bytes. */
static envl_result source_window(const hdr_source *src, uint64_t off, size_t n, uint8_t **buf,
                                 size_t *cap, hdr_reader *rd)
{
    if (off > src->size)
        off = src->size;
    if (src->mem || n > src->size - off)
        n = (size_t)(src->size - off);
    rd->base = off;
    rd->size = n;
    rd->name = src->name;
    if (src->mem) {
        rd->data = src->mem + off;
        return ENVL_OK;
    }
    if (n > *cap) {
        free(*buf);
        *cap = 0;
        if (!(*buf = malloc(n ? n : 1)))
            return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate a read window of %zu bytes",
                              src->name, n);
        *cap = n;
    }
    rd->data = *buf;
    return n ? envl__infile_read(src->file, off, *buf, n) : ENVL_OK;
}

/* The window ends before the file does: a parse that ran out of bytes may need a wider one. */
static int window_short(const hdr_reader *rd, const hdr_source *src)
{
    return rd->base + rd->size < src->size;
}

typedef struct decode_job {
    const hdr_source *src;
    const uint64_t *starts;   /* file offset of each scanline (pass 1), and of the end */
    int32_t len, w, h, ymajor, xdecr, ydecr;
    float *px;
    float scale[256];         /* 2^(e-136) for e > 0, 0 for e = 0 (see read_hdr) */
    pthread_mutex_t lock;     /* guards the failure below */
    int64_t failed_scan;      /* the first scanline (file order) that failed, or -1 */
    envl_result rc;
    char msg[512];            /* its message (workers' messages are thread-local) */
} decode_job;

static void job_fail(decode_job *j, int64_t scan, envl_result rc)
{
    pthread_mutex_lock(&j->lock);
    if (j->failed_scan < 0 || scan < j->failed_scan) {
        j->failed_scan = scan;
        j->rc = rc;
        snprintf(j->msg, sizeof j->msg, "%s", envl_last_error());
    }
    pthread_mutex_unlock(&j->lock);
}

/* Pass 2 of the reader: scanlines [begin, end) decoded, converted and put in place (see the
 * orientation notes below), in batches read from the file. */
static void decode_scanlines(void *ctx, int64_t begin, int64_t end)
{
    decode_job *j = ctx;
    int32_t len = j->len, w = j->w, h = j->h;
    uint8_t *mem = malloc((size_t)len * 4), *buf = NULL;
    size_t cap = 0;
    if (!mem) {
        job_fail(j, begin, envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate a scanline of %d "
                                      "pixels", j->src->name, (int)len));
        return;
    }
    uint8_t *planes[4] = {mem, mem + len, mem + 2 * (size_t)len, mem + 3 * (size_t)len};
    const uint8_t *pr = planes[0], *pg = planes[1], *pb = planes[2], *pe = planes[3];
    const float *scale = j->scale;
    hdr_reader rd;
    for (int64_t s = begin, t; s < end; s = t) {
        for (t = s + 1; t < end && j->starts[t + 1] - j->starts[s] <= HDR_BATCH; t++)
            ;
        envl_result rc = source_window(j->src, j->starts[s], (size_t)(j->starts[t] - j->starts[s]),
                                       &buf, &cap, &rd);
        if (rc) {
            job_fail(j, s, rc);
            break;
        }
        for (int64_t k = s; k < t; k++) {
            size_t pos = (size_t)(j->starts[k] - rd.base);
            /* pass 1 checked it; a failure here means the file changed in between */
            if ((rc = read_scanline(&rd, &pos, len, (int32_t)k, planes))) {
                job_fail(j, k, rc);
                t = end;
                break;
            }
            /* where pixel i = 0 of this scanline goes, and the step between pixels */
            ptrdiff_t base, step;
            if (j->ymajor) {
                int32_t row = j->ydecr ? (int32_t)k : h - 1 - (int32_t)k;
                base = (ptrdiff_t)row * w + (j->xdecr ? w - 1 : 0);
                step = j->xdecr ? -1 : 1;
            } else {
                int32_t col = j->xdecr ? w - 1 - (int32_t)k : (int32_t)k;
                base = (ptrdiff_t)(j->ydecr ? 0 : h - 1) * w + col;
                step = j->ydecr ? (ptrdiff_t)w : -(ptrdiff_t)w;
            }
            if (step == 1) {
                float *q = j->px + 3 * base;
                for (int32_t i = 0; i < len; i++, q += 3) {
                    float f = scale[pe[i]];
                    q[0] = ((float)pr[i] + 0.5f) * f;
                    q[1] = ((float)pg[i] + 0.5f) * f;
                    q[2] = ((float)pb[i] + 0.5f) * f;
                }
            } else {
                ptrdiff_t at = base;
                for (int32_t i = 0; i < len; i++, at += step) {
                    float f = scale[pe[i]], *q = j->px + 3 * at;
                    q[0] = ((float)pr[i] + 0.5f) * f;
                    q[1] = ((float)pg[i] + 0.5f) * f;
                    q[2] = ((float)pb[i] + 0.5f) * f;
                }
            }
        }
    }
    free(buf);
    free(mem);
}

/* Orientation. Radiance (src/common/resolu.h, resolu.c pix2loc): the picture's true frame
 * has its origin at the lower left, x to the right, y up; xr and yr are the counts after "X"
 * and "Y" whatever their order, so the displayed image is always xr wide and yr high. The
 * axis named first varies slowest: "-Y ... +X ..." (YMAJOR) stores rows, "±X ... ±Y ..."
 * stores columns. For scanline s (file order) and position i within it, pix2loc gives
 *   YMAJOR:  x = i, y = s;   otherwise x = s, y = i;
 *   then x -> xr-1-x if X is '-' (XDECR), y -> yr-1-y if Y is '-' (YDECR).
 * Our row 0 is the top: row = yr-1-y, column = x. Hence
 *   YMAJOR:  row = YDECR ? s : yr-1-s,  column = XDECR ? xr-1-i : i   (scanline = a row)
 *   XMAJOR:  column = XDECR ? xr-1-s : s,  row = YDECR ? i : yr-1-i   (scanline = a column)
 * so "-Y H +X W" is rows top to bottom, left to right; "+X W -Y H" columns left to right,
 * each top to bottom. */
static envl_result read_hdr(const hdr_source *src, const envl_limits *lim, envl_image *out)
{
    memset(out, 0, sizeof *out);
    const char *name = src->name;
    uint8_t *wbuf = NULL; /* pass 1's window, when reading from a file */
    size_t wcap = 0;
    hdr_reader rd;
    hdr_header hd;
    size_t pos = 0;
    envl_result rc;
    /* The header in a window of 64 KiB, doubled while a parse runs out of bytes. A parse that
     * succeeds in a window read only bytes in it, so it is the parse of the whole file. */
    for (size_t want = (size_t)64 << 10;; want *= 2) {
        if ((rc = source_window(src, 0, want, &wbuf, &wcap, &rd)))
            break;
        rc = read_header(&rd, &pos, &hd);
        if (!rc || !window_short(&rd, src))
            break;
    }
    if (rc) {
        free(wbuf);
        return rc;
    }

    double xyz2rgb[3][3];
    int prims_nonzero = 0;
    if (hd.has_primaries_line)
        for (int i = 0; i < 8; i++)
            prims_nonzero |= hd.primaries[i] != 0.0;
    if (hd.xyze && !xyz_to_rgb_matrix(prims_nonzero ? hd.primaries : hdr_std_prims, xyz2rgb)) {
        free(wbuf);
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: the PRIMARIES line does not describe a colour space, so the "
                          "XYZE pixels cannot be converted to RGB",
                          name);
    }

    if (hd.xres > INT32_MAX || hd.yres > INT32_MAX) {
        free(wbuf);
        return envl__fail(ENVL_ERR_LIMIT, "%s: image size %lld x %lld exceeds the limit of %lld "
                          "pixels",
                          name, (long long)hd.xres, (long long)hd.yres,
                          (long long)(lim && lim->max_pixels > 0 ? lim->max_pixels
                                                                 : ENVL_DEFAULT_MAX_PIXELS));
    }
    int32_t w = (int32_t)hd.xres, h = (int32_t)hd.yres;
    int32_t len = hd.ymajor ? w : h;      /* pixels per scanline */
    int32_t nscans = hd.ymajor ? h : w;
    /* Limit first, then the bytes present: every scanline takes at least 4 bytes. */
    int64_t max = lim && lim->max_pixels > 0 ? lim->max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    if ((int64_t)w * h > max) {
        free(wbuf);
        return envl__fail(ENVL_ERR_LIMIT,
                          "%s: image size %d x %d = %lld pixels exceeds the limit of %lld pixels",
                          name, (int)w, (int)h, (long long)w * h, (long long)max);
    }
    if (src->size - pos < (uint64_t)nscans * 4u) {
        free(wbuf);
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: truncated: %d scanlines need at least %llu bytes, %llu left after "
                          "the resolution line at byte %zu",
                          name, (int)nscans, (unsigned long long)nscans * 4u,
                          (unsigned long long)(src->size - pos), pos);
    }
    /* Pass 1: where each scanline starts. Every scanline is checked here exactly as pass 2
     * reads it, so errors are found and named in file order, before the image is allocated.
     * From a file: in windows, moved on (or doubled, for a scanline longer than the window)
     * when a scanline runs past a window's end that is not the file's. */
    uint64_t *starts = malloc(sizeof(uint64_t) * ((size_t)nscans + 1));
    if (!starts) {
        free(wbuf);
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %d scanline offsets", name,
                          (int)nscans);
    }
    uint64_t at = pos;
    size_t want = HDR_WINDOW;
    rc = source_window(src, at, want, &wbuf, &wcap, &rd);
    for (int32_t s = 0; s < nscans && !rc;) {
        size_t p = (size_t)(at - rd.base);
        rc = read_scanline(&rd, &p, len, s, NULL);
        if (rc && window_short(&rd, src)) {
            if (at == rd.base)
                want *= 2; /* the scanline alone is longer than the window */
            rc = source_window(src, at, want, &wbuf, &wcap, &rd);
            continue;
        }
        starts[s++] = at;
        at = rd.base + p;
    }
    starts[nscans] = at;
    free(wbuf);
    if (!rc)
        rc = envl__image_alloc(out, w, h, lim, name);
    if (rc) {
        free(starts);
        return rc;
    }
    /* Pass 2: scanlines decoded in parallel, each into its own place (the result does not
     * depend on the thread count). Small images stay on this thread. */
    decode_job job = {.src = src, .starts = starts, .len = len, .w = w, .h = h,
                      .ymajor = hd.ymajor, .xdecr = hd.xdecr, .ydecr = hd.ydecr, .px = out->px,
                      .failed_scan = -1};
    pthread_mutex_init(&job.lock, NULL);
    /* 2^(e-136) for e > 0, 0 for e = 0: exact in float for every e (the smallest, 2^-135,
     * is a subnormal, and (m + 0.5) * 2^-135 = (2m + 1) 2^-136 still fits). */
    for (int e = 1; e < 256; e++)
        job.scale[e] = ldexpf(1.0f, e - 136);
    envl__parallel_for(nscans,
                       (int64_t)w * h >= 65536 ? envl__threads(lim ? lim->threads : 0) : 1,
                       decode_scanlines, &job);
    pthread_mutex_destroy(&job.lock);
    free(starts);
    rc = job.failed_scan >= 0 ? job.rc : ENVL_OK;
    /* From a file: bytes that differ between the passes, or a file rewritten in place while
     * it was read, are an error, not a mixture of two files. */
    if (src->file && (rc == ENVL_OK || rc == ENVL_ERR_FORMAT) && envl__infile_unchanged(src->file))
        rc = ENVL_ERR_IO;
    else if (rc)
        envl__fail(rc, "%s", job.msg);
    if (rc) {
        envl__image_free(out);
        return rc;
    }
    if (hd.xyze)
        xyz_image_to_rgb(out->px, (size_t)w * (size_t)h, xyz2rgb);
    snprintf(out->meta.format, sizeof out->meta.format, "hdr");
    out->meta.channels = 3;
    out->meta.exposure = hd.exposure;
    out->meta.has_primaries = prims_nonzero;
    for (int i = 0; i < 8; i++)
        out->meta.primaries[i] = (float)hd.primaries[i];
    /* (m + 0.5) 2^(e - 136) <= 255.5 x 2^119 < FLT_MAX: finite and positive. XYZE's matrix can
     * push a value past FLT_MAX or below 0, so its pixels are checked on load as any file's. */
    out->meta.finite_nonnegative = !hd.xyze;
    return ENVL_OK;
}

envl_result envl__read_hdr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{
    hdr_source src = {data ? data : (const uint8_t *)"", NULL, data ? size : 0,
                      name ? name : "<memory>"};
    return read_hdr(&src, lim, out);
}

envl_result envl__read_hdr_file(const envl_infile *f, const envl_limits *lim, envl_image *out)
{
    hdr_source src = {NULL, f, f->size, f->path};
    return read_hdr(&src, lim, out);
}

/* ---- writer -------------------------------------------------------------------------------- */

/* Radiance's setcolr: d = max channel; d <= 1e-32 -> all zero; else d = frexp(d, &e),
 * mantissas = channel * (frac * 256 / d) truncated, exponent byte e + 128. Decoding with
 * (m + 0.5) 2^(E - 136) then errs by at most half a mantissa step, 2^(e-9) <= 2^-8 d.
 * Negative and NaN channels are written as 0; +Inf and values whose exponent would not fit
 * (max >= 2^127) are clamped to the largest RGBE value (mantissa 255, exponent byte 255).
 * envl_image_save refuses such pixels before it gets here (imageio.c, rgbe_holds). */
static void float_to_rgbe(const float *c, uint8_t out[4])
{
    double v[3];
    for (int i = 0; i < 3; i++)
        v[i] = c[i] > 0.0f ? (double)c[i] : 0.0; /* NaN and negatives fail the test */
    double d = v[0] > v[1] ? v[0] : v[1];
    if (v[2] > d)
        d = v[2];
    if (d <= 1e-32) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    int e;
    double f;
    if (d >= 0x1p127) { /* includes +Inf */
        e = 127;
        f = 0x1p-119;
    } else {
        f = frexp(d, &e) * 256.0 / d;
    }
    for (int i = 0; i < 3; i++) {
        double m = v[i] * f;
        out[i] = m >= 255.0 ? 255 : (uint8_t)m;
    }
    out[3] = (uint8_t)(e + 128);
}

/* Adaptive RLE of one component plane (stride 4 in `rgbe`), Radiance's fwritecolrs rules
 * simplified: a run of >= HDR_MINRUN equal bytes (up to 127) is written as a run, everything
 * between runs as literals of up to 128 bytes. Returns the bytes written to `o`. */
static size_t rle_plane(const uint8_t *rgbe, int32_t len, uint8_t *o)
{
    size_t n = 0;
    int32_t j = 0;
    while (j < len) {
        int32_t beg = j, run = 0;
        while (beg < len) {
            run = 1;
            while (run < 127 && beg + run < len && rgbe[4 * (beg + run)] == rgbe[4 * beg])
                run++;
            if (run >= HDR_MINRUN)
                break;
            beg += run;
        }
        while (j < beg) {
            int32_t k = beg - j > 128 ? 128 : beg - j;
            o[n++] = (uint8_t)k;
            for (int32_t i = 0; i < k; i++)
                o[n++] = rgbe[4 * (j + i)];
            j += k;
        }
        if (beg < len) {
            o[n++] = (uint8_t)(128 + run);
            o[n++] = rgbe[4 * beg];
            j = beg + run;
        }
    }
    return n;
}

envl_result envl__write_hdr(const char *path, const float *rgb, int32_t w, int32_t h)
{
    if (!path || !rgb || w <= 0 || h <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: write .hdr: need pixels and a positive size "
                          "(got %d x %d)",
                          path ? path : "(null)", (int)w, (int)h);
    int rle = w >= HDR_MINELEN && w <= HDR_MAXELEN;
    /* scanline in RGBE, plus the encoded scanline: at worst 4 + 4 (w + ceil(w / 128)) */
    size_t cap = 4 + 4 * ((size_t)w + (size_t)w / 128 + 1);
    uint8_t *line = malloc((size_t)w * 4);
    uint8_t *enc = rle ? malloc(cap) : NULL;
    if (!line || (rle && !enc)) {
        free(line);
        free(enc);
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate a scanline of %d pixels", path,
                          (int)w);
    }
    FILE *f = envl__io_fault() ? NULL : fopen(path, "wb");
    if (!f) {
        int err = errno;
        free(line);
        free(enc);
        return envl__fail(ENVL_ERR_IO, "%s: cannot write: %s", path, strerror(err));
    }
    int err = 0;
    errno = 0;
    if (envl__io_fault() ||
        fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", (int)h, (int)w) < 0)
        err = errno ? errno : EIO;
    for (int32_t r = 0; r < h && !err; r++) {
        const float *src = rgb + (size_t)r * (size_t)w * 3;
        for (int32_t i = 0; i < w; i++)
            float_to_rgbe(src + 3 * (size_t)i, line + 4 * (size_t)i);
        const uint8_t *bytes = line;
        size_t n = (size_t)w * 4;
        if (rle) {
            enc[0] = 2;
            enc[1] = 2;
            enc[2] = (uint8_t)(w >> 8);
            enc[3] = (uint8_t)(w & 255);
            n = 4;
            for (int c = 0; c < 4; c++)
                n += rle_plane(line + c, w, enc + n);
            bytes = enc;
        }
        errno = 0;
        if (envl__io_fault() || fwrite(bytes, 1, n, f) != n)
            err = errno ? errno : EIO;
    }
    free(line);
    free(enc);
    return envl__close_written(f, path, err);
}
