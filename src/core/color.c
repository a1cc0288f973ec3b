/* Colour-space matrices shared by the Radiance and OpenEXR readers. */
#include "color.h"

#include <math.h>
#include <string.h>

static double det3(const double m[3][3])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

bool envl__invert3(const double m[3][3], double inv[3][3])
{
    double d = det3(m);
    if (!(fabs(d) > 1e-12) || !isfinite(d))
        return false;
    double t[3][3];
    t[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / d;
    t[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / d;
    t[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / d;
    t[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / d;
    t[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / d;
    t[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / d;
    t[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / d;
    t[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / d;
    t[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / d;
    memcpy(inv, t, sizeof t);
    return true;
}

void envl__mul3(const double a[3][3], const double b[3][3], double out[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    memcpy(out, t, sizeof t);
}

/* RGB -> XYZ matrix (column vectors: XYZ = M * RGB) of primaries c = {xr, yr, xg, yg, xb, yb,
 * xw, yw}, normalised so that RGB (1,1,1) is the white point with luminance Y = 1:
 *   P = [xr xg xb; yr yg yb; zr zg zb] with z = 1 - x - y (each column a primary's xyz),
 *   W = (xw / yw, 1, zw / yw)  (the white point's XYZ at Y = 1),
 *   S = P^-1 W,   M = P diag(S).
 * Written with unnormalised primary columns (as OpenEXR's RGBtoXYZ does) so a primary with
 * y = 0, such as the blue of the XYZ "primaries" (0, 0), needs no division by its y. */
bool envl__rgb_to_xyz_matrix(const double c[8], double m[3][3])
{
    for (int i = 0; i < 8; i++)
        if (!isfinite(c[i]))
            return false;
    double xw = c[6], yw = c[7];
    if (!(fabs(yw) > 1e-9))
        return false;
    double p[3][3], pinv[3][3];
    for (int j = 0; j < 3; j++) {
        double x = c[2 * j], y = c[2 * j + 1];
        p[0][j] = x;
        p[1][j] = y;
        p[2][j] = 1.0 - x - y;
    }
    if (!envl__invert3(p, pinv))
        return false;
    double w[3] = {xw / yw, 1.0, (1.0 - xw - yw) / yw};
    for (int j = 0; j < 3; j++) {
        double s = pinv[j][0] * w[0] + pinv[j][1] * w[1] + pinv[j][2] * w[2];
        for (int i = 0; i < 3; i++)
            m[i][j] = p[i][j] * s;
    }
    return true;
}
