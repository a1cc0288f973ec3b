/* OpenEXR reader and writer through the OpenEXR C API (OpenEXRCore, <openexr.h>).
 *
 * Reading: the file reaches the library through a read_fn / size_fn stream, from memory (so a
 * fuzzer can drive it) or from the open file by offset (no copy of the whole file; its chunks
 * are decoded in parallel, see "the chunks" below). One part is chosen (by name, or the first
 * with colour channels), its level-0 chunks are decoded by the library's own decoder, straight
 * into the output (row 0 = top of the display window) when a chunk lies inside the display
 * window, through a per-chunk scratch buffer otherwise. DWAA / DWAB parts, which OpenEXRCore 3.1
 * cannot decode, are decoded by the OpenEXR C++ library (exr_dwa.cpp) in bands of one chunk's
 * rows, placed the same way. Chroma-subsampled channels (Y/RY/BY)
 * are decoded into sample planes and upsampled bilinearly afterwards. Colours in another
 * primaries' space (the `chromaticities` attribute) are converted to linear Rec.709.
 *
 * Writing: one scanline part, channels B, G, R, ZIP, float or half, the `envmap` attribute when
 * the pixels are an OpenEXR lat-long or cube map, through the library's encoder, to a file descriptor through a write_fn.
 *
 * Every library message goes to our error handler, which keeps the first detailed message
 * for our own error text; nothing is printed on stderr.
 */
#include "internal.h"
#include "color.h"
#include "exr_dwa.h"

#include <openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- the library's messages and our streams ---------------------------------------------- */

typedef struct exr_stream {
    const uint8_t *data;    /* reading: the whole file, or NULL: read from `file` by offset */
    size_t size;
    const envl_infile *file;
    int fd;                 /* writing */
    char msg[640];          /* first detailed message the library reported ("" if none) */
} exr_stream;

/* The stream of the read or write running on this thread, for the error handler. The handler
 * must not ask the context for its user data: exr_get_user_data() takes the lock of a write
 * context, which the library already holds when it calls our write function, whose error
 * report reaches the handler (exr_write_header -> exr_fd_write -> error_cb -> exr_on_error):
 * a self-deadlock on a full disk (issue 19). The library calls the handler on the thread of
 * the call that failed, and our reads and writes run on one thread each. */
static _Thread_local exr_stream *current_stream;

static void exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    exr_stream *s = current_stream;
    if (s && !s->msg[0])
        snprintf(s->msg, sizeof s->msg, "%s (%s)", msg ? msg : "",
                 exr_get_error_code_as_string(code));
}

/* "NAME: <what the library said while doing `what`>". The detailed message if the library
 * reported one, else the generic text of the code. */
static envl_result exr_fail(exr_stream *s, envl_result code, const char *name, exr_result_t rc,
                            const char *what)
{
    if (rc == EXR_ERR_OUT_OF_MEMORY)
        code = ENVL_ERR_MEMORY;
    else if (rc == EXR_ERR_FEATURE_NOT_IMPLEMENTED && code == ENVL_ERR_FORMAT)
        code = ENVL_ERR_UNSUPPORTED; /* e.g. DWAA / DWAB, which OpenEXRCore 3.1 cannot decode */
    if (s->msg[0])
        return envl__fail(code, "%s: %s: %s", name, what, s->msg);
    return envl__fail(code, "%s: %s: %s (%s)", name, what, exr_get_default_error_message(rc),
                      exr_get_error_code_as_string(rc));
}

/* The library's reads, from any decoding thread: from memory, or from the file by offset. */
static int64_t exr_mem_read(exr_const_context_t ctxt, void *userdata, void *buffer, uint64_t sz,
                            uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    const exr_stream *s = userdata;
    if (offset >= s->size)
        return 0; /* like pread at end of file: the library reports the short read */
    uint64_t n = s->size - offset;
    if (n > sz)
        n = sz;
    if (!s->data) {
        if (!envl__infile_read(s->file, offset, buffer, (size_t)n))
            return (int64_t)n;
        if (error_cb)
            error_cb(ctxt, EXR_ERR_READ_IO, "%s", envl_last_error());
        return -1;
    }
    memcpy(buffer, s->data + offset, (size_t)n);
    return (int64_t)n;
}

static int64_t exr_mem_size(exr_const_context_t ctxt, void *userdata)
{
    (void)ctxt;
    const exr_stream *s = userdata;
    return s->size > (size_t)INT64_MAX ? INT64_MAX : (int64_t)s->size;
}

