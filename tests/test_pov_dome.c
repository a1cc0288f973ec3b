/* The dome's lights (pov_dome.c) and their shapes (pov_area.c): a region of uniform radiance
 * lit through its grid gives every normal that sees the whole region exactly the region's
 * irradiance, the grid has the region's second moments, it stays on its side of the horizon;
 * the dome of the built-in sky holds the map's power, splits its sun off and cuts the ground
 * half apart only without a ground. Renders of the grids: tests/py_pov.py. */
#include "envlight.h"
#include "envmap_impl.h"
#include "pov_light.h"
#include "check.h"

#include <math.h>

#define W 256
#define H 128

/* A black map with the pixel rectangle [x0, x1) x [y0, y1) of radiance rgb. */
static envl_envmap *patch_map(int x0, int x1, int y0, int y1, const float rgb[3])
{
    static float px[W * H * 3];
    memset(px, 0, sizeof px);
    for (int r = y0; r < y1; r++)
        for (int c = x0; c < x1; c++)
            for (int ch = 0; ch < 3; ch++)
                px[3 * (r * W + c) + ch] = rgb[ch];
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, W, H, 3, &lo, &m));
    return m;
}

static void pixel_direction(const envl_envmap *m, int c, int r, double d[3])
{
    d[0] = m->row_cos[r] * m->col_cos[c];
    d[1] = m->row_cos[r] * m->col_sin[c];
    d[2] = m->row_sin[r];
}

/* The light of the patch as the library's cuts make one: rgb its power, direction its
 * luminance centroid. */
static pov_light patch_light(const envl_envmap *m, int x0, int x1, int y0, int y1)
{
    pov_light p;
    memset(&p, 0, sizeof p);
    double sum[3] = {0, 0, 0}, dir[3] = {0, 0, 0};
    for (int r = y0; r < y1; r++)
        for (int c = x0; c < x1; c++) {
            const float *v = m->px + 3 * (r * W + c);
            double d[3], dw = m->row_omega[r], y = envl_luminance(v[0], v[1], v[2]);
            pixel_direction(m, c, r, d);
            for (int k = 0; k < 3; k++) {
                sum[k] += v[k] * dw;
                dir[k] += y * dw * d[k];
            }
        }
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int k = 0; k < 3; k++) {
        p.l.rgb[k] = sum[k];
        p.l.direction[k] = dir[k] / len;
    }
    p.l.rect[0] = x0, p.l.rect[1] = y0, p.l.rect[2] = x1, p.l.rect[3] = y1;
    return p;
}

/* The exact irradiance of the patch at n (each pixel a direction: pov_area.c's sum). */
static void patch_irradiance(const envl_envmap *m, int x0, int x1, int y0, int y1,
                             const double n[3], double out[3], double *least)
{
    out[0] = out[1] = out[2] = 0;
    *least = 1;
    for (int r = y0; r < y1; r++)
        for (int c = x0; c < x1; c++) {
            double d[3];
            pixel_direction(m, c, r, d);
            double t = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            *least = fmin(*least, t);
            for (int k = 0; k < 3; k++)
                out[k] += m->px[3 * (r * W + c) + k] * m->row_omega[r] * fmax(0, t);
        }
}

/* Gnomonic coordinates of d about the light's direction along its grid's axes. */
static void gnomonic(const pov_light *p, const double d[3], double uv[2])
{
    const double *l = p->l.direction;
    double t = d[0] * l[0] + d[1] * l[1] + d[2] * l[2];
    for (int k = 0; k < 2; k++) {
        const double *a = p->axis[k];
        double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        uv[k] = (d[0] * a[0] + d[1] * a[1] + d[2] * a[2]) / len / t;
    }
}

