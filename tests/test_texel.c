/* The texels of a product and their error (docs/design.md, "Error measures": the per-texel
 * error; layout.c, texel_error.c): the cube faces' exact solid angles add up to 4 pi, each
 * texel's centre lies on its own face, the faces re-laid as OpenGL's strip or the cross are
 * the same texels (nothing resampled), and envl__texel_error states what its definition gives
 * for products made here from the brute force: a known error at one texel, a dark texel
 * measured against the floor, a product with more texels than it measures. */
#include "internal.h"
#include "check.h"
#include "error_measure.h"

/* Sum of the texels' solid angles of a product image. */
static double total_solid_angle(int32_t layout, int32_t w, int32_t h)
{
    double s = 0;
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++)
            s += envl__texel_solid_angle(layout, w, h, c, r);
    return s;
}

/* Solid angles: exact (the corner formula), so the faces hold 4 pi to rounding; so do the
 * lat-long rows. A face's centre texel of an odd face is the largest, its corner texel the
 * smallest (the gnomonic projection shrinks towards the corners by (1 + s^2 + t^2)^-3/2). */
static void test_geometry(void)
{
    static const int32_t faces[4] = {1, 3, 16, 33};
    for (int i = 0; i < 4; i++) {
        int32_t f = faces[i];
        CHECK_NEAR(total_solid_angle(ENVL_LAYOUT_STRIP_H, 6 * f, f), 4 * M_PI, 1e-12);
        CHECK_NEAR(total_solid_angle(ENVL_LAYOUT_LATLONG, 4 * f, 2 * f), 4 * M_PI, 1e-12);
    }
    CHECK(envl__texel_solid_angle(ENVL_LAYOUT_STRIP_H, 6 * 33, 33, 16, 16) >
          envl__texel_solid_angle(ENVL_LAYOUT_STRIP_H, 6 * 33, 33, 0, 0));
    /* every texel's centre is on its face: the face's axis is the largest component, with
     * its sign (strip order px nx py ny pz nz), and the direction is a unit vector */
    const int axis[6] = {0, 0, 1, 1, 2, 2};
    const double sign[6] = {1, -1, 1, -1, 1, -1};
    int32_t f = 8;
    for (int32_t r = 0; r < f; r++)
        for (int32_t c = 0; c < 6 * f; c++) {
            double d[3];
            envl__texel_direction(ENVL_LAYOUT_STRIP_H, 6 * f, f, c, r, d);
            int k = c / f, a = axis[k];
            CHECK_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-14);
            CHECK(sign[k] * d[a] > fabs(d[(a + 1) % 3]) && sign[k] * d[a] > fabs(d[(a + 2) % 3]));
        }
}

/* A strip whose texels hold their own centre direction (+ 2, so every value is positive),
 * re-laid as OpenGL's faces of the glTF frame and as the vertical cross: every output texel
 * holds the direction of its own centre, read here from OpenGL's face table (glTF's (x, y, z)
 * is Blender's (x, -z, y)) and from the cross's geometry (docs/design.md), exactly: the texels
 * are moved, not resampled. */