static int64_t exr_fd_write(exr_const_context_t ctxt, void *userdata, const void *buffer,
                            uint64_t sz, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    const exr_stream *s = userdata;
    const uint8_t *p = buffer;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = envl__io_fault()
                        ? -1
                        : pwrite(s->fd, p + done, (size_t)(sz - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            if (error_cb)
                error_cb(ctxt, EXR_ERR_WRITE_IO, "write of %llu bytes at offset %llu failed: %s",
                         (unsigned long long)sz, (unsigned long long)offset,
                         n < 0 ? strerror(errno) : "no progress");
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

/* ---- colour: primaries -> XYZ ------------------------------------------------------------- */

static const double rec709_chroma[8] = {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290};

/* ---- channels ----------------------------------------------------------------------------- */

enum { PICK_RGB, PICK_GREY, PICK_YC };

/* Which channels of a part feed the output and how: idx[k] is the channel list index for
 * output slot k (RGB: R, G, B; grey: slot 0; YC: RY, Y, BY), -1 when absent. */
typedef struct chan_pick {
    int mode;
    int idx[3];
    int used;  /* meta.channels: colour channels used, + 1 for alpha beside them */
} chan_pick;

static int find_channel(const exr_attr_chlist_t *cl, const char *prefix, size_t plen,
                        const char *suffix)
{
    size_t slen = strlen(suffix);
    for (int i = 0; i < cl->num_channels; i++) {
        const exr_attr_string_t *n = &cl->entries[i].name;
        if (n->length >= 0 && (size_t)n->length == plen + slen && !memcmp(n->str, prefix, plen) &&
            !memcmp(n->str + plen, suffix, slen))
            return i;
    }
    return -1;
}

/* Colour channels named prefix + R/G/B, or prefix + Y (+ RY, BY). */
static bool pick_with_prefix(const exr_attr_chlist_t *cl, const char *prefix, size_t plen,
                             chan_pick *pk)
{
    int r = find_channel(cl, prefix, plen, "R"), g = find_channel(cl, prefix, plen, "G"),
        b = find_channel(cl, prefix, plen, "B"), a = find_channel(cl, prefix, plen, "A");
    int extra = a >= 0 ? 1 : 0;
    int n = (r >= 0) + (g >= 0) + (b >= 0);
    if (n > 1) {
        *pk = (chan_pick){PICK_RGB, {r, g, b}, n + extra};
        return true;
    }
    if (n == 1) { /* a single colour channel: grey */
        *pk = (chan_pick){PICK_GREY, {r >= 0 ? r : g >= 0 ? g : b, -1, -1}, 1 + extra};
        return true;
    }
    int y = find_channel(cl, prefix, plen, "Y");
    if (y < 0)
        return false;
    int ry = find_channel(cl, prefix, plen, "RY"), by = find_channel(cl, prefix, plen, "BY");
    if (ry >= 0 && by >= 0)
        *pk = (chan_pick){PICK_YC, {ry, y, by}, 3 + extra};
    else
        *pk = (chan_pick){PICK_GREY, {y, -1, -1}, 1 + extra};
    return true;
}

/* Plain R, G, B / Y first; then the first layer ("left.R") that has them. */
static bool pick_colour(const exr_attr_chlist_t *cl, chan_pick *pk)
{
    if (pick_with_prefix(cl, "", 0, pk))
        return true;
    for (int i = 0; i < cl->num_channels; i++) {
        const char *s = cl->entries[i].name.str;
        const char *dot = s ? strrchr(s, '.') : NULL;
        if (dot && pick_with_prefix(cl, s, (size_t)(dot - s) + 1, pk))
            return true;
    }
    return false;
}

static void list_channels(const exr_attr_chlist_t *cl, char *buf, size_t cap)
{
    size_t n = 0;
    buf[0] = '\0';
    for (int i = 0; i < cl->num_channels && n + 1 < cap; i++) {
        int k = snprintf(buf + n, cap - n, "%s%s", i ? ", " : "", cl->entries[i].name.str);
        if (k < 0)
            break;
        n += (size_t)k;
    }
}

/* ---- decoding ----------------------------------------------------------------------------- */

static int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
static int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

/* A subsampled channel's samples over the region needed (sample indices k: pixel k * s). */
typedef struct sample_plane {
    float *px;
    int32_t sx, sy;          /* sampling */
    int64_t kx0, ky0;        /* first sample index held */
    int64_t nkx, nky;        /* samples held (0: none) */
} sample_plane;

typedef struct exr_reader {
    exr_const_context_t ctxt;
    int part;
    exr_stream *stream;
    const char *name;
    envl_image *out;
    const exr_attr_chlist_t *channels;
    chan_pick pick;
    int64_t max_pixels;
    exr_attr_box2i_t dw;     /* data window */
    int64_t dx0, dy0, dx1, dy1; /* display window (inclusive) */
    int64_t ix0, iy0, ix1, iy1; /* display window ∩ data window (inclusive); empty: ix0 > ix1 */
    int64_t nx0, ny0, nx1, ny1; /* rows / columns whose chunks must be decoded */
    bool sampled;            /* some used channel is subsampled: decode into sample planes */
    sample_plane plane[3];
    float *scratch;
    size_t scratch_cap;      /* floats */
    exr_decode_pipeline_t dec;
    bool dec_ready;
} exr_reader;

static int slot_of(const exr_reader *r, const char *channel_name)
{
    const exr_attr_chlist_t *cl = r->channels;
    if (!channel_name)
        return -1;
    for (int k = 0; k < 3; k++) {
        int i = r->pick.idx[k];
        if (i >= 0 && !strcmp(cl->entries[i].name.str, channel_name))
            return k;
    }
    return -1;
}

/* IEEE half -> float, exactly (every half is a float). */
static float half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h >> 15) << 31, exp = (h >> 10) & 31u, man = h & 1023u, bits;
    if (exp == 0) {
        float f = ldexpf((float)man, -24); /* zero or subnormal: man * 2^-24 */
        return sign ? -f : f;
    }
    if (exp == 31)
        bits = sign | 0x7f800000u | (man << 13); /* Inf / NaN (payload kept) */
    else
        bits = sign | ((exp + 112u) << 23) | (man << 13);
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

/* Lines of a chunk (rows y0 .. y0 + h - 1) on which a channel has samples (y % y_sampling
 * == 0). Computed here because OpenEXRCore 3.1 miscounts them for negative odd y. */
static int64_t sampled_lines(const exr_coding_channel_info_t *dc, int64_t y0, int64_t h)
{
    int64_t s = dc->y_samples > 1 ? dc->y_samples : 1;
    return s == 1 ? h : floor_div(y0 + h - 1, s) - floor_div(y0 - 1, s);
}

/* Unpacking of a decompressed scanline chunk with subsampled channels. OpenEXR 3.1's default
 * unpacker misplaces the samples of subsampled channels (luminance / chroma files decode to
 * noise), so for those parts we install this routine through the pipeline's documented
 * unpack_and_convert_fn hook; the library still reads and decompresses. Layout of the
 * decompressed block (OpenEXR file layout): for each scanline y of the chunk, for each channel
 * in channel-list order that has samples on y (y % y_sampling == 0), its `width` samples,
 * little-endian half / float / uint. Output: float samples at decode_to_ptr with the user
 * strides, row i of a channel = its i-th sampled line in the chunk. */
static exr_result_t unpack_sampled(exr_decode_pipeline_t *d)
{
    const uint8_t *src = d->unpacked_buffer ? d->unpacked_buffer : d->packed_buffer;
    if (!src)
        return EXR_ERR_INVALID_ARGUMENT;
    const uint8_t *end = src + d->chunk.unpacked_size;
    int64_t y0 = d->chunk.start_y;
    for (int64_t y = y0; y < y0 + d->chunk.height; y++) {
        for (int c = 0; c < d->channel_count; c++) {
            const exr_coding_channel_info_t *dc = &d->channels[c];
            int64_t ys = dc->y_samples > 0 ? dc->y_samples : 1;
            if (y % ys != 0)
                continue;
            size_t bpe = dc->data_type == EXR_PIXEL_HALF ? 2 : 4;
            size_t bytes = (size_t)(dc->width > 0 ? dc->width : 0) * bpe;
            if ((size_t)(end - src) < bytes)
                return EXR_ERR_CORRUPT_CHUNK;
            if (dc->decode_to_ptr) {
                int64_t row = floor_div(y - 1, ys) - floor_div(y0 - 1, ys);
                if (row < 0 || row >= sampled_lines(dc, y0, d->chunk.height))
                    return EXR_ERR_CORRUPT_CHUNK;
                uint8_t *dst = dc->decode_to_ptr + (size_t)row * (size_t)dc->user_line_stride;
                for (int32_t i = 0; i < dc->width; i++, dst += dc->user_pixel_stride) {
                    const uint8_t *b = src + (size_t)i * bpe;
                    float v;
                    if (bpe == 2) {
                        v = half_to_float((uint16_t)(b[0] | b[1] << 8));
                    } else {
                        uint32_t u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                                     (uint32_t)b[3] << 24;
                        if (dc->data_type == EXR_PIXEL_UINT)
                            v = (float)u;
                        else
                            memcpy(&v, &u, sizeof v);
                    }
                    memcpy(dst, &v, sizeof v);
                }
            }
            src += bytes;
        }
    }
    return src == end ? EXR_ERR_SUCCESS : EXR_ERR_CORRUPT_CHUNK;
}

/* Puts the decoded samples of output slot `slot` of the chunk of columns [cx0, cx0 + cw) and
 * rows [cy0, cy0 + ch) in place: src holds `lines` sampled lines of `nx` samples each (not
 * subsampled: nx = cw, lines = ch). Into the output where displayed, else into the slot's
 * sample plane. */
static void place_samples(exr_reader *r, int slot, const float *src, int64_t nx, int64_t lines,
                          int64_t cx0, int64_t cy0, int64_t cw, int64_t ch)
{
    envl_image *out = r->out;
    if (!r->sampled) {
        /* displayed part of the chunk */
        int64_t x0 = cx0 > r->dx0 ? cx0 : r->dx0, x1 = cx0 + cw - 1 < r->dx1 ? cx0 + cw - 1 : r->dx1;
        int64_t y0 = cy0 > r->dy0 ? cy0 : r->dy0, y1 = cy0 + ch - 1 < r->dy1 ? cy0 + ch - 1 : r->dy1;
        for (int64_t y = y0; y <= y1; y++) {
            const float *s = src + (size_t)(y - cy0) * (size_t)nx;
            float *d = out->px + ((size_t)(y - r->dy0) * (size_t)out->width) * 3 + slot;
            for (int64_t x = x0; x <= x1; x++)
                d[(size_t)(x - r->dx0) * 3] = s[x - cx0];
        }
        return;
    }
    /* samples of this chunk: rows ky = ceil(cy0 / sy) + i, columns kx = ceil(cx0 / sx) + j */
    sample_plane *pl = &r->plane[slot];
    if (!pl->px)
        return;
    int64_t ky_first = ceil_div(cy0, pl->sy), kx_first = ceil_div(cx0, pl->sx);
    for (int64_t i = 0; i < lines; i++) {
        int64_t ky = ky_first + i;
        if (ky < pl->ky0 || ky >= pl->ky0 + pl->nky)
            continue;
        for (int64_t j = 0; j < nx; j++) {
            int64_t kx = kx_first + j;
            if (kx < pl->kx0 || kx >= pl->kx0 + pl->nkx)
                continue;
            pl->px[(size_t)(ky - pl->ky0) * (size_t)pl->nkx + (size_t)(kx - pl->kx0)] =
                src[(size_t)i * (size_t)nx + (size_t)j];
        }
    }
}

/* The scratch buffer grown to at least `need` floats (a chunk's or a DWA band's samples). */
static envl_result scratch_reserve(exr_reader *r, size_t need)
{
    if (need <= r->scratch_cap)
        return ENVL_OK;
    float *p = realloc(r->scratch, need * sizeof(float));
    if (!p)
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate a chunk of %zu values", r->name,
                          need);
    r->scratch = p;
    r->scratch_cap = need;
    return ENVL_OK;
}

/* Decodes one chunk whose pixels are columns [cx0, cx0 + cw) and rows [cy0, cy0 + ch). */
static envl_result decode_chunk(exr_reader *r, const exr_chunk_info_t *ci, int64_t cx0,
                                int64_t cy0, int64_t cw, int64_t ch)
{
    exr_result_t rc;
    if (!r->dec_ready) {
        rc = exr_decoding_initialize(r->ctxt, r->part, ci, &r->dec);
        if (rc != EXR_ERR_SUCCESS)
            return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, "cannot set up the decoder");
        r->dec_ready = true;
    } else {
        rc = exr_decoding_update(r->ctxt, r->part, ci, &r->dec);
        if (rc != EXR_ERR_SUCCESS)
            return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, "cannot read a chunk");
    }
    if (cw <= 0 || ch <= 0 || ci->width != cw || ci->height != ch)
        return envl__fail(ENVL_ERR_FORMAT,
                          "%s: chunk at (%lld, %lld) is %d x %d pixels, expected %lld x %lld",
                          r->name, (long long)cx0, (long long)cy0, (int)ci->width,
                          (int)ci->height, (long long)cw, (long long)ch);
    if ((uint64_t)cw * (uint64_t)ch > (uint64_t)r->max_pixels ||
        ci->unpacked_size > (uint64_t)r->max_pixels * 16u + ((uint64_t)1 << 20))
        return envl__fail(ENVL_ERR_LIMIT, "%s: a chunk of %lld x %lld pixels (%llu bytes) exceeds "
                          "the limit", r->name, (long long)cw, (long long)ch,
                          (unsigned long long)ci->unpacked_size);

    envl_image *out = r->out;
    /* Straight into the output when the whole chunk is displayed and nothing is subsampled. */
    bool direct = !r->sampled && cx0 >= r->dx0 && cy0 >= r->dy0 && cx0 + cw - 1 <= r->dx1 &&
                  cy0 + ch - 1 <= r->dy1;
    size_t need = 0;
    int filled = 0;
    for (int c = 0; c < r->dec.channel_count; c++) {
        exr_coding_channel_info_t *dc = &r->dec.channels[c];
        int slot = slot_of(r, dc->channel_name);
        dc->decode_to_ptr = NULL;
        dc->user_data_type = EXR_PIXEL_FLOAT;
        dc->user_bytes_per_element = 4;
        if (dc->width < 0 || dc->height < 0)
            return envl__fail(ENVL_ERR_FORMAT, "%s: channel %s: bad chunk size", r->name,
                              dc->channel_name);
        if (!r->sampled && slot >= 0 && (dc->width != cw || dc->height != ch))
            return envl__fail(ENVL_ERR_FORMAT, "%s: channel %s: chunk of %d x %d samples, "
                              "expected %lld x %lld", r->name, dc->channel_name, dc->width,
                              dc->height, (long long)cw, (long long)ch);
        /* Channels we do not use are decoded too, into the scratch buffer: OpenEXRCore 3.1.5's
         * unpackers can write through a NULL destination (found by the fuzzer). */
        if (!direct || slot < 0)
            need += (size_t)dc->width * (size_t)sampled_lines(dc, cy0, ch);
    }
    envl_result grown = scratch_reserve(r, need);
    if (grown)
        return grown;
    size_t off = 0;
    for (int c = 0; c < r->dec.channel_count; c++) {
        exr_coding_channel_info_t *dc = &r->dec.channels[c];
        int slot = slot_of(r, dc->channel_name);
        int64_t lines = sampled_lines(dc, cy0, ch);
        if (dc->width == 0 || lines == 0)
            continue; /* a subsampled channel without samples in this chunk */
        if (slot < 0) {
            dc->decode_to_ptr = (uint8_t *)(r->scratch + off);
            dc->user_pixel_stride = (int32_t)sizeof(float);
            dc->user_line_stride = (int32_t)sizeof(float) * dc->width;
            off += (size_t)dc->width * (size_t)lines;
            continue;
        }
        filled++;
        if (direct) {
            size_t at = ((size_t)(cy0 - r->dy0) * (size_t)out->width + (size_t)(cx0 - r->dx0)) * 3;
            dc->decode_to_ptr = (uint8_t *)(out->px + at + slot);
            dc->user_pixel_stride = 3 * (int32_t)sizeof(float);
            dc->user_line_stride = 3 * (int32_t)sizeof(float) * out->width;
        } else {
            dc->decode_to_ptr = (uint8_t *)(r->scratch + off);
            dc->user_pixel_stride = (int32_t)sizeof(float);
            dc->user_line_stride = (int32_t)sizeof(float) * dc->width;
            off += (size_t)dc->width * (size_t)lines;
        }
    }
    if (!filled)
        return ENVL_OK;
    /* The unpacking routine depends on the layout just set (direct or scratch). */
    rc = exr_decoding_choose_default_routines(r->ctxt, r->part, &r->dec);
    if (rc == EXR_ERR_SUCCESS && r->sampled)
        r->dec.unpack_and_convert_fn = unpack_sampled;
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_decoding_run(r->ctxt, r->part, &r->dec);
    if (rc != EXR_ERR_SUCCESS) {
        char what[96];
        snprintf(what, sizeof what, "cannot decode the chunk at (%lld, %lld)", (long long)cx0,
                 (long long)cy0);
        return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, what);
    }
    if (direct)
        return ENVL_OK;

    off = 0;
    for (int c = 0; c < r->dec.channel_count; c++) {
        const exr_coding_channel_info_t *dc = &r->dec.channels[c];
        int slot = slot_of(r, dc->channel_name);
        int64_t lines = sampled_lines(dc, cy0, ch);
        if (dc->width == 0 || lines == 0)
            continue;
        const float *src = r->scratch + off;
        off += (size_t)dc->width * (size_t)lines;
        if (slot >= 0)
            place_samples(r, slot, src, dc->width, lines, cx0, cy0, cw, ch);
    }
    return ENVL_OK;
}