/* A patch of 20 x 10 pixels (28 x 14 degrees) high in the sky: every normal within 60 degrees
 * of its centre sees all of it, and the grid gives such a normal the patch's irradiance to
 * rounding (the colour's resultant makes it exact, docs/methods.md); the grid's variance along
 * each axis is the patch's (an n-point grid over [-w/2, w/2]: w^2 (n + 1) / (12 (n - 1))). */
static void test_patch_grid(void)
{
    const float rgb[3] = {2.0f, 1.5f, 1.0f};
    int x0 = 100, x1 = 120, y0 = 20, y1 = 30;
    envl_envmap *m = patch_map(x0, x1, y0, y1, rgb);
    pov_light p = patch_light(m, x0, x1, y0, y1);
    p.side = POV_SIDE_UP;
    pov_area_shape(m, 0, &p);
    pov_area_samples(&p, 1);   /* alone: all the light, the largest grid */
    CHECK(p.samples == POV_AREA_MAX_SAMPLES);
    int tested = 0;
    for (int i = 0; i < 1024; i++) {
        double n[3], exact[3], least, got[3];
        envl_fibonacci_direction(i, 1024, n);
        patch_irradiance(m, x0, x1, y0, y1, n, exact, &least);
        if (least < 0.05)
            continue;   /* the patch crosses n's horizon */
        pov_light_irradiance(&p, n, got);
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(got[k], exact[k], 1e-12 * exact[k]);
        tested++;
    }
    CHECK(tested > 100);
    /* second moments: the patch's (luminance x solid angle weights) against the grid's */
    double mom[2] = {0, 0}, weight = 0, grid[2] = {0, 0};
    for (int r = y0; r < y1; r++)
        for (int c = x0; c < x1; c++) {
            double d[3], uv[2];
            pixel_direction(m, c, r, d);
            gnomonic(&p, d, uv);
            mom[0] += m->row_omega[r] * uv[0] * uv[0];
            mom[1] += m->row_omega[r] * uv[1] * uv[1];
            weight += m->row_omega[r];
        }
    int n = p.samples;
    for (int i = 0; i < n; i++) {
        double s = (double)i / (n - 1) - 0.5;
        for (int k = 0; k < 2; k++) {
            const double *a = p.axis[k];
            grid[k] += s * s * (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) / n;
        }
    }
    for (int k = 0; k < 2; k++)
        CHECK_NEAR(grid[k], mom[k] / weight, 1e-9 * mom[k] / weight);
    envl_envmap_free(m);
}

/* A region whose grid the horizon shrinks to nothing (a strip 7 degrees wide in the row just
 * above the horizon of a 2048 x 1024 map: its direction is lower than HORIZON_MARGIN) is one
 * point, coloured by its mean resultant: a normal that sees the whole strip gets the strip's
 * irradiance n . M to rounding, where the region's power (rgb) alone is r_c = 1 - 6e-4 too
 * bright. */
