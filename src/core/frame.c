/* The canonical frame's geometry (docs/design.md): lat-long pixels <-> directions, their solid
 * angles, luminance, and a light's cone from its solid angle. Every layer above uses these. */
#include "internal.h"

#include <math.h>

/* Solid angle of a pixel in row r of a W x H lat-long map:
 * (2 pi / W) * (sin(pi (0.5 - r/H)) - sin(pi (0.5 - (r+1)/H))). */
double envl_latlong_solid_angle(int32_t width, int32_t height, int32_t row)
{
    if (width <= 0 || height <= 0 || row < 0 || row >= height)
        return 0.0;
    double top = sin(ENVL_PI * (0.5 - (double)row / height));
    double bot = sin(ENVL_PI * (0.5 - (double)(row + 1) / height));
    return 2.0 * ENVL_PI / width * (top - bot);
}

/* u = (c + 0.5)/W, v = (r + 0.5)/H, phi = pi (1 - 2u), theta = pi (0.5 - v). */
void envl_latlong_direction(int32_t width, int32_t height, double column, double row,
                            double d[3])
{
    double u = (column + 0.5) / width, v = (row + 0.5) / height;
    double phi = ENVL_PI * (1.0 - 2.0 * u), theta = ENVL_PI * (0.5 - v);
    d[0] = cos(theta) * cos(phi);
    d[1] = cos(theta) * sin(phi);
    d[2] = sin(theta);
}

void envl_latlong_pixel(int32_t width, int32_t height, const double d[3], double *column,
                        double *row)
{
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double z = len > 0 ? d[2] / len : 1.0;
    z = z > 1 ? 1 : z < -1 ? -1 : z;
    double phi = atan2(d[1], d[0]); /* (-pi, pi] */
    double u = 0.5 * (1.0 - phi / ENVL_PI), v = 0.5 - asin(z) / ENVL_PI;
    *column = u * width - 0.5;
    *row = v * height - 0.5;
}

double envl_luminance(double r, double g, double b) { return envl__lum(r, g, b); }

/* Angular diameter of a cone of the light's solid angle: 2 acos(1 - omega / 2 pi), capped at
 * pi (docs/design.md). */
void envl__light_set_angle(envl_light *l)
{
    double c = 1.0 - l->solid_angle / (2.0 * ENVL_PI);
    l->angle = fmin(ENVL_PI, 2.0 * acos(c < -1 ? -1 : c > 1 ? 1 : c));
}
