/* test_eigen3.c — the symmetric 3×3 Jacobi eigensolver (core/geom/eigen3.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "eigen3.h"

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_unit(uint64_t *s)
{
    return (double)(rng_next(s) >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

static double frob(const double a[3][3])
{
    double s = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) s += a[i][j] * a[i][j];
    return sqrt(s);
}

/* Checks A v = λ v for each pair, orthonormality, order, right-handedness. */
static void assert_decomposition(const double a[3][3], const double val[3], const double vec[3][3],
                                 double tol)
{
    double scale = frob(a) > 0 ? frob(a) : 1.0;
    assert_true(val[0] <= val[1] && val[1] <= val[2]);
    for (int k = 0; k < 3; k++) {
        for (int i = 0; i < 3; i++) {
            double r = -val[k] * vec[k][i];
            for (int j = 0; j < 3; j++) r += a[i][j] * vec[k][j];
            assert_true(isfinite(r));
            assert_true(fabs(r) <= tol * scale);
        }
        for (int l = 0; l < 3; l++) {
            double dot = 0;
            for (int j = 0; j < 3; j++) dot += vec[k][j] * vec[l][j];
            assert_true(fabs(dot - (k == l ? 1.0 : 0.0)) <= 1e-14);
        }
    }
    double c[3] = {vec[0][1] * vec[1][2] - vec[0][2] * vec[1][1],
                   vec[0][2] * vec[1][0] - vec[0][0] * vec[1][2],
                   vec[0][0] * vec[1][1] - vec[0][1] * vec[1][0]};
    assert_true(c[0] * vec[2][0] + c[1] * vec[2][1] + c[2] * vec[2][2] > 0.999);
}

/* Q diag(l) Qᵀ with Q a random rotation from a seeded quaternion. */
static void make_matrix(uint64_t *s, const double l[3], double a[3][3], double q[3][3])
{
    double w = rng_unit(s), x = rng_unit(s), y = rng_unit(s), z = rng_unit(s);
    double n = sqrt(w * w + x * x + y * y + z * z);
    w /= n, x /= n, y /= n, z /= n;
    double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            q[i][j] = r[i][j];
            a[i][j] = 0;
            for (int k = 0; k < 3; k++) a[i][j] += r[i][k] * l[k] * r[j][k];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < i; j++) a[i][j] = a[j][i]; /* exactly symmetric */
}

static void diagonal_matrix_gives_sorted_values_and_axes(void **state)
{
    (void)state;
    double a[3][3] = {{3, 0, 0}, {0, -2, 0}, {0, 0, 1}};
    double val[3], vec[3][3];
    assert_true(sv_eigen3_symmetric(a, val, vec));
    assert_true(val[0] == -2 && val[1] == 1 && val[2] == 3);
    assert_true(fabs(fabs(vec[0][1]) - 1) == 0 && fabs(fabs(vec[1][2]) - 1) == 0);
    assert_true(fabs(fabs(vec[2][0]) - 1) == 0);
    assert_decomposition(a, val, vec, 1e-15);
}

static void random_indefinite_matrices_decompose_to_rounding(void **state)
{
    (void)state;
    uint64_t s = 12345;
    for (int t = 0; t < 2000; t++) {
        double l[3] = {rng_unit(&s) * 10, rng_unit(&s), rng_unit(&s) * 0.01};
        double a[3][3], q[3][3], val[3], vec[3][3];
        make_matrix(&s, l, a, q);
        assert_true(sv_eigen3_symmetric(a, val, vec));
        assert_decomposition(a, val, vec, 1e-13);
        /* eigenvalues agree with the construction */
        double sorted[3] = {l[0], l[1], l[2]};
        for (int i = 1; i < 3; i++)
            for (int j = i; j > 0 && sorted[j] < sorted[j - 1]; j--) {
                double tmp = sorted[j];
                sorted[j] = sorted[j - 1];
                sorted[j - 1] = tmp;
            }
        for (int k = 0; k < 3; k++) assert_true(fabs(val[k] - sorted[k]) <= 1e-13 * 10);
    }
}

static void multiple_of_identity_returns_identity_basis(void **state)
{
    (void)state;
    double a[3][3] = {{2.5, 0, 0}, {0, 2.5, 0}, {0, 0, 2.5}};
    double val[3], vec[3][3];
    assert_true(sv_eigen3_symmetric(a, val, vec));
    for (int k = 0; k < 3; k++) {
        assert_true(val[k] == 2.5);
        for (int j = 0; j < 3; j++) assert_true(vec[k][j] == (k == j ? 1.0 : 0.0));
    }
}