static void test_horizon_point(void)
{
    enum { MW = 2048, MH = 1024, X0 = 1000, X1 = 1040, ROW = MH / 2 - 1 };
    float *px = calloc((size_t)3 * MW * MH, sizeof(float));
    const float rgb[3] = {1.0f, 0.5f, 0.25f};
    for (int c = X0; c < X1; c++)
        for (int ch = 0; ch < 3; ch++)
            px[3 * ((size_t)ROW * MW + c) + ch] = rgb[ch];
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    envl_envmap *m = NULL;
    CHECK_OK(envl_envmap_from_pixels(px, MW, MH, 3, &lo, &m));
    pov_light p;
    memset(&p, 0, sizeof p);
    double M[3][3] = {{0}}, dir[3] = {0, 0, 0}, dw = m->row_omega[ROW];
    for (int c = X0; c < X1; c++) {
        double d[3] = {m->row_cos[ROW] * m->col_cos[c], m->row_cos[ROW] * m->col_sin[c],
                       m->row_sin[ROW]};
        for (int k = 0; k < 3; k++) {
            p.l.rgb[k] += rgb[k] * dw;
            dir[k] += envl_luminance(rgb[0], rgb[1], rgb[2]) * dw * d[k];
            for (int ch = 0; ch < 3; ch++)
                M[ch][k] += rgb[ch] * dw * d[k];
        }
    }
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int k = 0; k < 3; k++)
        p.l.direction[k] = dir[k] / len;
    p.l.rect[0] = X0, p.l.rect[1] = ROW, p.l.rect[2] = X1, p.l.rect[3] = ROW + 1;
    p.side = POV_SIDE_UP;
    pov_area_shape(m, 0, &p);
    pov_area_samples(&p, 1);
    CHECK(p.samples == 1 && p.resultant[0] < 1 - 1e-4);
    int tested = 0;
    for (int i = 0; i < 1024; i++) {
        double n[3], got[3];
        envl_fibonacci_direction(i, 1024, n);
        double least = 1;
        for (int c = X0; c < X1; c++)
            least = fmin(least, n[0] * m->row_cos[ROW] * m->col_cos[c] +
                                    n[1] * m->row_cos[ROW] * m->col_sin[c] + n[2] * m->row_sin[ROW]);
        if (least < 0.05)
            continue;
        pov_light_irradiance(&p, n, got);
        for (int ch = 0; ch < 3; ch++) {
            double exact = n[0] * M[ch][0] + n[1] * M[ch][1] + n[2] * M[ch][2];
            CHECK_NEAR(got[ch], exact, 1e-12 * exact);
        }
        tested++;
    }
    CHECK(tested > 100);
    envl_envmap_free(m);
    free(px);
}

/* A patch that reaches the horizon (its lowest row just above it): its grid is shrunk so that
 * no direction of it falls below, where a ground plane would shadow it; a lower-half patch
 * stays below. */
static void test_horizon(void)
{
    const float rgb[3] = {1, 1, 1};
    for (int up = 1; up >= 0; up--) {
        int y0 = up ? H / 2 - 12 : H / 2, y1 = up ? H / 2 : H / 2 + 12;
        envl_envmap *m = patch_map(40, 80, y0, y1, rgb);
        pov_light p = patch_light(m, 40, 80, y0, y1);
        p.side = up ? POV_SIDE_UP : POV_SIDE_DOWN;
        pov_area_shape(m, 0, &p);
        pov_area_samples(&p, 1);
        CHECK(p.samples >= 2);
        for (int i = 0; i < p.samples; i++)
            for (int j = 0; j < p.samples; j++) {
                double s = (double)i / (p.samples - 1) - 0.5;
                double t = (double)j / (p.samples - 1) - 0.5, d[3];
                for (int k = 0; k < 3; k++)
                    d[k] = p.l.direction[k] + s * p.axis[0][k] + t * p.axis[1][k];
                double z = d[2] / sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                CHECK(up ? z > 0.004 : z < -0.004);
            }
        envl_envmap_free(m);
    }
}

/* The dome of the built-in sky: without a ground its lights hold the map's power, the sun is
 * one of them (as small as its pixels) and the ground half has its own; over a
 * ground the sky half's power, nothing below. Grids by share: no more than 4 x 4. */