/* Bilinear reconstruction of a subsampled channel at pixel (x, y): samples sit at multiples
 * of the sampling; between two samples the value is interpolated linearly (even pixels of a
 * 2x subsampled channel are the samples, odd ones the mean of their neighbours); at the edges
 * of the data window the nearest sample is repeated. */
static float plane_at(const sample_plane *pl, int64_t x, int64_t y)
{
    if (!pl->px || pl->nkx <= 0 || pl->nky <= 0)
        return 0.0f;
    int64_t k[2][2];
    double t[2];
    int64_t pos[2] = {x, y}, s[2] = {pl->sx, pl->sy}, k0[2] = {pl->kx0, pl->ky0},
            n[2] = {pl->nkx, pl->nky};
    for (int a = 0; a < 2; a++) {
        int64_t f = floor_div(pos[a], s[a]);
        t[a] = (double)(pos[a] - f * s[a]) / (double)s[a];
        for (int e = 0; e < 2; e++) {
            int64_t v = f + e - k0[a];
            k[a][e] = v < 0 ? 0 : v >= n[a] ? n[a] - 1 : v;
        }
    }
    double acc = 0.0;
    for (int ey = 0; ey < 2; ey++) {
        double wy = ey ? t[1] : 1.0 - t[1];
        if (wy == 0.0)
            continue;
        for (int ex = 0; ex < 2; ex++) {
            double wx = ex ? t[0] : 1.0 - t[0];
            if (wx == 0.0)
                continue;
            acc += wx * wy * pl->px[(size_t)k[1][ey] * (size_t)pl->nkx + (size_t)k[0][ex]];
        }
    }
    return (float)acc;
}