static void repeated_eigenvalues_in_rotated_frame_stay_orthonormal(void **state)
{
    (void)state;
    uint64_t s = 99;
    const double cases[][3] = {{1, 1, 2},         {-1, 3, 3},         {0, 0, 1}, {5, 5, 5},
                               {1, 1 + 1e-14, 2}, {-1e-12, 0, 1e-12}, {0, 0, 0}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
        for (int t = 0; t < 200; t++) {
            double a[3][3], q[3][3], val[3], vec[3][3];
            make_matrix(&s, cases[c], a, q);
            assert_true(sv_eigen3_symmetric(a, val, vec));
            assert_decomposition(a, val, vec, 1e-13);
        }
}

static void smallest_eigenvector_of_distinct_spectrum_matches_construction(void **state)
{
    (void)state;
    uint64_t s = 7;
    for (int t = 0; t < 500; t++) {
        double l[3] = {-1, 0.5, 2}, a[3][3], q[3][3], val[3], vec[3][3];
        make_matrix(&s, l, a, q);
        assert_true(sv_eigen3_symmetric(a, val, vec));
        /* column 0 of q is the eigenvector of l[0] = -1 */
        double dot = vec[0][0] * q[0][0] + vec[0][1] * q[1][0] + vec[0][2] * q[2][0];
        assert_true(fabs(fabs(dot) - 1) < 1e-13);
    }
}

static void rank_one_negative_matrix_gives_its_direction_first(void **state)
{
    (void)state;
    /* A = -α n nᵀ: the matrix of a one-leaf cluster; singular. */
    double n[3] = {0.48, -0.6, 0.64}, a[3][3], val[3], vec[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) a[i][j] = -0.01 * n[i] * n[j];
    assert_true(sv_eigen3_symmetric(a, val, vec));
    assert_true(fabs(val[0] + 0.01) < 1e-16);
    assert_true(fabs(val[1]) < 1e-17 && fabs(val[2]) < 1e-17);
    double dot = vec[0][0] * n[0] + vec[0][1] * n[1] + vec[0][2] * n[2];
    assert_true(fabs(fabs(dot) - 1) < 1e-14);
}

static void extreme_scales_neither_overflow_nor_underflow(void **state)
{
    (void)state;
    uint64_t s = 3;
    const double scales[] = {1e-300, 1e-150, 1e-8, 1e8, 1e150, 1e300};
    for (size_t c = 0; c < sizeof scales / sizeof scales[0]; c++) {
        double l[3] = {-scales[c], 0.25 * scales[c], 0.5 * scales[c]};
        double a[3][3], q[3][3], val[3], vec[3][3];
        make_matrix(&s, l, a, q);
        assert_true(sv_eigen3_symmetric(a, val, vec));
        for (int k = 0; k < 3; k++) assert_true(isfinite(val[k]));
        assert_true(fabs(val[0] / scales[c] + 1) < 1e-13);
        assert_true(fabs(val[2] / scales[c] - 0.5) < 1e-13);
    }
}

static void zero_matrix_gives_zero_values_and_identity(void **state)
{
    (void)state;
    double a[3][3] = {{0}}, val[3], vec[3][3];
    assert_true(sv_eigen3_symmetric(a, val, vec));
    for (int k = 0; k < 3; k++) {
        assert_true(val[k] == 0);
        for (int j = 0; j < 3; j++) assert_true(vec[k][j] == (k == j ? 1.0 : 0.0));
    }
}

static void non_finite_entry_is_rejected(void **state)
{
    (void)state;
    double a[3][3] = {{1, NAN, 0}, {NAN, 1, 0}, {0, 0, 1}}, val[3], vec[3][3];
    assert_false(sv_eigen3_symmetric(a, val, vec));
    for (int k = 0; k < 3; k++) assert_true(val[k] == 0 && vec[k][k] == 1);
    double b[3][3] = {{1, 0, 0}, {0, INFINITY, 0}, {0, 0, 1}};
    assert_false(sv_eigen3_symmetric(b, val, vec));
}

static void same_matrix_gives_bitwise_identical_result(void **state)
{
    (void)state;
    uint64_t s = 5;
    double l[3] = {1, 1, 3}, a[3][3], q[3][3], v1[3], v2[3], e1[3][3], e2[3][3];
    make_matrix(&s, l, a, q);
    sv_eigen3_symmetric(a, v1, e1);
    sv_eigen3_symmetric(a, v2, e2);
    assert_memory_equal(v1, v2, sizeof v1);
    assert_memory_equal(e1, e2, sizeof e1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(diagonal_matrix_gives_sorted_values_and_axes),
        cmocka_unit_test(random_indefinite_matrices_decompose_to_rounding),
        cmocka_unit_test(multiple_of_identity_returns_identity_basis),
        cmocka_unit_test(repeated_eigenvalues_in_rotated_frame_stay_orthonormal),
        cmocka_unit_test(smallest_eigenvector_of_distinct_spectrum_matches_construction),
        cmocka_unit_test(rank_one_negative_matrix_gives_its_direction_first),
        cmocka_unit_test(extreme_scales_neither_overflow_nor_underflow),
        cmocka_unit_test(zero_matrix_gives_zero_values_and_identity),
        cmocka_unit_test(non_finite_entry_is_rejected),
        cmocka_unit_test(same_matrix_gives_bitwise_identical_result),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
