/* The lights' insides, shared by their files (not installed):
 *   lights.c      the call (envl_lights_compute), evaluation, the error, the accessors
 *   lights_cut.c  median cut and variance cut: regions of the map, one light each
 *   lights_fit.c  K fitted lights + an SH remainder
 *   lights_take.c what the fitted lights take from the map: their colour, size, the residual
 *   lights_sun.c  the map's suns split off exactly (sun_split.c), the rest a residual map
 * Energy of a pixel = luminance x its solid angle. */
#ifndef ENVL_LIGHTS_IMPL_H
#define ENVL_LIGHTS_IMPL_H

#include "clock.h"
#include "envmap_impl.h"

#include <math.h>

struct envl_lights {
    envl_lights_summary summary;
    envl_light *lights;
    double *remainder;      /* irradiance SH, (order+1)^2 x 3, or NULL */
    int32_t width, height;
    float *residual;        /* width x height x 3 (fit: what the takes left; sun: the map
                               less the suns' excess); for the cuts (which take everything)
                               made, all zero, only when asked for */
    int32_t residual_skipped; /* fit or sun with options.skip_residual: there is none */
    envl_pixel_patch *patch;  /* sun: the pixels where the residual differs from the map (the
                                 kept suns' pixels at the split's threshold), row-major */
    int32_t npatch;
};

/* A pixel rectangle of the canonical lat-long map, [x0, x1) x [y0, y1); x1 may exceed the width:
 * the region then wraps across the seam. */
typedef struct region {
    int32_t x0, x1, y0, y1;
    double energy;
    double priority;        /* which region to split next */
} region;

/* max(a.b, 0) */
static inline double envl__clamped_dot(const double a[3], const double b[3])
{
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return d > 0 ? d : 0;
}