static void test_dome_sky(void)
{
    envl_sky_options so = {.width = 512};
    envl_envmap *map, *upper;
    CHECK_OK(envl_envmap_sky(&so, &map));
    CHECK_OK(envl_sky_hemisphere_map(map, 0, &upper));
    for (int ground = 0; ground <= 1; ground++) {
        pov_light *lights = NULL;
        int32_t n = 0, suns = 0, below = 0;
        CHECK_OK(pov_dome_lights(upper, ground ? NULL : map, 32, 0, &lights, &n, &suns,
                                 &below));
        CHECK(n == 32 && suns == 1 && (ground ? below == 0 : below >= 2 && below <= 8));
        const envl_envmap *whole = ground ? upper : map;
        double power[3] = {0, 0, 0};
        for (int32_t j = 0; j < n; j++) {
            for (int k = 0; k < 3; k++)
                power[k] += lights[j].l.rgb[k];
            CHECK(lights[j].samples >= 1 && lights[j].samples <= POV_AREA_MAX_SAMPLES);
            CHECK(lights[j].side == (j < n - below ? POV_SIDE_UP : POV_SIDE_DOWN));
        }
        for (int k = 0; k < 3; k++)
            CHECK_NEAR(power[k], whole->info.power[k], 1e-6 * whole->info.power[k]);
        /* the sun first, as small as the pixels it lights at 512 wide (2 x 2 of 0.7 degrees):
         * its grid under 1.5 degrees */
        const double *a = lights[0].axis[0];
        CHECK(lights[0].sun && sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) < 0.026);
        free(lights);
    }
    envl_envmap_free(upper);
    envl_envmap_free(map);
}

/* The dome from windows of the map's rows (no copies: pov_dome.c) is the dome from copies of
 * its halves, bit for bit: the built-in sky with a glint below the horizon brighter than the
 * sky half's sun threshold (a window that read it would split it off as a sun of the sky) and
 * a bright patch across the seam. The map's pixels are its own again afterwards (the suns'
 * patches put back); a window's power is its half's; rows that are no window fail. */
static void test_dome_windows(void)
{
    envl_sky_options so = {.width = 512};
    envl_envmap *sky, *map, *upper, *window;
    CHECK_OK(envl_envmap_sky(&so, &sky));
    int32_t w = sky->width, h = sky->height;
    size_t n = (size_t)3 * w * h;
    float *px = malloc(sizeof(float) * n), *before = malloc(sizeof(float) * n);
    memcpy(px, sky->px, sizeof(float) * n);
    for (int r = h / 2 + 20; r < h / 2 + 22; r++)
        for (int c = 100; c < 102; c++)
            for (int ch = 0; ch < 3; ch++)
                px[3 * ((size_t)r * w + c) + ch] = 1e4f;
    for (int r = 60; r < 70; r++)
        for (int c = w - 4; c < w + 4; c++)
            for (int ch = 0; ch < 3; ch++)
                px[3 * ((size_t)r * w + c % w) + ch] += 50.0f;
    envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
    CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &map));
    memcpy(before, map->px, sizeof(float) * n);
    CHECK_OK(envl_sky_hemisphere_map(map, 0, &upper));
    pov_light *a = NULL, *b = NULL;
    int32_t na = 0, sa = 0, ba = 0, nb = 0, sb = 0, bb = 0;
    CHECK_OK(pov_dome_lights(upper, map, 32, 0, &a, &na, &sa, &ba)); /* copies */
    CHECK_OK(pov_dome_lights(NULL, map, 32, 0, &b, &nb, &sb, &bb));  /* windows */
    CHECK(na == 32 && nb == na && sb == sa && bb == ba && ba >= 2);
    CHECK(a && b && !memcmp(a, b, sizeof *a * (size_t)na));
    CHECK(!memcmp(before, map->px, sizeof(float) * n));
    CHECK_OK(envl__envmap_window(map, 0, h / 2, &window));
    for (int k = 0; k < 3; k++)
        CHECK(window->info.power[k] == upper->info.power[k]);
    envl_envmap_free(window);
    /* a window takes its map's rows' statistics over, but for the rows a patch wrote (the sun
     * residual's view): the same as a map of the patched pixels gives */
    envl_pixel_patch patch[2] = {{10, 7, {1e5f, 2e5f, 3e5f}}, {40, 3, {0, 0, 0}}};
    envl_envmap *patched, *view;
    for (int i = 0; i < 2; i++)
        memcpy(map->px + 3 * ((size_t)patch[i].r * w + patch[i].c), patch[i].rgb,
               sizeof patch[i].rgb);
    CHECK_OK(envl_envmap_from_pixels(map->px, w, h, 3, &lo, &patched));
    CHECK_OK(envl__envmap_window(patched, 0, h / 2, &window));
    CHECK_OK(envl__envmap_window_patched(map, 0, h / 2, patch, 2, &view));
    CHECK(!memcmp(&window->info.power, &view->info.power, sizeof view->info.power));
    CHECK(!memcmp(&window->info.max, &view->info.max, sizeof view->info.max));
    CHECK(!memcmp(&window->info.brightest_direction, &view->info.brightest_direction,
                  sizeof view->info.brightest_direction));
    CHECK(view->info.max[2] == 3e5f && upper->info.max[2] < 3e5f);
    memcpy(map->px, before, sizeof(float) * n);
    envl_envmap_free(view);
    envl_envmap_free(window);
    envl_envmap_free(patched);
    CHECK(envl__envmap_window(map, h / 2, h / 2, &window) == ENVL_ERR_ARGUMENT && !window);
    CHECK(envl__envmap_window(map, 0, h + 1, &window) == ENVL_ERR_ARGUMENT && !window);
    free(a);
    free(b);
    free(px);
    free(before);
    envl_envmap_free(upper);
    envl_envmap_free(map);
    envl_envmap_free(sky);
}

