/* The cell pyramid of a lat-long map and its Barnes-Hut quadrature of the GGX lobe (cells.c):
 * the specular levels (specular.c) and the glossy measure's reference (glossy_reference.c).
 * Not installed. */
#ifndef ENVL_CELLS_H
#define ENVL_CELLS_H

#include "envmap_impl.h"

typedef struct envl_cells envl_cells;
/* The cells of a W x H lat-long image from level `base` up, read once on `threads` threads
 * (0: the online cores; the result does not depend on it). One malloc'd block:
 * envl__cells_free or free. px must outlive the cells (a bright cell across R's horizon at
 * the base is summed from its pixels). */
envl_result envl__cells_build(const float *px, int32_t w, int32_t h, int32_t base,
                              int32_t threads, envl_cells **out);
/* How finely a cut sums: a cell whole when its centroid is at least rho of its widths from R;
 * never coarser than HWHM / core_k near R; R's horizon resolved to horizon_eps of the lobe's
 * weight, and a cell across it opened (down to the pyramid's base) while what its power may
 * move exceeds horizon_power x the map's mean radiance (cells.c). */
typedef struct cut_accuracy {
    double rho, core_k, horizon_eps, horizon_power;
} cut_accuracy;
extern const cut_accuracy envl__level_cut; /* the specular levels' (rho set per level) */
/* The finest level a cut of GGX alpha needs on a map h tall (a NULL accuracy: the levels'),
 * and the finest one built. */
int32_t envl__cells_base(const cut_accuracy *a, double alpha, int32_t h);
int32_t envl__cells_base_of(const envl_cells *C);
void envl__cells_free(envl_cells *c);
int32_t envl__cells_levels(const envl_cells *C);
/* The map's cells from level `base` (or finer) up, built once and cached in it (rebuilt when a
 * finer base is asked for). */
envl_result envl__map_cells(envl_envmap *m, int32_t base, const envl_cells **out, int *built);
/* The w x h level of GGX alpha into out (RGB), each texel at its centre direction (layout:
 * ENVL_LAYOUT_LATLONG or _STRIP_H, layout.c), each level of the pyramid serving rho .. 4 rho
 * of its cells' widths from R (envl__level_rho); *terms: the mean number of cells summed per
 * texel. */
envl_result envl__cells_level(const envl_cells *C, double alpha, double rho, int32_t layout,
                              int32_t w, int32_t h, int32_t threads, float *out, double *terms);
/* P(R) of GGX alpha at count directions (out: RGB each), cut with accuracy a. */
envl_result envl__cells_at(const envl_cells *C, const cut_accuracy *a, double alpha,
                           int32_t count, const double *dirs, int32_t threads, double *out);
/* Integral of L dw of the image the cells were built from, per channel. */
void envl__cells_energy(const envl_cells *C, double e[3]);

#endif
