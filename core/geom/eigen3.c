/* eigen3.c — symmetric 3×3 eigensolver by cyclic Jacobi rotations.
 *
 * Garcia, Sbert, Szirmay-Kalos, "Leaf Cluster Impostors for Tree Rendering
 * with Parallax", §2.2, find the plane normal as the eigenvector of the
 * smallest eigenvalue of A (eq. 5) and suggest power iteration on A⁻¹. We do
 * not, because that iteration fails exactly in the cases clustering produces
 * all the time:
 *   - A is singular for a one-leaf cluster (A = −α·nnᵀ has rank 1) and for
 *     leaves on a line or exactly coplanar with equal normals: A⁻¹ does not exist;
 *   - A is indefinite whenever the α·Σnᵢnᵢᵀ term dominates the scatter (any
 *     small or flat cluster): power iteration on A⁻¹ converges to the
 *     eigenvalue of smallest MAGNITUDE, not the smallest signed one, so it
 *     returns the wrong plane;
 *   - with repeated or nearly repeated eigenvalues (leaves on a sphere, an
 *     isotropic cloud) power iteration converges arbitrarily slowly.
 * Cyclic Jacobi (Golub & Van Loan, "Matrix Computations", §8.5; rotation
 * formulas as in Numerical Recipes §11.1) needs no inverse, handles any sign,
 * converges quadratically, and its eigenvectors are a product of plane
 * rotations, hence orthonormal to rounding even when eigenvalues coincide: a
 * matrix that is already diagonal (e.g. a multiple of I) gets no rotation at
 * all and returns the identity basis. Eigenvalues carry absolute error of
 * order eps·‖A‖.
 */
#include "eigen3.h"

#include <math.h>

#define MAX_SWEEPS 50

static void set_identity(double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) v[i][j] = i == j ? 1.0 : 0.0;
}

/* One Jacobi rotation that zeroes m[p][q] (p < q, r the third index). The
 * columns of v accumulate the rotations. */
static void rotate(double m[3][3], double v[3][3], int p, int q, int r, double g)
{
    double apq = m[p][q];
    double h = m[q][q] - m[p][p];
    double t;
    if (fabs(h) + g == fabs(h)) {
        t = apq / h; /* the angle is tiny: t = tan θ ≈ apq/h, no overflow in θ² */
    } else {
        double theta = 0.5 * h / apq;
        t = 1.0 / (fabs(theta) + sqrt(1.0 + theta * theta));
        if (theta < 0.0) t = -t;
    }
    double c = 1.0 / sqrt(1.0 + t * t);
    double s = t * c;
    double tau = s / (1.0 + c);
    double dh = t * apq;
    m[p][p] -= dh;
    m[q][q] += dh;
    m[p][q] = m[q][p] = 0.0;
    double arp = m[r][p], arq = m[r][q];
    m[r][p] = m[p][r] = arp - s * (arq + arp * tau);
    m[r][q] = m[q][r] = arq + s * (arp - arq * tau);
    for (int j = 0; j < 3; j++) {
        double vp = v[j][p], vq = v[j][q];
        v[j][p] = vp - s * (vq + vp * tau);
        v[j][q] = vq + s * (vp - vq * tau);
    }
}

bool sv_eigen3_symmetric(const double a[3][3], double values[3], double vectors[3][3])
{
    double m[3][3], v[3][3];
    double amax = 0.0;
    bool finite = true;
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) {
            if (!isfinite(a[i][j])) finite = false;
            else if (fabs(a[i][j]) > amax) amax = fabs(a[i][j]);
        }
    set_identity(vectors);
    values[0] = values[1] = values[2] = 0.0;
    if (!finite) return false;
    if (amax == 0.0) return true;

    /* Scale by a power of two (exact) so entries are O(1): no overflow or
     * underflow for matrices of trees in micrometres or kilometres. */
    int ex;
    frexp(amax, &ex);
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) m[i][j] = m[j][i] = ldexp(a[i][j], -ex);
    set_identity(v);

    static const int pairs[3][3] = {{0, 1, 2}, {0, 2, 1}, {1, 2, 0}};
    for (int sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        double off = fabs(m[0][1]) + fabs(m[0][2]) + fabs(m[1][2]);
        if (off == 0.0) break;
        /* Early sweeps skip small elements (threshold Jacobi); later sweeps
         * set negligible ones to zero so the iteration provably ends. */
        double thresh = sweep < 3 ? 0.2 * off / 9.0 : 0.0;
        for (int k = 0; k < 3; k++) {
            int p = pairs[k][0], q = pairs[k][1], r = pairs[k][2];
            double g = 100.0 * fabs(m[p][q]);
            if (sweep > 3 && fabs(m[p][p]) + g == fabs(m[p][p]) &&
                fabs(m[q][q]) + g == fabs(m[q][q])) {
                m[p][q] = m[q][p] = 0.0;
            } else if (fabs(m[p][q]) > thresh) {
                rotate(m, v, p, q, r, g);
            }
        }
    }

    /* Sort ascending (stable: equal eigenvalues keep their axis order). */
    int order[3] = {0, 1, 2};
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && m[order[j]][order[j]] < m[order[j - 1]][order[j - 1]]; j--) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    for (int k = 0; k < 3; k++) {
        values[k] = ldexp(m[order[k]][order[k]], ex);
        for (int j = 0; j < 3; j++) vectors[k][j] = v[j][order[k]];
    }
    /* Right-handed basis: flipping an eigenvector's sign keeps it one. */
    double cx = vectors[0][1] * vectors[1][2] - vectors[0][2] * vectors[1][1];
    double cy = vectors[0][2] * vectors[1][0] - vectors[0][0] * vectors[1][2];
    double cz = vectors[0][0] * vectors[1][1] - vectors[0][1] * vectors[1][0];
    if (cx * vectors[2][0] + cy * vectors[2][1] + cz * vectors[2][2] < 0.0)
        for (int j = 0; j < 3; j++) vectors[2][j] = -vectors[2][j];
    return true;
}
