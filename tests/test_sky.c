/* The built-in sky: the sun disc's irradiance is exact, it sits where it was asked to. */
#include "internal.h"
#include "check.h"

static const double PI = 3.14159265358979323846;

static double lum_power(const envl_envmap *m)
{
    envl_info i;
    envl_envmap_info(m, &i);
    return envl_luminance(i.power[0], i.power[1], i.power[2]);
}

/* Doubling the sun's irradiance E adds E times the disc's visible fraction to the disc
 * (luminance, exact by construction) and albedo * E sin(elev) / pi of radiance to the ground's 2 pi steradians. */
static void test_sun_power(double elevation, double azimuth, int width, double visible)
{
    envl_sky_options o = {.sun_elevation_degrees = elevation, .sun_elevation_is_set = 1,
                          .sun_azimuth_degrees = azimuth, .width = width};
    envl_envmap *a, *b;
    CHECK_OK(envl_envmap_sky(&o, &a));
    o.sun_irradiance = 24.0;
    CHECK_OK(envl_envmap_sky(&o, &b));
    double el = elevation * PI / 180;
    double expect = 12.0 * visible + 0.2 * 12.0 * fmax(0, sin(el)) / PI * 2 * PI;
    /* Disc pixels are floats of ~1e5: 2^-24 relative each. */
    CHECK_REL(lum_power(b) - lum_power(a), expect, 1e-5);
    /* The brightest pixel lies within the disc radius plus one pixel of the sun direction. */
    envl_info info;
    envl_envmap_info(a, &info);
    double az = azimuth * PI / 180;
    double sun[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)};
    double dot = sun[0] * info.brightest_direction[0] + sun[1] * info.brightest_direction[1] +
                 sun[2] * info.brightest_direction[2];
    double pixel = 2 * PI / width / fmax(cos(el), 1e-3);
    if (visible > 0)
        CHECK(acos(fmin(1, dot)) <= 0.265 * PI / 180 + pixel);
    for (int i = 0; i < envl_envmap_width(a) * envl_envmap_height(a) * 3; i++)
        if (!(isfinite(envl_envmap_pixels(a)[i]) && envl_envmap_pixels(a)[i] >= 0)) {
            CHECK(!"sky pixel not finite and non-negative");
            break;
        }
    envl_envmap_free(a);
    envl_envmap_free(b);
}

/* Defaults: 1024 x 512, sun at 35 degrees elevation towards +X; the sun's radiance is more
 * than 1e5 times the zenith's (a hard case for every method). */
static void test_defaults(void)
{
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(NULL, &m));
    CHECK(envl_envmap_width(m) == 1024 && envl_envmap_height(m) == 512);
    envl_info info;
    envl_envmap_info(m, &info);
    CHECK(info.max[1] > 1e5 * 0.6);
    CHECK_NEAR(info.brightest_direction[2], sin(35 * PI / 180), 2 * PI / 512);
    envl_envmap_free(m);
}

int main(void)
{
    test_defaults();
    test_sun_power(35, 0, 1024, 1);
    test_sun_power(60, 123, 512, 1);
    /* On the horizon: rows are symmetric about z = 0, so exactly half the samples show. */
    test_sun_power(0, 0, 256, 0.5);
    test_sun_power(89.9, 10, 256, 1); /* at the pole */
    test_sun_power(10, 180, 2048, 1); /* on the seam */
    test_sun_power(-1, 0, 256, 0);    /* set: no sun */
    return check_report("test_sky");
}
