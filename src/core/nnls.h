/* Non-negative least squares in Gram form (nnls.c). */
#ifndef ENVL_NNLS_H
#define ENVL_NNLS_H

#define ENVL_NNLS_MAX 128

/* Minimises x'Gx - 2 h'x with x_i >= 0 for i < n_nonneg, x_i free for i >= n_nonneg.
 * G is n x n symmetric positive semi-definite, row-major. Returns 0, or -1 (n too large,
 * singular). */
int envl__nnls_gram(int n, int n_nonneg, const double *G, const double *h, double *x);

#endif
