/* planes.h — billboard-cloud plane selection (greedy_planes.c) and its
 * k-planes refinement (kplanes.c).
 *
 * Décoret, Durand, Sillion, Dorsey, "Billboard Clouds for Extreme Model
 * Simplification" (SIGGRAPH 2003), with the tree-specific fixes of Behrendt et
 * al., "Realistic real-time rendering of landscapes using billboard clouds"
 * (papers/billboard-cloud-forests.txt, §3). Pure geometry: no GL, no files.
 *
 * A face is valid for a plane when every vertex lies within ε of it (§3.1).
 * Planes are points (θ, φ, ρ) of a dual grid: normal
 *   n(θ, φ) = (cos φ cos θ, sin φ, cos φ sin θ),  θ ∈ [0, 2π), φ ∈ [−π/2, π/2]
 * (+Y up, so φ = ±90° are the horizontal planes, the "poles"), and ρ ∈ [0, R]
 * the distance from the bounding-sphere centre. The greedy loop takes the
 * densest cell, refines it, simplifies every face valid for the refined plane
 * and repeats until every face is simplified (the fail-safe of §3.3.2 makes
 * sure each round simplifies at least one face, so it always terminates).
 *
 * Speed (see docs/methods/billboard_cloud.md): the ρ-range of an element valid
 * somewhere in a (θ, φ) column is an interval in closed form, so each column
 * is a difference array over ρ bins in exact int64 fixed point; removing faces
 * subtracts their intervals (bit-identical to a rebuild); columns, the
 * refinement's sub-cells and the element scans are split between threads by
 * index (parallel.h), so the result never depends on the thread count.
 *
 * Elements: the caller groups triangles into elements (a leaf, or one trunk
 * triangle). An element is simplified as a whole; an element thicker than ε
 * along its own normal is split into its triangles for that ε.
 */
#ifndef SV_BBC_PLANES_H
#define SV_BBC_PLANES_H

#include "sv.h"

/* What sv_bbc_select learns of its ε runs, kept by the caller across
 * selections (a target search's tries, through method_ops.h sv_memo): per
 * input (a hash of the elements and of every option but ε and max_planes)
 * and ε, the largest plane budget a run was seen to exceed and the planes a
 * complete run drew. A run known to exceed the budget asked for is not made
 * again (it would stop at the same plane and be discarded), so a selection
 * is byte for byte the one made without the memo, only sooner. */
typedef struct sv_bbc_memo sv_bbc_memo;
/* An empty memo (NULL: out of memory). */
void *sv_bbc_memo_create(void);
/* Frees a memo made by sv_bbc_memo_create (NULL is fine). */
void sv_bbc_memo_free(void *memo);

typedef struct sv_bbc_options {
    double epsilon;          /* validity distance in world units (>= 0) */
    uint32_t grid_theta;     /* dual grid: θ columns, even (default 32) */
    uint32_t grid_phi;       /* φ rows (default 16) */
    uint32_t grid_rho;       /* ρ bins over [0, R] (default 32) */
    uint32_t refine_levels;  /* 3×3 direction refinements of the picked cell (default 5) */
    double miss_penalty;     /* Décoret's penalty for planes that nearly miss a face,
                                    as a fraction of its contribution; coarse grid only
                                    (§3.2.2: omitted for sub-cells). Default 0.5, 0 = off */
    double max_angle_deg;    /* a face is simplified by a plane only within this angle
                                    (the Fig. 4b remedy; 90 = the papers' plain rule).
                                    Default 75 */
    bool horizontal_penalty; /* §3.3.5 (default off; the method turns it on for ground viewers) */
    double horizontal_value; /* maximum penalty at the poles, default 0.6 */
    double horizontal_angle_deg; /* cutoff: no penalty below this elevation of the normal,
                                    default 50 */
    bool tweak;                  /* post-plane tweaking §3.3.3 (default true) */
    bool weld;                   /* vertex welding §3.3.4 in the trunk pass (default true) */
    bool cardboard;              /* cardboard planes §3.3.6 (default false) */
    double cardboard_coverage;   /* acceptance threshold, fraction of primary coverage (0.8) */
    uint32_t max_planes;         /* 0 = no limit; otherwise ε is raised until the primary
                                    planes fit, and cardboard planes only fill what is left */
    uint32_t threads;            /* worker threads for the dual grid, the refinement and
                                    the scans (default 2; same bytes for any) */
    sv_bbc_memo *memo;           /* NULL (default): nothing kept; not used with cardboard */
} sv_bbc_options;

/* Sets every field to the defaults listed above (epsilon 0). */
void sv_bbc_options_init(sv_bbc_options *opt);