/* ---- the chunks, decoded in parallel --------------------------------------------------------
 * The chunks' tables are read on the calling thread, in file order, CHUNK_BLOCK at a time; each
 * block's chunks are then decoded in parallel, each by one thread with its own decoding
 * pipeline and scratch buffer, into its own pixels (or sample-plane rows): the image does not
 * depend on the thread count, and the error named is the first in file order. */
enum { CHUNK_BLOCK = 1024 };

typedef struct exr_chunk {
    exr_chunk_info_t ci;
    int64_t x, y, w, h;       /* its pixels: columns [x, x + w), rows [y, y + h) */
} exr_chunk;

typedef struct chunk_job {
    const exr_reader *r;
    const exr_chunk *chunks;
    pthread_mutex_t lock;     /* guards the failure below */
    int64_t failed;           /* the first chunk of the block that failed, or -1 */
    envl_result rc;
    char msg[2048];           /* its message (a worker's own messages are thread-local) */
} chunk_job;

static void decode_chunks(void *ctx, int64_t begin, int64_t end)
{
    chunk_job *j = ctx;
    exr_stream ws = *j->r->stream; /* this thread's copy, for the library's messages */
    ws.msg[0] = '\0';
    exr_stream *outer = current_stream;
    current_stream = &ws;
    exr_reader wr = *j->r;
    wr.stream = &ws;
    wr.scratch = NULL;
    wr.scratch_cap = 0;
    wr.dec_ready = false;
    memset(&wr.dec, 0, sizeof wr.dec);
    for (int64_t k = begin; k < end; k++) {
        const exr_chunk *c = &j->chunks[k];
        envl_result e = decode_chunk(&wr, &c->ci, c->x, c->y, c->w, c->h);
        if (e) {
            pthread_mutex_lock(&j->lock);
            if (j->failed < 0 || k < j->failed) {
                j->failed = k;
                j->rc = e;
                snprintf(j->msg, sizeof j->msg, "%s", envl_last_error());
            }
            pthread_mutex_unlock(&j->lock);
            break;
        }
    }
    if (wr.dec_ready)
        exr_decoding_destroy(wr.ctxt, &wr.dec);
    free(wr.scratch);
    current_stream = outer;
}

static envl_result decode_block(const exr_reader *r, const exr_chunk *chunks, int64_t n,
                                int32_t threads)
{
    chunk_job j = {.r = r, .chunks = chunks, .failed = -1};
    pthread_mutex_init(&j.lock, NULL);
    envl__parallel_for(n, threads, decode_chunks, &j);
    pthread_mutex_destroy(&j.lock);
    if (j.failed < 0)
        return ENVL_OK;
    return envl__fail(j.rc, "%s", j.msg);
}

static envl_result read_chunks(exr_reader *r, exr_storage_t storage, int32_t threads)
{
    exr_chunk *block = malloc(sizeof(exr_chunk) * CHUNK_BLOCK);
    if (!block)
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate the chunk table", r->name);
    int64_t n = 0;
    envl_result e = ENVL_OK;
    exr_result_t rc;
    if (storage == EXR_STORAGE_SCANLINE) {
        int32_t lines = 0;
        rc = exr_get_scanlines_per_chunk(r->ctxt, r->part, &lines);
        if (rc != EXR_ERR_SUCCESS || lines <= 0) {
            free(block);
            return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, "cannot read the chunk layout");
        }
        int64_t w = (int64_t)r->dw.max.x - r->dw.min.x + 1;
        for (int64_t y = r->dw.min.y; y <= r->dw.max.y && !e; y += lines) {
            int64_t h = r->dw.max.y - y + 1 < lines ? r->dw.max.y - y + 1 : lines;
            if (y + h - 1 < r->ny0 || y > r->ny1)
                continue;
            exr_chunk *c = &block[n];
            rc = exr_read_scanline_chunk_info(r->ctxt, r->part, (int)y, &c->ci);
            if (rc != EXR_ERR_SUCCESS) {
                char what[80];
                snprintf(what, sizeof what, "cannot read the chunk of scanline %lld", (long long)y);
                e = exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, what);
                break;
            }
            c->x = r->dw.min.x, c->y = y, c->w = w, c->h = h;
            if (++n == CHUNK_BLOCK) {
                e = decode_block(r, block, n, threads);
                n = 0;
            }
        }
    } else {
        /* tiled: level 0 only (mip / rip levels are smaller copies) */
        int32_t tw = 0, th = 0, lw = 0, lh = 0;
        rc = exr_get_tile_sizes(r->ctxt, r->part, 0, 0, &tw, &th);
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_get_level_sizes(r->ctxt, r->part, 0, 0, &lw, &lh);
        if (rc != EXR_ERR_SUCCESS || tw <= 0 || th <= 0 || lw <= 0 || lh <= 0) {
            free(block);
            return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, "cannot read the tile layout");
        }
        for (int64_t ty = 0; ty * th < lh && !e; ty++) {
            int64_t y = r->dw.min.y + ty * th, h = lh - ty * th < th ? lh - ty * th : th;
            if (y + h - 1 < r->ny0 || y > r->ny1)
                continue;
            for (int64_t tx = 0; tx * tw < lw && !e; tx++) {
                int64_t x = r->dw.min.x + tx * tw, w = lw - tx * tw < tw ? lw - tx * tw : tw;
                if (x + w - 1 < r->nx0 || x > r->nx1)
                    continue;
                exr_chunk *c = &block[n];
                rc = exr_read_tile_chunk_info(r->ctxt, r->part, (int)tx, (int)ty, 0, 0, &c->ci);
                if (rc != EXR_ERR_SUCCESS) {
                    char what[80];
                    snprintf(what, sizeof what, "cannot read tile (%lld, %lld)", (long long)tx,
                             (long long)ty);
                    e = exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, what);
                    break;
                }
                c->x = x, c->y = y, c->w = w, c->h = h;
                if (++n == CHUNK_BLOCK) {
                    e = decode_block(r, block, n, threads);
                    n = 0;
                }
            }
        }
    }
    /* the chunks before a damaged table entry are decoded first: their errors come first */
    if (n) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", envl_last_error());
        envl_result d = decode_block(r, block, n, threads);
        if (d)
            e = d;
        else if (e)
            envl__fail(e, "%s", msg);
    }
    free(block);
    return e;
}

