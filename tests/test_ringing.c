/* Negative pixels filled from the light around them (src/envmap/ringing.c, docs/methods.md,
 * "Negative pixels"): no value left negative, the file's signed sum of L dw kept, each window's
 * values changed by exactly the documented rule and nothing outside the window touched; a DWAB
 * file whose codec rang (written by OpenEXR's C++ library, tests/dwa_write.cpp) filled within
 * its 8 x 8 blocks, wherever the data window puts them. */
#include "internal.h"
#include "check.h"


static const double PI = 3.14159265358979323846;

enum { W = 64, H = 32 }; /* a small lat-long map: tiles of 8 x 8, 8 x 4 of them */

static float *sky_map(float sky)
{
    float *px = malloc(sizeof(float) * 3 * W * H);
    for (int i = 0; i < 3 * W * H; i++)
        px[i] = sky;
    return px;
}

static void put(float *px, int x, int y, float v)
{
    for (int k = 0; k < 3; k++)
        px[3 * (y * W + x) + k] = v;
}

/* Sum of L dw of channel 0 over the lat-long map (negative values included), in double. */
static double power_of(const float *px, int w, int h)
{
    double sum = 0.0;
    for (int y = 0; y < h; y++) {
        double row = 0.0;
        for (int x = 0; x < w; x++)
            row += px[3 * (y * w + x)];
        sum += row * envl_latlong_solid_angle(w, h, y);
    }
    return sum;
}

/* The rule, written again here by bisection: over the window's positive values the c with
 * sum of L dw min(c L, 1/2) = D (channel 0). */
static double gift_rate(const float *px, int x0, int x1, int y0, int y1, double deficit)
{
    double lo = 0.0, hi = 1.0;
    for (;;) { /* an upper bound first */
        double g = 0.0;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                double v = px[3 * (y * W + ((x % W) + W) % W)];
                if (v > 0)
                    g += v * envl_latlong_solid_angle(W, H, y) * fmin(hi * v, 0.5);
            }
        if (g >= deficit)
            break;
        hi *= 2.0;
    }
    for (int it = 0; it < 200; it++) {
        double c = 0.5 * (lo + hi), g = 0.0;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                double v = px[3 * (y * W + ((x % W) + W) % W)];
                if (v > 0)
                    g += v * envl_latlong_solid_angle(W, H, y) * fmin(c * v, 0.5);
            }
        if (g < deficit)
            lo = c;
        else
            hi = c;
    }
    return 0.5 * (lo + hi);
}

/* Loads px (W x H lat-long); checks no value is negative, the power is the signed sum (float
 * storage: each value rounded to 2^-24 relative, so the sum to 1e-6) and returns the map. */
static envl_envmap *load_checked(const float *px, envl_info *info)
{
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, W, H, 3, &(envl_load_options){.layout = 1}, &m));
    if (!m)
        return NULL;
    envl_envmap_info(m, info);
    const float *q = envl_envmap_pixels(m);
    int negative = 0;
    for (int i = 0; i < 3 * W * H; i++)
        negative += !(q[i] >= 0);
    CHECK(negative == 0);
    double signed_sum = power_of(px, W, H);
    CHECK_REL(info->signed_power[0], signed_sum, 1e-12);
    CHECK_REL(info->power[0], signed_sum, 1e-6);
    CHECK_REL(power_of(q, W, H), signed_sum, 1e-6);
    return m;
}

/* Every value of the loaded map outside columns [x0, x1) (modulo W) x rows [y0, y1) is the
 * input's, bit for bit; inside, negative values are 0 and positive ones L (1 - min(c L, 1/2)). */
static void check_window(const float *px, const float *q, int x0, int x1, int y0, int y1,
                         double c)
{
    int outside = 0, inside = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int in = y >= y0 && y < y1 && (((x - x0) % W) + W) % W < x1 - x0;
            for (int k = 0; k < 3; k++) {
                float v = px[3 * (y * W + x) + k], got = q[3 * (y * W + x) + k];
                if (!in) {
                    outside += got != v;
                    continue;
                }
                double want = v < 0 ? 0.0 : v * (1.0 - fmin(c * v, 0.5));
                inside += fabs(got - want) > 2e-7 * fabs(want) + 1e-30;
            }
        }
    CHECK(outside == 0);
    CHECK(inside == 0);
    if (outside || inside)
        fprintf(stderr, "  window [%d, %d) x [%d, %d): %d values changed outside, %d off inside\n",
                x0, x1, y0, y1, outside, inside);
}

/* Loads px and checks the filling of its one window, columns [x0, x1) (past the seam: modulo
 * W) x rows [y0, y1), of that deficit and width in pixels; returns c (-1 if the load failed). */
