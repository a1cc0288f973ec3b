/* The canonical frame, solid angles, sanitising, rotation and resampling of the envmap. */
#include "internal.h"
#include "check.h"

static const double PI = 3.14159265358979323846;

static double luminance_power(const envl_envmap *m)
{
    envl_info info;
    envl_envmap_info(m, &info);
    return envl_luminance(info.power[0], info.power[1], info.power[2]);
}

/* Solid angles of all pixels sum to 4 pi (docs/design.md formula telescopes): relative 1e-9. */
static void test_solid_angles(void)
{
    const int sizes[][2] = {{1, 1}, {2, 1}, {8192, 1}, {3, 7}, {512, 256}, {1024, 512}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        double sum = 0;
        for (int r = 0; r < h; r++)
            sum += w * envl_latlong_solid_angle(w, h, r);
        CHECK_REL(sum, 4 * PI, 1e-9);
    }
}

/* docs/design.md: u = 0.5 -> +X, u = 0.25 -> +Y, u = 0.75 -> -Y, u = 0 -> -X, top row -> +Z. */
static void test_directions(void)
{
    double d[3], c, r;
    envl_latlong_direction(1024, 512, 511.5, 255.5, d); /* u = 0.5, v = 0.5 */
    CHECK_NEAR(d[0], 1, 1e-12);
    CHECK_NEAR(d[1], 0, 1e-12);
    CHECK_NEAR(d[2], 0, 1e-12);
    envl_latlong_direction(1024, 512, 255.5, 255.5, d); /* u = 0.25 */
    CHECK_NEAR(d[1], 1, 1e-12);
    envl_latlong_direction(1024, 512, 767.5, 255.5, d); /* u = 0.75 */
    CHECK_NEAR(d[1], -1, 1e-12);
    envl_latlong_direction(1024, 512, -0.5, 255.5, d); /* u = 0 */
    CHECK_NEAR(d[0], -1, 1e-12);
    envl_latlong_direction(1024, 512, 100, -0.5, d); /* v = 0: the zenith */
    CHECK_NEAR(d[2], 1, 1e-12);
    /* envl_latlong_pixel inverts envl_latlong_direction. */
    for (int i = 0; i < 50; i++) {
        double cc = (i * 37) % 1024 + 0.25, rr = (i * 11) % 512 + 0.75;
        envl_latlong_direction(1024, 512, cc, rr, d);
        envl_latlong_pixel(1024, 512, d, &c, &r);
        CHECK_NEAR(c, cc, 1e-9);
        CHECK_NEAR(r, rr, 1e-9);
    }
}

/* A one-pixel spot at a known pixel: brightest_direction is that pixel's docs/design.md direction,
 * power is L * omega of its row. */
static void test_spot(void)
{
    const int w = 64, h = 32, c0 = 40, r0 = 9;
    float *px = calloc((size_t)w * h * 3, sizeof(float));
    for (int k = 0; k < 3; k++)
        px[3 * (r0 * w + c0) + k] = 1000.0f;
    envl_envmap *m;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
    envl_info info;
    envl_envmap_info(m, &info);
    double u = (c0 + 0.5) / w, v = (r0 + 0.5) / h;
    double phi = PI * (1 - 2 * u), theta = PI * (0.5 - v);
    CHECK_NEAR(info.brightest_direction[0], cos(theta) * cos(phi), 1e-12);
    CHECK_NEAR(info.brightest_direction[1], cos(theta) * sin(phi), 1e-12);
    CHECK_NEAR(info.brightest_direction[2], sin(theta), 1e-12);
    CHECK_REL(info.power[0], 1000.0 * envl_latlong_solid_angle(w, h, r0), 1e-12);
    CHECK_NEAR(info.mean[1], info.power[1] / (4 * PI), 1e-15);
    /* Rotating by 90 degrees about +Z moves the spot from phi to phi + 90 degrees. */
    envl_envmap *rot;
    o.rotate_degrees = 90;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &rot));
    envl_envmap_info(rot, &info);
    CHECK_NEAR(info.brightest_direction[0], cos(theta) * cos(phi + PI / 2), 1e-12);
    CHECK_NEAR(info.brightest_direction[1], cos(theta) * sin(phi + PI / 2), 1e-12);
    CHECK_REL(luminance_power(rot), luminance_power(m), 1e-7);
    /* A quarter-pixel turn spreads the spot over two pixels and keeps its power. */
    envl_envmap_free(rot);
    o.rotate_degrees = 360.0 / w / 4;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &rot));
    const float *q = envl_envmap_pixels(rot);
    /* The output at u samples the input at u + a/360: column c0-1 takes a quarter. */
    CHECK_NEAR(q[3 * (r0 * w + c0)], 750.0, 1e-3);
    CHECK_NEAR(q[3 * (r0 * w + c0 - 1)], 250.0, 1e-3);
    CHECK_REL(luminance_power(rot), luminance_power(m), 1e-7);
    envl_envmap_free(rot);
    envl_envmap_free(m);
    free(px);
}

