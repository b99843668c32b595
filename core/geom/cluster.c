/* cluster.c — k-means over planes and the least-error merge hierarchy.
 *
 * Implements Garcia, Sbert, Szirmay-Kalos, "Leaf Cluster Impostors for Tree
 * Rendering with Parallax": the leaf/plane error of §2.1 (eq. 1), the optimal
 * plane of a cluster of §2.2 (eq. 3: d = −c·n; eq. 4–5: n is the eigenvector
 * of the smallest eigenvalue of A, solved by Jacobi rotations, see eigen3.c
 * for why not the paper's power iteration on A⁻¹), the K-means iteration of §2
 * (MacQueen) with k-means++-style seeding, and the hierarchical levels of
 * §2.4 built bottom-up by least-error merges.
 *
 * Numerics: leaf centres are moved into a local frame centred on the
 * bounding box of the centres, so a tree at 1e6 m from the origin clusters
 * like one at the origin; cluster scatter matrices are always taken about the
 * cluster's own centroid (two passes, and the parallel-axis rule when two
 * clusters merge), never as raw second moments, so nothing cancels.
 */
#include "cluster.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "eigen3.h"
#include "rng.h"
#include "vec3.h"

#define DEFAULT_ITERATIONS 50u
#define DEFAULT_SEED_TRIES 4u
#define MIN_WEIGHT 1e-6 /* smallest relative leaf weight with area weighting */
#define STALL_REL 1e-10 /* "the error stops falling": less than this relative decrease */

static const uint32_t default_levels[3] = {32, 16, 8};

typedef struct leaf_rec {
    double p[3]; /* centre in the local frame */
    double n[3]; /* unit normal */
    double w;    /* weight */
} leaf_rec;

typedef struct plane_l {
    double n[3];
    double d; /* local frame */
} plane_l;

/* Weighted statistics of a cluster: W, centroid (local frame), scatter about
 * the centroid and Σ w n nᵀ, both as symmetric 3×3. */
typedef struct stats {
    double w;
    double c[3];
    double m[3][3];
    double nn[3][3];
} stats;

/* ---- random numbers: splitmix64 (rng.h), seeded ---- */

/* Uniform in [0, 1). */
static double rng_unit(uint64_t *s)
{
    return (double)(sv_splitmix64(s) >> 11) * 0x1.0p-53;
}

/* ---- small geometry ---- */

static double rec_error(const leaf_rec *r, const plane_l *pl, double alpha)
{
    double dist = sv_dot3(r->p, pl->n) + pl->d;
    double c = sv_dot3(r->n, pl->n);
    double ang = 1.0 - c * c;
    if (ang < 0.0) ang = 0.0;
    return r->w * (dist * dist + alpha * ang);
}

double sv_cluster_leaf_error(const sv_leaf *leaf, const double normal[3], double d, double alpha)
{
    double dist = sv_dot3(leaf->centre, normal) + d;
    double c = sv_dot3(leaf->normal, normal);
    double ang = 1.0 - c * c;
    if (ang < 0.0) ang = 0.0;
    return dist * dist + alpha * ang;
}

void sv_plane_orient(double normal[3], double *d, const double ref[3], double tol)
{
    double s = sv_dot3(normal, ref) + *d;
    bool flip;
    if (fabs(s) > tol) {
        flip = s > 0.0; /* ref must be behind the plane */
    } else {
        int k = 0;
        for (int j = 1; j < 3; j++)
            if (fabs(normal[j]) > fabs(normal[k])) k = j;
        flip = normal[k] < 0.0;
    }
    if (flip) {
        for (int j = 0; j < 3; j++) normal[j] = -normal[j];
        *d = -*d;
    }
    for (int j = 0; j < 3; j++) normal[j] += 0.0; /* no negative zeros in output */
    *d += 0.0;
}

/* ---- statistics and the eq. 5 fit ---- */