static double check_fill(const float *px, int x0, int x1, int y0, int y1, double deficit,
                         int width, envl_info *info)
{
    envl_envmap *m = load_checked(px, info);
    if (!m)
        return -1.0;
    double c = gift_rate(px, x0, x1, y0, y1, deficit);
    check_window(px, envl_envmap_pixels(m), x0, x1, y0, y1, c);
    CHECK(info->fill_window == width && info->unfilled_values == 0);
    CHECK_REL(info->filled_energy[1], deficit, 1e-12);
    envl_envmap_free(m);
    return c;
}

/* A sun with its ringing inside one 8 x 8 tile: filled from that tile alone, the sun giving
 * most (c L, capped at 1/2), the sky beside it nearly nothing. */
static void test_fill_in_tile(void)
{
    float *px = sky_map(1.0f);
    put(px, 27, 11, 1e4f);
    put(px, 26, 11, -500.0f), put(px, 28, 11, -500.0f);
    put(px, 27, 10, -500.0f), put(px, 27, 12, -500.0f);
    put(px, 25, 11, 100.0f), put(px, 29, 11, 100.0f);
    double deficit = 0.0;
    for (int y = 10; y <= 12; y++)
        deficit += (y == 11 ? 2 : 1) * 500.0 * envl_latlong_solid_angle(W, H, y);
    envl_info info;
    double c = check_fill(px, 24, 32, 8, 16, deficit, 8, &info);
    CHECK(c > 0 && c < 1e-3); /* a sky value of 1 loses less than 0.1 % */
    CHECK(info.negative_pixels == 4 && info.negative_min == -500.0);
    CHECK(info.added_energy[0] == 0.0);
    free(px);
}

/* Ringing lobes whose own tile holds too little light (the sky: 62 dw against 4 x 200 dw):
 * the window widens to the 3 x 3 tiles that reach the sun. */
static void test_fill_widens(void)
{
    float *px = sky_map(1.0f);
    put(px, 33, 12, 1e4f);                              /* tile (4, 1) */
    put(px, 30, 12, -100.0f), put(px, 29, 12, -100.0f); /* tile (3, 1) */
    envl_info info;
    check_fill(px, 16, 40, 0, 24, 200.0 * envl_latlong_solid_angle(W, H, 12), 24, &info);
    free(px);
}

/* Across the seam of a lat-long map: a negative value in column 0, the sun in column W - 1. */
static void test_fill_wraps(void)
{
    float *px = sky_map(1.0f);
    put(px, W - 1, 20, 1e4f);
    put(px, 0, 20, -300.0f);
    envl_info info;
    check_fill(px, -8, 16, 8, 32, 300.0 * envl_latlong_solid_angle(W, H, 20), 24, &info);
    free(px);
}

/* A dead pixel (-25) in an even sky, no sun: its tile (63 dw) cannot give 4 x 25 dw; the
 * 3 x 3 tiles can, each sky value losing the same small fraction. */
static void test_hot_pixel(void)
{
    float *px = sky_map(1.0f);
    put(px, 43, 18, -25.0f);
    envl_info info;
    double c = check_fill(px, 32, 56, 8, 32, 25.0 * envl_latlong_solid_angle(W, H, 18), 24,
                          &info);
    CHECK(c > 0 && c < 0.1); /* no sky value loses a tenth */
    free(px);
}

/* A negative value with no light within 72 pixels: set to 0, and what that adds is said. */
static void test_unfilled(void)
{
    enum { BW = 256, BH = 128 };
    float *px = calloc(3 * BW * BH, sizeof(float));
    for (int k = 0; k < 3; k++) {
        px[3 * (64 * BW + 10) + k] = -1.0f;
        px[3 * (64 * BW + 200) + k] = 50.0f; /* 66 columns away across the seam: 8 tiles */
    }
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, BW, BH, 3, &(envl_load_options){.layout = 1}, &m));
    if (m) {
        envl_info info;
        envl_envmap_info(m, &info);
        double dw = envl_latlong_solid_angle(BW, BH, 64);
        CHECK(info.unfilled_values == 3 && info.fill_window == 0);
        CHECK_REL(info.added_energy[0], dw, 1e-12);
        CHECK(info.filled_energy[0] == 0.0);
        CHECK_REL(info.signed_power[0], 49.0 * dw, 1e-12);
        CHECK_REL(info.power[0], 50.0 * dw, 1e-6); /* signed sum + what was added */
        CHECK(envl_envmap_pixels(m)[3 * (64 * BW + 10)] == 0.0f);
        CHECK(envl_envmap_pixels(m)[3 * (64 * BW + 200)] == 50.0f);
    }
    envl_envmap_free(m);
    free(px);
}

/* Negative values where a probe sees nothing (outside the disc) carry no light: set to 0 with
 * nothing moved or added. Pixel solid angles of every layout sum to 4 pi. */