/* n floats of a fixed pseudo-random sequence (the C standard's example LCG from `seed`), each
 * in [0, 100) in steps of 100 / steps: a map with detail everywhere, the same on every machine. */
static void random_pixels(float *px, size_t n, unsigned seed, unsigned steps)
{
    unsigned s = seed;
    for (size_t i = 0; i < n; i++) {
        s = s * 1103515245u + 12345u;
        px[i] = (float)((s >> 8) % steps) / (float)(steps / 100);
    }
}

/* Resampling to other sizes keeps the integral of L dw (area weights are exact). */
static void test_resample_power(void)
{
    const int w = 200, h = 100;
    float *px = malloc(sizeof(float) * w * h * 3);
    random_pixels(px, (size_t)w * h * 3, 12345u, 1000);
    px[3 * (17 * w + 3)] = 1e6f; /* a sun */
    envl_envmap *ref;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &ref));
    const int widths[] = {1, 2, 3, 64, 199, 256, 1000};
    for (size_t i = 0; i < sizeof widths / sizeof widths[0]; i++) {
        envl_envmap *m;
        o.width = widths[i];
        o.rotate_degrees = 17.3 * i;
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
        /* The aspect ratio of a lat-long input is kept: height = round(width * h / w). */
        CHECK(envl_envmap_height(m) == (int)fmax(1, llround(widths[i] * (double)h / w)));
        /* Float outputs: each pixel rounds at 2^-24 relative; sums in double. */
        CHECK_REL(luminance_power(m), luminance_power(ref), 1e-6);
        envl_envmap_free(m);
    }
    envl_envmap_free(ref);
    free(px);
}

/* NaN -> 0, +Inf -> largest finite value, a negative value with too little light around it
 * (ringing.c; test_ringing has the filling) -> 0; counted and reported; strict refuses. */
static void test_sanitise(void)
{
    float px[4 * 2 * 3] = {0};
    for (int i = 0; i < 24; i++)
        px[i] = 1.0f;
    px[0] = NAN;
    px[4] = INFINITY;
    px[8] = -2.0f;
    px[9] = -INFINITY; /* same pixel: one negative/non-finite pixel */
    px[12] = 7.0f;
    envl_envmap *m;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, 4, 2, 3, &o, &m));
    envl_info info;
    envl_envmap_info(m, &info);
    CHECK(info.nonfinite_pixels == 3);
    CHECK(info.negative_pixels == 1);
    CHECK(info.infinity_value == 7.0 && info.negative_min == -2.0);
    /* the -2 (blue) beside seven 1s: less than 4 x its deficit around it, so set to 0 */
    CHECK(info.unfilled_values == 1 && info.fill_window == 0);
    CHECK_REL(info.added_energy[2], 2.0 * envl_latlong_solid_angle(4, 2, 1), 1e-12);
    const float *q = envl_envmap_pixels(m);
    CHECK(q[0] == 0.0f);
    CHECK(q[4] == 7.0f);
    CHECK(q[8] == 0.0f && q[9] == 0.0f);
    for (int i = 0; i < 24; i++)
        CHECK(isfinite(q[i]) && q[i] >= 0);
    envl_envmap_free(m);
    o.strict = 1;
    CHECK_RC(envl_envmap_from_pixels(px, 4, 2, 3, &o, &m), ENVL_ERR_NONFINITE);
    CHECK(m == NULL);
    CHECK(strstr(envl_last_error(), "3 pixels with NaN or Inf") != NULL);
}

/* +Inf stands for the largest finite value of the file; with none positive (all +Inf, or +Inf
 * over black) nothing can stand for it: an error naming the count, not a black map. */
