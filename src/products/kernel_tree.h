/* Sums of a kernel f(n.d) against a lat-long map, in about one pass over the map per call plus a
 * few thousand nodes per direction (kernel_tree.c): the references behind the error measures
 * (irradiance.c, glossy_reference.c). Not installed.
 *
 * The tree holds, for blocks of 4 x 4, 8 x 8, ... pixels, per channel the sums
 *   S = sum of L m  and  M = sum of L m d   (m, d: a pixel's weight and direction moments).
 * A block far from where f bends is summed from S and M alone; one near it is opened, down to
 * the pixels. Every accepted block states a bound on what it may be off by, so a sum comes with
 * a rigorous bound on its distance from the pixel-by-pixel sum (the brute force, the oracle). */
#ifndef ENVL_KERNEL_TREE_H
#define ENVL_KERNEL_TREE_H

#include "envmap_impl.h"

#define KTREE_LEAF 4          /* pixels per side of the smallest block */
#define KTREE_MAX_CHANNELS 4  /* R, G, B and, for a normalised kernel, a channel of ones */

/* A pixel (c, r) has weight m = row_w[r] and moment vector
 * (row_a[r] col_x[c], row_a[r] col_y[c], row_z[r]): the exact integrals of 1 and d over the
 * pixel (irradiance), or dw and dw d at its centre (the glossy midpoint sum). */
typedef struct ktree_moments {
    const double *row_w, *row_a, *row_z, *col_x, *col_y;
    int ones;                 /* add a 4th channel with L = 1 (the kernel's own sum) */
} ktree_moments;

typedef struct ktree ktree;

/* Builds the tree of a w x h RGB map (px must outlive it), one parallel pass. */
envl_result envl__ktree_build(const float *px, int32_t w, int32_t h,
                              const ktree_moments *moments, int32_t threads, ktree **out);
void envl__ktree_free(ktree *t);
int32_t envl__ktree_channels(const ktree *t);
/* Per channel: sum of L m over the whole map. */
void envl__ktree_total(const ktree *t, double *s);

/* What a kernel does with a block of the tree or with pixels. */
typedef struct ktree_kernel {
    /* For a block with sums s (S[ch], then M[3 ch]), solid angle omega and n.d within
     * [lo, hi] over it: adds its estimate to est[ch] and its bound to bound[ch] and returns 1,
     * or returns 0 to open it. */
    int (*block)(const void *ctx, const double n[3], const double *s, int32_t channels,
                 double lo, double hi, double omega, double rho, double *est, double *bound);
    /* Adds the sum over pixels [c0, c1) x [r0, r1) to est[ch] and its bound to bound[ch]. */
    void (*pixels)(const void *ctx, const double n[3], int32_t c0, int32_t c1, int32_t r0,
                   int32_t r1, double *est, double *bound);
    const void *ctx;
} ktree_kernel;

/* The exact range of n.d over pixel (c, r). */
void envl__ktree_pixel_range(const ktree *t, const double n[3], int32_t c, int32_t r,
                             double *lo, double *hi);
/* The sum for one direction n: est[ch] and bound[ch] (|est - brute force| <= bound). */
void envl__ktree_sum(const ktree *t, const ktree_kernel *k, const double n[3], double *est,
                     double *bound);

#endif
