/* The KTX2 writer (src/io/ktx2.c): binary16 conversion with exact expectations and exhaustively
 * against its definition (round to nearest, ties to even, clamp at 65504, never inf or NaN);
 * then a small cube with two mip levels read back byte by byte against the KTX 2.0
 * specification's layout. tests/cli_ktx2.sh reads the CLI's files with ktx-parse. */
#include "ktx2.h"
#include "check.h"

#include <stdint.h>

static uint32_t get32(const uint8_t *p)
{
    return p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t get64(const uint8_t *p) { return get32(p) | (uint64_t)get32(p + 4) << 32; }

static uint16_t get16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

static void test_half_values(void)
{
    static const struct { float f; uint16_t h; } t[] = {
        {1.0f, 0x3C00},             {-2.0f, 0xC000},
        {0.0f, 0x0000},             {-0.0f, 0x8000},
        {65504.0f, 0x7BFF},         /* the largest half */
        {65519.99f, 0x7BFF},        /* below the midpoint to 2^16: rounds down anyway */
        {65520.0f, 0x7BFF},         /* would round to inf: clamped */
        {1e30f, 0x7BFF},            {-1e30f, 0xFBFF},
        {INFINITY, 0x7BFF},         {-INFINITY, 0xFBFF},
        {NAN, 0x0000},
        {0x1p-14f, 0x0400},         /* the smallest normal */
        {0x1p-24f, 0x0001},         /* the smallest subnormal */
        {0x1p-25f, 0x0000},         /* half of it: a tie, to even (0) */
        {0x1.8p-24f, 0x0002},       /* 1.5 x 2^-24: a tie, to even (2) */
        {0x1.000002p-25f, 0x0001},  /* just above the tie: up */
        {0x1p-14f - 0x1p-25f, 0x0400}, /* 1023.5 x 2^-24: a tie, to even (1024 = 0x0400) */
        {1.0f + 0x1p-11f, 0x3C00},  /* a tie between 0x3C00 and 0x3C01: to even */
        {1.0f + 3 * 0x1p-11f, 0x3C02}, /* a tie between 0x3C01 and 0x3C02: to even */
        {1.0f + 0x1p-11f + 0x1p-20f, 0x3C01},
        {2047.5f, 0x6800},          /* ulp 1 below 2048: a tie between 0x67FF and 0x6800 */
        {0.1f, 0x2E66},             /* 0.0999755859375 */
        {-0x1p-24f, 0x8001},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        uint16_t h = envl__half_from_float(t[i].f);
        if (h != t[i].h)
            fprintf(stderr, "half(%a) = 0x%04X, expected 0x%04X\n", (double)t[i].f, h, t[i].h);
        CHECK(h == t[i].h);
    }
}

/* Every finite half round-trips; every midpoint between neighbours goes to the even one, and
 * the floats just either side of it to the nearer one. */
static void test_half_exhaustive(void)
{
    int bad = 0;
    for (uint32_t h = 0; h < 0x10000 && bad < 5; h++) {
        if ((h & 0x7C00) == 0x7C00)
            continue; /* inf / NaN are never written */
        float f = envl__float_from_half((uint16_t)h);
        if (envl__half_from_float(f) != (h == 0x8000 ? 0x8000 : h))
            bad++, fprintf(stderr, "half 0x%04X does not round-trip\n", h);
        if ((h & 0x7FFF) == 0x7BFF)
            continue; /* the largest: above it everything clamps (test_half_values) */
        float g = envl__float_from_half((uint16_t)(h + 1)); /* the next in magnitude */
        float mid = (f + g) / 2;                            /* exact: 11 significant bits */
        uint16_t even = (h & 1) ? (uint16_t)(h + 1) : (uint16_t)h;
        if (envl__half_from_float(mid) != even)
            bad++, fprintf(stderr, "midpoint after 0x%04X: 0x%04X\n", h,
                           envl__half_from_float(mid));
        float below = nextafterf(mid, f), above = nextafterf(mid, g);
        if (envl__half_from_float(below) != h || envl__half_from_float(above) != h + 1)
            bad++, fprintf(stderr, "neighbours of the midpoint after 0x%04X\n", h);
    }
    CHECK(bad == 0);
}

/* A cube of 2-texel faces with 2 mip levels: every field where the specification puts it. */
static void test_container(int32_t vk)
{
    int half = vk == ENVL__VK_FORMAT_R16G16B16A16_SFLOAT;
    float l0[6 * 4 * 3], l1[6 * 1 * 3];
    for (int i = 0; i < 6 * 4 * 3; i++)
        l0[i] = 0.25f * i;
    for (int i = 0; i < 6 * 3; i++)
        l1[i] = -0.5f * i;
    l0[5] = 1e6f;      /* clamped in half */
    l0[6] = INFINITY;  /* clamped in both */
    l1[2] = NAN;       /* written 0 */
    const float *levels[2] = {l0, l1};
    char path[4200];
    snprintf(path, sizeof path, "%s", tmp_path(half ? "cube_half.ktx2" : "cube_float.ktx2"));
    envl__ktx2_report rep;
    CHECK_OK(envl__write_ktx2(path, &(envl__ktx2_desc){.vk_format = vk, .size = 2, .faces = 6,
                                                       .levels = 2, .rgb = levels,
                                                       .writer = "envlight test"},
                              &rep));
    CHECK(rep.clamped == (half ? 2 : 1) && rep.nan == 1);
    uint8_t *b;
    size_t n;
    CHECK_OK(envl__read_file(path, 1 << 20, &b, &n));
    static const uint8_t id[12] = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
    CHECK(!memcmp(b, id, 12));
    uint32_t block = half ? 8 : 16;
    uint32_t hdr[9] = {(uint32_t)vk, half ? 2u : 4u, 2, 2, 0, 0, 6, 2, 0};
    for (int i = 0; i < 9; i++)
        CHECK(get32(b + 12 + 4 * i) == hdr[i]);
    uint32_t dfd_off = get32(b + 48), dfd_len = get32(b + 52);
    uint32_t kvd_off = get32(b + 56), kvd_len = get32(b + 60);
    CHECK(dfd_off == 80 + 2 * 24 && dfd_len == 4 + 24 + 4 * 16);
    CHECK(get64(b + 64) == 0 && get64(b + 72) == 0); /* no supercompression global data */
    CHECK(kvd_off == dfd_off + dfd_len);
    /* the level index: level 0 (4 texels per face) after level 1 in the file, both aligned */
    uint64_t off0 = get64(b + 80), len0 = get64(b + 88), un0 = get64(b + 96);
    uint64_t off1 = get64(b + 104), len1 = get64(b + 112), un1 = get64(b + 120);
    CHECK(len0 == 6 * 4 * block && un0 == len0 && len1 == 6 * 1 * block && un1 == len1);
    CHECK(off1 >= kvd_off + kvd_len && off1 < kvd_off + kvd_len + block && off1 % block == 0);
    CHECK(off0 == off1 + len1 && off0 % block == 0 && off0 + len0 == n);
    /* the DFD: one Basic block, RGBSDA / BT709 / linear, 4 float signed samples */
    const uint8_t *d = b + dfd_off;
    CHECK(get32(d) == dfd_len && get32(d + 4) == 0);
    CHECK(get32(d + 8) == (2u | (24u + 64u) << 16));
    CHECK(d[12] == 1 && d[13] == 1 && d[14] == 1 && d[15] == 0);
    CHECK(get32(d + 16) == 0 && get32(d + 20) == block && get32(d + 24) == 0);
    static const uint8_t ch[4] = {0, 1, 2, 15};
    for (int s = 0; s < 4; s++) {
        const uint8_t *q = d + 28 + 16 * s;
        uint32_t bits = half ? 16 : 32;
        CHECK(get16(q) == bits * s && q[2] == bits - 1 && q[3] == (0xC0 | ch[s]));
        CHECK(get32(q + 4) == 0 && get32(q + 8) == 0xBF800000u && get32(q + 12) == 0x3F800000u);
    }
    /* key/value: KTXwriter = "envlight test" NUL, padded to 4 */
    const char kv[] = "KTXwriter\0envlight test";
    CHECK(get32(b + kvd_off) == sizeof kv && !memcmp(b + kvd_off + 4, kv, sizeof kv));
    CHECK(kvd_len == 4 + ((sizeof kv + 3) / 4) * 4);
    /* texels: face 1 (-X) texel 2 of level 0 (row 1, column 0), and level 1's face 0 */
    const float *src = l0 + 3 * (4 * 1 + 2);
    const uint8_t *t = b + off0 + block * (4 * 1 + 2);
    for (int c = 0; c < 4; c++) {
        float want = c == 3 ? 1.0f : src[c];
        uint32_t bits;
        memcpy(&bits, &want, 4);
        if (half)
            CHECK(get16(t + 2 * c) == envl__half_from_float(want));
        else
            CHECK(get32(t + 4 * c) == bits);
    }
    if (half) {
        CHECK(get16(b + off0 + block * 1 + 2 * 2) == 0x7BFF);  /* l0[5]: texel 1, B */
        CHECK(get16(b + off0 + block * 2 + 2 * 0) == 0x7BFF);  /* l0[6] = inf: texel 2, R */
    } else {
        CHECK(get32(b + off0 + block * 1 + 4 * 2) == 0x49742400u); /* 1e6f exactly */
        CHECK(get32(b + off0 + block * 2) == 0x7F7FFFFFu);         /* inf -> FLT_MAX */
    }
    /* l1[2] = NaN -> +0 (B of texel 0) */
    CHECK(half ? get16(b + off1 + 4) == 0 : get32(b + off1 + 8) == 0);
    free(b);
}

static void test_refusals(void)
{
    float px[3] = {1, 1, 1};
    const float *lv[2] = {px, px};
    const char *path = tmp_path("bad.ktx2");
    CHECK_RC(envl__write_ktx2(path, &(envl__ktx2_desc){.vk_format = 2, .size = 1, .faces = 1,
                                                       .levels = 1, .rgb = lv}, NULL),
             ENVL_ERR_ARGUMENT);
    CHECK_RC(envl__write_ktx2(path, &(envl__ktx2_desc){.vk_format = 97, .size = 1, .faces = 1,
                                                       .levels = 2, .rgb = lv}, NULL),
             ENVL_ERR_ARGUMENT); /* a 1-texel image has one level */
    CHECK_RC(envl__write_ktx2(path, &(envl__ktx2_desc){.vk_format = 97, .size = 1, .faces = 3,
                                                       .levels = 1, .rgb = lv}, NULL),
             ENVL_ERR_ARGUMENT);
}

int main(void)
{
    test_half_values();
    test_half_exhaustive();
    test_container(ENVL__VK_FORMAT_R16G16B16A16_SFLOAT);
    test_container(ENVL__VK_FORMAT_R32G32B32A32_SFLOAT);
    test_refusals();
    return check_report("test_ktx2");
}