static void test_infinite(void)
{
    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = INFINITY;
    envl_envmap *m = (envl_envmap *)1;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_RC(envl_envmap_from_pixels(px, 4, 2, 3, &o, &m), ENVL_ERR_NONFINITE);
    CHECK(m == NULL);
    CHECK(strstr(envl_last_error(), "8 pixels are +Inf and no value is positive and finite"));
    for (int i = 3; i < 24; i++)
        px[i] = i % 2 ? 0.0f : NAN;
    CHECK_RC(envl_envmap_from_pixels(px, 4, 2, 3, &o, &m), ENVL_ERR_NONFINITE);
    CHECK(strstr(envl_last_error(), "1 pixels are +Inf"));
    px[23] = 2.5f;
    CHECK_OK(envl_envmap_from_pixels(px, 4, 2, 3, &o, &m));
    if (m) {
        envl_info info;
        envl_envmap_info(m, &info);
        CHECK(info.infinity_value == 2.5);
        CHECK(envl_envmap_pixels(m)[0] == 2.5f && envl_envmap_pixels(m)[2] == 2.5f);
    }
    envl_envmap_free(m);
}

static void test_arguments(void)
{
    envl_envmap *m = (envl_envmap *)1;
    float px[3] = {1, 1, 1};
    CHECK_RC(envl_envmap_from_pixels(NULL, 1, 1, 3, NULL, &m), ENVL_ERR_ARGUMENT);
    CHECK(m == NULL);
    CHECK_RC(envl_envmap_from_pixels(px, 1, 1, 2, NULL, &m), ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_envmap_from_pixels(px, 0, 1, 3, NULL, &m), ENVL_ERR_FORMAT);
    envl_load_options o = {.max_pixels = 100};
    CHECK_RC(envl_envmap_from_pixels(px, 1000, 1000, 3, &o, &m), ENVL_ERR_LIMIT);
    /* a width whose W x W/2 map is over max_pixels: refused before any allocation (40000
     * wide was 9.6 GB), with the default limit 2^28 too */
    CHECK_RC(envl_envmap_from_pixels(px, 1, 1, 3, &(envl_load_options){.width = 40000}, &m),
             ENVL_ERR_LIMIT);
    CHECK(strstr(envl_last_error(), "width 40000 makes a 40000 x 20000 map") != NULL);
    CHECK_RC(envl_envmap_from_pixels(px, 1, 1, 3, &(envl_load_options){.width = 20,
                                                                       .max_pixels = 199}, &m),
             ENVL_ERR_LIMIT);
    CHECK_OK(envl_envmap_from_pixels(px, 1, 1, 3, &(envl_load_options){.width = 20,
                                                                       .max_pixels = 200}, &m));
    envl_envmap_free(m);
    CHECK_RC(envl_envmap_load("/nonexistent/x.hdr", NULL, &m), ENVL_ERR_IO);
    CHECK(strstr(envl_last_error(), "/nonexistent/x.hdr") != NULL);
    CHECK_RC(envl_envmap_load("/", NULL, &m), ENVL_ERR_IO);
    CHECK(strcmp(envl_result_name(ENVL_ERR_LIMIT), "ENVL_ERR_LIMIT") == 0);
    CHECK(strcmp(envl_result_name(999), "ENVL_UNKNOWN") == 0);
    CHECK(envl_abi_version() == ENVL_ABI_VERSION);
    envl_envmap_free(NULL);
    /* 1x1 and 2x1 lat-long maps: the whole sphere in one or two pixels. */
    CHECK_OK(envl_envmap_from_pixels(px, 1, 1, 3, &(envl_load_options){.layout = 1}, &m));
    CHECK_REL(envl_envmap_solid_angle(m, 0), 4 * PI, 1e-12);
    /* a bad albedo names itself (the message of an earlier failure used to show) */
    envl_envmap *g = (envl_envmap *)1;
    CHECK_RC(envl_ground_plane_map(m, 1.5, 1, &g, NULL), ENVL_ERR_ARGUMENT);
    CHECK(g == NULL && strstr(envl_last_error(), "albedo 1.5") != NULL);
    envl_envmap_free(m);
}