static void stats_merge(const stats *a, const stats *b, stats *out)
{
    stats r;
    r.w = a->w + b->w;
    double fa = a->w / r.w, fb = b->w / r.w;
    double diff[3];
    for (int j = 0; j < 3; j++) {
        r.c[j] = fa * a->c[j] + fb * b->c[j];
        diff[j] = a->c[j] - b->c[j];
    }
    double k = a->w * fb; /* Wa·Wb / W */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            r.m[i][j] = a->m[i][j] + b->m[i][j] + k * diff[i] * diff[j];
            r.nn[i][j] = a->nn[i][j] + b->nn[i][j];
        }
    *out = r;
}

/* Optimal plane of eq. 3–5 for the statistics; returns the model error
 * nᵀMn + α(W − nᵀ(Σwnnᵀ)n), each part clamped at 0. */
static double stats_fit(const stats *s, double alpha, plane_l *pl)
{
    double a[3][3], val[3], vec[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) a[i][j] = s->m[i][j] - alpha * s->nn[i][j];
    sv_eigen3_symmetric(a, val, vec);
    double len = sqrt(sv_dot3(vec[0], vec[0]));
    for (int j = 0; j < 3; j++) pl->n[j] = vec[0][j] / len;
    pl->d = -sv_dot3(s->c, pl->n);
    double mn = 0.0, nnn = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            mn += pl->n[i] * s->m[i][j] * pl->n[j];
            nnn += pl->n[i] * s->nn[i][j] * pl->n[j];
        }
    double ang = s->w - nnn;
    if (mn < 0.0) mn = 0.0;
    if (ang < 0.0) ang = 0.0;
    return mn + alpha * ang;
}

/* Two-pass statistics of every cluster from an assignment (k clusters). */
static void stats_from_assign(const leaf_rec *r, uint32_t n, const uint32_t *assign, uint32_t k,
                              stats *st)
{
    memset(st, 0, (size_t)k * sizeof *st);
    for (uint32_t i = 0; i < n; i++) {
        stats *s = &st[assign[i]];
        s->w += r[i].w;
        for (int j = 0; j < 3; j++) s->c[j] += r[i].w * r[i].p[j];
    }
    for (uint32_t c = 0; c < k; c++)
        if (st[c].w > 0.0)
            for (int j = 0; j < 3; j++) st[c].c[j] /= st[c].w;
    for (uint32_t i = 0; i < n; i++) {
        stats *s = &st[assign[i]];
        double q[3] = {r[i].p[0] - s->c[0], r[i].p[1] - s->c[1], r[i].p[2] - s->c[2]};
        for (int a = 0; a < 3; a++)
            for (int b = a; b < 3; b++) {
                s->m[a][b] += r[i].w * q[a] * q[b];
                s->nn[a][b] += r[i].w * r[i].n[a] * r[i].n[b];
            }
    }
    for (uint32_t c = 0; c < k; c++)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < a; b++) {
                st[c].m[a][b] = st[c].m[b][a];
                st[c].nn[a][b] = st[c].nn[b][a];
            }
}

/* ---- input ---- */

/* Copies the leaves into the local frame; *origin receives the frame's
 * origin (bounding-box centre of the centres), *extent its half diagonal. */