/* A tangent frame (t1, t2) of the unit vector d: d, t1, t2 right-handed. */
static inline void envl__tangents(const double d[3], double t1[3], double t2[3])
{
    double a[3] = {fabs(d[0]) < 0.9 ? 1.0 : 0.0, fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    t1[0] = a[1] * d[2] - a[2] * d[1];
    t1[1] = a[2] * d[0] - a[0] * d[2];
    t1[2] = a[0] * d[1] - a[1] * d[0];
    double l = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (int i = 0; i < 3; i++)
        t1[i] /= l;
    t2[0] = d[1] * t1[2] - d[2] * t1[1];
    t2[1] = d[2] * t1[0] - d[0] * t1[2];
    t2[2] = d[0] * t1[1] - d[1] * t1[0];
}

/* ---- the fit's take (lights_take.c) ---- */
/* A light's aim: its direction l, a tangent frame (t1, t2), the side of the horizon it is on
 * (+1 above or on it, -1 below). */
typedef struct envl__aim {
    double l[3], t1[3], t2[3];
    double side;
} envl__aim;

/* The shape of a light's level at direction (x, y, z): kappa (1 - d.l), plus depth / sin_h
 * across the horizon from l (depth = |d_z| there); u1, u2 = d.t1, d.t2. */
static inline double envl__aim_shape(const envl__aim *a, double kappa, double sin_h, double x,
                                     double y, double z, double *u1, double *u2)
{
    double zs = z * a->side;
    *u1 = x * a->t1[0] + y * a->t1[1] + z * a->t1[2];
    *u2 = x * a->t2[0] + y * a->t2[1] + z * a->t2[2];
    double dl = x * a->l[0] + y * a->l[1] + z * a->l[2];
    return kappa * (1.0 - dl) + (zs < 0.0 ? -zs / sin_h : 0.0);
}

/* What a light took, beyond its rgb: V = sum e d dw (e its luminance taken) and its pixels' own
 * extent, sum e dw^2 / 4 pi; and the level it took above on the map (lights_take.c). */
typedef struct envl__take {
    double moment[3];
    double own;
    envl__aim aim;
    double lb, e1, e2;
} envl__take;
/* The log of a take's level at direction (x, y, z) (envl__take_lights' own arithmetic: a pixel
 * there of luminance Y > exp of it kept that over Y of each channel). */
double envl__take_level_log(const envl__take *t, double x, double y, double z);
/* A light's solid_angle and angle: the uniform disc about its direction with the spread of
 * what it took (rgb set). */
void envl__light_size(const envl__take *t, envl_light *l);
/* A light's take_direction, take_solid_angle and take_angle: the direction of its take's moment
 * V and the disc about it (envl__light_size about V); the direction when it took nothing. */
void envl__light_take_size(const envl__take *t, envl_light *l);

/* ---- cones about a direction (lights_fit.c) ---- */
/* The pixels within `radius` (radians) of the unit vector dir, and a pixel more: rows r0..r1
 * (none when r0 > r1), in each a run of columns around the axis (envl__cone_span). */
typedef struct envl__cone_geom {
    int full;               /* the whole map */
    double cos_r, z, xy;    /* cos of the visited radius; the axis' z and |(x, y)| */
    double col;             /* the axis' column, c = (1 - phi / pi) W / 2 - 1/2 */
    int32_t r0, r1;
} envl__cone_geom;
envl__cone_geom envl__cone_geometry(const envl_envmap *m, const double dir[3], double radius);
/* Columns lo..hi (wrapping: c mod W, lo may be negative, hi past W) of row r within the
 * cone; 0 if none. */
int envl__cone_span(const envl_envmap *m, const envl__cone_geom *g, int32_t r, int32_t *lo,
                    int32_t *hi);

/* ---- cuts (lights_cut.c) ---- */
/* Cuts the map into n regions (median or variance cut); *out malloc'd, *count of them. The
 * first region starts at the darkest column, so a sun on the seam is never cut in two. */
envl_result envl__cut_regions(envl_envmap *m, int32_t method, int32_t n, region **out,
                              int32_t *count);
/* One light per region: rgb = sum of L dw, at the energy-weighted centroid of its directions. */
void envl__region_lights(const envl_envmap *m, const region *rs, int32_t k, envl_light *out);

/* ---- the variance cut's marginals from block sums (cut_marginals.c) ---- */
#define CUT_BLOCK 64 /* rows of a row block, columns of a column block */
typedef struct cut_marginals {
    int32_t nbx, nby;   /* column blocks, row blocks */
    double *cols;       /* [by][x][3]: column x over row block by: sum e, e cos t, e sin t */
    double *rows;       /* [y][bx][3]: row y over column block bx: sum e, e cos p, e sin p */
    int failed;         /* a thread's scratch could not be allocated */
} cut_marginals;
envl_result envl__cut_marginals_build(const envl_envmap *m, cut_marginals *t);
void envl__cut_marginals_free(cut_marginals *t);
/* Adds region r's column marginals to col (3 per column, x - x0) and its row marginals to row
 * (3 per row, y - y0): what one pass over its pixels would sum. */
void envl__cut_marginals_of(const envl_envmap *m, const cut_marginals *t, const region *r,
                            double *col, double *row);

/* ---- fit (lights_fit.c, lights_take.c) ---- */
/* The next chunk of the positive pixels brightest first (luminance y of px's n RGB pixels, ties
 * in index order): those whose binade (the exponent of y) lies below *top and at or above the
 * highest binade that brings at least `least` of them (or all that are left), as (y, index)
 * pairs sorted into out (room for 2 n doubles); returns their count (0: none left) and lowers
 * *top to that binade. Chunk after chunk, from *top = INT32_MAX, they are the whole order, each
 * chunk sorted alone: a scan that stops early sorts about what it reads. */
size_t envl__bright_chunk(const float *px, size_t n, size_t least, int *top, double *out);
/* At most K lights + an SH remainder of `order` (-1: none) into ls; keep_residual: ls->residual
 * is the map less what the lights took (else none is kept; the lights are the same). */
envl_result envl__fit_lights(envl_envmap *m, int32_t K, int32_t order, int keep_residual,
                             envl_lights *ls);
/* The fit's take (lights_take.c): each of ls's lights, aimed along its direction with its
 * luminance as the target, takes the light above a smooth level around it from what the
 * lights before it left; its rgb, size (about its direction) and rect become those of its
 * take, and out (may be NULL) gets each light's moment and extent. coarse: a copy of m
 * area-resampled smaller, where the solve starts (or m itself). ls->residual: a copy of m's
 * pixels, made the residual; or NULL: none is kept (the lights are the same). */
envl_result envl__take_lights(envl_envmap *m, const envl_envmap *coarse, envl_lights *ls,
                              envl__take *out);

/* ---- sun (lights_sun.c) ---- */
/* The map's n brightest suns as lights and the patches that make the map their residual;
 * the residual map itself (ls->residual) only with keep_residual. */
envl_result envl__sun_lights(const envl_envmap *m, int32_t n, int32_t keep_residual,
                             envl_lights *ls);
/* Adds the exact irradiance of the sun method's residual at the error normals (`normals`,
 * envl__fibonacci_dirs) to approx, from the map's reference `ref` and the patches. */
envl_result envl__add_residual_irradiance(const envl_envmap *m, const envl_lights *ls,
                                          const double *ref, const double *normals,
                                          double *approx);

#endif
