/* KTX 2.0 writer: uncompressed float RGBA cube maps and 2D images with their mip chain.
 *
 * Layout (Khronos KTX 2.0 specification, "File Structure"; all numbers little-endian):
 *   identifier (12 bytes) | header: vkFormat typeSize pixelWidth pixelHeight pixelDepth
 *   layerCount faceCount levelCount supercompressionScheme (9 x UInt32) | index: dfdByteOffset
 *   dfdByteLength kvdByteOffset kvdByteLength (UInt32) sgdByteOffset sgdByteLength (UInt64) |
 *   level index: {byteOffset, byteLength, uncompressedByteLength} (UInt64) for level 0 (the
 *   largest) first | data format descriptor | key/value data | the levels' images, the
 *   SMALLEST level first, each starting at a multiple of lcm(texel block size, 4) (mipPadding,
 *   zeros), a level's faces one after another, rows tightly packed.
 * No supercompression (scheme 0, so byteLength = uncompressedByteLength), no array layers
 * (layerCount 0), 2D (pixelDepth 0).
 *
 * The data format descriptor is one Basic descriptor block (Khronos Data Format 1.3, as
 * KTX-Software's createDFDUnpacked writes for an *_SFLOAT format): colour model RGBSDA,
 * primaries BT.709, transfer linear, straight alpha, a 1x1x1x1 texel block of bytesPlane0 =
 * 4 x channel bytes; one sample per channel R G B A (channel ids 0 1 2 15) with the FLOAT and
 * SIGNED qualifiers, bitLength = bits - 1, sampleLower / sampleUpper = -1.0f / 1.0f as
 * binary32 bit patterns (also for 16-bit samples). */
#include "ktx2.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const uint8_t ktx2_identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32,
                                            0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};

/* binary16 from binary32, round to nearest even. Half: 1 sign, 5 exponent (bias 15), 10
 * fraction bits; float: 8 exponent bits (bias 127), 23 fraction bits.
 * - |f| >= 2^-14 (half normals): the exponent is rebiased by 127 - 15 = 112 and the fraction
 *   keeps its top 10 bits; the 13 dropped bits round the result (above half: up; exactly half:
 *   up only if the kept last bit is odd). A carry out of the fraction correctly bumps the
 *   exponent.
 * - |f| < 2^-14 (half subnormals and zero): the half is |f| / 2^-24 as an integer; |f| * 2^24
 *   is exact in binary32 and nearbyintf rounds it to nearest even (the default rounding mode;
 *   1024 there is 0x0400, the smallest normal, which is the right encoding too). */
uint16_t envl__half_from_float(float f)
{
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    uint16_t sign = (uint16_t)((x >> 16) & 0x8000u);
    uint32_t ax = x & 0x7FFFFFFFu;
    if (ax > 0x7F800000u)
        return 0;                 /* NaN */
    if (ax > 0x477FE000u)         /* above 65504, or infinite */
        return sign | 0x7BFFu;
    if (ax < 0x38800000u)         /* below 2^-14 */
        return sign | (uint16_t)nearbyintf(fabsf(f) * 0x1p24f);
    uint32_t h = (ax >> 13) - (112u << 10), rest = ax & 0x1FFFu;
    if (rest > 0x1000u || (rest == 0x1000u && (h & 1u)))
        h++;
    return sign | (uint16_t)h;
}