static sv_status make_records(const sv_leaf *leaves, const uint32_t *idx, uint32_t n,
                              bool area_weighted, leaf_rec **out, double origin[3], double *extent,
                              sv_error *err)
{
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    double area_sum = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        const sv_leaf *l = &leaves[idx ? idx[i] : i];
        uint32_t id = idx ? idx[i] : i;
        for (int j = 0; j < 3; j++)
            if (!isfinite(l->centre[j]) || !isfinite(l->normal[j]))
                return sv_fail(err, SV_ERR_INVALID,
                               "cluster: leaf %u has a non-finite centre or normal", id);
        double len = sqrt(sv_dot3(l->normal, l->normal));
        if (!(len > 1e-12) || !isfinite(len))
            return sv_fail(err, SV_ERR_INVALID, "cluster: leaf %u has a zero normal", id);
        if (area_weighted && !(l->area >= 0.0 && isfinite(l->area)))
            return sv_fail(err, SV_ERR_INVALID,
                           "cluster: leaf %u has area %g; area weighting needs finite areas >= 0",
                           id, l->area);
        area_sum += area_weighted ? l->area : 1.0;
        for (int j = 0; j < 3; j++) {
            if (l->centre[j] < lo[j]) lo[j] = l->centre[j];
            if (l->centre[j] > hi[j]) hi[j] = l->centre[j];
        }
    }
    leaf_rec *r = sv_calloc(n, sizeof *r);
    if (!r) return sv_fail(err, SV_ERR_NOMEM, "cluster: out of memory for %u leaves", n);
    double half = 0.0;
    for (int j = 0; j < 3; j++) {
        origin[j] = 0.5 * lo[j] + 0.5 * hi[j];
        half += (0.5 * (hi[j] - lo[j])) * (0.5 * (hi[j] - lo[j]));
    }
    *extent = sqrt(half);
    double mean = area_sum / n;
    if (!(mean > 0.0)) mean = 1.0; /* all areas zero: every weight is the floor */
    for (uint32_t i = 0; i < n; i++) {
        const sv_leaf *l = &leaves[idx ? idx[i] : i];
        double len = sqrt(sv_dot3(l->normal, l->normal));
        for (int j = 0; j < 3; j++) {
            r[i].p[j] = l->centre[j] - origin[j];
            r[i].n[j] = l->normal[j] / len;
        }
        /* floor: a zero-area leaf still counts a little, so no cluster has W = 0 */
        r[i].w = area_weighted ? fmax(l->area / mean, MIN_WEIGHT) : 1.0;
    }
    *out = r;
    return SV_OK;
}

static double orient_tol(double extent)
{
    return 1e-9 * (extent > 0.0 ? extent : 1.0);
}

/* Converts a local plane to world (oriented by ref_local) in out. */
static void plane_to_world(const plane_l *pl, const double origin[3], const double ref_local[3],
                           double extent, double normal[3], double *d)
{
    double n[3] = {pl->n[0], pl->n[1], pl->n[2]}, dl = pl->d;
    sv_plane_orient(n, &dl, ref_local, orient_tol(extent));
    for (int j = 0; j < 3; j++) normal[j] = n[j];
    *d = dl - sv_dot3(n, origin);
    *d += 0.0;
}

sv_status sv_cluster_fit_plane(const sv_leaf *leaves, const uint32_t *idx, uint32_t n, double alpha,
                               bool area_weighted, const double *centre, double normal[3],
                               double *d, double *error, sv_error *err)
{
    if (!leaves || n == 0)
        return sv_fail(err, SV_ERR_INVALID, "cluster: fitting a plane to no leaves");
    leaf_rec *r;
    double origin[3], extent;
    sv_status st = make_records(leaves, idx, n, area_weighted, &r, origin, &extent, err);
    if (st != SV_OK) return st;
    uint32_t *assign = sv_calloc(n, sizeof *assign);
    if (!assign) {
        free(r);
        return sv_fail(err, SV_ERR_NOMEM, "cluster: out of memory for %u leaves", n);
    }
    stats s;
    stats_from_assign(r, n, assign, 1, &s);
    plane_l pl;
    stats_fit(&s, alpha, &pl);
    double ref[3];
    for (int j = 0; j < 3; j++) ref[j] = centre ? centre[j] - origin[j] : s.c[j];
    plane_to_world(&pl, origin, ref, extent, normal, d);
    if (error) {
        double e = 0.0;
        for (uint32_t i = 0; i < n; i++) e += rec_error(&r[i], &pl, alpha);
        *error = e;
    }
    free(assign);
    free(r);
    return SV_OK;
}

/* ---- k-means ---- */

