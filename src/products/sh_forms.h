/* The artist forms of an irradiance SH expansion (sh.c): the SH summary's and the POV-Ray
 * include's hemispheric ambient (pov_include.c) use this one implementation. Not installed. */
#ifndef ENVL_SH_FORMS_H
#define ENVL_SH_FORMS_H

#include "envlight.h"

/* From bands 0 and 1 of `irradiance` ((order + 1)^2 x RGB, canonical frame; order 0: no
 * gradient) the least-squares linear fit over the sphere, by orthogonality:
 * E(n) ~ ambient + deltas . n, ambient = Y00 E00, deltas = 0.488603 (E11, E1-1, E10); and the
 * hemispheric pair along the luminance gradient (up when there is none): sky = E at n = axis,
 * ground = E at n = -axis, the best fit with both >= 0 (docs/design.md, "Spherical
 * harmonics"). Every output may be NULL but axis, sky and ground. */
void envl__sh_artist_forms(int32_t order, const double *irradiance, double ambient[3],
                           double deltas[3][3], double axis[3], double sky[3],
                           double ground[3]);

#endif