static void test_layouts(void)
{
    enum { S = 32 };
    float px[3 * S * S];
    for (int i = 0; i < 3 * S * S; i++)
        px[i] = 1.0f;
    px[0] = px[1] = px[2] = -7.0f; /* the corner: outside the disc */
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, S, S, 3, &(envl_load_options){.layout = 2}, &m));
    if (m) {
        envl_info info;
        envl_envmap_info(m, &info);
        CHECK(info.negative_pixels == 1 && info.unfilled_values == 0);
        CHECK(info.filled_energy[0] == 0.0 && info.added_energy[0] == 0.0);
        CHECK(info.fill_window == 0);
    }
    envl_envmap_free(m);
    /* the sums: lat-long exact; the others the midpoint (OpenEXR's: trapezoid) rule, whose
     * error goes as the step squared: measured 3e-7 .. 2.1e-4 at these sizes, bounded by 5e-4 */
    const int sizes[][3] = {
        {ENVL_LAYOUT_LATLONG, 64, 32},    {ENVL_LAYOUT_ANGULAR, 256, 256},
        {ENVL_LAYOUT_MIRRORBALL, 256, 256}, {ENVL_LAYOUT_CROSS_V, 192, 256},
        {ENVL_LAYOUT_CROSS_H, 256, 192},  {ENVL_LAYOUT_STRIP_H, 384, 64},
        {ENVL_LAYOUT_STRIP_V, 64, 384},   {ENVL_LAYOUT_EXR_LATLONG, 128, 64},
        {ENVL_LAYOUT_EXR_CUBE, 64, 384}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        double sum = 0.0;
        for (int j = 0; j < sizes[s][2]; j++)
            for (int i = 0; i < sizes[s][1]; i++)
                sum += envl__layout_pixel_solid_angle(sizes[s][0], sizes[s][1], sizes[s][2], i, j);
        CHECK_REL(sum, 4 * PI, sizes[s][0] == ENVL_LAYOUT_LATLONG ? 1e-12 : 5e-4);
        if (fabs(sum / (4 * PI) - 1) > 5e-4)
            fprintf(stderr, "  %s: pixel solid angles sum to 4 pi x %.6f\n",
                    envl_layout_name(sizes[s][0]), sum / (4 * PI));
    }
}

/* A point light of 1e4 on a black 16 x 8 sky, DWAB at level 10000: the 8 x 8 DCT of its block
 * rings (values down to about -0.4). The display window is the data window moved by (ox, oy),
 * so the codec's blocks start at (-ox, -oy) of the image read: every value changed lies inside
 * the sun's block, filled from it alone. */
static void test_dwab_file(int ox, int oy)
{
    const char *path = tmp_path("ringing_sun.exr");
    if (run_command("'%s' '%s' dwab 10000 --sun 16 8 0 3 2 10000 %d %d", ENVL_DWA_WRITE, path, ox,
            oy) != 0) {
        CHECK(!"dwa_write wrote the file");
        return;
    }
    envl_image raw;
    CHECK_OK(envl__read_image_file(path, &(envl_limits){ENVL_DEFAULT_MAX_PIXELS, NULL, 0},
                                   &raw));
    if (!raw.px)
        return;
    CHECK(raw.meta.block_x0 == ((-ox) % 8 + 8) % 8 && raw.meta.block_y0 == ((-oy) % 8 + 8) % 8);
    int negative = 0;
    double signed_sum[3] = {0, 0, 0};
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 16; x++)
            for (int k = 0; k < 3; k++) {
                float v = raw.px[3 * (y * 16 + x) + k];
                negative += v < 0;
                signed_sum[k] += v * envl_latlong_solid_angle(16, 8, y);
            }
    CHECK(negative > 0); /* the codec rang (OpenEXR 3.1's DWAB) */
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_load(path, NULL, &m));
    if (m) {
        envl_info info;
        envl_envmap_info(m, &info);
        const float *q = envl_envmap_pixels(m);
        int changed_outside = 0, left_negative = 0;
        for (int y = 0; y < 8; y++)
            for (int x = 0; x < 16; x++)
                for (int k = 0; k < 3; k++) {
                    float v = raw.px[3 * (y * 16 + x) + k], got = q[3 * (y * 16 + x) + k];
                    /* the sun's block: data (0..7, 0..7) = display (-ox .. 7 - ox, ...) */
                    int in = x + ox >= 0 && x + ox < 8 && y + oy >= 0 && y + oy < 8;
                    changed_outside += !in && got != v;
                    left_negative += got < 0;
                }
        CHECK(left_negative == 0);
        CHECK(changed_outside == 0);
        CHECK(info.fill_window == 8);
        for (int k = 0; k < 3; k++) {
            CHECK_REL(info.signed_power[k], signed_sum[k], 1e-12);
            CHECK_REL(info.power[k], signed_sum[k], 1e-6);
        }
    }
    envl_envmap_free(m);
    envl__image_free(&raw);
}

int main(void)
{
    test_fill_in_tile();
    test_fill_widens();
    test_fill_wraps();
    test_hot_pixel();
    test_unfilled();
    test_layouts();
    test_dwab_file(0, 0);
    test_dwab_file(-3, -2);
    return check_report("test_ringing");
}