static void leaf_plane(const leaf_rec *r, plane_l *pl)
{
    for (int j = 0; j < 3; j++) pl->n[j] = r->n[j];
    pl->d = -sv_dot3(r->p, r->n);
}

/* Index i with the cumulative sum of w[0..i] first exceeding target; only
 * entries with w > 0 can be returned. */
static uint32_t pick_cumulative(const double *w, uint32_t n, double target)
{
    double cum = 0.0;
    uint32_t last = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (w[i] <= 0.0) continue;
        cum += w[i];
        last = i;
        if (cum > target) return i;
    }
    return last;
}

/* k-means++ seeding on eq. 1 (Arthur & Vassilvitskii 2007), greedy variant:
 * `tries` candidates per seed, the one lowering the potential most wins.
 * Returns the number of seeds (< k when every leaf already fits exactly). */
static uint32_t seed_planes(const leaf_rec *r, uint32_t n, uint32_t k, uint32_t tries, double alpha,
                            uint64_t *rng, plane_l *planes, double *dist, double *tmp)
{
    double wsum = 0.0;
    double *w = tmp;
    for (uint32_t i = 0; i < n; i++) w[i] = r[i].w;
    for (uint32_t i = 0; i < n; i++) wsum += w[i];
    uint32_t first = pick_cumulative(w, n, rng_unit(rng) * wsum);
    leaf_plane(&r[first], &planes[0]);
    for (uint32_t i = 0; i < n; i++) dist[i] = rec_error(&r[i], &planes[0], alpha);
    uint32_t got = 1;
    while (got < k) {
        double total = 0.0;
        for (uint32_t i = 0; i < n; i++) total += dist[i];
        if (!(total > 0.0)) break;
        double best_pot = INFINITY;
        plane_l best = planes[0];
        for (uint32_t t = 0; t < tries; t++) {
            uint32_t c = pick_cumulative(dist, n, rng_unit(rng) * total);
            plane_l cand;
            leaf_plane(&r[c], &cand);
            double pot = 0.0;
            for (uint32_t i = 0; i < n; i++) {
                double e = rec_error(&r[i], &cand, alpha);
                pot += e < dist[i] ? e : dist[i];
            }
            if (pot < best_pot) {
                best_pot = pot;
                best = cand;
            }
        }
        planes[got++] = best;
        for (uint32_t i = 0; i < n; i++) {
            double e = rec_error(&r[i], &best, alpha);
            if (e < dist[i]) dist[i] = e;
        }
    }
    return got;
}

/* Assigns every leaf to its nearest plane; returns how many changed and
 * fills err[i] with the leaf's error. */
static uint32_t assign_leaves(const leaf_rec *r, uint32_t n, const plane_l *planes, uint32_t k,
                              double alpha, uint32_t *assign, double *lerr)
{
    uint32_t changes = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t best = 0;
        double be = rec_error(&r[i], &planes[0], alpha);
        for (uint32_t c = 1; c < k; c++) {
            double e = rec_error(&r[i], &planes[c], alpha);
            if (e < be) {
                be = e;
                best = c;
            }
        }
        if (assign[i] != best) changes++;
        assign[i] = best;
        lerr[i] = be;
    }
    return changes;
}

/* Moves the worst-fitting leaf (not alone in its cluster, error > 0) into
 * each empty cluster. Returns the number of moves. */
static uint32_t reseed_empty(const leaf_rec *r, uint32_t n, plane_l *planes, uint32_t k,
                             uint32_t *assign, double *lerr, uint32_t *size)
{
    memset(size, 0, (size_t)k * sizeof *size);
    for (uint32_t i = 0; i < n; i++) size[assign[i]]++;
    uint32_t moved = 0;
    for (uint32_t c = 0; c < k; c++) {
        if (size[c]) continue;
        uint32_t worst = UINT32_MAX;
        double we = 0.0;
        for (uint32_t i = 0; i < n; i++)
            if (size[assign[i]] > 1 && lerr[i] > we) {
                we = lerr[i];
                worst = i;
            }
        if (worst == UINT32_MAX) break; /* every leaf fits exactly: leave it empty */
        size[assign[worst]]--;
        assign[worst] = c;
        size[c] = 1;
        lerr[worst] = 0.0;
        leaf_plane(&r[worst], &planes[c]);
        moved++;
    }
    return moved;
}