/* Writing an empty file leaves nothing half-written: a failed save keeps the old file. */
static void test_atomic_save(void)
{
    const char *path = tmp_path("atomic.pfm");
    float px[6] = {1, 2, 3, 4, 5, 6};
    CHECK_OK(envl_image_save(path, px, 2, 1, NULL));
    uint8_t *before;
    size_t nb;
    CHECK_OK(envl__read_file(path, 1 << 20, &before, &nb));
    CHECK_RC(envl_image_save(path, px, 2, 1, &(envl_save_options){.format = "bogus"}),
             ENVL_ERR_ARGUMENT);
    CHECK_RC(envl_image_save(tmp_path("no/such/dir/x.pfm"), px, 2, 1, NULL), ENVL_ERR_IO);
    uint8_t *after;
    size_t na;
    CHECK_OK(envl__read_file(path, 1 << 20, &after, &na));
    CHECK(na == nb && memcmp(before, after, nb) == 0);
    free(before);
    free(after);
}

/* Resampling with a few pixels patched (resample.c) gives what resampling a patched copy gives,
 * bit for bit: down, the same size (plain, and turned), up, odd sizes; patches in the first
 * and last rows, on the seam, several in one row. */
static void test_resample_patched(void)
{
    const int w = 200, h = 100;
    float *px = malloc(sizeof(float) * w * h * 3), *copy = malloc(sizeof(float) * w * h * 3);
    random_pixels(px, (size_t)w * h * 3, 777u, 1000);
    envl_pixel_patch patch[8] = {{0, 0, {1e5f, 2e5f, 3e5f}},  {0, 199, {7, 8, 9}},
                                 {17, 3, {1e6f, 0, 0}},        {17, 4, {0, 1e6f, 0}},
                                 {17, 150, {0, 0, 1e6f}},      {50, 100, {0.5f, 0.25f, 0.125f}},
                                 {98, 42, {3e4f, 3e4f, 3e4f}}, {99, 199, {11, 12, 13}}};
    memcpy(copy, px, sizeof(float) * w * h * 3);
    for (int i = 0; i < 8; i++)
        memcpy(copy + 3 * (patch[i].r * w + patch[i].c), patch[i].rgb, sizeof patch[i].rgb);
    const struct { int w, h; double rot; } out[] = {{64, 32, 0}, {200, 100, 0}, {200, 100, 33.3},
                                                    {1000, 500, 0}, {199, 37, 12}, {1, 1, 0}};
    for (size_t k = 0; k < sizeof out / sizeof *out; k++) {
        float *a = NULL, *b = NULL;
        CHECK_OK(envl__latlong_resample(copy, w, h, out[k].w, out[k].h, out[k].rot, &a));
        CHECK_OK(envl__latlong_resample_patched(px, w, h, patch, 8, out[k].w, out[k].h,
                                                out[k].rot, &b));
        CHECK(a && b && !memcmp(a, b, sizeof(float) * 3 * out[k].w * out[k].h));
        free(a);
        free(b);
    }
    free(px);
    free(copy);
}

/* Down by a whole factor with no turn, each output pixel is the mean of its input pixels summed
 * in order in double (the overlap loop's weights are all 1 there: resample.c's whole-pixel
 * path gives its floats), bit for bit. */
static void test_resample_whole_pixels(void)
{
    const int w = 200, h = 100, f = 4;
    float *px = malloc(sizeof(float) * w * h * 3), *out = NULL;
    random_pixels(px, (size_t)w * h * 3, 4242u, 100000);
    CHECK_OK(envl__latlong_resample(px, w, h, w / f, h, 0, &out));
    int differ = 0;
    for (int r = 0; out && r < h; r++)
        for (int c = 0; c < w / f; c++)
            for (int ch = 0; ch < 3; ch++) {
                double acc = 0;
                for (int j = 0; j < f; j++)
                    acc += 1.0 * px[3 * ((size_t)r * w + c * f + j) + ch];
                differ += out[3 * ((size_t)r * (w / f) + c) + ch] != (float)(acc / f);
            }
    CHECK(out && differ == 0);
    free(out);
    free(px);
}

/* The map's statistics (power, maxima, brightest pixel: rows in parallel, combined in row order)
 * are those of one plain pass, bit for bit, at 1 and 3 threads; the parallel look for NaN,
 * Inf and negative values finds one value of each at the far ends of the map. */