/* DWAA / DWAB parts: bands of rows (the part's scanlines per chunk, or one row of tiles) decoded
 * by the OpenEXR C++ library into the scratch buffer, then placed as the chunks above. */
static envl_result read_dwa(exr_reader *r, exr_storage_t storage)
{
    int32_t band = 0, tw = 0;
    exr_result_t rc = storage == EXR_STORAGE_SCANLINE
                          ? exr_get_scanlines_per_chunk(r->ctxt, r->part, &band)
                          : exr_get_tile_sizes(r->ctxt, r->part, 0, 0, &tw, &band);
    if (rc != EXR_ERR_SUCCESS || band <= 0)
        return exr_fail(r->stream, ENVL_ERR_FORMAT, r->name, rc, "cannot read the chunk layout");
    int64_t w = (int64_t)r->dw.max.x - r->dw.min.x + 1, h = (int64_t)r->dw.max.y - r->dw.min.y + 1;
    if (band > h)
        band = (int32_t)h;
    if ((uint64_t)w * (uint64_t)band > (uint64_t)r->max_pixels)
        return envl__fail(ENVL_ERR_LIMIT, "%s: a chunk of %lld x %d pixels exceeds the limit",
                          r->name, (long long)w, (int)band);
    /* the channels used: names, sampling, samples per line (nx) and lines per band */
    const char *names[3];
    int32_t xs[3], ys[3];
    int slots[3], n = 0;
    int64_t nx[3];
    size_t need = 0;
    for (int k = 0; k < 3; k++) {
        int i = r->pick.idx[k];
        if (i < 0)
            continue;
        const exr_attr_chlist_entry_t *ce = &r->channels->entries[i];
        if (ce->x_sampling <= 0 || ce->y_sampling <= 0 || r->dw.min.x % ce->x_sampling ||
            r->dw.min.y % ce->y_sampling)
            return envl__fail(ENVL_ERR_FORMAT, "%s: channel %s: sampling %d x %d does not divide "
                              "the data window's origin (%d, %d)", r->name, ce->name.str,
                              ce->x_sampling, ce->y_sampling, r->dw.min.x, r->dw.min.y);
        names[n] = ce->name.str, xs[n] = ce->x_sampling, ys[n] = ce->y_sampling, slots[n] = k;
        nx[n] = (w + xs[n] - 1) / xs[n];
        need += (size_t)nx[n] * (size_t)(((int64_t)band + ys[n] - 1) / ys[n]); /* >= lines */
        n++;
    }
    envl_result grown = scratch_reserve(r, need);
    if (grown)
        return grown;
    float *dst[3];
    size_t off = 0;
    for (int k = 0; k < n; k++) {
        dst[k] = r->scratch + off;
        off += (size_t)nx[k] * (size_t)(((int64_t)band + ys[k] - 1) / ys[k]);
    }
    char msg[512] = "";
    envl_exr_dwa *d = NULL;
    /* the C++ library reads from memory: a file is read whole for it */
    const uint8_t *data = r->stream->data;
    uint8_t *whole = NULL;
    if (!data) {
        if (!(whole = malloc(r->stream->size ? r->stream->size : 1)))
            return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %zu bytes", r->name,
                              r->stream->size);
        envl__huge_pages(whole, r->stream->size);
        if ((grown = envl__infile_read(r->stream->file, 0, whole, r->stream->size))) {
            free(whole);
            return grown;
        }
        data = whole;
    }
    int dr = envl__exr_dwa_open(data, r->stream->size, r->name, r->part, &d, msg, sizeof msg);
    if (dr != ENVL_DWA_OK) {
        free(whole);
        return envl__fail(dr == ENVL_DWA_MEMORY ? ENVL_ERR_MEMORY : ENVL_ERR_FORMAT,
                          "%s: the OpenEXR C++ library cannot open the DWA part: %s", r->name, msg);
    }
    envl_result e = ENVL_OK;
    for (int64_t y = r->dw.min.y; y <= r->dw.max.y && !e; y += band) {
        int64_t bh = r->dw.max.y - y + 1 < band ? r->dw.max.y - y + 1 : band;
        if (y + bh - 1 < r->ny0 || y > r->ny1)
            continue;
        dr = envl__exr_dwa_read(d, n, names, dst, xs, ys, (int32_t)y, (int32_t)(y + bh - 1), msg,
                                sizeof msg);
        if (dr != ENVL_DWA_OK) {
            e = envl__fail(dr == ENVL_DWA_MEMORY ? ENVL_ERR_MEMORY : ENVL_ERR_FORMAT,
                           "%s: cannot decode the DWA rows %lld - %lld: %s", r->name,
                           (long long)y, (long long)(y + bh - 1), msg);
            break;
        }
        for (int k = 0; k < n; k++)
            place_samples(r, slots[k], dst[k], nx[k], floor_div(y + bh - 1, ys[k]) -
                          floor_div(y - 1, ys[k]), r->dw.min.x, y, w, bh);
    }
    envl__exr_dwa_close(d);
    free(whole);
    return e;
}

/* Picks the part: by name, or the first (not deep) with colour channels, else the first not
 * deep. */
static envl_result choose_part(exr_context_t ctxt, exr_stream *s, const char *name,
                               const envl_limits *lim, int *part_out)
{
    int count = 0;
    exr_result_t rc = exr_get_count(ctxt, &count);
    if (rc != EXR_ERR_SUCCESS || count <= 0)
        return exr_fail(s, ENVL_ERR_FORMAT, name, rc, "cannot count the parts");
    if (lim && lim->exr_part) {
        char names[512];
        size_t n = 0;
        names[0] = '\0';
        for (int p = 0; p < count; p++) {
            const char *pn = NULL;
            if (exr_get_name(ctxt, p, &pn) != EXR_ERR_SUCCESS)
                pn = NULL;
            if (pn && !strcmp(pn, lim->exr_part)) {
                exr_storage_t st;
                if (exr_get_storage(ctxt, p, &st) == EXR_ERR_SUCCESS &&
                    (st == EXR_STORAGE_DEEP_SCANLINE || st == EXR_STORAGE_DEEP_TILED))
                    return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: part '%s' holds deep data, "
                                      "which is not supported", name, pn);
                s->msg[0] = '\0';
                *part_out = p;
                return ENVL_OK;
            }
            if (n + 1 < sizeof names) {
                int k = snprintf(names + n, sizeof names - n, "%s'%s'", p ? ", " : "",
                                 pn ? pn : "(unnamed)");
                if (k > 0)
                    n += (size_t)k;
            }
        }
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: no part named '%s' (parts: %s)", name,
                          lim->exr_part, names);
    }
    int first_flat = -1;
    for (int p = 0; p < count; p++) {
        exr_storage_t st;
        if (exr_get_storage(ctxt, p, &st) != EXR_ERR_SUCCESS)
            continue;
        if (st != EXR_STORAGE_SCANLINE && st != EXR_STORAGE_TILED)
            continue;
        if (first_flat < 0)
            first_flat = p;
        const exr_attr_chlist_t *cl = NULL;
        chan_pick pk;
        if (exr_get_channels(ctxt, p, &cl) == EXR_ERR_SUCCESS && cl && pick_colour(cl, &pk)) {
            *part_out = p;
            return ENVL_OK;
        }
    }
    s->msg[0] = '\0';
    if (first_flat < 0)
        return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: only deep parts (%d), which are not "
                          "supported", name, count);
    *part_out = first_flat;
    return ENVL_OK;
}

