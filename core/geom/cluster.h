/* cluster.h — k-means clustering of leaf elements into planes, with a
 * hierarchy of coarser levels (Garcia, Sbert, Szirmay-Kalos, "Leaf Cluster
 * Impostors for Tree Rendering with Parallax", §2.1, §2.2, §2.4).
 *
 * Error of leaf i (centre pᵢ, unit normal nᵢ, weight wᵢ) against the plane
 * n·x + d = 0 (|n| = 1):   wᵢ·[ (pᵢ·n + d)² + α·(1 − (nᵢ·n)²) ]      (eq. 1)
 * α has units of length² (the method passes α_rel·R²). wᵢ is 1, or with area
 * weighting the leaf's area divided by the mean leaf area, floored at 1e-6
 * (so Σwᵢ ≈ N in both modes, errors stay comparable, and a zero-area leaf
 * cannot leave a cluster weightless).
 *
 * Plane orientation convention (every plane this module returns): the
 * reference point `centre` (the tree centre) lies on the back side,
 * n·centre + d < 0, i.e. the normal points away from the tree centre; the
 * texture is seen from +n, from outside the tree. A plane through the centre
 * (|n·centre + d| <= 1e-9 × the leaves' extent) has the largest-magnitude
 * component of n positive (ties: lowest axis). This replaces the paper's
 * "d ≥ 0" (origin on the front side), which is not invariant to translating
 * the tree.
 */
#ifndef SV_CLUSTER_H
#define SV_CLUSTER_H

#include "classify.h"

typedef struct sv_cluster_options {
    const uint32_t *levels;  /* cluster counts per level, finest first, strictly
                                 decreasing, each >= 1; NULL = {32, 16, 8} */
    uint32_t level_count;    /* entries in levels (ignored when levels is NULL) */
    double alpha;            /* α of eq. 1, length² (>= 0); 0 = distance only */
    bool area_weighted;      /* weight leaves by area (see above) */
    uint32_t max_iterations; /* k-means iterations at the finest level; 0 = 50 */
    uint32_t seed_tries;     /* k-means++ candidates per seed (greedy); 0 = 4 */
    uint64_t seed;           /* every random choice derives from it */
    const double *centre;    /* orientation reference (3 doubles); NULL = centre
                                 of the bounding box of the leaf centres */
} sv_cluster_options;

typedef struct sv_cluster_plane {
    double normal[3]; /* unit */
    double d;         /* plane: normal·x + d = 0, oriented as above */
    double error;     /* Σ of eq. 1 over the member leaves (weighted) */
    double weight;    /* Σ wᵢ of the members */
    uint32_t leaves;  /* member count (>= 1: empty clusters are dropped) */
} sv_cluster_plane;

typedef struct sv_cluster_level {
    uint32_t count;           /* clusters; fewer than asked when there are fewer
                                 leaves or every leaf already fits exactly */
    sv_cluster_plane *planes; /* count; ordered by their lowest leaf index */
    int32_t *parent;          /* count; index into the next (coarser) level that
                                 this cluster merges into; -1 at the coarsest */
    uint32_t *assign;         /* leaf_count; cluster of each leaf at this level */
    double error;             /* Σ of planes[].error */
} sv_cluster_level;

typedef struct sv_clusters {
    sv_cluster_level *levels; /* finest first */
    uint32_t level_count;
    uint32_t leaf_count;
    uint32_t iterations; /* k-means iterations run at the finest level */
    uint32_t reseeds;    /* empty clusters reseeded with the worst-fitting leaf */
    double alpha;        /* α used */
    double weight;       /* Σ wᵢ over all leaves (≈ leaf_count) */
} sv_clusters;

/* Error of eq. 1 for one leaf with weight 1. */
double sv_cluster_leaf_error(const sv_leaf *leaf, const double normal[3], double d, double alpha);

/* Fits the plane of eq. 5 to the leaves idx[0..n) (idx NULL: leaves[0..n)):
 * d = −c·n with c the (weighted) centroid, n the eigenvector of the smallest
 * eigenvalue of A = Σwᵢ(pᵢ−c)(pᵢ−c)ᵀ − αΣwᵢnᵢnᵢᵀ (symmetric Jacobi, eigen3.h).
 * Weights as in sv_cluster_build but relative to these leaves' mean area.
 * Orients by `centre` (NULL: relative to the centroid, which lies on the
 * plane, so the largest-component rule applies). *error receives the weighted total of
 * eq. 1 (may be NULL). Fails with SV_ERR_INVALID when n is 0 or a leaf is not
 * finite. */
sv_status sv_cluster_fit_plane(const sv_leaf *leaves, const uint32_t *idx, uint32_t n, double alpha,
                               bool area_weighted, const double *centre, double normal[3],
                               double *d, double *error, sv_error *err);

/* Orients the plane (normal, *d) by the convention above relative to ref, with
 * `tol` the distance below which ref counts as on the plane. */
void sv_plane_orient(double normal[3], double *d, const double ref[3], double tol);

/* Clusters leaves[0..count) into opt->levels[0] planes by deterministic k-means
 * (k-means++ seeding on eq. 1 with a seeded RNG, nearest-plane assignment,
 * eq. 5 refit, empty clusters reseeded with the worst-fitting leaf; stops
 * when no leaf changes cluster, the error stops falling, or after
 * max_iterations), then builds each coarser level by repeatedly merging the
 * pair of clusters whose merge raises the total error least (§2.4), recording
 * parent links. Leaves need finite centres, non-zero normals (renormalised)
 * and, with area weighting, finite areas >= 0; otherwise SV_ERR_INVALID naming
 * the leaf. count == 0 fails with SV_ERR_INVALID. Same input and options give
 * byte-identical output. On success release *out with sv_clusters_free. */
sv_status sv_cluster_build(const sv_leaf *leaves, uint32_t count, const sv_cluster_options *opt,
                           sv_clusters *out, sv_error *err);

/* Frees the levels. NULL is fine; *c is zeroed. */
void sv_clusters_free(sv_clusters *c);

#endif