static void test_stats_threads(void)
{
    const int w = 300, h = 151;
    float *px = malloc(sizeof(float) * w * h * 3);
    random_pixels(px, (size_t)w * h * 3, 99u, 100000);
    px[3 * (70 * w + 12) + 1] = 1e4f;  /* the brightest, twice: the first counts */
    px[3 * (120 * w + 5) + 1] = 1e4f;
    double power[3] = {0, 0, 0};
    for (int r = 0; r < h; r++) {
        double row[3] = {0, 0, 0};
        for (int c = 0; c < w; c++)
            for (int k = 0; k < 3; k++)
                row[k] += px[3 * (r * w + c) + k];
        for (int k = 0; k < 3; k++)
            power[k] += row[k] * envl_latlong_solid_angle(w, h, r);
    }
    for (int32_t t = 1; t <= 3; t += 2) {
        envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG, .threads = t};
        envl_envmap *m;
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
        envl_info info;
        envl_envmap_info(m, &info);
        for (int k = 0; k < 3; k++)
            CHECK(info.power[k] == power[k]);
        CHECK(info.max[1] == 1e4);
        double d[3];
        envl_envmap_direction(m, 12, 70, d);
        CHECK(!memcmp(d, info.brightest_direction, sizeof d));
        envl_envmap_free(m);
    }
    px[0] = -1.0f;                           /* first value: negative */
    px[3 * w * h - 1] = NAN;                 /* last value: NaN */
    for (int32_t t = 1; t <= 3; t += 2) {
        envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG, .threads = t};
        envl_envmap *m;
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
        envl_info info;
        envl_envmap_info(m, &info);
        CHECK(info.negative_pixels == 1 && info.nonfinite_pixels == 1);
        envl_envmap_free(m);
    }
    free(px);
}

/* envl_envmap_adopt_pixels makes, in the memory it is given, the very map that
 * envl_envmap_from_pixels makes of the same pixels (bit for bit, info too): 1, 3 and 4
 * channels, top-down and bottom-up (odd and even heights: the middle row stays), a negative
 * value filled the same way; it frees the memory on a bad argument (ASan / Valgrind see a
 * leak otherwise) and refuses what envl_pixels_alloc refuses. */
static void test_adopt_pixels(void)
{
    const int w = 37;
    for (int h = 18; h <= 19; h++)
        for (int ch = 1; ch <= 4; ch++) {
            if (ch == 2)
                continue;
            for (int bottom_up = 0; bottom_up <= 1; bottom_up++) {
                size_t n = (size_t)w * h * ch;
                float *src = malloc(n * sizeof(float));
                random_pixels(src, n, 7u + (unsigned)(ch * 2 + bottom_up), 1000);
                src[ch * (5 * w + 3)] = -0.25f; /* one negative value to fill */
                float *top = malloc(n * sizeof(float));
                for (int r = 0; r < h; r++) /* the reference's rows top-down */
                    memcpy(top + (size_t)r * w * ch,
                           src + (size_t)(bottom_up ? h - 1 - r : r) * w * ch,
                           (size_t)w * ch * sizeof(float));
                envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG};
                envl_envmap *want, *got;
                CHECK_OK(envl_envmap_from_pixels(top, w, h, ch, &o, &want));
                float *mem;
                CHECK_OK(envl_pixels_alloc(w, h, ch, &o, &mem));
                memcpy(mem, src, n * sizeof(float));
                CHECK_OK(envl_envmap_adopt_pixels(mem, w, h, ch, bottom_up, &o, &got));
                CHECK(envl_envmap_width(got) == w && envl_envmap_height(got) == h);
                CHECK(!memcmp(envl_envmap_pixels(got), envl_envmap_pixels(want),
                              (size_t)w * h * 3 * sizeof(float)));
                envl_info a, b;
                envl_envmap_info(got, &a);
                envl_envmap_info(want, &b);
                CHECK(a.negative_pixels == 1 && b.negative_pixels == 1);
                CHECK(!memcmp(a.power, b.power, sizeof a.power));
                CHECK(!memcmp(a.filled_energy, b.filled_energy, sizeof a.filled_energy));
                CHECK(a.channels == ch && !strcmp(a.format, "memory"));
                envl_envmap_free(got);
                envl_envmap_free(want);
                free(top);
                free(src);
            }
        }
    float *mem;
    envl_envmap *m = (envl_envmap *)&mem;
    CHECK_RC(envl_pixels_alloc(4, 2, 2, NULL, &mem), ENVL_ERR_ARGUMENT);
    CHECK(mem == NULL);
    envl_load_options small = {.max_pixels = 7};
    CHECK_RC(envl_pixels_alloc(4, 2, 4, &small, &mem), ENVL_ERR_LIMIT);
    CHECK_OK(envl_pixels_alloc(4, 2, 4, NULL, &mem));
    CHECK_RC(envl_envmap_adopt_pixels(mem, 4, 2, 2, 0, NULL, &m), ENVL_ERR_ARGUMENT);
    CHECK(m == NULL); /* and mem freed */
    CHECK_OK(envl_pixels_alloc(4, 2, 4, NULL, &mem));
    CHECK_RC(envl_envmap_adopt_pixels(mem, 4, 2, 4, 0, &small, &m), ENVL_ERR_LIMIT);
    CHECK(strstr(envl_last_error(), "4 x 2") != NULL);
    CHECK_OK(envl_pixels_alloc(4, 2, 3, NULL, &mem));
    envl_pixels_free(mem);
    CHECK_RC(envl_envmap_adopt_pixels(NULL, 4, 2, 3, 0, NULL, &m), ENVL_ERR_ARGUMENT);
}