static envl_result read_part(exr_context_t ctxt, exr_stream *s, const char *name,
                             const envl_limits *lim, int64_t max_pixels, envl_image *out)
{
    int part = 0;
    envl_result e = choose_part(ctxt, s, name, lim, &part);
    if (e)
        return e;
    exr_storage_t storage;
    exr_result_t rc = exr_get_storage(ctxt, part, &storage);
    if (rc != EXR_ERR_SUCCESS)
        return exr_fail(s, ENVL_ERR_FORMAT, name, rc, "cannot read the part type");
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: deep data is not supported", name);

    const exr_attr_chlist_t *cl = NULL;
    rc = exr_get_channels(ctxt, part, &cl);
    if (rc != EXR_ERR_SUCCESS || !cl || cl->num_channels <= 0)
        return exr_fail(s, ENVL_ERR_FORMAT, name, rc, "cannot read the channel list");
    exr_reader r = {.ctxt = ctxt, .part = part, .stream = s, .name = name, .out = out,
                    .channels = cl, .max_pixels = max_pixels};
    if (!pick_colour(cl, &r.pick)) {
        if (cl->num_channels != 1) {
            char list[400];
            list_channels(cl, list, sizeof list);
            return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: no R, G, B or Y channel (channels: %s)",
                              name, list);
        }
        r.pick = (chan_pick){PICK_GREY, {0, -1, -1}, 1};
    }

    exr_attr_box2i_t disp;
    rc = exr_get_data_window(ctxt, part, &r.dw);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_get_display_window(ctxt, part, &disp);
    if (rc != EXR_ERR_SUCCESS)
        return exr_fail(s, ENVL_ERR_FORMAT, name, rc, "cannot read the windows");
    int64_t dww = (int64_t)r.dw.max.x - r.dw.min.x + 1, dwh = (int64_t)r.dw.max.y - r.dw.min.y + 1;
    int64_t w = (int64_t)disp.max.x - disp.min.x + 1, h = (int64_t)disp.max.y - disp.min.y + 1;
    if (w <= 0 || h <= 0 || w > INT32_MAX || h > INT32_MAX)
        return envl__fail(ENVL_ERR_FORMAT, "%s: display window (%d, %d) - (%d, %d) is empty or "
                          "too large", name, disp.min.x, disp.min.y, disp.max.x, disp.max.y);
    /* A data window may exceed the display window, but not absurdly: its chunks are walked. */
    if (dww <= 0 || dwh <= 0 || dww > INT32_MAX || dwh > INT32_MAX ||
        dww * dwh > 4 * max_pixels)
        return envl__fail(ENVL_ERR_LIMIT, "%s: data window (%d, %d) - (%d, %d) is empty or "
                          "exceeds 4 x the limit of %lld pixels", name, r.dw.min.x, r.dw.min.y,
                          r.dw.max.x, r.dw.max.y, (long long)max_pixels);
    e = envl__image_alloc(out, (int32_t)w, (int32_t)h, lim, name);
    if (e)
        return e;

    r.dx0 = disp.min.x, r.dy0 = disp.min.y, r.dx1 = disp.max.x, r.dy1 = disp.max.y;
    r.ix0 = r.dx0 > r.dw.min.x ? r.dx0 : r.dw.min.x;
    r.iy0 = r.dy0 > r.dw.min.y ? r.dy0 : r.dw.min.y;
    r.ix1 = r.dx1 < r.dw.max.x ? r.dx1 : r.dw.max.x;
    r.iy1 = r.dy1 < r.dw.max.y ? r.dy1 : r.dw.max.y;
    r.nx0 = r.ix0, r.ny0 = r.iy0, r.nx1 = r.ix1, r.ny1 = r.iy1;
    if (r.ix0 > r.ix1 || r.iy0 > r.iy1)
        return envl__fail(ENVL_ERR_FORMAT, "%s: the data window (%d, %d) - (%d, %d) lies wholly "
                          "outside the display window (%d, %d) - (%d, %d): no pixel of the image "
                          "holds data (it would read as black)", name, r.dw.min.x, r.dw.min.y,
                          r.dw.max.x, r.dw.max.y, disp.min.x, disp.min.y, disp.max.x,
                          disp.max.y);
    for (int k = 0; k < 3; k++) {
        int i = r.pick.idx[k];
        if (i >= 0 && (cl->entries[i].x_sampling != 1 || cl->entries[i].y_sampling != 1))
            r.sampled = true;
    }

    if (r.sampled && storage != EXR_STORAGE_SCANLINE)
        return envl__fail(ENVL_ERR_UNSUPPORTED, "%s: subsampled channels in a tiled part",
                          name);

    /* metadata */
    memcpy(out->meta.format, "exr", 4);
    out->meta.channels = r.pick.used;
    out->meta.exposure = 1.0;
    exr_envmap_t env;
    if (exr_attr_get_envmap(ctxt, part, "envmap", &env) == EXR_ERR_SUCCESS)
        out->meta.envmap_layout = env == EXR_ENVMAP_LATLONG ? ENVL_LAYOUT_EXR_LATLONG
                                  : env == EXR_ENVMAP_CUBE  ? ENVL_LAYOUT_EXR_CUBE
                                                            : 0;
    exr_attr_chromaticities_t chr;
    double chroma[8];
    memcpy(chroma, rec709_chroma, sizeof chroma);
    if (exr_attr_get_chromaticities(ctxt, part, "chromaticities", &chr) == EXR_ERR_SUCCESS) {
        float c[8] = {chr.red_x, chr.red_y, chr.green_x, chr.green_y,
                      chr.blue_x, chr.blue_y, chr.white_x, chr.white_y};
        for (int i = 0; i < 8; i++)
            chroma[i] = c[i];
        memcpy(out->meta.primaries, c, sizeof c);
        out->meta.has_primaries = 1;
    }
    s->msg[0] = '\0'; /* absent optional attributes are not errors */

    /* sample planes for subsampled channels: the samples around the displayed data */
    if (r.sampled && r.ix0 <= r.ix1 && r.iy0 <= r.iy1) {
        for (int k = 0; k < 3; k++) {
            int i = r.pick.idx[k];
            if (i < 0)
                continue;
            sample_plane *pl = &r.plane[k];
            pl->sx = cl->entries[i].x_sampling;
            pl->sy = cl->entries[i].y_sampling;
            if (pl->sx <= 0 || pl->sy <= 0) {
                e = envl__fail(ENVL_ERR_FORMAT, "%s: channel %s: bad sampling %d x %d", name,
                               cl->entries[i].name.str, pl->sx, pl->sy);
                goto done;
            }
            int64_t kx0 = floor_div(r.ix0, pl->sx), kx1 = floor_div(r.ix1, pl->sx) + 1;
            int64_t ky0 = floor_div(r.iy0, pl->sy), ky1 = floor_div(r.iy1, pl->sy) + 1;
            int64_t dkx0 = ceil_div(r.dw.min.x, pl->sx), dkx1 = floor_div(r.dw.max.x, pl->sx);
            int64_t dky0 = ceil_div(r.dw.min.y, pl->sy), dky1 = floor_div(r.dw.max.y, pl->sy);
            kx0 = kx0 < dkx0 ? dkx0 : kx0, kx1 = kx1 > dkx1 ? dkx1 : kx1;
            ky0 = ky0 < dky0 ? dky0 : ky0, ky1 = ky1 > dky1 ? dky1 : ky1;
            if (kx0 > kx1 || ky0 > ky1)
                continue;
            pl->kx0 = kx0, pl->ky0 = ky0, pl->nkx = kx1 - kx0 + 1, pl->nky = ky1 - ky0 + 1;
            if ((uint64_t)pl->nkx * (uint64_t)pl->nky > (uint64_t)max_pixels * 4u) {
                e = envl__fail(ENVL_ERR_LIMIT, "%s: channel %s has too many samples", name,
                               cl->entries[i].name.str);
                goto done;
            }
            pl->px = calloc((size_t)pl->nkx * (size_t)pl->nky, sizeof(float));
            if (!pl->px) {
                e = envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate the samples of channel %s",
                               name, cl->entries[i].name.str);
                goto done;
            }
            if (kx0 * pl->sx < r.nx0) r.nx0 = kx0 * pl->sx;
            if (kx1 * pl->sx > r.nx1) r.nx1 = kx1 * pl->sx;
            if (ky0 * pl->sy < r.ny0) r.ny0 = ky0 * pl->sy;
            if (ky1 * pl->sy > r.ny1) r.ny1 = ky1 * pl->sy;
        }
    }

    exr_compression_t comp = EXR_COMPRESSION_NONE;
    if (exr_get_compression(ctxt, part, &comp) != EXR_ERR_SUCCESS)
        comp = EXR_COMPRESSION_NONE; /* the chunk reads then report what is wrong */
    s->msg[0] = '\0';
    if (comp == EXR_COMPRESSION_DWAA || comp == EXR_COMPRESSION_DWAB) {
        /* its 8 x 8 DCT blocks start at the data window's origin (ringing.c fills by them) */
        out->meta.block_x0 = (int32_t)(((r.dw.min.x - r.dx0) % 8 + 8) % 8);
        out->meta.block_y0 = (int32_t)(((r.dw.min.y - r.dy0) % 8 + 8) % 8);
        e = read_dwa(&r, storage);
    } else
        e = read_chunks(&r, storage,
                        (int64_t)w * h >= 65536 ? envl__threads(lim ? lim->threads : 0) : 1);
    if (e)
        goto done;

    float *px = out->px;
    size_t npx = (size_t)out->width * (size_t)out->height;
    if (r.sampled) {
        for (int64_t y = r.iy0; y <= r.iy1; y++)
            for (int64_t x = r.ix0; x <= r.ix1; x++) {
                float *d = px + ((size_t)(y - r.dy0) * (size_t)out->width + (size_t)(x - r.dx0)) * 3;
                for (int k = 0; k < 3; k++)
                    if (r.plane[k].px)
                        d[k] = plane_at(&r.plane[k], x, y);
            }
    }

    double to_xyz[3][3], xyz709[3][3], to709[3][3], m[3][3];
    bool chroma_ok = envl__rgb_to_xyz_matrix(chroma, to_xyz);
    if (!chroma_ok)
        envl__rgb_to_xyz_matrix(rec709_chroma, to_xyz);
    if (r.pick.mode == PICK_GREY) {
        for (size_t i = 0; i < npx; i++)
            px[3 * i + 1] = px[3 * i + 2] = px[3 * i];
    } else if (r.pick.mode == PICK_YC) {
        /* As OpenEXR's RgbaYca::YCAtoRGBA: R = (RY + 1) Y, B = (BY + 1) Y,
         * G = (Y - R yw.x - B yw.z) / yw.y, yw = the Y row of RGB -> XYZ (sums to 1). */
        double ywx = to_xyz[1][0], ywy = to_xyz[1][1], ywz = to_xyz[1][2];
        double sum = ywx + ywy + ywz;
        if (!(fabs(ywy) > 1e-9) || !(fabs(sum) > 1e-9)) {
            ywx = 0.2126, ywy = 0.7152, ywz = 0.0722, sum = 1.0;
        }
        ywx /= sum, ywy /= sum, ywz /= sum;
        for (size_t i = 0; i < npx; i++) {
            float *p = px + 3 * i;
            double yv = p[1], rr = (p[0] + 1.0) * yv, bb = (p[2] + 1.0) * yv;
            p[0] = (float)rr;
            p[1] = (float)((yv - rr * ywx - bb * ywz) / ywy);
            p[2] = (float)bb;
        }
    }
    /* Other primaries: RGB -> XYZ -> linear Rec.709 (no white-point adaptation, as OpenEXR). */
    bool is709 = true;
    for (int i = 0; i < 8; i++)
        if (fabs(chroma[i] - rec709_chroma[i]) > 1e-3)
            is709 = false;
    if (!is709 && chroma_ok && envl__rgb_to_xyz_matrix(rec709_chroma, xyz709) &&
        envl__invert3(xyz709, m)) {
        envl__mul3(m, to_xyz, to709);
        for (size_t i = 0; i < npx; i++) {
            float *p = px + 3 * i;
            double a = p[0], b = p[1], c = p[2];
            for (int k = 0; k < 3; k++)
                p[k] = (float)(to709[k][0] * a + to709[k][1] * b + to709[k][2] * c);
        }
    }
    e = ENVL_OK;
