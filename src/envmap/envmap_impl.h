/* The envmap's insides, shared by the files that compute products from it. */
#ifndef ENVL_ENVMAP_IMPL_H
#define ENVL_ENVMAP_IMPL_H

#include "internal.h"

struct envl_envmap {
    int32_t width, height;
    float *px;            /* RGB, row 0 = top (canonical lat-long) */
    int32_t px_borrowed;  /* px belongs to another map (envl__sun_residual_view): not freed */
    int32_t window;       /* a window (envl__envmap_window): only rows [row0, row1) are the
                             map's, the others read as black in the statistics, the region
                             table, the cuts, the sun split and pov_area (not elsewhere) */
    int32_t row0, row1;
    double *row_omega;    /* solid angle of a pixel of each row (exact) */
    double *row_cos;      /* cos(theta) at each row's centre */
    double *row_sin;      /* sin(theta) = z at each row's centre */
    double *col_cos;      /* cos(phi) at each column's centre */
    double *col_sin;      /* sin(phi) */
    envl_info info;
    char *source_path;    /* the file it was read from (envl_envmap_load), in full; NULL for the
                             sky and pixels from memory: an input no output may replace
                             (envl_outputs_check) */
    int32_t apply_exposure; /* the load option apply_exposure was given: the pixels may be the
                               file's divided by its EXPOSURE (the POV-Ray include then does
                               not name the file as its sky) */
    int32_t threads;
    double *reference;    /* cached exact irradiance at the ENVL_ERROR_NORMALS Fibonacci normals */
    struct envl_envmap *reference_copy; /* cached: the map area-resampled to
                                           ENVL_REFERENCE_WIDTH when wider (irradiance.c) */
    double *region_table; /* cached region table of the lights (region_table.c) */
    struct envl_row_stats *row_stats; /* per row: sums, maxima, brightest pixel (envmap.c):
                                         a window of the map takes them over */
    /* mips.c: the cached area-averaged mip pyramid. Level 0 is px itself; levels mip_first ..
     * mip_levels - 1 live in mip_px at mip_offset[level] (floats; levels 1 .. mip_first - 1,
     * wider than 4096, are not kept). mip_levels 0: not built. */
    float *mip_px;
    int32_t mip_levels, mip_first;
    int32_t mip_w[40], mip_h[40];
    size_t mip_offset[40];
    /* cells.c: the cached cell pyramid of the specular levels (one malloc'd block) or NULL */
    void *cells;
    /* envl__points_map: the finer copy a map too coarse for the GGX sums is split into, or
     * NULL (none made yet, or none needed) */
    struct envl_envmap *points_copy;
};

/* Rows [*y0, *y1) clipped to the map's window (unchanged for a whole map): the rows outside
 * it are black, and a black row adds nothing to any of the sums that read a window. */
static inline void envl__window_rows(const envl_envmap *m, int32_t *y0, int32_t *y1)
{
    if (m->window) {
        *y0 = *y0 < m->row0 ? m->row0 : *y0;
        *y1 = *y1 > m->row1 ? m->row1 : *y1;
    }
}

/* The rows [row0, row1) of map (0 <= row0 < row1 <= its height) as a map of its own size over
 * its pixels (borrowed: map must outlive it), every other row black: the sky half or the
 * ground half of a map without a copy (pov_dome.c). Only the functions named at `window`
 * read it as such. */
envl_result envl__envmap_window(const envl_envmap *map, int32_t row0, int32_t row1,
                                envl_envmap **out);
/* The same window of map's pixels while `patch` (sorted by row) is written into them: the
 * statistics of the patched rows are the pixels' as they now are, the other rows' map's. */
envl_result envl__envmap_window_patched(const envl_envmap *map, int32_t row0, int32_t row1,
                                        const envl_pixel_patch *patch, int32_t npatch,
                                        envl_envmap **out);
/* The largest luminance of row r's pixels as the map's statistics hold it (0 for a window's
 * black rows; below 0 for a row of none positive): the pass it took at load, not another. */
double envl__row_max_luminance(const envl_envmap *m, int32_t r);
/* A map of its own of a window's pixels, its other rows black, resampled to out_w wide (height
 * in proportion; out_w = the width: a copy): what resampling a copy of the map with those rows
 * black gives, bit for bit. */
envl_result envl__envmap_window_copy(const envl_envmap *m, int32_t out_w, envl_envmap **out);

/* The GGX sums (the levels' cell pyramid, the glossy reference) take each pixel as a point at
 * its centre. A map whose pixels are too coarse for that (fewer than 16 columns or 8 rows, or
 * pixels more than twice as wide as tall or as tall as wide: a map one pixel wide puts every
 * point on one meridian) is prefiltered from a copy with each pixel split evenly into k x j
 * pixels (the same function) of at least 64 x 32 with pixels within that aspect; a copy that
 * would exceed 1024 x 512 pixels is the map area-resampled to 1024 x 512 instead.
 * envl__points_copy: *copy NULL when m is fine as it is, else that copy (the caller frees it);
 * envl__points_map: m itself or the copy, cached on m (envl_envmap_drop_mips frees it). */
envl_result envl__points_copy(const envl_envmap *m, envl_envmap **copy);
/* 1 when m's pixels are fine enough as points: envl__points_copy makes no copy of it. */
int envl__points_fine(const envl_envmap *m);
envl_result envl__points_map(envl_envmap *m, envl_envmap **out);

/* ---- the lights' region table (region_table.c): sums over pixel rectangles ---- */
#define ENVL_TABLE_BLOCK 32 /* columns per block of the table */
/* Builds the table once and caches it in the map. */
envl_result envl__region_table(envl_envmap *m);
/* With the table built: over columns [x0, x1) (0 <= x0 < W, x1 <= x0 + W: past W wraps across
 * the seam) and rows [y0, y1), out = sum of L dw (R, G, B) and sum of Y d dw (x, y, z), Y the
 * luminance, d the pixel's direction. */
void envl__rect_sums(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                     double out[6]);
/* The energy (sum of Y dw) of such a rectangle. */
double envl__rect_energy(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1);
/* Energy of each column [x0, x1) (wrapping) over rows [y0, y1), directly from the pixels. */
void envl__column_energies(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                           double *out);
/* The energy median along x of a region of x1 - x0 >= 2 columns: the smallest s in
 * [x0 + 1, x1 - 1] with energy([x0, s)) >= half (else x1 - 1), or s - 1 when that is as close
 * to half; *left = energy([x0, s)). Binary search over the table's block boundaries, then
 * column by column inside one block. */
int32_t envl__median_column(const envl_envmap *m, int32_t x0, int32_t x1, int32_t y0, int32_t y1,
                            double half, double *left);

#endif