/* The sun method's residual as a view of the map's own pixels (gltf.c: no copy) is the copy
 * envl__lights_residual_map makes, bit for bit: pixels, info (power, maxima, brightest
 * direction) and the SH projected from it; afterwards the map's pixels are its own again, bit
 * for bit. Two suns (3 x 3 pixels of 1e5 and 2 x 2 of 5e4) on a random map. */
static void test_sun_residual_view(void)
{
    const int w = 256, h = 128;
    size_t n = (size_t)w * h * 3;
    float *px = malloc(sizeof(float) * n), *before = malloc(sizeof(float) * n);
    random_pixels(px, n, 4242u, 1000);
    for (int r = 30; r < 33; r++)
        for (int c = 40; c < 43; c++)
            px[3 * (r * w + c)] = px[3 * (r * w + c) + 1] = px[3 * (r * w + c) + 2] = 1e5f;
    for (int r = 50; r < 52; r++)
        for (int c = 200; c < 202; c++)
            px[3 * (r * w + c)] = px[3 * (r * w + c) + 1] = px[3 * (r * w + c) + 2] = 5e4f;
    envl_load_options o = {.layout = ENVL_LAYOUT_LATLONG, .threads = 2};
    envl_envmap *m = NULL, *copy = NULL, *view = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &o, &m));
    memcpy(before, envl_envmap_pixels(m), sizeof(float) * n);
    envl_lights_options lo = {.method = ENVL_METHOD_SUN, .count = 4, .skip_residual = 1};
    envl_lights *ls = NULL;
    CHECK_OK(envl_lights_compute(m, &lo, &ls));
    CHECK(envl_lights_count(ls) == 2);
    CHECK_OK(envl__lights_residual_map(m, ls, 2, &copy));
    float *saved = NULL;
    CHECK_OK(envl__sun_residual_view(m, ls, 2, &saved, &view));
    CHECK(envl_envmap_pixels(view) == envl_envmap_pixels(m)); /* borrowed, not copied */
    CHECK(!memcmp(envl_envmap_pixels(view), envl_envmap_pixels(copy), sizeof(float) * n));
    CHECK(memcmp(envl_envmap_pixels(view), before, sizeof(float) * n)); /* the suns are out */
    envl_info a, b;
    envl_envmap_info(view, &a);
    envl_envmap_info(copy, &b);
    CHECK(!memcmp(&a, &b, sizeof a));
    envl_sh_options so = {.order = 4};
    envl_sh *sa = NULL, *sb = NULL;
    CHECK_OK(envl_sh_compute(view, &so, &sa));
    CHECK_OK(envl_sh_compute(copy, &so, &sb));
    CHECK(!memcmp(envl_sh_radiance(sa), envl_sh_radiance(sb), sizeof(double) * 3 * 25));
    envl__sun_residual_view_end(m, ls, saved, view);
    CHECK(!memcmp(envl_envmap_pixels(m), before, sizeof(float) * n));
    envl_sh_free(sa);
    envl_sh_free(sb);
    envl_envmap_free(copy);
    envl_lights_free(ls);
    envl_envmap_free(m);
    free(px);
    free(before);
}

int main(void)
{
    test_adopt_pixels();
    test_solid_angles();
    test_directions();
    test_spot();
    test_resample_power();
    test_resample_patched();
    test_resample_whole_pixels();
    test_stats_threads();
    test_sun_residual_view();
    test_sanitise();
    test_infinite();
    test_arguments();
    test_atomic_save();
    return check_report("test_envmap");
}