done:
    if (r.dec_ready)
        exr_decoding_destroy(ctxt, &r.dec);
    free(r.scratch);
    for (int k = 0; k < 3; k++)
        free(r.plane[k].px);
    return e;
}

static envl_result read_exr(exr_stream *s, const char *name, const envl_limits *lim,
                            envl_image *out)
{
    memset(out, 0, sizeof *out);
    int64_t max_pixels = lim && lim->max_pixels > 0 ? lim->max_pixels : ENVL_DEFAULT_MAX_PIXELS;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.user_data = s;
    init.read_fn = exr_mem_read;
    init.size_fn = exr_mem_size;
    /* The library's own header checks: no side may exceed twice the pixel limit (our checks
     * then say ENVL_ERR_LIMIT for anything between). */
    int64_t side = 2 * max_pixels;
    int dim = side > INT_MAX / 2 ? INT_MAX / 2 : (int)side;
    init.max_image_width = init.max_image_height = dim;
    init.max_tile_width = init.max_tile_height = dim;

    exr_context_t ctxt = NULL;
    exr_stream *outer = current_stream;
    current_stream = s;
    exr_result_t rc = exr_start_read(&ctxt, name, &init);
    envl_result e;
    if (rc != EXR_ERR_SUCCESS)
        e = exr_fail(s, ENVL_ERR_FORMAT, name, rc, "not a readable OpenEXR file");
    else
        e = read_part(ctxt, s, name, lim, max_pixels, out);
    if (ctxt)
        exr_finish(&ctxt);
    current_stream = outer;
    /* From a file: a file rewritten in place while it was read is an error, not a mixture */
    if (s->file && (e == ENVL_OK || e == ENVL_ERR_FORMAT) && envl__infile_unchanged(s->file))
        e = ENVL_ERR_IO;
    if (e)
        envl__image_free(out);
    return e;
}