static void test_relayout(void)
{
    int32_t f = 5;
    float *strip = malloc(sizeof(float) * 3 * 6 * f * f);
    for (int32_t r = 0; r < f; r++)
        for (int32_t c = 0; c < 6 * f; c++) {
            double d[3];
            envl__texel_direction(ENVL_LAYOUT_STRIP_H, 6 * f, f, c, r, d);
            for (int k = 0; k < 3; k++)
                strip[3 * (r * 6 * f + c) + k] = (float)(d[k] + 2);
        }
    envl_image gl, cross;
    CHECK_OK(envl__faces_to_layout(strip, f, ENVL__LAYOUT_GL_STRIP, &gl));
    CHECK(gl.width == 6 * f && gl.height == f);
    for (int32_t g = 0; g < 6; g++)
        for (int32_t j = 0; j < f; j++)
            for (int32_t i = 0; i < f; i++) {
                double sc = 2 * (i + 0.5) / f - 1, tc = 2 * (j + 0.5) / f - 1, q[3];
                const double t[6][3] = {{1, -tc, -sc}, {-1, -tc, sc}, {sc, 1, tc},
                                        {sc, -1, -tc}, {sc, -tc, 1}, {-sc, -tc, -1}};
                double n = sqrt(t[g][0] * t[g][0] + t[g][1] * t[g][1] + t[g][2] * t[g][2]);
                q[0] = t[g][0] / n, q[1] = -t[g][2] / n, q[2] = t[g][1] / n; /* to Blender's */
                const float *v = gl.px + 3 * ((size_t)j * 6 * f + (size_t)g * f + i);
                for (int k = 0; k < 3; k++)
                    CHECK_NEAR(v[k], (float)(q[k] + 2), 0);
            }
    CHECK_OK(envl__faces_to_layout(strip, f, ENVL_LAYOUT_CROSS_V, &cross));
    CHECK(cross.width == 3 * f && cross.height == 4 * f);
    /* cells (row, column) of the cross: centre, right, up of each face; empty cells are 0 */
    const int cell[6][2] = {{0, 1}, {1, 0}, {1, 1}, {1, 2}, {2, 1}, {3, 1}};
    const double fr[6][3][3] = {{{0, 0, 1}, {0, -1, 0}, {-1, 0, 0}},  /* top */
                                {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},    /* left */
                                {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}},   /* front */
                                {{0, -1, 0}, {-1, 0, 0}, {0, 0, 1}},  /* right */
                                {{0, 0, -1}, {0, -1, 0}, {1, 0, 0}},  /* bottom */
                                {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}}}; /* back, turned */
    double filled = 0;
    for (int k = 0; k < 6; k++)
        for (int32_t j = 0; j < f; j++)
            for (int32_t i = 0; i < f; i++) {
                double s = 2 * (i + 0.5) / f - 1, t = 1 - 2 * (j + 0.5) / f, d[3];
                for (int a = 0; a < 3; a++)
                    d[a] = fr[k][0][a] + s * fr[k][1][a] + t * fr[k][2][a];
                double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                const float *v = cross.px + 3 * ((size_t)(cell[k][0] * f + j) * 3 * f +
                                                 (size_t)cell[k][1] * f + i);
                for (int a = 0; a < 3; a++)
                    CHECK_NEAR(v[a], (float)(d[a] / n + 2), 0);
            }
    for (size_t i = 0; i < (size_t)3 * 3 * f * 4 * f; i++)
        filled += cross.px[i] != 0;
    CHECK_NEAR(filled, 3.0 * 6 * f * f, 0); /* the six empty cells stay 0 */
    envl__image_free(&gl);
    envl__image_free(&cross);
    free(strip);
}

/* A w x h lat-long map of `above` over the horizon and `below` under it (takes px). */
static envl_envmap *two_halves(int32_t w, int32_t h, float above, float below, float **px)
{
    *px = malloc(sizeof(float) * 3 * w * h);
    for (int32_t i = 0; i < 3 * w * h; i++)
        (*px)[i] = i / 3 / w < h / 2 ? above : below;
    envl_envmap *m = NULL;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(*px, w, h, 3, &lo, &m));
    return m;
}

/* The exact irradiance (the brute force) at every texel of a product image. */
static float *exact_product(envl_envmap *m, int32_t layout, int32_t w, int32_t h)
{
    double *d = calloc(3 * (size_t)w * h, sizeof(double)), *e = malloc(sizeof(double) * 3 * w * h);
    float *px = malloc(sizeof(float) * 3 * w * h);
    for (int32_t r = 0; r < h; r++)
        for (int32_t c = 0; c < w; c++)
            envl__texel_direction(layout, w, h, c, r, d + 3 * (r * w + c));
    CHECK_OK(envl_irradiance_exact(m, w * h, d, e));
    for (int32_t i = 0; i < 3 * w * h; i++)
        px[i] = (float)e[i];
    free(d);
    free(e);
    return px;
}

/* The definition: e = (Y - Y_exact) / max(Y_exact, 0.01 x the mean of E over the sphere, the
 * power / 4). A product equal to the brute force but 1 % high at one texel: worst 1 %, RMS
 * 0.01 sqrt(omega_t / 4 pi), both to the reference's 1e-3 of the value (plus float
 * rounding); a texel where E = 0 (facing straight down) holding 1e-3 of the mean: e = 0.1
 * (against the floor, 1e-2 of the mean), not infinite. */