typedef struct sv_bbc_input {
    const double *positions; /* 3 per vertex, world units */
    uint32_t vertex_count;
    const uint32_t *indices; /* 3 per triangle */
    uint32_t triangle_count;
    const uint32_t *elem_tris;  /* triangle ids grouped by element */
    const uint32_t *elem_first; /* elem_count + 1 offsets into elem_tris */
    const uint8_t *elem_part;   /* elem_count: SV_PART_TRUNK (welded pass) or SV_PART_FOLIAGE;
                                    NULL = all foliage */
    uint32_t elem_count;
    double centre[3]; /* bounding sphere: every vertex within radius of centre */
    double radius;
} sv_bbc_input;

typedef enum sv_bbc_origin {
    SV_BBC_REFINED = 0,      /* densest cell, refined */
    SV_BBC_FAILSAFE_SUPPORT, /* §3.3.2: supporting plane of a face of the cell */
    SV_BBC_FAILSAFE_AVERAGE, /* §3.3.2: averaged plane of the cell's faces */
    SV_BBC_CARDBOARD         /* §3.3.6 */
} sv_bbc_origin;

typedef struct sv_bbc_plane {
    double normal[3];      /* unit */
    double d;              /* normal·x + d = 0, world units */
    uint8_t part;          /* pass: SV_PART_TRUNK or SV_PART_FOLIAGE */
    uint8_t origin;        /* sv_bbc_origin */
    bool tweaked;          /* §3.3.3 refinement was kept */
    int32_t cardboard_of;  /* -1 for a primary plane, else the index of its primary */
    uint32_t first, count; /* triangles in result.tris: those simplified (primary), or
                                    the primary's faces valid for it (cardboard: simplifies none) */
    double area;           /* total area of those triangles */
    double coverage;       /* cardboard: coverage ratio; primary: 1 */
} sv_bbc_plane;

typedef struct sv_bbc_stats {
    double epsilon; /* ε finally used (after the max_planes search) */
    uint32_t runs;  /* greedy runs (1 + ε search steps) */
    uint32_t primary_planes, cardboard_planes, failsafe_planes, tweaked_planes;
    uint32_t elements;       /* elements in the final run, after splitting */
    uint32_t split_elements; /* input elements split into triangles (thicker than ε) */
    uint32_t welded_vertices;
    double seconds_setup;  /* element geometry (all runs) */
    double seconds_grid;   /* dual-grid accumulation and updates (all runs) */
    double seconds_refine; /* refinement, fail-safe, tweak, assignment (all runs) */
    double seconds_cardboard;
    double seconds_total;
} sv_bbc_stats;

typedef struct sv_bbc_result {
    sv_bbc_plane *planes; /* trunk pass first, then foliage; cardboards follow their pass */
    uint32_t plane_count;
    uint32_t *tris;
    uint32_t tri_count;
    sv_bbc_stats stats;
} sv_bbc_result;

/* Selects the planes. Every triangle of every element is simplified by
 * exactly one primary plane. Deterministic: the same input and options give
 * byte-identical planes whatever opt->threads is. On failure *out is zeroed.
 * Fails with SV_ERR_INVALID on bad input (index out of range, non-finite
 * position, radius <= 0, negative ε), SV_ERR_LIMIT when max_planes is smaller
 * than the number of non-empty passes, SV_ERR_NOMEM. */
sv_status sv_bbc_select(const sv_bbc_input *in, const sv_bbc_options *opt, sv_bbc_result *out,
                        sv_error *err);

/* Frees the arrays of r and zeroes it. NULL is fine. */
void sv_bbc_result_free(sv_bbc_result *r);

/* Incremental LODs (§3.3.8): the simplified model of a level as the input of
 * the next. Writes *positions_out (3 per vertex, malloc'ed) and *indices_out
 * (3 per triangle, malloc'ed) where triangle t gets three fresh vertices
 * projected onto the primary plane that simplifies it (unchanged if none), so
 * the caller can run sv_bbc_select again with the same elements and a larger ε.
 * *vertex_count_out = 3 × in->triangle_count. */
sv_status sv_bbc_project(const sv_bbc_input *in, const sv_bbc_result *res, double **positions_out,
                         uint32_t **indices_out, uint32_t *vertex_count_out, sv_error *err);

/* k-planes refinement (kplanes.c): first adds foliage planes until
 * res has target_planes planes in all (0 or fewer = none added; each seeded
 * parallel to the plane of the leaf drawn farthest from it, through that
 * leaf), then moves the foliage planes to the total-least-squares planes of
 * their leaves and reassigns each foliage element of `in` (original
 * positions; res's triangle ids index in's triangles) to its nearest plane,
 * for at most `iterations` Lloyd steps or until no element moves. Trunk and
 * cardboard planes are kept (with cardboard planes present nothing is
 * changed); emptied planes are dropped. Every triangle stays in exactly one
 * primary plane. Deterministic: its per-element steps run on
 * SV_PARALLEL_DEFAULT threads with the same bytes as one (parallel.h). */
sv_status sv_bbc_kplanes(const sv_bbc_input *in, uint32_t iterations, uint32_t target_planes,
                         sv_bbc_result *res, sv_error *err);

#endif
