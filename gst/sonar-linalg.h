/* sonar-linalg.h: the small dense linear algebra of the estimators
 * (ego-motion, tracks): matrices of at most a few rows, row-major double
 * arrays, no allocation. Nothing here is fast for large matrices; nothing
 * needs to be. */
#ifndef SONAR_LINALG_H
#define SONAR_LINALG_H

#include <glib.h>

G_BEGIN_DECLS

/* The largest matrix the helpers take (rows or columns). */
#define SONAR_LINALG_MAX 8

/* c (n x k) = a (n x m) b (m x k); c may not alias a or b. */
void sonar_linalg_multiply (const double *a, const double *b, double *c,
    guint n, guint m, guint k);
/* c (n x k) = a (n x m) b^T (b is k x m). */
void sonar_linalg_multiply_transposed (const double *a, const double *b,
    double *c, guint n, guint m, guint k);

/* Inverts the symmetric positive definite @a (n x n) in place, through
 * its Cholesky factor; *@log_det (may be NULL) receives ln det a. FALSE,
 * @a unchanged, when @a is not positive definite. */
gboolean sonar_linalg_invert_spd (double *a, guint n, double *log_det);

/* The Cholesky factor L (a = L L^T) of the symmetric positive definite
 * @a (n x n, any n), in place in its lower triangle (the upper is left
 * as it was). FALSE when @a is not positive definite. */
gboolean sonar_linalg_cholesky (double *a, guint n);
/* Solves L L^T x = @b in place, @l from sonar_linalg_cholesky (). */
void sonar_linalg_cholesky_solve (const double *l, guint n, double *b);

/* Eigen-decomposition of the symmetric 3 x 3 @a (Jacobi rotations):
 * @values in decreasing order, @vectors[i] the unit eigenvector of
 * @values[i] (rows). */
void sonar_linalg_eigen_symmetric3 (const double a[3][3], double values[3],
    double vectors[3][3]);

/* The peak (*x, *y) of a quadratic with gradient (@gx, @gy) and Hessian
 * [@hxx @hxy; @hxy @hyy] at the origin: where H (x, y) = -g. FALSE (and
 * nothing written) unless H is negative definite (the quadratic has a
 * maximum). */
gboolean sonar_linalg_quadratic_peak (double gx, double gy, double hxx,
    double hxy, double hyy, double *x, double *y);

G_END_DECLS

#endif /* SONAR_LINALG_H */