static void test_definition(void)
{
    float *map_px;
    envl_envmap *m = two_halves(64, 32, 1.0f, 0.0f, &map_px); /* E(-Z) = 0: the floor */
    free(map_px);
    envl_info info;
    envl_envmap_info(m, &info);
    double mean = envl_luminance(info.power[0], info.power[1], info.power[2]) / 4;
    int32_t layout[2] = {ENVL_LAYOUT_LATLONG, ENVL_LAYOUT_STRIP_H};
    int32_t size[2][2] = {{16, 8}, {6 * 8, 8}};
    for (int l = 0; l < 2; l++) {
        int32_t w = size[l][0], h = size[l][1], t = w * h / 3 + 1; /* a texel above the horizon */
        float *px = exact_product(m, layout[l], w, h);
        envl_texel_error te;
        CHECK_OK(envl__texel_error(m, NULL, px, layout[l], w, h, NULL, 0, -1, &te));
        CHECK(te.measured == w * h && te.texels == w * h);
        CHECK_NEAR(te.worst, 0, 1e-3);
        for (int k = 0; k < 3; k++)
            px[3 * t + k] *= 1.01f;
        CHECK_OK(envl__texel_error(m, NULL, px, layout[l], w, h, NULL, 0, -1, &te));
        double om = envl__texel_solid_angle(layout[l], w, h, t % w, t / w);
        CHECK_NEAR(te.worst, 0.01, 1e-3 * 1.01 + 1e-6);
        CHECK_NEAR(te.rms, 0.01 * sqrt(om / (4 * M_PI)), 1e-3);
        double d[3];
        envl__texel_direction(layout[l], w, h, t % w, t / w, d);
        CHECK_NEAR(te.worst_direction[0], d[0], 0);
        CHECK_NEAR(te.worst_direction[2], d[2], 0);
        free(px);
    }
    /* a face texel facing down (the bottom face's centre, 3 x 3 face) lit by nothing */
    float *px = exact_product(m, ENVL_LAYOUT_STRIP_H, 18, 3);
    int32_t t = 1 * 18 + 5 * 3 + 1; /* row 1, face 5 (nz), its column 1 */
    double d[3];
    envl__texel_direction(ENVL_LAYOUT_STRIP_H, 18, 3, t % 18, t / 18, d);
    CHECK_NEAR(d[2], -1, 1e-15);
    CHECK_NEAR(px[3 * t + 1], 0, 0);
    for (int k = 0; k < 3; k++)
        px[3 * t + k] = (float)(1e-3 * mean);
    envl_texel_error te;
    CHECK_OK(envl__texel_error(m, NULL, px, ENVL_LAYOUT_STRIP_H, 18, 3, NULL, 0, -1, &te));
    CHECK_NEAR(te.worst, 0.1, 1e-3 * 1.1 + 1e-6);
    free(px);
    envl_envmap_free(m);
}

/* A product with more texels than ENVL_TEXEL_SAMPLES measures that many, says so, and (a
 * constant map, every texel exact) finds nothing wrong; at roughness > 0 the same through
 * the glossy reference. */
static void test_samples(void)
{
    int32_t w = 256, h = 128;
    float *px;
    envl_envmap *m = two_halves(w, h, 0.5f, 0.5f, &px);
    envl_texel_error te;
    CHECK_OK(envl__texel_error(m, NULL, px, ENVL_LAYOUT_LATLONG, w, h, NULL, 0, 0.5, &te));
    CHECK(te.measured == ENVL_TEXEL_SAMPLES && te.texels == w * h);
    CHECK_NEAR(te.worst, 0, 1e-5); /* a constant map: P = L at every R, to float rounding */
    CHECK_NEAR(te.rms, 0, 1e-5);
    envl_envmap_free(m);
    free(px);
}

int main(void)
{
    test_geometry();
    test_relayout();
    test_definition();
    test_samples();
    return check_report("test_texel");
}