/* ---- hierarchy ---- */

static void level_free(sv_cluster_level *l)
{
    free(l->planes);
    free(l->parent);
    free(l->assign);
    memset(l, 0, sizeof *l);
}

void sv_clusters_free(sv_clusters *c)
{
    if (!c) return;
    if (c->levels)
        for (uint32_t i = 0; i < c->level_count; i++) level_free(&c->levels[i]);
    free(c->levels);
    memset(c, 0, sizeof *c);
}

/* Relabels clusters 0..k) by their lowest leaf index, dropping empty ones.
 * Returns the new count; map receives old → new (UINT32_MAX for empty). */
static uint32_t canonical_labels(uint32_t *assign, uint32_t n, uint32_t k, uint32_t *map)
{
    for (uint32_t c = 0; c < k; c++) map[c] = UINT32_MAX;
    uint32_t next = 0;
    for (uint32_t i = 0; i < n; i++)
        if (map[assign[i]] == UINT32_MAX) map[assign[i]] = next++;
    for (uint32_t i = 0; i < n; i++) assign[i] = map[assign[i]];
    return next;
}

static sv_status level_alloc(sv_cluster_level *l, uint32_t count, uint32_t n)
{
    l->count = count;
    l->planes = sv_calloc(count, sizeof *l->planes);
    l->parent = sv_calloc(count, sizeof *l->parent);
    l->assign = sv_calloc(n, sizeof *l->assign);
    if (!l->planes || !l->parent || !l->assign) return SV_ERR_NOMEM;
    for (uint32_t c = 0; c < count; c++) l->parent[c] = -1;
    return SV_OK;
}

/* Fills a level's planes (world frame, oriented) and exact errors from its
 * assignment. */
static void level_finish(sv_cluster_level *l, const leaf_rec *r, uint32_t n, const stats *st,
                         double alpha, const double origin[3], const double ref[3], double extent,
                         plane_l *local)
{
    l->error = 0.0;
    for (uint32_t c = 0; c < l->count; c++) {
        stats_fit(&st[c], alpha, &local[c]);
        /* orient the local plane too, so exact errors use the same plane */
        sv_plane_orient(local[c].n, &local[c].d, ref, orient_tol(extent));
        plane_to_world(&local[c], origin, ref, extent, l->planes[c].normal, &l->planes[c].d);
        l->planes[c].weight = st[c].w;
        l->planes[c].error = 0.0;
        l->planes[c].leaves = 0;
    }
    for (uint32_t i = 0; i < n; i++) {
        sv_cluster_plane *p = &l->planes[l->assign[i]];
        p->error += rec_error(&r[i], &local[l->assign[i]], alpha);
        p->leaves++;
    }
    for (uint32_t c = 0; c < l->count; c++) l->error += l->planes[c].error;
}

/* Merges the finer level's clusters down to at most `target`, least error
 * increase first (§2.4). st (fine->count entries) is overwritten. */