/* Over a ground (envlight pov --ground, a dome with its bounce pass: pov_include.c) the sky
 * half is a window of the map's rows, not a copy with the lower half black: the same dome and
 * the same reference irradiance (the error measure's), bit for bit, on a map wider than the
 * reference's 256 columns (a resampled copy of the window) and on one narrower (a copy), each
 * with a glint below the horizon that a window read whole would add. */
static void test_ground_window(void)
{
    const int widths[2] = {512, 200};
    for (int t = 0; t < 2; t++) {
        envl_sky_options so = {.width = widths[t]};
        envl_envmap *sky, *map, *upper, *window;
        CHECK_OK(envl_envmap_sky(&so, &sky));
        int32_t w = sky->width, h = sky->height;
        size_t n = (size_t)3 * w * h;
        float *px = malloc(sizeof(float) * n);
        memcpy(px, sky->px, sizeof(float) * n);
        for (int ch = 0; ch < 3; ch++)
            px[3 * ((size_t)(h / 2 + 5) * w + w / 3) + ch] = 1e4f;
        envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG};
        CHECK_OK(envl_envmap_from_pixels(px, w, h, 3, &lo, &map));
        CHECK_OK(envl_sky_hemisphere_map(map, 0, &upper));
        CHECK_OK(envl__envmap_window(map, 0, h / 2, &window));
        const double *ra, *rb;
        CHECK_OK(envl_envmap_reference_irradiance(upper, &ra));
        CHECK_OK(envl_envmap_reference_irradiance(window, &rb));
        CHECK(!memcmp(ra, rb, sizeof(double) * 3 * ENVL_ERROR_NORMALS));
        pov_light *a = NULL, *b = NULL;
        int32_t na = 0, sa = 0, ba = 0, nb = 0, sb = 0, bb = 0;
        CHECK_OK(pov_dome_lights(upper, NULL, 48, 0, &a, &na, &sa, &ba));
        CHECK_OK(pov_dome_lights(window, NULL, 48, 0, &b, &nb, &sb, &bb));
        CHECK(na == 48 && nb == na && sb == sa && ba == 0 && bb == 0);
        CHECK(a && b && !memcmp(a, b, sizeof *a * (size_t)na));
        free(a);
        free(b);
        free(px);
        envl_envmap_free(window);
        envl_envmap_free(upper);
        envl_envmap_free(map);
        envl_envmap_free(sky);
    }
}

int main(void)
{
    test_patch_grid();
    test_horizon();
    test_horizon_point();
    test_dome_sky();
    test_dome_windows();
    test_ground_window();
    return check_report("test_pov_dome");
}
