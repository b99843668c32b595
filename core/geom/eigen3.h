/* eigen3.h — eigen-decomposition of symmetric 3×3 matrices.
 *
 * Used by the leaf-cluster plane fit (Garcia et al. eq. 5), whose matrix is
 * often singular, indefinite or has repeated eigenvalues; see eigen3.c for why
 * this is a cyclic Jacobi solver and not the paper's power iteration on A⁻¹.
 */
#ifndef SV_EIGEN3_H
#define SV_EIGEN3_H

#include <stdbool.h>

/* Eigenvalues and eigenvectors of the symmetric matrix a (a[i][j] == a[j][i];
 * only the upper triangle is read). On return values[0] <= values[1] <=
 * values[2] and vectors[k] (a row) is a unit eigenvector for values[k]; the
 * three rows are orthonormal to rounding and form a right-handed basis
 * (vectors[2] = vectors[0] × vectors[1]). Repeated eigenvalues are fine: any
 * orthonormal basis of the eigenspace is returned, never NaN. Deterministic.
 * Returns false (values zeroed, vectors = identity) when an entry of a is not
 * finite. a may alias nothing of the outputs. */
bool sv_eigen3_symmetric(const double a[3][3], double values[3], double vectors[3][3]);

#endif
