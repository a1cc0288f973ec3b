/* PFM: round trips, both byte orders, grey, and malformed headers. */
#include "internal.h"
#include "check.h"

static envl_result read_buf(const char *bytes, size_t n, envl_image *img)
{
    envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};
    return envl__read_pfm((const uint8_t *)bytes, n, "t.pfm", &lim, img);
}

static void test_round_trip(void)
{
    float px[3 * 3 * 2] = {0, 1, 2, 1e6f, 1e-30f, 3.5f, -1, 0.25f, 7, 8, 9, 10, 11, 12, 13,
                           65504, 1e30f, 0.1f};
    const char *path = tmp_path("rt.pfm");
    CHECK_OK(envl_image_save(path, px, 3, 2, NULL));
    envl_image img;
    envl_limits lim = {ENVL_DEFAULT_MAX_PIXELS, NULL, 0};
    CHECK_OK(envl__read_image_file(path, &lim, &img));
    CHECK(img.width == 3 && img.height == 2);
    CHECK(memcmp(img.px, px, sizeof px) == 0); /* bit-exact */
    CHECK(strcmp(img.meta.format, "pfm") == 0 && img.meta.channels == 3);
    envl__image_free(&img);
}

/* Big-endian (positive scale) grey, rows from the bottom: pixel (0,0) is the last row. */
static void test_big_endian_grey(void)
{
    char buf[64];
    int n = snprintf(buf, sizeof buf, "Pf\n2 2\n1.0\n");
    const uint8_t data[16] = {0x3f, 0x80, 0, 0,  0x40, 0, 0, 0,     /* bottom: 1, 2 */
                              0x40, 0x40, 0, 0,  0x40, 0x80, 0, 0}; /* top: 3, 4 */
    memcpy(buf + n, data, 16);
    envl_image img;
    CHECK_OK(read_buf(buf, n + 16, &img));
    CHECK(img.px[0] == 3 && img.px[1] == 3 && img.px[2] == 3);
    CHECK(img.px[3] == 4 && img.px[6] == 1 && img.px[9] == 2);
    CHECK(img.meta.channels == 1);
    envl__image_free(&img);
}

static void test_malformed(void)
{
    envl_image img;
    CHECK_RC(read_buf("P6\n1 1\n255\n", 11, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF\n0 1\n-1\n", 10, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF\n-3 1\n-1\n", 11, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF\n1 1\n0\n", 9, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF\n1 1\nabc\n", 11, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF\n1 1\n-1\nxxxx", 14, &img), ENVL_ERR_FORMAT); /* 4 of 12 bytes */
    CHECK(strstr(envl_last_error(), "t.pfm: PFM data truncated") != NULL);
    CHECK_RC(read_buf("PF\n1000000 1000000\n-1\n", 22, &img), ENVL_ERR_LIMIT);
    CHECK_RC(read_buf("PF\n99999999999999999999 1\n-1\n", 29, &img), ENVL_ERR_FORMAT);
    CHECK_RC(read_buf("PF", 2, &img), ENVL_ERR_FORMAT);
    /* every prefix of a valid file fails cleanly */
    char full[64];
    int n = snprintf(full, sizeof full, "PF\n1 1\n-1.0\n");
    memset(full + n, 0, 12);
    CHECK_OK(read_buf(full, n + 12, &img));
    envl__image_free(&img);
    for (int len = 0; len < n + 12; len++)
        CHECK_RC(read_buf(full, len, &img), ENVL_ERR_FORMAT);
}

int main(void)
{
    test_round_trip();
    test_big_endian_grey();
    test_malformed();
    return check_report("test_pfm");
}
