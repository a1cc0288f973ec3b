/* The error measures' references (docs/design.md, "Error measures"): the exact irradiance
 * (irradiance.c, through the kernel tree of kernel_tree.h) and the glossy reference
 * (glossy_reference.c, through the cell pyramid of cells.c), each within a stated tolerance of
 * the pixel-by-pixel brute force, which stays the test oracle (envl_irradiance_exact,
 * envl_prefilter_reference). Not installed. */
#ifndef ENVL_ERROR_MEASURE_H
#define ENVL_ERROR_MEASURE_H

#include "envmap_impl.h"
#include "cells.h"

/* The ENVL_ERROR_NORMALS Fibonacci directions (malloc'd; NULL when out of memory). */
double *envl__fibonacci_dirs(void);

/* The tolerance of the references behind the error measures: at every direction, each is
 * within this fraction of the mean over the sphere of what it computes (per channel) of the
 * brute force. 2e-4 moves an error figure by at most 0.02 percentage points. */
#define ENVL_REFERENCE_TOLERANCE 2e-4
/* The split irradiance map's promise (irradiance_map.c): the rest of the map (the bright
 * pixels apart) summed through the kernel tree within this fraction of each texel's E (at
 * least ENVL_TEXEL_DARK x the mean of E). */
#define ENVL_SPLIT_RELATIVE 5e-3
/* envl_irradiance_exact's E(n) (irradiance.c), each value within `tolerance` x the mean of E
 * over the sphere; bound_out (may be NULL): count x 3, the bound of each value's distance from
 * envl_irradiance_exact's (besides rounding). */
envl_result envl__irradiance_fast(const envl_envmap *m, int32_t count, const double *normals,
                                  double tolerance, double *rgb_out, double *bound_out);

/* The integral of max(0, n.d) dw over pixel (c, r) of a w x h lat-long map, as
 * envl_irradiance_exact integrates a pixel across n's horizon (exact in elevation, azimuth in
 * slices of at most 0.25 degrees). */
double envl__pixel_cosine(int32_t w, int32_t h, int32_t c, int32_t r, const double n[3]);
/* D = the integral of d dw over pixel (c, r) (the top of irradiance.c): a pixel lit throughout
 * by n gives n . D exactly. Near a pole D / dw is off the pixel's centre by a good part of its
 * height (the pixel is wider at one end), so n . (centre) dw is not. */
void envl__pixel_moment(int32_t w, int32_t h, int32_t c, int32_t r, double D[3]);
/* The same integral for `count` normals (out[i] for normals + 3 i): in closed form, n . D,
 * where the pixel is lit throughout, 0 where unlit, envl__pixel_cosine across the horizon. */
void envl__pixel_cosines(const envl_envmap *m, int32_t c, int32_t r, int32_t count,
                         const double *normals, double *out);
/* The same sums, each within relative x max(base + E, floor) of envl_irradiance_exact's, per
 * normal and channel (base: count x 3, what the caller adds to E, or NULL; floor: per channel,
 * absolute): accurate where E is small, cheap where it is large. */
envl_result envl__irradiance_relative(const envl_envmap *m, int32_t count, const double *normals,
                                      double relative, const double floor[3], const double *base,
                                      double *rgb_out);

/* Sets the diffuse_error of an SH projection (sh.c) or of lights (lights.c) computed from m. */
envl_result envl__sh_measure(envl_envmap *m, envl_sh *sh);
envl_result envl__lights_measure(envl_envmap *m, envl_lights *ls);

/* The slices envl_irradiance_exact took across the horizon's pixels on this thread (its cost
 * beyond one multiply-add a pixel): for tests, as envl__io_calls. */
extern _Thread_local int64_t envl__horizon_slices;

/* The map, or its copy area-resampled to ENVL_REFERENCE_WIDTH when wider (cached in it); a
 * map of pixels far from square split into square ones first (envl__points_map). */
envl_result envl__reference_copy(envl_envmap *m, const envl_envmap **out);
/* The references' irradiance: envl__irradiance_fast at ENVL_REFERENCE_TOLERANCE, or on maps
 * of at most 256 x 128 pixels envl_irradiance_exact itself. */
envl_result envl__irradiance_reference(const envl_envmap *m, int32_t count,
                                       const double *normals, double *rgb_out);

/* The glossy reference of the error measure: P(R) summed over the map's cell pyramid with a
 * finer cut than the levels' (envl__reference_cut), within ENVL_GLOSSY_REFERENCE_TOLERANCE
 * relative RMS (luminance, over the error measure's directions) of envl_prefilter_reference;
 * the mirror (roughness 0) is the brute force's nearest pixel. C: the map's pyramid, or NULL;
 * one is built (and freed) when C is NULL or coarser than envl__glossy_reference_base. */
#define ENVL_GLOSSY_REFERENCE_TOLERANCE 1e-3
extern const cut_accuracy envl__reference_cut;
int32_t envl__glossy_reference_base(double roughness, int32_t height);
envl_result envl__glossy_reference(const envl_envmap *m, const envl_cells *C, double roughness,
                                   int32_t count, const double *dirs, double *out);

/* The error of a product image read bilinearly (layout ENVL_LAYOUT_LATLONG, or _STRIP_H: cube
 * faces, across their edges), plus n_sun sun lights as they add to P(R) at `roughness` (or to
 * E(n) for roughness < 0), against ref at dirs. */
envl_result envl__sampled_error(const double *dirs, const double *ref, const float *rgb,
                                int32_t layout, int32_t w, int32_t h, const envl_light *sun,
                                int32_t n_sun, double roughness, double *error);

/* ---- the per-texel error (texel_error.c) ---- */
extern const envl_texel_error envl__texel_error_none; /* not measured: rms, worst -1 */
/* docs/design.md's per-texel error of a product image (layout, w x h; plus n_sun sun lights
 * as they add to P(R) at `roughness`, or to E(n) for roughness < 0) against m's exact values
 * at the texels' centres: E (roughness < 0), P(R) (roughness > 0; C: m's cell pyramid or NULL)
 * or the map's mean over the texel (roughness 0). */
envl_result envl__texel_error(envl_envmap *m, const envl_cells *C, const float *rgb,
                              int32_t layout, int32_t w, int32_t h, const envl_light *sun,
                              int32_t n_sun, double roughness, envl_texel_error *out);

#endif