envl_result envl__read_exr(const uint8_t *data, size_t size, const char *name,
                           const envl_limits *lim, envl_image *out)
{
    if (!name)
        name = "(memory)";
    if (!out || (!data && size))
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: read_exr: no data or no output", name);
    exr_stream s = {.data = data, .size = size, .fd = -1};
    return read_exr(&s, name, lim, out);
}

envl_result envl__read_exr_file(const envl_infile *f, const envl_limits *lim, envl_image *out)
{
    exr_stream s = {.size = (size_t)f->size, .file = f, .fd = -1};
    return read_exr(&s, f->path, lim, out);
}

/* ---- writing ------------------------------------------------------------------------------ */

/* OpenEXRCore 3.1.5 keeps a deflated chunk whose size equals the raw size, but a reader must
 * take a chunk whose stored size equals its raw size for raw data. So after the library's
 * compressor: if compression saved nothing, store the raw bytes. */
typedef struct compress_hook {
    exr_result_t (*compress)(exr_encode_pipeline_t *);
} compress_hook;

static exr_result_t compress_or_raw(exr_encode_pipeline_t *e)
{
    const compress_hook *hook = e->encoding_user_data;
    exr_result_t rc = hook->compress(e);
    if (rc == EXR_ERR_SUCCESS && e->compressed_buffer && e->packed_buffer &&
        e->compressed_buffer != e->packed_buffer && e->compressed_bytes >= e->packed_bytes &&
        e->compressed_alloc_size >= e->packed_bytes) {
        memcpy(e->compressed_buffer, e->packed_buffer, (size_t)e->packed_bytes);
        e->compressed_bytes = (size_t)e->packed_bytes;
    }
    return rc;
}

envl_result envl__write_exr(const char *path, const float *rgb, int32_t w, int32_t h,
                            int32_t pixel_type, int32_t envmap)
{
    if (!path || !rgb || w <= 0 || h <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: write_exr: need pixels and a positive size",
                          path ? path : "(null)");
    if (pixel_type != ENVL_PIXEL_FLOAT && pixel_type != ENVL_PIXEL_HALF)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: unknown pixel type %d", path, (int)pixel_type);
    if (envmap != 0 && envmap != ENVL_LAYOUT_EXR_LATLONG && envmap != ENVL_LAYOUT_EXR_CUBE)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: envmap %d is not an OpenEXR envmap layout",
                          path, (int)envmap);
    const bool half = pixel_type == ENVL_PIXEL_HALF;
    exr_stream s = {.fd = envl__io_fault() ? -1
                                           : open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC,
                                                  0644)};
    if (s.fd < 0)
        return envl__fail(ENVL_ERR_IO, "%s: cannot create: %s", path, strerror(errno));

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.user_data = &s;
    init.write_fn = exr_fd_write;
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool enc_ready = false;
    float *scratch = NULL;
    const char *what = "cannot start the file";
    int part = 0;
    int32_t lines = 0;
    exr_pixel_type_t type = half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
    compress_hook hook = {NULL};

    exr_stream *outer = current_stream;
    current_stream = &s;
    exr_result_t rc = exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc == EXR_ERR_SUCCESS) {
        what = "cannot define the image";
        rc = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    }
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_initialize_required_attr_simple(ctxt, part, w, h, EXR_COMPRESSION_ZIP);
    /* channels in the order OpenEXR keeps them (alphabetical) */
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_add_channel(ctxt, part, "B", type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_add_channel(ctxt, part, "G", type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_add_channel(ctxt, part, "R", type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    /* Imf::Envmap (ImfEnvmap.h): ENVMAP_LATLONG = 0, ENVMAP_CUBE = 1; read back by read_part */
    if (rc == EXR_ERR_SUCCESS && envmap)
        rc = exr_attr_set_envmap(ctxt, part, "envmap", envmap == ENVL_LAYOUT_EXR_CUBE
                                                           ? EXR_ENVMAP_CUBE
                                                           : EXR_ENVMAP_LATLONG);
    if (rc == EXR_ERR_SUCCESS) {
        what = "cannot write the header";
        rc = exr_write_header(ctxt);
    }
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_get_scanlines_per_chunk(ctxt, part, &lines);
    if (rc == EXR_ERR_SUCCESS && lines <= 0)
        rc = EXR_ERR_UNKNOWN;
    if (rc == EXR_ERR_SUCCESS && half) {
        scratch = malloc((size_t)lines * (size_t)w * 3 * sizeof(float));
        if (!scratch)
            rc = EXR_ERR_OUT_OF_MEMORY;
    }
    for (int32_t y = 0; rc == EXR_ERR_SUCCESS && y < h; y += lines) {
        what = "cannot encode the pixels";
        int32_t n = h - y < lines ? h - y : lines;
        const float *src = rgb + (size_t)y * (size_t)w * 3;
        if (half) {
            /* Half holds +-65504 at most: clamp (never Inf); NaN -> 0. */
            size_t cnt = (size_t)n * (size_t)w * 3;
            for (size_t i = 0; i < cnt; i++) {
                float v = src[i];
                scratch[i] = isnan(v) ? 0.0f : v > 65504.0f ? 65504.0f
                                                : v < -65504.0f ? -65504.0f : v;
            }
            src = scratch;
        }
        exr_chunk_info_t ci;
        rc = exr_write_scanline_chunk_info(ctxt, part, y, &ci);
        if (rc != EXR_ERR_SUCCESS)
            break;
        if (!enc_ready) {
            rc = exr_encoding_initialize(ctxt, part, &ci, &enc);
            enc_ready = rc == EXR_ERR_SUCCESS;
        } else {
            rc = exr_encoding_update(ctxt, part, &ci, &enc);
        }
        if (rc != EXR_ERR_SUCCESS)
            break;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ec = &enc.channels[c];
            const char *cn = ec->channel_name;
            int slot = !strcmp(cn, "R") ? 0 : !strcmp(cn, "G") ? 1 : 2;
            ec->encode_from_ptr = (const uint8_t *)(src + slot);
            ec->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ec->user_line_stride = 3 * (int32_t)sizeof(float) * w;
            ec->user_data_type = EXR_PIXEL_FLOAT;
            ec->user_bytes_per_element = 4;
        }
        rc = exr_encoding_choose_default_routines(ctxt, part, &enc);
        if (rc == EXR_ERR_SUCCESS && enc.compress_fn && enc.compress_fn != compress_or_raw) {
            hook.compress = enc.compress_fn;
            enc.encoding_user_data = &hook;
            enc.compress_fn = compress_or_raw;
        }
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_encoding_run(ctxt, part, &enc);
    }
    if (enc_ready)
        exr_encoding_destroy(ctxt, &enc);
    free(scratch);
    if (ctxt) {
        exr_result_t frc = exr_finish(&ctxt); /* writes the chunk offset table */
        if (rc == EXR_ERR_SUCCESS && frc != EXR_ERR_SUCCESS) {
            what = "cannot finish the file";
            rc = frc;
        }
    }
    current_stream = outer;
    int cerr = (close(s.fd) != 0 || envl__io_fault()) ? errno : 0;
    if (rc != EXR_ERR_SUCCESS)
        return exr_fail(&s, ENVL_ERR_IO, path, rc, what);
    if (cerr)
        return envl__fail(ENVL_ERR_IO, "%s: close failed: %s", path, strerror(cerr));
    return ENVL_OK;
}
