/* Colour-space matrices shared by the readers (color.c). */
#ifndef ENVL_COLOR_H
#define ENVL_COLOR_H

#include <stdbool.h>

/* Inverse by cofactors; false if (near) singular or not finite. */
bool envl__invert3(const double m[3][3], double inv[3][3]);
/* out = a b (out may alias a or b). */
void envl__mul3(const double a[3][3], const double b[3][3], double out[3][3]);
/* RGB -> XYZ (XYZ = M RGB) for primaries p = {xr, yr, xg, yg, xb, yb, xw, yw}, normalised so
 * RGB (1,1,1) is the white point at Y = 1. False when degenerate. */
bool envl__rgb_to_xyz_matrix(const double p[8], double m[3][3]);

#endif