float envl__float_from_half(uint16_t h)
{
    int e = (h >> 10) & 0x1F, m = h & 0x3FF;
    float v = e == 0    ? ldexpf((float)m, -24)
              : e == 31 ? (m ? NAN : INFINITY)
                        : ldexpf((float)(m | 0x400), e - 25);
    return h & 0x8000u ? -v : v;
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint64_t align_up(uint64_t v, uint64_t a) { return (v + a - 1) / a * a; }

static int32_t level_size(int32_t size, int32_t k)
{
    int32_t s = size >> k;
    return s > 0 ? s : 1;
}

float *envl__half_rounded(const float *v, size_t n)
{
    float *out = malloc(sizeof(float) * (n ? n : 1));
    for (size_t i = 0; out && i < n; i++)
        out[i] = envl__float_from_half(envl__half_from_float(v[i]));
    return out;
}

/* One float as stored: finite, clamped as the header says; counted in rep. */
static void put_value(uint8_t *p, float v, int half, envl__ktx2_report *rep)
{
    if (isnan(v)) {
        rep->nan++;
        v = 0.0f;
    }
    if (half) {
        if (fabsf(v) > 65504.0f)
            rep->clamped++;
        uint16_t h = envl__half_from_float(v);
        p[0] = (uint8_t)h, p[1] = (uint8_t)(h >> 8);
        return;
    }
    if (isinf(v)) {
        rep->clamped++;
        v = v > 0 ? FLT_MAX : -FLT_MAX;
    }
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    put32(p, u);
}

envl_result envl__write_ktx2(const char *path, const envl__ktx2_desc *d, envl__ktx2_report *rep)
{
    envl__ktx2_report ignored;
    rep = rep ? rep : &ignored;
    memset(rep, 0, sizeof *rep);
    int half = d && d->vk_format == ENVL__VK_FORMAT_R16G16B16A16_SFLOAT;
    if (!d || !d->rgb || (!half && d->vk_format != ENVL__VK_FORMAT_R32G32B32A32_SFLOAT) ||
        (d->faces != 1 && d->faces != 6) || d->size < 1 || d->size > 65536 || d->levels < 1 ||
        (d->levels > 1 && (d->size >> (d->levels - 1)) < 1))
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: KTX2: bad image description", path);
    for (int32_t k = 0; k < d->levels; k++)
        if (!d->rgb[k])
            return envl__fail(ENVL_ERR_ARGUMENT, "%s: KTX2: level %d has no pixels", path,
                              (int)k);
    uint32_t chan_bytes = half ? 2 : 4, block = 4 * chan_bytes; /* texel block size */
    uint64_t align = block;                                      /* lcm(8 or 16, 4) */
    const char *writer = d->writer ? d->writer : "envlight";

    /* header, index, level index, DFD, key/value data: one buffer */
    uint32_t n_samples = 4, dfd_len = 4 + 24 + 16 * n_samples;
    uint32_t dfd_off = 12 + 68 + 24 * (uint32_t)d->levels;
    uint32_t kv_len = (uint32_t)(sizeof "KTXwriter" + strlen(writer) + 1); /* key NUL value NUL */
    uint32_t kvd_off = dfd_off + dfd_len, kvd_len = 4 + (uint32_t)align_up(kv_len, 4);
    uint64_t start = kvd_off + kvd_len;
    uint64_t *level_off = calloc((size_t)d->levels, sizeof *level_off);
    uint8_t *head = calloc(1, start);
    size_t max_face = (size_t)d->size * d->size * block;
    uint8_t *face = malloc(max_face);
    if (!level_off || !head || !face) {
        free(level_off);
        free(head);
        free(face);
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    }
    uint64_t pos = start;
    for (int32_t k = d->levels - 1; k >= 0; k--) { /* smallest level first in the file */
        int32_t s = level_size(d->size, k);
        level_off[k] = align_up(pos, align);
        pos = level_off[k] + (uint64_t)d->faces * s * s * block;
    }
    uint8_t *p = head;
    memcpy(p, ktx2_identifier, 12);
    p += 12;
    uint32_t header[9] = {(uint32_t)d->vk_format, chan_bytes, (uint32_t)d->size,
                          (uint32_t)d->size, 0, 0, (uint32_t)d->faces, (uint32_t)d->levels, 0};
    for (int i = 0; i < 9; i++, p += 4)
        put32(p, header[i]);
    put32(p, dfd_off), put32(p + 4, dfd_len), put32(p + 8, kvd_off), put32(p + 12, kvd_len);
    put64(p + 16, 0), put64(p + 24, 0); /* no supercompression global data */
    p += 32;
    for (int32_t k = 0; k < d->levels; k++, p += 24) {
        int32_t s = level_size(d->size, k);
        uint64_t bytes = (uint64_t)d->faces * s * s * block;
        put64(p, level_off[k]), put64(p + 8, bytes), put64(p + 16, bytes);
    }
    /* the DFD */
    put32(p, dfd_len);
    put32(p + 4, 0);                              /* vendorId 0 (Khronos), descriptorType 0 */
    put32(p + 8, 2u | (24u + 16u * n_samples) << 16); /* version 2, descriptorBlockSize */
    put32(p + 12, 1u | 1u << 8 | 1u << 16);       /* RGBSDA, BT709, LINEAR, flags 0 (straight) */
    put32(p + 16, 0);                             /* texelBlockDimension 1x1x1x1 (stored - 1) */
    put32(p + 20, block);                         /* bytesPlane0; bytesPlane1..7 = 0 */
    put32(p + 24, 0);
    static const uint8_t channel_id[4] = {0, 1, 2, 15};
    float lower = -1.0f, upper = 1.0f;
    uint32_t lower_bits, upper_bits;
    memcpy(&lower_bits, &lower, 4);
    memcpy(&upper_bits, &upper, 4);
    for (uint32_t i = 0; i < n_samples; i++) {
        uint8_t *q = p + 28 + 16 * i;
        uint32_t bits = 8 * chan_bytes;
        put32(q, (bits * i) | (bits - 1) << 16 | (uint32_t)(channel_id[i] | 0x80u | 0x40u) << 24);
        put32(q + 4, 0); /* samplePosition */
        put32(q + 8, lower_bits), put32(q + 12, upper_bits);
    }
    p += dfd_len;
    /* the key/value data: KTXwriter only (valuePadding zeros come from calloc) */
    put32(p, kv_len);
    memcpy(p + 4, "KTXwriter", sizeof "KTXwriter");
    memcpy(p + 4 + sizeof "KTXwriter", writer, strlen(writer) + 1);

    FILE *f = envl__io_fault() ? NULL : fopen(path, "wb");
    if (!f) {
        int err = errno;
        free(level_off);
        free(head);
        free(face);
        return envl__fail(ENVL_ERR_IO, "%s: cannot write: %s", path, strerror(err));
    }
    int err = 0;
    errno = 0;
    if (envl__io_fault() || fwrite(head, 1, start, f) != start)
        err = errno ? errno : EIO;
    pos = start;
    static const uint8_t zeros[16];
    float one = 1.0f;
    for (int32_t k = d->levels - 1; k >= 0 && !err; k--) {
        int32_t s = level_size(d->size, k);
        size_t pad = (size_t)(level_off[k] - pos), texels = (size_t)s * s;
        errno = 0;
        if (pad && (envl__io_fault() || fwrite(zeros, 1, pad, f) != pad))
            err = errno ? errno : EIO;
        for (int32_t fc = 0; fc < d->faces && !err; fc++) {
            const float *src = d->rgb[k] + 3 * texels * fc;
            for (size_t t = 0; t < texels; t++) {
                uint8_t *o = face + block * t;
                for (int c = 0; c < 3; c++)
                    put_value(o + chan_bytes * c, src[3 * t + c], half, rep);
                put_value(o + chan_bytes * 3, one, half, rep);
            }
            errno = 0;
            if (envl__io_fault() || fwrite(face, block, texels, f) != texels)
                err = errno ? errno : EIO;
        }
        pos = level_off[k] + (uint64_t)d->faces * texels * block;
    }
    free(level_off);
    free(head);
    free(face);
    return envl__close_written(f, path, err);
}