static sv_status merge_level(const sv_cluster_level *fine, sv_cluster_level *coarse,
                             uint32_t target, uint32_t n, stats *st, double alpha)
{
    uint32_t k = fine->count;
    size_t kk;
    if (!sv_mul_size(k, k, &kk)) return SV_ERR_NOMEM;
    double *cost = sv_calloc(kk, sizeof *cost);
    double *err = sv_calloc(k, sizeof *err);
    uint32_t *root = sv_calloc(k, sizeof *root);
    uint8_t *active = sv_calloc(k, 1);
    uint32_t *label = sv_calloc(k, sizeof *label);
    sv_status status = SV_ERR_NOMEM;
    if (!cost || !err || !root || !active || !label) goto out;
    plane_l pl;
    for (uint32_t a = 0; a < k; a++) {
        err[a] = stats_fit(&st[a], alpha, &pl);
        root[a] = a;
        active[a] = 1;
    }
    for (uint32_t a = 0; a < k; a++)
        for (uint32_t b = a + 1; b < k; b++) {
            stats m;
            stats_merge(&st[a], &st[b], &m);
            cost[(size_t)a * k + b] = stats_fit(&m, alpha, &pl) - err[a] - err[b];
        }
    uint32_t alive = k;
    while (alive > target) {
        uint32_t ba = 0, bb = 0;
        double bc = INFINITY;
        for (uint32_t a = 0; a < k; a++) {
            if (!active[a]) continue;
            for (uint32_t b = a + 1; b < k; b++)
                if (active[b] && cost[(size_t)a * k + b] < bc) {
                    bc = cost[(size_t)a * k + b];
                    ba = a;
                    bb = b;
                }
        }
        if (ba == bb) break; /* unreachable with alive >= 2 and finite costs */
        stats m;
        stats_merge(&st[ba], &st[bb], &m);
        st[ba] = m;
        err[ba] = stats_fit(&st[ba], alpha, &pl);
        active[bb] = 0;
        for (uint32_t c = 0; c < k; c++)
            if (root[c] == bb) root[c] = ba;
        alive--;
        for (uint32_t c = 0; c < k; c++) {
            if (!active[c] || c == ba) continue;
            uint32_t a = c < ba ? c : ba, b = c < ba ? ba : c;
            stats_merge(&st[a], &st[b], &m);
            cost[(size_t)a * k + b] = stats_fit(&m, alpha, &pl) - err[a] - err[b];
        }
    }
    /* Active clusters in index order are in order of their lowest leaf index
     * (the finer level is, and a merge keeps the lower index). */
    uint32_t next = 0;
    for (uint32_t a = 0; a < k; a++) label[a] = active[a] ? next++ : UINT32_MAX;
    if (level_alloc(coarse, next, n) != SV_OK) goto out;
    for (uint32_t c = 0; c < k; c++) fine->parent[c] = (int32_t)label[root[c]];
    for (uint32_t i = 0; i < n; i++) coarse->assign[i] = label[root[fine->assign[i]]];
    status = SV_OK;
out:
    free(cost);
    free(err);
    free(root);
    free(active);
    free(label);
    return status;
}

