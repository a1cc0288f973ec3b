/* `envlight preview`: the map with its lights, and spheres shaded by the exact reference and by
 * each approximation (preview.c, font5x7.c). Part of the library: envl_preview_write in
 * envlight.h is its public entry; these internal steps are for the tests. Not installed. */
#ifndef ENVL_PREVIEW_H
#define ENVL_PREVIEW_H

#include "envlight.h"

#include <stdio.h>

/* Rows (shading) and columns (lighting) of the sphere grid. */
#define PREVIEW_ROWS 4    /* diffuse, glossy roughness[0], glossy roughness[1], mirror */
#define PREVIEW_COLS 5    /* reference, median cut, fit + SH remainder, SH order 2, prefiltered */

/* Linear radiance of every sphere (size x size x 3, row 0 = top; 0 outside the disc, and all 0
 * in a cell the column's method does not serve), its picture error (preview_picture_error
 * against the row's reference; -1: none) and the seconds printed under it. */
typedef struct preview_data {
    int32_t size;
    double view[3];           /* unit vector towards the camera */
    double *sphere[PREVIEW_ROWS][PREVIEW_COLS];
    int32_t served[PREVIEW_ROWS][PREVIEW_COLS]; /* 1: drawn and measured (preview_serves) */
    double error[PREVIEW_ROWS][PREVIEW_COLS];
    double seconds[PREVIEW_ROWS][PREVIEW_COLS];
    double diffuse_error[PREVIEW_COLS]; /* docs/design.md's diffuse error of the column's product
                                 (irradiance, whatever --diffuse draws); -1 for the reference */
    double exposure_ev;       /* the exposure used */
    double reference_error;   /* diffuse reference on the resampled copy against the full map,
                                 docs/design.md's measure */
    envl_lights *median, *fit;
    int32_t median_lights, fit_lights; /* the counts the methods returned (the fit may stop
                                 before fit_count: docs/methods.md, "Lights") */
} preview_data;

void preview_defaults(envl_preview_options *o);
/* Tone curves on exposed linear values (result in [0, 1], before the sRGB OETF). */
double preview_aces(double x);
double preview_reinhard(double x);
/* Reinhard 2002's key: EV = log2(0.18 / Lavg), Lavg = exp(mean over the sphere (solid-angle
 * weighted) of log(1e-4 + Y)). */
double preview_auto_exposure(const envl_envmap *map);
/* Normal at sphere pixel (i, j) of a size x size sphere seen along -view (orthographic, +Z up
 * on screen); 0 outside the disc. */
int preview_sphere_normal(int32_t size, const double view[3], int32_t i, int32_t j, double n[3]);
/* Picture size and the top-left corner of sphere (row, col). */
void preview_layout(int32_t size, int32_t *width, int32_t *height);
void preview_sphere_origin(int32_t size, int32_t row, int32_t col, int32_t *x, int32_t *y);

/* Computes the lights, SH, prefiltered maps, references and every sphere. `notes` (may be
 * NULL) gets, once all is computed, a line per column: the texts under its spheres (as the
 * picture prints them) and docs/design.md's diffuse error of its product; then the references. */
envl_result preview_compute(envl_envmap *map, const envl_preview_options *o, FILE *notes,
                            preview_data *d);
void preview_data_free(preview_data *d);
/* Tone-mapped picture (display-linear RGB in [0, 1], width x height x 3; free()). */
envl_result preview_compose(const envl_envmap *map, const envl_preview_options *o,
                            const preview_data *d, float **rgb, int32_t *width, int32_t *height);

/* Whether the method of column `col` serves row `row`: the reference and the prefiltered maps
 * every row; the lights (median cut, fit + SH remainder) diffuse and glossy, not the mirror (a
 * mirror shows the map itself, a light's reflection there is a delta no renderer draws); SH
 * order 2 diffuse only (irradiance; as radiance it rings around any bright source). */
int preview_serves(int32_t row, int32_t col);
/* The error printed under a sphere, on what the picture shows: both spheres as drawn,
 * display-linear D = T(2^EV x) per channel (T the tone curve), their luminance
 * Y = 0.2126 D_R + 0.7152 D_G + 0.0722 D_B, and docs/design.md's formula over the disc's `count`
 * pixels: sqrt(mean((Ya - Yr)^2)) / mean(Yr). -1 when mean(Yr) = 0. */
double preview_picture_error(int32_t tonemap, double exposure_ev, int32_t count,
                             const double *approx, const double *ref);
/* The texts of the picture, also printed on stderr (so both say the same): a column's header
 * (line 0, 1; the light counts the methods returned) and the first line under a sphere ("err
 * 3.28%", the reference's method, or, in a cell the method does not serve, its note over two
 * lines: line 0, 1: "SH:", "diffuse only" or "lights:", "no mirror"). */
void preview_column_head(const preview_data *d, int32_t col, int32_t line, char *s, size_t n);
void preview_cell_text(const envl_preview_options *o, const preview_data *d, int32_t row,
                       int32_t col, int32_t line, char *s, size_t n);

/* 5 x 7 glyph of an ASCII character (columns, bit 0 = top row); '?' for others. */
const unsigned char *preview_glyph(int c);

#endif