sv_status sv_cluster_build(const sv_leaf *leaves, uint32_t count, const sv_cluster_options *opt,
                           sv_clusters *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    sv_cluster_options o = {0};
    if (opt) o = *opt;
    const uint32_t *levels = o.levels ? o.levels : default_levels;
    uint32_t nlev = o.levels ? o.level_count : 3;
    if (!leaves || count == 0) return sv_fail(err, SV_ERR_INVALID, "cluster: no leaves to cluster");
    if (nlev == 0) return sv_fail(err, SV_ERR_INVALID, "cluster: no levels requested");
    for (uint32_t l = 0; l < nlev; l++) {
        if (levels[l] == 0)
            return sv_fail(err, SV_ERR_INVALID, "cluster: level %u asks for 0 clusters", l);
        if (l > 0 && levels[l] >= levels[l - 1])
            return sv_fail(err, SV_ERR_INVALID,
                           "cluster: level counts must strictly decrease (level %u: %u after %u)",
                           l, levels[l], levels[l - 1]);
    }
    if (!(o.alpha >= 0.0) || !isfinite(o.alpha))
        return sv_fail(err, SV_ERR_INVALID, "cluster: alpha must be finite and >= 0 (got %g)",
                       o.alpha);
    uint32_t max_it = o.max_iterations ? o.max_iterations : DEFAULT_ITERATIONS;
    uint32_t tries = o.seed_tries ? o.seed_tries : DEFAULT_SEED_TRIES;
    double alpha = o.alpha;

    leaf_rec *r = NULL;
    double origin[3], extent;
    sv_status st = make_records(leaves, NULL, count, o.area_weighted, &r, origin, &extent, err);
    if (st != SV_OK) return st;
    double ref[3];
    for (int j = 0; j < 3; j++) ref[j] = o.centre ? o.centre[j] - origin[j] : 0.0;

    uint32_t k = levels[0] < count ? levels[0] : count;
    plane_l *planes = sv_calloc(k, sizeof *planes);
    stats *sts = sv_calloc(k, sizeof *sts);
    uint32_t *assign = sv_calloc(count, sizeof *assign);
    uint32_t *size = sv_calloc(k, sizeof *size);
    double *lerr = sv_calloc(count, sizeof *lerr);
    double *tmp = sv_calloc(count, sizeof *tmp);
    out->levels = sv_calloc(nlev, sizeof *out->levels);
    if (!planes || !sts || !assign || !size || !lerr || !tmp || !out->levels) {
        st = sv_fail(err, SV_ERR_NOMEM, "cluster: out of memory for %u leaves, %u clusters", count,
                     k);
        goto out;
    }
    out->level_count = nlev;
    out->leaf_count = count;
    out->alpha = alpha;
    for (uint32_t i = 0; i < count; i++) out->weight += r[i].w;

    uint64_t rng = o.seed ^ 0x6C656166636C7573ull; /* "leafclus" */
    k = seed_planes(r, count, k, tries, alpha, &rng, planes, lerr, tmp);

    /* Lloyd iterations (MacQueen's K-means, §2). */
    for (uint32_t i = 0; i < count; i++) assign[i] = UINT32_MAX;
    double prev = INFINITY;
    uint32_t it = 0;
    while (it < max_it) {
        uint32_t changes = assign_leaves(r, count, planes, k, alpha, assign, lerr);
        uint32_t moved = reseed_empty(r, count, planes, k, assign, lerr, size);
        changes += moved;
        out->reseeds += moved;
        it++;
        if (it > 1 && changes == 0) break; /* planes already fit this assignment */
        stats_from_assign(r, count, assign, k, sts);
        double total = 0.0;
        for (uint32_t c = 0; c < k; c++)
            if (sts[c].w > 0.0) total += stats_fit(&sts[c], alpha, &planes[c]);
        if (total >= prev - STALL_REL * prev) break;
        prev = total;
    }
    out->iterations = it;

    /* Finest level: canonical labels, statistics, planes. */
    uint32_t *map = size; /* k entries, reused */
    uint32_t kc = canonical_labels(assign, count, k, map);
    sv_cluster_level *fine = &out->levels[0];
    if (level_alloc(fine, kc, count) != SV_OK) {
        st = sv_fail(err, SV_ERR_NOMEM, "cluster: out of memory for level 0");
        goto out;
    }
    memcpy(fine->assign, assign, (size_t)count * sizeof *assign);
    stats_from_assign(r, count, fine->assign, kc, sts);
    level_finish(fine, r, count, sts, alpha, origin, ref, extent, planes);

    for (uint32_t l = 1; l < nlev; l++) {
        sv_cluster_level *f = &out->levels[l - 1], *c = &out->levels[l];
        /* st of the finer level, recomputed exactly (two passes) */
        stats_from_assign(r, count, f->assign, f->count, sts);
        if (merge_level(f, c, levels[l], count, sts, alpha) != SV_OK) {
            st = sv_fail(err, SV_ERR_NOMEM, "cluster: out of memory for level %u", l);
            goto out;
        }
        stats_from_assign(r, count, c->assign, c->count, sts);
        level_finish(c, r, count, sts, alpha, origin, ref, extent, planes);
    }
    st = SV_OK;
out:
    if (st != SV_OK) sv_clusters_free(out);
    free(planes);
    free(sts);
    free(assign);
    free(size);
    free(lerr);
    free(tmp);
    free(r);
    return st;
}
