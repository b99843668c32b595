/* greedy_planes.c — billboard-cloud plane selection (planes.h).
 *
 * Décoret, Durand, Sillion, Dorsey, "Billboard Clouds for Extreme Model
 * Simplification", SIGGRAPH 2003 (dual space, validity, density, greedy
 * selection, penalty, appendix: ρ-range of a face over a cell), and
 * Behrendt, Colditz, Franzke, Kopf, Deussen, "Realistic real-time rendering of
 * landscapes using billboard clouds", Eurographics 2005
 * (papers/billboard-cloud-forests.txt): §3.2.2 separate trunk/foliage passes
 * and no penalty for sub-cells, §3.3.1 angular contribution, §3.3.2 fail-safe,
 * §3.3.3 post-plane tweaking with the half-space normal flip, §3.3.4 vertex
 * welding, §3.3.5 horizontal-plane penalty, §3.3.6 cardboard planes, §3.3.8
 * incremental LODs (sv_bbc_project).
 *
 * What makes it fast (the paper's timings were minutes for a 109k-face tree):
 *  - Elements, not faces: a leaf is one element (a box: centre, normal, two
 *    in-plane axes, three half extents), so the grid sees ~7,000 leaves instead
 *    of 112,000 triangles on the ficus.
 *  - Closed-form ρ-range per (θ, φ) column: for a cell of angular radius δ
 *    around direction n, an element with box centre c and support half-width
 *    h(n) = Σ e_k |a_k·n| is valid for some plane of the cell only if
 *    ρ ∈ c·n ± (|c|δ + ε − max(0, h(n) − δ Σ e_k)) (conservative like Décoret's
 *    appendix; the refinement below is exact). One interval per column: a
 *    difference array over the ρ bins, two writes per element and column.
 *  - Exact int64 fixed-point densities: removing the faces of a chosen plane
 *    subtracts exactly what was added, so incremental updates equal a rebuild
 *    bit for bit, and a rebuild is used when it is cheaper.
 *  - Columns are split between threads by index and each column sums its
 *    elements in one fixed order: no reduction order to depend on, so the
 *    result is the same for any thread count. The refinement's sub-cells,
 *    the element scans and the input elements' geometry are split the same
 *    way (parallel.h): per-index results, picked or joined in index order.
 *  - Refinement solves ρ exactly per direction: the valid ρ of an element for
 *    direction n is [max p·n − ε, min p·n + ε]; the best ρ is a sweep over the
 *    sorted interval ends (the densest stabbing point), so only directions
 *    are subdivided (3×3 per level).
 */
#include "planes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"
#include "parallel.h"
#include "stand_in.h"
#include "vec3.h"

#define FAILSAFE_CAP 64     /* supporting planes tried by the fail-safe */
#define QSCALE 4294967296.0 /* fixed point: 2^32 per unit of relative weight */
#define BLOCK 64            /* elements per cache block in the grid update */
#define SUBCELLS 9          /* 3×3 directions per refinement level */
/* Below these sizes a region runs on one thread: creating and joining one
 * costs ~20 µs, about what a scan of this many elements or a refinement level
 * over this many candidates does. (Only speed: the bytes are the same.) */
#define PAR_MIN_SCAN 1024 /* elements in a candidate or validity scan */
#define PAR_MIN_CANDS 48  /* candidates of a refinement level */
#define HALF_PI 1.57079632679489661923

/* ---------------------------------------------------------------- helpers */

/* acos on [0, 1] (Abramowitz & Stegun 4.4.45, |error| <= 6.7e-5 rad): the
 * angular contribution is evaluated ~10^7 times per plane set. Pure
 * arithmetic, hence deterministic. */
static double acos_fast(double x)
{
    if (x >= 1.0) return 0.0;
    if (x < 0) x = 0;
    return sqrt(1.0 - x) * (1.5707288 + x * (-0.2121144 + x * (0.0742610 + x * -0.0187293)));
}

/* Unit vectors b1, b2 with n, b1, b2 orthonormal (deterministic choice). */
static void plane_basis(const double n[3], double b1[3], double b2[3])
{
    double ax[3] = {0, 0, 0};
    int k = 0;
    for (int i = 1; i < 3; i++)
        if (fabs(n[i]) < fabs(n[k])) k = i;
    ax[k] = 1;
    sv_cross3(n, ax, b1);
    sv_normalize3(b1);
    sv_cross3(n, b1, b2);
}

static void dir_of(double th, double ph, double n[3])
{
    double cp = cos(ph);
    n[0] = cp * cos(th);
    n[1] = sin(ph);
    n[2] = cp * sin(th);
}

/* ---------------------------------------------------------------- shared data */

/* One simplification element: a group of triangles simplified together. */
typedef struct elem {
    double c[3];     /* box centre, relative to the sphere centre */
    double cn;       /* |c| */
    double ax[3][3]; /* ax[0]: normal m; ax[1], ax[2]: in-plane axes */
    double ext[3];   /* half extents along ax */
    double sumext;
    double g[3]; /* area centroid (relative) */
    double area;
    double w; /* area / pass area: the weight unit of the grid */
    const uint32_t *tris;
    const uint32_t *verts; /* canonical vertex ids, unique */
    uint32_t tcount, vcount;
    uint32_t group; /* input element index */
} elem;

typedef struct base {
    const sv_bbc_input *in;
    sv_bbc_options opt;
    double R;
    double *rel;      /* 3 per vertex: position − centre */
    uint32_t *canon;  /* vertex → canonical vertex with the same position */
    elem *groups;     /* per input element, geometry from rel */
    uint32_t *gverts; /* vertex lists of groups */
    bool have_part[2];
    /* dual grid geometry */
    uint32_t nt, np, nr, ncol;
    double *dirs;  /* 3 per column: cell-centre normal; column = j * nt + i */
    double *delta; /* per φ row: angular radius of a cell */
    double dth, dph;
} base;

static double hfac_of(const sv_bbc_options *o, double ny)
{
    if (!o->horizontal_penalty) return 1.0;
    double el = asin(fmin(1.0, fabs(ny)));
    double cut = o->horizontal_angle_deg * M_PI / 180.0;
    if (el <= cut) return 1.0;
    double t = cut < HALF_PI ? (el - cut) / (HALF_PI - cut) : 1.0;
    if (t > 1) t = 1;
    return 1.0 - o->horizontal_value * t;
}

/* Area and unit normal of triangle t from positions pos (canonical ids). */
static double tri_geom(const base *b, const double *pos, uint32_t t, double n[3])
{
    const uint32_t *ix = &b->in->indices[3 * (size_t)t];
    const double *p0 = &pos[3 * (size_t)b->canon[ix[0]]];
    const double *p1 = &pos[3 * (size_t)b->canon[ix[1]]];
    const double *p2 = &pos[3 * (size_t)b->canon[ix[2]]];
    double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    sv_cross3(e1, e2, n);
    double l = sv_norm3(n);
    if (!(l > 0)) {
        n[0] = n[1] = n[2] = 0;
        return 0;
    }
    n[0] /= l;
    n[1] /= l;
    n[2] /= l;
    return 0.5 * l;
}

/* Geometry of an element from its triangles and vertices (§3.3.3's area
 * weighting for normal and centroid; normals flipped into the half-space of
 * the largest triangle so two-sided leaves do not cancel). */
static void elem_geometry(const base *b, const double *pos, elem *e)
{
    double m[3] = {0, 0, 0}, g[3] = {0, 0, 0}, n0[3] = {0, 0, 0};
    double area = 0, amax = -1;
    for (uint32_t k = 0; k < e->tcount; k++) {
        double n[3];
        double a = tri_geom(b, pos, e->tris[k], n);
        if (a > amax) {
            amax = a;
            memcpy(n0, n, sizeof n0);
        }
    }
    for (uint32_t k = 0; k < e->tcount; k++) {
        uint32_t t = e->tris[k];
        double n[3];
        double a = tri_geom(b, pos, t, n);
        double s = sv_dot3(n, n0) < 0 ? -a : a;
        const uint32_t *ix = &b->in->indices[3 * (size_t)t];
        for (int c = 0; c < 3; c++) {
            m[c] += s * n[c];
            for (int v = 0; v < 3; v++) g[c] += a / 3.0 * pos[3 * (size_t)b->canon[ix[v]] + c];
        }
        area += a;
    }
    e->area = area;
    if (area > 0) {
        for (int c = 0; c < 3; c++) e->g[c] = g[c] / area;
    } else {
        double s[3] = {0, 0, 0};
        for (uint32_t k = 0; k < e->vcount; k++)
            for (int c = 0; c < 3; c++) s[c] += pos[3 * (size_t)e->verts[k] + c];
        for (int c = 0; c < 3; c++) e->g[c] = e->vcount ? s[c] / e->vcount : 0;
    }
    if (!(sv_norm3(m) > 1e-9 * area) || !sv_normalize3(m)) {
        if (amax > 0) {
            memcpy(m, n0, sizeof m);
        } else {
            /* Degenerate: a plane containing the longest vertex-to-vertex span. */
            double best = 0, dir[3] = {0, 0, 0};
            for (uint32_t i = 0; i < e->vcount; i++)
                for (uint32_t j = i + 1; j < e->vcount; j++) {
                    const double *a = &pos[3 * (size_t)e->verts[i]];
                    const double *c = &pos[3 * (size_t)e->verts[j]];
                    double d[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
                    double l = sv_dot3(d, d);
                    if (l > best) {
                        best = l;
                        memcpy(dir, d, sizeof dir);
                    }
                }
            if (best > 0 && sv_normalize3(dir)) {
                double b1[3], b2[3];
                plane_basis(dir, b1, b2);
                memcpy(m, b1, sizeof m);
            } else {
                m[0] = 0;
                m[1] = 1;
                m[2] = 0;
            }
        }
    }
    /* In-plane axes: principal directions of the vertices (2×2 covariance). */
    double b1[3], b2[3];
    plane_basis(m, b1, b2);
    double mean[2] = {0, 0}, cxx = 0, cxy = 0, cyy = 0;
    for (uint32_t k = 0; k < e->vcount; k++) {
        const double *p = &pos[3 * (size_t)e->verts[k]];
        mean[0] += sv_dot3(p, b1);
        mean[1] += sv_dot3(p, b2);
    }
    if (e->vcount) {
        mean[0] /= e->vcount;
        mean[1] /= e->vcount;
    }
    for (uint32_t k = 0; k < e->vcount; k++) {
        const double *p = &pos[3 * (size_t)e->verts[k]];
        double x = sv_dot3(p, b1) - mean[0], y = sv_dot3(p, b2) - mean[1];
        cxx += x * x;
        cxy += x * y;
        cyy += y * y;
    }
    double ang = 0.5 * atan2(2 * cxy, cxx - cyy);
    double ca = cos(ang), sa = sin(ang);
    for (int c = 0; c < 3; c++) {
        e->ax[0][c] = m[c];
        e->ax[1][c] = ca * b1[c] + sa * b2[c];
    }
    sv_cross3(e->ax[0], e->ax[1], e->ax[2]);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = 0; k < e->vcount; k++) {
        const double *p = &pos[3 * (size_t)e->verts[k]];
        for (int a = 0; a < 3; a++) {
            double v = sv_dot3(p, e->ax[a]);
            if (v < lo[a]) lo[a] = v;
            if (v > hi[a]) hi[a] = v;
        }
    }
    e->sumext = 0;
    for (int c = 0; c < 3; c++) e->c[c] = 0;
    for (int a = 0; a < 3; a++) {
        if (!e->vcount) lo[a] = hi[a] = 0;
        double mid = 0.5 * (lo[a] + hi[a]);
        e->ext[a] = 0.5 * (hi[a] - lo[a]);
        e->sumext += e->ext[a];
        for (int c = 0; c < 3; c++) e->c[c] += mid * e->ax[a][c];
    }
    e->cn = sv_norm3(e->c);
}

/* ---------------------------------------------------------------- one pass */

typedef struct evt {
    double x, w;
    uint32_t e;
    uint32_t type; /* 0 start (sorted first at equal x: intervals are closed), 1 end */
} evt;

typedef struct pass {
    const base *b;
    uint8_t part;
    double eps, tol, max_angle, miss, bw, inv_bw;
    const double *pos; /* positions by canonical id (b->rel, or wpos when welding) */
    double *wpos;
    uint8_t *welded;
    elem *el;
    uint32_t n;
    uint32_t *sverts; /* vertex lists of split singletons */
    uint8_t *alive;
    uint32_t alive_count;
    double area0;  /* pass area at the start (weights are area / area0) */
    int64_t *diff; /* per column: nr + 1 difference entries */
    double *colmax;
    uint32_t *colarg;
    /* welding adjacency: canonical vertex → elements */
    uint32_t *adj_first, *adj;
    /* scratch */
    uint32_t *cand, *set, *tmp, *stamp;
    elem *batch;
    evt *ev, *ev2;     /* sort buffers, 2n events per refinement chunk */
    uint32_t nscratch; /* refinement chunks: sv_parallel_chunks(SUBCELLS, threads) */
    uint32_t round;
} pass;

static void pass_free(pass *p)
{
    free(p->wpos);
    free(p->welded);
    free(p->el);
    free(p->sverts);
    free(p->alive);
    free(p->diff);
    free(p->colmax);
    free(p->colarg);
    free(p->adj_first);
    free(p->adj);
    free(p->cand);
    free(p->set);
    free(p->tmp);
    free(p->stamp);
    free(p->batch);
    free(p->ev);
    free(p->ev2);
    memset(p, 0, sizeof *p);
}

/* Angular contribution (§3.3.1): area × (1 − angle/90°), and the Fig. 4b
 * remedy: no contribution, and no validity, beyond max_angle. Zero-area
 * elements weigh nothing and are never refused. */
static bool weight_of(const pass *p, const elem *e, const double n[3], double *w)
{
    if (!(e->area > 0)) {
        *w = 0;
        return true;
    }
    double ang = acos_fast(fabs(sv_dot3(e->ax[0], n)));
    if (ang > p->max_angle) return false;
    double f = 1.0 - ang / HALF_PI;
    *w = e->area * (f > 0 ? f : 0);
    return true;
}

/* Conservative extent of the planes of a cell (centre n, angular radius δ)
 * for which e may be valid: ρ ∈ cc ± half; and its contribution weight
 * (relative units). The antipodal cell (−n) gets −cc ± half with the same
 * weight, which is how one evaluation serves two columns. */
static bool cell_core(const pass *p, const double n[3], double delta, const elem *e, double *cc,
                      double *half, double *wgt)
{
    double d0 = sv_dot3(e->ax[0], n);
    double h = e->ext[0] * fabs(d0) + e->ext[1] * fabs(sv_dot3(e->ax[1], n)) +
               e->ext[2] * fabs(sv_dot3(e->ax[2], n));
    double hmin = h - e->sumext * delta;
    if (hmin < 0) hmin = 0;
    double slack = p->eps + p->tol - hmin;
    if (slack < 0) return false;
    double ang = acos_fast(fabs(d0));
    if (e->area > 0 && ang - delta > p->max_angle) return false;
    double f = 1.0 - ang / HALF_PI;
    *wgt = e->w * (f > 0 ? f : 0);
    *cc = sv_dot3(e->c, n);
    *half = e->cn * delta + slack;
    return true;
}

/* ρ bins [a, z] covered by [cc − half, cc + half] within [0, R). */
static bool rho_bins(const pass *p, double cc, double half, int *blo, int *bhi)
{
    double lo = cc - half, hi = cc + half;
    int nr = (int)p->b->nr;
    if (hi < 0 || lo >= p->b->R) return false;
    int a = lo <= 0 ? 0 : (int)(lo * p->inv_bw);
    int z = hi >= p->b->R ? nr - 1 : (int)(hi * p->inv_bw);
    if (a > nr - 1) a = nr - 1;
    if (z > nr - 1) z = nr - 1;
    if (z < a) z = a;
    *blo = a;
    *bhi = z;
    return true;
}

static bool cell_bins(const pass *p, const double n[3], double delta, const elem *e, int *blo,
                      int *bhi)
{
    double cc, half, w;
    return cell_core(p, n, delta, e, &cc, &half, &w) && rho_bins(p, cc, half, blo, bhi);
}

static void interval_add(const pass *p, double cc, double half, int64_t q, int64_t pq,
                         int64_t *diff, int64_t sign)
{
    int a, z;
    if (!rho_bins(p, cc, half, &a, &z)) return;
    diff[a] += sign * q;
    diff[z + 1] -= sign * q;
    /* Décoret's penalty: planes just behind the valid range (by less than ε,
     * on the centre side) nearly miss the face, which then sticks out of them.
     * Coarse grid only (Behrendt §3.2.2). */
    if (pq && a > 0) {
        double plo = cc - half - p->eps;
        int pa = plo <= 0 ? 0 : (int)(plo * p->inv_bw);
        if (pa < a) {
            diff[pa] -= sign * pq;
            diff[a] += sign * pq;
        }
    }
}

/* Adds an element to the column of n and to its antipodal column. */
static void column_add_pair(const pass *p, const double n[3], double delta, const elem *e,
                            int64_t *diff, int64_t *anti, int64_t sign)
{
    double cc, half, w;
    if (!cell_core(p, n, delta, e, &cc, &half, &w)) return;
    int64_t q = (int64_t)(w * QSCALE + 0.5);
    int64_t pq = p->miss > 0 ? (int64_t)(w * p->miss * QSCALE + 0.5) : 0;
    interval_add(p, cc, half, q, pq, diff, sign);
    interval_add(p, -cc, half, q, pq, anti, sign);
}

/* One grid update: the batch to add (sign +1) or subtract (-1). */
typedef struct gjob {
    pass *p;
    const elem *batch;
    uint32_t nb;
    int64_t sign;
    bool reset;
} gjob;

/* Column pair q: column (i, j) and its antipode (i + nt/2, np − 1 − j). */
static void pair_cols(const base *b, uint32_t q, uint32_t *c1, uint32_t *c2)
{
    uint32_t h = b->nt / 2, i = q % h, j = q / h;
    *c1 = j * b->nt + i;
    *c2 = (b->np - 1 - j) * b->nt + i + h;
}

static void scan_column(pass *p, uint32_t col)
{
    const base *b = p->b;
    const int64_t *diff = &p->diff[col * ((size_t)b->nr + 1)];
    double hf = hfac_of(&b->opt, b->dirs[3 * (size_t)col + 1]);
    int64_t run = 0;
    double best = -INFINITY;
    uint32_t arg = 0;
    for (uint32_t k = 0; k < b->nr; k++) {
        run += diff[k];
        double v = (double)run * hf;
        if (v > best) {
            best = v;
            arg = k;
        }
    }
    p->colmax[col] = best;
    p->colarg[col] = arg;
}

/* Column pairs [q0, q1) of a grid update (an sv_parallel_for chunk): each
 * pair is its chunk's alone, and every column adds the batch in batch order. */
static void gjob_run(void *arg, uint32_t t, uint32_t q0, uint32_t q1)
{
    (void)t;
    const gjob *j = arg;
    pass *p = j->p;
    const base *b = p->b;
    size_t stride = (size_t)b->nr + 1;
    if (j->reset)
        for (uint32_t q = q0; q < q1; q++) {
            uint32_t c1, c2;
            pair_cols(b, q, &c1, &c2);
            memset(&p->diff[c1 * stride], 0, stride * sizeof(int64_t));
            memset(&p->diff[c2 * stride], 0, stride * sizeof(int64_t));
        }
    for (uint32_t e0 = 0; e0 < j->nb; e0 += BLOCK) {
        uint32_t e1 = j->nb - e0 > BLOCK ? e0 + BLOCK : j->nb;
        for (uint32_t q = q0; q < q1; q++) {
            uint32_t c1, c2;
            pair_cols(b, q, &c1, &c2);
            const double *n = &b->dirs[3 * (size_t)c1];
            double delta = b->delta[c1 / b->nt];
            int64_t *d1 = &p->diff[c1 * stride], *d2 = &p->diff[c2 * stride];
            for (uint32_t e = e0; e < e1; e++)
                column_add_pair(p, n, delta, &j->batch[e], d1, d2, j->sign);
        }
    }
    /* Column maxima, with the horizontal-plane penalty applied on read (§3.3.5). */
    for (uint32_t q = q0; q < q1; q++) {
        uint32_t c1, c2;
        pair_cols(b, q, &c1, &c2);
        scan_column(p, c1);
        scan_column(p, c2);
    }
}

/* Adds (sign +1) or subtracts (-1) a batch of elements in every column, then
 * rescans the column maxima. reset zeroes the grid first. The column pairs
 * are split between threads (sv_parallel_for): each owns its columns, and
 * the sums are exact integers, so the grid does not depend on the split. */
static void grid_update(pass *p, const elem *batch, uint32_t nb, int sign, bool reset)
{
    gjob j = {p, batch, nb, sign, reset};
    sv_parallel_for(p->b->ncol / 2, p->b->opt.threads, gjob_run, &j);
}

/* ---------------------------------------------------------------- exact planes */

static void extent_along(const pass *p, const elem *e, const double n[3], double *mn, double *mx)
{
    double lo = INFINITY, hi = -INFINITY;
    for (uint32_t k = 0; k < e->vcount; k++) {
        double v = sv_dot3(&p->pos[3 * (size_t)e->verts[k]], n);
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    *mn = lo;
    *mx = hi;
}

/* Exact validity (§3.1): every vertex within ε of the plane n·x = rho. */
static bool valid_for(const pass *p, const elem *e, const double n[3], double rho)
{
    double w;
    if (!weight_of(p, e, n, &w)) return false;
    double mn, mx;
    extent_along(p, e, n, &mn, &mx);
    return mx - rho <= p->eps + p->tol && rho - mn <= p->eps + p->tol;
}

static bool evt_less(const evt *x, const evt *y)
{
    if (x->x != y->x) return x->x < y->x;
    if (x->type != y->type) return x->type < y->type;
    return x->e < y->e;
}

/* Bottom-up merge sort by (x, type, element): a total order, so the sweep
 * below adds the same numbers in the same order every time. No comparator
 * calls through a pointer: this sort is the inner loop of the refinement. */
static evt *evt_sort(evt *a, evt *tmp, uint32_t n)
{
    for (uint32_t w = 1; w < n; w *= 2) {
        for (uint32_t lo = 0; lo < n; lo += 2 * w) {
            uint32_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            uint32_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi) tmp[k++] = evt_less(&a[j], &a[i]) ? a[j++] : a[i++];
            while (i < mid) tmp[k++] = a[i++];
            while (j < hi) tmp[k++] = a[j++];
        }
        evt *t = a;
        a = tmp;
        tmp = t;
    }
    return a;
}

/* Best plane with normal n among the candidate elements: the ρ stabbing the
 * heaviest set of exact validity intervals (sub-cells: no miss penalty,
 * §3.2.2). Returns the score (horizontal penalty applied) or -1 when no
 * candidate is valid for any plane with this normal. Reads the pass, writes
 * only ev and ev2 (2·nc events each): the refinement's threads each pass
 * their own. */
static double eval_dir(const pass *p, const double n[3], const uint32_t *cand, uint32_t nc, evt *ev,
                       evt *ev2, double *rho)
{
    uint32_t m = 0;
    for (uint32_t i = 0; i < nc; i++) {
        const elem *e = &p->el[cand[i]];
        double w;
        if (!weight_of(p, e, n, &w)) continue;
        double mn, mx;
        extent_along(p, e, n, &mn, &mx);
        double lo = mx - p->eps - p->tol, hi = mn + p->eps + p->tol;
        if (lo > hi) continue;
        ev[m++] = (evt){lo, w, cand[i], 0};
        ev[m++] = (evt){hi, w, cand[i], 1};
    }
    if (!m) return -1;
    ev = evt_sort(ev, ev2, m);
    double run = 0, best = -1;
    for (uint32_t k = 0; k < m; k++) {
        if (ev[k].type == 0) {
            run += ev[k].w;
            if (run > best) {
                best = run;
                *rho = 0.5 * (ev[k].x + ev[k + 1].x); /* an end always follows a start */
            }
        } else {
            run -= ev[k].w;
        }
    }
    return best * hfac_of(&p->b->opt, n[1]);
}

/* Sub-cells of one refinement level (an sv_parallel_for chunk each): score
 * and ρ of direction k into s[k] and rho[k], with chunk t's event buffers. */
typedef struct rjob {
    const pass *p;
    const uint32_t *cand;
    uint32_t nc;
    const double (*n)[3];
    double *s, *rho;
} rjob;

static void rjob_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    const rjob *j = arg;
    size_t off = (size_t)t * 2 * j->p->n;
    for (uint32_t k = lo; k < hi; k++)
        j->s[k] = eval_dir(j->p, j->n[k], j->cand, j->nc, j->p->ev + off, j->p->ev2 + off,
                           &j->rho[k]);
}

/* Recursive refinement of the picked cell (column i, row j): 3×3 sub-cells
 * per level, the best one refined further; the best plane seen wins. The
 * sub-cells of a level are scored on the pass's threads (each score is one
 * eval_dir, the same on any thread), then picked here in row order, so ties
 * go where they always went. */
static bool refine(pass *p, uint32_t i, uint32_t j, const uint32_t *cand, uint32_t nc,
                   double n_out[3], double *rho_out)
{
    const base *b = p->b;
    double th0 = i * b->dth, dth = b->dth;
    double ph0 = -HALF_PI + j * b->dph, dph = b->dph;
    double best = -1, prev = -1;
    uint32_t levels = b->opt.refine_levels ? b->opt.refine_levels : 1;
    for (uint32_t lv = 0; lv < levels; lv++) {
        dth /= 3;
        dph /= 3;
        /* the centre of a deeper level is the cell picked one level up,
         * already scored (prev): not evaluated again */
        double dn[SUBCELLS][3], ds[SUBCELLS], drho[SUBCELLS];
        uint32_t nd = 0;
        for (int bb = 0; bb < 3; bb++)
            for (int aa = 0; aa < 3; aa++) {
                if (lv > 0 && aa == 1 && bb == 1) continue;
                dir_of(th0 + (aa + 0.5) * dth, ph0 + (bb + 0.5) * dph, dn[nd]);
                drho[nd++] = 0;
            }
        rjob job = {p, cand, nc, (const double(*)[3])dn, ds, drho};
        sv_parallel_for(nd, nc >= PAR_MIN_CANDS ? p->nscratch : 1, rjob_run, &job);
        double lbest = -1;
        int la = 1, lb = 1;
        uint32_t k = 0;
        for (int bb = 0; bb < 3; bb++)
            for (int aa = 0; aa < 3; aa++) {
                double n[3] = {0, 0, 0}, rho = 0, s;
                if (lv > 0 && aa == 1 && bb == 1) {
                    s = prev;
                } else {
                    memcpy(n, dn[k], sizeof n);
                    rho = drho[k];
                    s = ds[k++];
                }
                if (s > lbest) {
                    lbest = s;
                    la = aa;
                    lb = bb;
                }
                if (s > best) {
                    best = s;
                    memcpy(n_out, n, 3 * sizeof(double));
                    *rho_out = rho;
                }
            }
        th0 += la * dth;
        ph0 += lb * dph;
        prev = lbest;
    }
    return best >= 0;
}

/* A scan of the alive elements (an sv_parallel_for chunk each): those of
 * [lo, hi) that pass the test, in index order, into out[lo..]; chunk t
 * records where its list starts and how long it is. The test is either the
 * picked cell's (valid somewhere in the cell of normal n and angular radius
 * delta, with ρ bin k in range) or exact validity for the plane (n, rho). */
typedef struct sjob {
    const pass *p;
    bool cell;
    const double *n;
    double delta, rho;
    int k;
    uint32_t *out;
    uint32_t first[SV_PARALLEL_MAX], found[SV_PARALLEL_MAX];
} sjob;

static void sjob_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    sjob *j = arg;
    const pass *p = j->p;
    uint32_t m = lo;
    for (uint32_t e = lo; e < hi; e++) {
        if (!p->alive[e]) continue;
        bool in;
        if (j->cell) {
            int a, z;
            in = cell_bins(p, j->n, j->delta, &p->el[e], &a, &z) && a <= j->k && j->k <= z;
        } else {
            in = valid_for(p, &p->el[e], j->n, j->rho);
        }
        if (in) j->out[m++] = e;
    }
    j->first[t] = lo;
    j->found[t] = m - lo;
}

/* Runs the scan over every element and returns the count: the chunks' lists
 * joined in chunk order, the list one thread would have written. */
static uint32_t scan_alive(const pass *p, sjob *j)
{
    uint32_t thr = p->n >= PAR_MIN_SCAN ? p->b->opt.threads : 1;
    uint32_t nch = sv_parallel_chunks(p->n, thr);
    sv_parallel_for(p->n, thr, sjob_run, j);
    uint32_t m = 0;
    for (uint32_t t = 0; t < nch; t++) {
        if (m != j->first[t])
            memmove(&j->out[m], &j->out[j->first[t]], j->found[t] * sizeof *j->out);
        m += j->found[t];
    }
    return m;
}

static uint32_t collect_valid(pass *p, const double n[3], double rho, uint32_t *out)
{
    sjob j = {.p = p, .cell = false, .n = n, .rho = rho, .out = out};
    return scan_alive(p, &j);
}

static uint32_t count_faces(const pass *p, const uint32_t *list, uint32_t nl, const double n[3],
                            double rho)
{
    uint32_t c = 0;
    for (uint32_t k = 0; k < nl; k++)
        if (valid_for(p, &p->el[list[k]], n, rho)) c += p->el[list[k]].tcount;
    return c;
}

/* Averaged plane (§3.3.3): area-weighted normal with every normal flipped into
 * the half-space of ref (two-sided leaves would cancel otherwise), through the
 * area-weighted centroid. */
static bool averaged_plane(const pass *p, const uint32_t *list, uint32_t nl, const double ref[3],
                           double n[3], double *rho)
{
    double m[3] = {0, 0, 0}, g[3] = {0, 0, 0}, a = 0;
    for (uint32_t k = 0; k < nl; k++) {
        const elem *e = &p->el[list[k]];
        double s = sv_dot3(e->ax[0], ref) < 0 ? -e->area : e->area;
        for (int c = 0; c < 3; c++) {
            m[c] += s * e->ax[0][c];
            g[c] += e->area * e->g[c];
        }
        a += e->area;
    }
    if (!(a > 0) || !sv_normalize3(m)) return false;
    for (int c = 0; c < 3; c++) g[c] /= a;
    memcpy(n, m, sizeof m);
    *rho = sv_dot3(m, g);
    return true;
}

static int area_desc_cmp_ctx(const elem *el, uint32_t a, uint32_t b)
{
    if (el[a].area > el[b].area) return -1;
    if (el[a].area < el[b].area) return 1;
    return a < b ? -1 : a > b;
}

/* Fail-safe (§3.3.2): the supporting planes of the cell's faces (the
 * FAILSAFE_CAP largest, so the cost stays linear) and the averaged plane; the
 * one that simplifies the most faces wins. Never fails for a non-empty list:
 * an element is always valid for its own supporting plane (thicker ones were
 * split into triangles). */
static uint8_t failsafe(pass *p, const uint32_t *list, uint32_t nl, const double ref[3],
                        double n[3], double *rho)
{
    /* Top FAILSAFE_CAP by area (insertion into a short sorted array). */
    uint32_t top[FAILSAFE_CAP];
    uint32_t nt = 0;
    for (uint32_t k = 0; k < nl; k++) {
        uint32_t e = list[k];
        uint32_t pos = nt;
        while (pos > 0 && area_desc_cmp_ctx(p->el, e, top[pos - 1]) < 0) pos--;
        if (pos >= FAILSAFE_CAP) continue;
        uint32_t last = nt < FAILSAFE_CAP ? nt : FAILSAFE_CAP - 1;
        memmove(&top[pos + 1], &top[pos], (last - pos) * sizeof top[0]);
        top[pos] = e;
        if (nt < FAILSAFE_CAP) nt++;
    }
    uint32_t best = 0;
    uint8_t origin = SV_BBC_FAILSAFE_SUPPORT;
    for (uint32_t k = 0; k < nt; k++) {
        const elem *e = &p->el[top[k]];
        double r = sv_dot3(e->c, e->ax[0]);
        uint32_t c = count_faces(p, list, nl, e->ax[0], r);
        if (c > best) {
            best = c;
            memcpy(n, e->ax[0], 3 * sizeof(double));
            *rho = r;
        }
    }
    double an[3], ar;
    if (averaged_plane(p, list, nl, ref, an, &ar)) {
        uint32_t c = count_faces(p, list, nl, an, ar);
        if (c > best) {
            best = c;
            memcpy(n, an, sizeof an);
            *rho = ar;
            origin = SV_BBC_FAILSAFE_AVERAGE;
        }
    }
    return origin;
}

/* Projected area of the triangles of the listed elements on a plane. */
static double projected_area(const pass *p, const uint32_t *list, uint32_t nl, const double n[3])
{
    double s = 0;
    for (uint32_t k = 0; k < nl; k++) {
        const elem *e = &p->el[list[k]];
        for (uint32_t t = 0; t < e->tcount; t++) {
            double tn[3];
            double a = tri_geom(p->b, p->pos, e->tris[t], tn);
            s += a * fabs(sv_dot3(tn, n));
        }
    }
    return s;
}

/* Post-plane tweaking (§3.3.3): the averaged plane of the simplified faces
 * (normals flipped into the half-space of the untweaked normal), kept when all
 * of them stay valid and their projection covers at least as much. */
static bool tweak(pass *p, const uint32_t *set, uint32_t ns, double n[3], double *rho)
{
    double tn[3], tr;
    if (!averaged_plane(p, set, ns, n, tn, &tr)) return false;
    for (uint32_t k = 0; k < ns; k++)
        if (!valid_for(p, &p->el[set[k]], tn, tr)) return false;
    if (projected_area(p, set, ns, tn) < projected_area(p, set, ns, n)) return false;
    memcpy(n, tn, sizeof tn);
    *rho = tr;
    return true;
}

/* ---------------------------------------------------------------- run output */

typedef struct rplane {
    double n[3], rho; /* n·(x − centre) = rho */
    uint8_t part, origin;
    bool tweaked;
    int32_t of; /* cardboard: index of its primary in runout.pl */
    size_t first;
    uint32_t count;
    double area, coverage;
} rplane;

typedef struct runout {
    rplane *pl, *cb;
    uint32_t npl, ncb;
    size_t plcap, cbcap;
    uint32_t *tris;
    size_t ntris, tcap;
    bool exceeded;
    double eps;
    uint32_t failsafe, tweaked, elements, split, welded;
    double t_setup, t_grid, t_refine, t_card;
} runout;

static void runout_free(runout *r)
{
    free(r->pl);
    free(r->cb);
    free(r->tris);
    memset(r, 0, sizeof *r);
}

static bool grow(void **arr, size_t *cap, size_t need, size_t elsize)
{
    if (need <= *cap) return true;
    size_t nc = *cap ? *cap : 16;
    while (nc < need) {
        if (nc > SIZE_MAX / 2) return false;
        nc *= 2;
    }
    size_t bytes;
    if (!sv_mul_size(nc, elsize, &bytes)) return false;
    void *p = realloc(*arr, bytes);
    if (!p) return false;
    *arr = p;
    *cap = nc;
    return true;
}

static int u32_cmp(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Appends the triangles of the listed elements (sorted) to r->tris. */
static bool append_tris(const pass *p, const uint32_t *set, uint32_t ns, runout *r, size_t *first,
                        uint32_t *count, double *area)
{
    size_t add = 0;
    for (uint32_t k = 0; k < ns; k++) add += p->el[set[k]].tcount;
    if (!grow((void **)&r->tris, &r->tcap, r->ntris + add, sizeof *r->tris)) return false;
    *first = r->ntris;
    double a = 0;
    for (uint32_t k = 0; k < ns; k++) {
        const elem *e = &p->el[set[k]];
        for (uint32_t t = 0; t < e->tcount; t++) {
            double tn[3];
            a += tri_geom(p->b, p->b->rel, e->tris[t], tn);
            r->tris[r->ntris++] = e->tris[t];
        }
    }
    qsort(&r->tris[*first], add, sizeof *r->tris, u32_cmp);
    *count = (uint32_t)add;
    *area = a;
    return true;
}

/* Whether triangle tri is valid for the plane (n, rho): each vertex within
 * the pass's ε (+ tolerance) of it (§3.3.6's "faces valid for" a plane). */
static bool tri_within(const base *b, const pass *p, uint32_t tri, const double n[3], double rho)
{
    const uint32_t *ix = &b->in->indices[3 * (size_t)tri];
    for (int v = 0; v < 3; v++)
        if (!(fabs(sv_dot3(&p->pos[3 * (size_t)b->canon[ix[v]]], n) - rho) <= p->eps + p->tol))
            return false;
    return true;
}

/* Cardboard plane (§3.3.6): two planes perpendicular to the primary, through
 * the centroid of its faces projected onto it, parallel to the edges of its
 * bounding rectangle; coverage = projected area of the primary's faces valid
 * for the cardboard plane over their projected area on the primary. The
 * larger one is kept when it reaches the threshold. */
static sv_status cardboard(pass *p, const uint32_t *set, uint32_t ns, const double n[3], double rho,
                           uint32_t primary, runout *r, sv_error *err)
{
    const base *b = p->b;
    size_t npts = 0;
    for (uint32_t k = 0; k < ns; k++) npts += p->el[set[k]].vcount;
    double prim = projected_area(p, set, ns, n);
    if (!(prim > 0) || npts == 0) return SV_OK;
    double *pts = sv_calloc(npts, 3 * sizeof(double));
    if (!pts) return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (cardboard)");
    size_t c = 0;
    double g[3] = {0, 0, 0}, a = 0;
    for (uint32_t k = 0; k < ns; k++) {
        const elem *e = &p->el[set[k]];
        for (uint32_t v = 0; v < e->vcount; v++, c++)
            memcpy(&pts[3 * c], &p->pos[3 * (size_t)e->verts[v]], 3 * sizeof(double));
        for (int i = 0; i < 3; i++) g[i] += e->area * e->g[i];
        a += e->area;
    }
    sv_quad q;
    memset(&q, 0, sizeof q);
    memcpy(q.normal, n, 3 * sizeof(double));
    q.d = -rho;
    sv_quad_fit_points(&q, pts, npts);
    free(pts);
    for (int i = 0; i < 3; i++) g[i] /= a;
    double off = sv_dot3(g, n) - rho;
    for (int i = 0; i < 3; i++) g[i] -= off * n[i];

    double best = -1, bn[3] = {0, 0, 0}, brho = 0;
    for (int which = 0; which < 2; which++) {
        const double *cn = which ? q.axis_v : q.axis_u;
        double cr = sv_dot3(cn, g), cov = 0;
        for (uint32_t k = 0; k < ns; k++) {
            const elem *e = &p->el[set[k]];
            for (uint32_t t = 0; t < e->tcount; t++) {
                if (!tri_within(b, p, e->tris[t], cn, cr)) continue;
                double tn[3];
                double ta = tri_geom(b, p->pos, e->tris[t], tn);
                cov += ta * fabs(sv_dot3(tn, cn));
            }
        }
        if (cov / prim > best) {
            best = cov / prim;
            memcpy(bn, cn, sizeof bn);
            brho = cr;
        }
    }
    if (best < b->opt.cardboard_coverage || !(best > 0)) return SV_OK;
    /* The faces it shows: the primary's triangles valid for it. */
    size_t add = 0;
    for (uint32_t k = 0; k < ns; k++) add += p->el[set[k]].tcount;
    if (!grow((void **)&r->tris, &r->tcap, r->ntris + add, sizeof *r->tris) ||
        !grow((void **)&r->cb, &r->cbcap, (size_t)r->ncb + 1, sizeof *r->cb))
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (cardboard)");
    rplane *cp = &r->cb[r->ncb];
    memset(cp, 0, sizeof *cp);
    memcpy(cp->n, bn, sizeof bn);
    cp->rho = brho;
    cp->part = p->part;
    cp->origin = SV_BBC_CARDBOARD;
    cp->of = (int32_t)primary;
    cp->first = r->ntris;
    cp->coverage = best;
    for (uint32_t k = 0; k < ns; k++) {
        const elem *e = &p->el[set[k]];
        for (uint32_t t = 0; t < e->tcount; t++) {
            if (!tri_within(b, p, e->tris[t], bn, brho)) continue;
            double tn[3];
            cp->area += tri_geom(b, b->rel, e->tris[t], tn);
            r->tris[r->ntris++] = e->tris[t];
        }
    }
    cp->count = (uint32_t)(r->ntris - cp->first);
    qsort(&r->tris[cp->first], cp->count, sizeof *r->tris, u32_cmp);
    r->ncb++;
    return SV_OK;
}

/* ---------------------------------------------------------------- pass set-up */

static uint8_t group_part(const base *b, uint32_t g)
{
    return b->in->elem_part && b->in->elem_part[g] == SV_PART_TRUNK ? SV_PART_TRUNK
                                                                    : SV_PART_FOLIAGE;
}

static sv_status pass_build(const base *b, uint8_t part, double eps, pass *p, runout *r,
                            sv_error *err)
{
    memset(p, 0, sizeof *p);
    p->b = b;
    p->part = part;
    p->eps = eps;
    p->tol = 1e-9 * b->R;
    p->max_angle = b->opt.max_angle_deg >= 90 ? 10.0 : b->opt.max_angle_deg * M_PI / 180.0;
    p->miss = b->opt.miss_penalty;
    p->bw = b->R / b->nr;
    p->inv_bw = b->nr / b->R;
    p->pos = b->rel;
    bool weld = b->opt.weld && part == SV_PART_TRUNK;
    const sv_bbc_input *in = b->in;

    /* Elements: groups as they are, or split into triangles when thicker than
     * ε along their own normal (they could never be valid as a whole) or when
     * welding (displaced vertices would bend them). */
    uint32_t n = 0, nsplit = 0;
    for (uint32_t g = 0; g < in->elem_count; g++) {
        const elem *ge = &b->groups[g];
        if (group_part(b, g) != part || ge->tcount == 0) continue;
        bool split = ge->tcount > 1 && (weld || ge->ext[0] > eps + p->tol);
        if (split) {
            n += ge->tcount;
            nsplit += ge->tcount;
            r->split++;
        } else {
            n++;
        }
    }
    p->n = n;
    if (n == 0) return SV_OK;
    size_t ncell;
    if (!sv_mul_size(b->ncol, (size_t)b->nr + 1, &ncell)) goto nomem;
    p->el = sv_calloc(n, sizeof *p->el);
    p->sverts = sv_calloc((size_t)nsplit, 3 * sizeof(uint32_t));
    p->alive = sv_calloc(n, 1);
    p->diff = sv_calloc(ncell, sizeof *p->diff);
    p->colmax = sv_calloc(b->ncol, sizeof *p->colmax);
    p->colarg = sv_calloc(b->ncol, sizeof *p->colarg);
    p->cand = sv_calloc(n, sizeof *p->cand);
    p->set = sv_calloc(n, sizeof *p->set);
    p->tmp = sv_calloc(n, sizeof *p->tmp);
    p->stamp = sv_calloc(n, sizeof *p->stamp);
    p->batch = sv_calloc(n, sizeof *p->batch);
    p->nscratch = sv_parallel_chunks(SUBCELLS, b->opt.threads);
    p->ev = sv_calloc((size_t)n * p->nscratch, 2 * sizeof *p->ev);
    p->ev2 = sv_calloc((size_t)n * p->nscratch, 2 * sizeof *p->ev2);
    if (!p->ev2 || !p->el || !p->sverts || !p->alive || !p->diff || !p->colmax || !p->colarg ||
        !p->cand || !p->set || !p->tmp || !p->stamp || !p->batch || !p->ev)
        goto nomem;
    if (weld) {
        p->wpos = sv_calloc(in->vertex_count, 3 * sizeof(double));
        p->welded = sv_calloc(in->vertex_count, 1);
        if (!p->wpos || !p->welded) goto nomem;
        memcpy(p->wpos, b->rel, (size_t)in->vertex_count * 3 * sizeof(double));
        p->pos = p->wpos;
    }
    uint32_t k = 0, s = 0;
    for (uint32_t g = 0; g < in->elem_count; g++) {
        const elem *ge = &b->groups[g];
        if (group_part(b, g) != part || ge->tcount == 0) continue;
        bool split = ge->tcount > 1 && (weld || ge->ext[0] > eps + p->tol);
        if (!split) {
            p->el[k++] = *ge;
            continue;
        }
        for (uint32_t t = 0; t < ge->tcount; t++, s++) {
            elem *e = &p->el[k++];
            const uint32_t *ix = &in->indices[3 * (size_t)ge->tris[t]];
            for (int v = 0; v < 3; v++) p->sverts[3 * (size_t)s + v] = b->canon[ix[v]];
            e->tris = &ge->tris[t];
            e->tcount = 1;
            e->verts = &p->sverts[3 * (size_t)s];
            e->vcount = 3;
            e->group = g;
            elem_geometry(b, p->pos, e);
        }
    }
    p->area0 = 0;
    for (uint32_t e = 0; e < n; e++) p->area0 += p->el[e].area;
    for (uint32_t e = 0; e < n; e++) {
        p->el[e].w = p->area0 > 0 ? p->el[e].area / p->area0 : 0;
        p->alive[e] = 1;
    }
    p->alive_count = n;
    if (weld) {
        /* canonical vertex → elements, for the updates after welding */
        p->adj_first = sv_calloc((size_t)in->vertex_count + 1, sizeof *p->adj_first);
        size_t tot = 0;
        for (uint32_t e = 0; e < n; e++) tot += p->el[e].vcount;
        p->adj = sv_calloc(tot ? tot : 1, sizeof *p->adj);
        if (!p->adj_first || !p->adj) goto nomem;
        for (uint32_t e = 0; e < n; e++)
            for (uint32_t v = 0; v < p->el[e].vcount; v++) p->adj_first[p->el[e].verts[v] + 1]++;
        for (uint32_t v = 0; v < in->vertex_count; v++) p->adj_first[v + 1] += p->adj_first[v];
        uint32_t *fill = sv_calloc(in->vertex_count, sizeof *fill);
        if (!fill) goto nomem;
        for (uint32_t e = 0; e < n; e++)
            for (uint32_t v = 0; v < p->el[e].vcount; v++) {
                uint32_t cv = p->el[e].verts[v];
                p->adj[p->adj_first[cv] + fill[cv]++] = e;
            }
        free(fill);
    }
    r->elements += n;
    return SV_OK;
nomem:
    return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (%u elements)", n);
}

/* Vertex welding (§3.3.4): the vertices of the faces just simplified move onto
 * their first simplifying plane for good; the remaining faces that share them
 * are updated in the grid (subtract old, add new). */
static void weld(pass *p, const uint32_t *set, uint32_t ns, const double n[3], double rho,
                 runout *r)
{
    p->round++;
    uint32_t nchg = 0;
    for (uint32_t s = 0; s < ns; s++) {
        const elem *e = &p->el[set[s]];
        for (uint32_t v = 0; v < e->vcount; v++) {
            uint32_t cv = e->verts[v];
            if (p->welded[cv]) continue;
            double *x = &p->wpos[3 * (size_t)cv];
            double d = sv_dot3(x, n) - rho;
            for (int c = 0; c < 3; c++) x[c] -= d * n[c];
            p->welded[cv] = 1;
            r->welded++;
            for (uint32_t a = p->adj_first[cv]; a < p->adj_first[cv + 1]; a++) {
                uint32_t o = p->adj[a];
                if (p->alive[o] && p->stamp[o] != p->round) {
                    p->stamp[o] = p->round;
                    p->tmp[nchg++] = o;
                }
            }
        }
    }
    if (!nchg) return;
    for (uint32_t k = 0; k < nchg; k++) p->batch[k] = p->el[p->tmp[k]];
    grid_update(p, p->batch, nchg, -1, false);
    for (uint32_t k = 0; k < nchg; k++) {
        elem *e = &p->el[p->tmp[k]];
        elem_geometry(p->b, p->pos, e);
        e->w = p->area0 > 0 ? e->area / p->area0 : 0;
        p->batch[k] = *e;
    }
    grid_update(p, p->batch, nchg, +1, false);
}

/* The greedy loop of one pass (Décoret §4; Behrendt §3.1). Stops early, with
 * r->exceeded, when the pass would need more than `budget` planes. */
static sv_status pass_run(pass *p, uint32_t budget, runout *r, sv_error *err)
{
    const base *b = p->b;
    if (!p->n) return SV_OK;
    double t0 = sv_now();
    grid_update(p, p->el, p->n, +1, true);
    r->t_grid += sv_now() - t0;
    uint32_t planes = 0;
    while (p->alive_count) {
        if (planes >= budget) {
            r->exceeded = true;
            break;
        }
        double t1 = sv_now();
        uint32_t bc = 0;
        double bv = -INFINITY;
        for (uint32_t col = 0; col < b->ncol; col++)
            if (p->colmax[col] > bv) {
                bv = p->colmax[col];
                bc = col;
            }
        uint32_t k = p->colarg[bc], ci = bc % b->nt, cj = bc / b->nt;
        const double *cn = &b->dirs[3 * (size_t)bc];
        uint32_t nc = 0;
        if (bv > 0) {
            sjob j = {
                .p = p, .cell = true, .n = cn, .delta = b->delta[cj], .k = (int)k, .out = p->cand};
            nc = scan_alive(p, &j);
        }
        if (!nc)
            for (uint32_t e = 0; e < p->n; e++)
                if (p->alive[e]) p->cand[nc++] = e;
        double n[3] = {0, 1, 0}, rho = 0;
        uint8_t origin = SV_BBC_REFINED;
        uint32_t ns = 0;
        if (bv > 0 && refine(p, ci, cj, p->cand, nc, n, &rho))
            ns = collect_valid(p, n, rho, p->set);
        if (!ns) {
            origin = failsafe(p, p->cand, nc, cn, n, &rho);
            ns = collect_valid(p, n, rho, p->set);
            r->failsafe++;
        }
        if (!ns)
            return sv_fail(err, SV_ERR_INTERNAL, "billboard cloud: the fail-safe found no plane");
        bool tw = false;
        if (b->opt.tweak && tweak(p, p->set, ns, n, &rho)) {
            tw = true;
            r->tweaked++;
            ns = collect_valid(p, n, rho, p->set);
        }
        if (!grow((void **)&r->pl, &r->plcap, (size_t)r->npl + 1, sizeof *r->pl))
            return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (planes)");
        rplane *pl = &r->pl[r->npl];
        memset(pl, 0, sizeof *pl);
        memcpy(pl->n, n, sizeof n);
        pl->rho = rho;
        pl->part = p->part;
        pl->origin = origin;
        pl->tweaked = tw;
        pl->of = -1;
        pl->coverage = 1;
        if (!append_tris(p, p->set, ns, r, &pl->first, &pl->count, &pl->area))
            return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (faces)");
        r->npl++;
        r->t_refine += sv_now() - t1;
        if (b->opt.cardboard) {
            double t2 = sv_now();
            sv_status st = cardboard(p, p->set, ns, n, rho, r->npl - 1, r, err);
            if (st) return st;
            r->t_card += sv_now() - t2;
        }
        /* Remove the simplified faces: subtract them, or rebuild from the
         * survivors when that is less work (exact integers: same grid). */
        double t3 = sv_now();
        for (uint32_t s = 0; s < ns; s++) p->alive[p->set[s]] = 0;
        p->alive_count -= ns;
        if (p->alive_count) {
            if (ns > p->alive_count) {
                uint32_t m = 0;
                for (uint32_t e = 0; e < p->n; e++)
                    if (p->alive[e]) p->batch[m++] = p->el[e];
                grid_update(p, p->batch, m, +1, true);
            } else {
                for (uint32_t s = 0; s < ns; s++) p->batch[s] = p->el[p->set[s]];
                grid_update(p, p->batch, ns, -1, false);
            }
            if (p->wpos) weld(p, p->set, ns, n, rho, r);
        }
        r->t_grid += sv_now() - t3;
        planes++;
    }
    return SV_OK;
}

/* One complete selection at a given ε: trunk pass, then foliage (§3.2.2). */
static sv_status run_eps(const base *b, double eps, uint32_t max_primary, runout *r, sv_error *err)
{
    memset(r, 0, sizeof *r);
    r->eps = eps;
    static const uint8_t parts[2] = {SV_PART_TRUNK, SV_PART_FOLIAGE};
    for (int i = 0; i < 2; i++) {
        if (!b->have_part[parts[i]]) continue;
        pass p;
        double t0 = sv_now();
        sv_status st = pass_build(b, parts[i], eps, &p, r, err);
        r->t_setup += sv_now() - t0;
        uint32_t budget = max_primary ? (max_primary > r->npl ? max_primary - r->npl : 0)
                                      : UINT32_MAX;
        if (!st) st = pass_run(&p, budget, r, err);
        pass_free(&p);
        if (st) {
            runout_free(r);
            return st;
        }
        if (r->exceeded) break;
    }
    return SV_OK;
}

/* ---------------------------------------------------------------- memo */

typedef struct memo_entry {
    uint64_t key;
    double eps, angle;    /* the run's ε and angle limit (raised to 90° late in a search) */
    uint32_t exceeded_at; /* the largest budget a run at them exceeded (0: none seen) */
    uint32_t done_npl;    /* the planes a complete run drew (0: none seen) */
} memo_entry;

struct sv_bbc_memo {
    memo_entry *e;
    size_t n, cap;
};

void *sv_bbc_memo_create(void) { return calloc(1, sizeof(sv_bbc_memo)); }

void sv_bbc_memo_free(void *memo)
{
    sv_bbc_memo *m = memo;
    if (!m) return;
    free(m->e);
    free(m);
}

/* What a run depends on besides ε and the budget: the input and the
 * options (field by field: no padding bytes). */
static uint64_t memo_key(const sv_bbc_input *in, const sv_bbc_options *o)
{
    uint64_t h = SV_FNV1A_BASIS;
    h = sv_fnv1a(h, in->positions, (size_t)in->vertex_count * 3 * sizeof *in->positions);
    h = sv_fnv1a(h, in->indices, (size_t)in->triangle_count * 3 * sizeof *in->indices);
    h = sv_fnv1a(h, &in->elem_count, sizeof in->elem_count);
    if (in->elem_first) {
        h = sv_fnv1a(h, in->elem_first, ((size_t)in->elem_count + 1) * sizeof *in->elem_first);
        h = sv_fnv1a(h, in->elem_tris, (size_t)in->elem_first[in->elem_count] * sizeof *in->elem_tris);
    }
    if (in->elem_part) h = sv_fnv1a(h, in->elem_part, in->elem_count);
    h = sv_fnv1a(h, in->centre, sizeof in->centre);
    h = sv_fnv1a(h, &in->radius, sizeof in->radius);
    const uint32_t u[] = {o->grid_theta, o->grid_phi, o->grid_rho, o->refine_levels,
                          o->horizontal_penalty, o->tweak, o->weld};
    const double d[] = {o->miss_penalty, o->max_angle_deg, o->horizontal_value,
                        o->horizontal_angle_deg};
    h = sv_fnv1a(h, u, sizeof u);
    return sv_fnv1a(h, d, sizeof d);
}

static memo_entry *memo_find(sv_bbc_memo *m, uint64_t key, double eps, double angle, bool add)
{
    for (size_t i = 0; i < m->n; i++)
        if (m->e[i].key == key && m->e[i].eps == eps && m->e[i].angle == angle) return &m->e[i];
    if (!add) return NULL;
    if (m->n == m->cap) {
        size_t cap = m->cap ? 2 * m->cap : 32;
        memo_entry *e = realloc(m->e, cap * sizeof *e);
        if (!e) return NULL; /* not remembered: only slower */
        m->e = e;
        m->cap = cap;
    }
    memo_entry *e = &m->e[m->n++];
    memset(e, 0, sizeof *e);
    e->key = key;
    e->eps = eps;
    e->angle = angle;
    return e;
}

/* run_eps through the memo (m NULL: plainly). A run the memo knows exceeds
 * max_primary is not made: r says exceeded with no planes, which is all the
 * caller reads of an exceeded run. *ran: whether a run was made. */
static sv_status run_eps_memo(const base *b, sv_bbc_memo *m, uint64_t key, double eps,
                              uint32_t max_primary, runout *r, bool *ran, sv_error *err)
{
    *ran = false;
    memo_entry *e = m ? memo_find(m, key, eps, b->opt.max_angle_deg, false) : NULL;
    if (e && max_primary && (e->exceeded_at >= max_primary || e->done_npl > max_primary)) {
        memset(r, 0, sizeof *r);
        r->eps = eps;
        r->exceeded = true;
        return SV_OK;
    }
    sv_status st = run_eps(b, eps, max_primary, r, err);
    *ran = true;
    if (st || !m || !(e = memo_find(m, key, eps, b->opt.max_angle_deg, true))) return st;
    if (r->exceeded) {
        if (max_primary > e->exceeded_at) e->exceeded_at = max_primary;
    } else {
        e->done_npl = r->npl;
    }
    return SV_OK;
}

/* ---------------------------------------------------------------- public */

void sv_bbc_options_init(sv_bbc_options *o)
{
    memset(o, 0, sizeof *o);
    o->grid_theta = 32;
    o->grid_phi = 16;
    o->grid_rho = 32;
    o->refine_levels = 5;
    o->miss_penalty = 0.5;
    o->max_angle_deg = 75;
    o->horizontal_value = 0.6;
    o->horizontal_angle_deg = 50;
    o->tweak = true;
    o->weld = true;
    o->cardboard_coverage = 0.8;
    o->threads = 2;
}

void sv_bbc_result_free(sv_bbc_result *r)
{
    if (!r) return;
    free(r->planes);
    free(r->tris);
    memset(r, 0, sizeof *r);
}

static void base_free(base *b)
{
    free(b->rel);
    free(b->canon);
    free(b->groups);
    free(b->gverts);
    free(b->dirs);
    free(b->delta);
}

typedef struct vkey {
    double x, y, z;
    uint32_t v;
} vkey;

static int vkey_cmp(const void *pa, const void *pb)
{
    const vkey *a = pa, *b = pb;
    if (a->x != b->x) return a->x < b->x ? -1 : 1;
    if (a->y != b->y) return a->y < b->y ? -1 : 1;
    if (a->z != b->z) return a->z < b->z ? -1 : 1;
    return a->v < b->v ? -1 : a->v > b->v;
}

/* Geometry of the input elements [lo, hi) (an sv_parallel_for chunk): each
 * group's vertex list lives in its own room of gverts (3 per triangle, at
 * its first triangle), so no group's place depends on another's. */
static void group_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    (void)t;
    base *b = arg;
    const sv_bbc_input *in = b->in;
    for (uint32_t g = lo; g < hi; g++) {
        elem *e = &b->groups[g];
        e->tris = &in->elem_tris[in->elem_first[g]];
        e->tcount = in->elem_first[g + 1] - in->elem_first[g];
        e->group = g;
        uint32_t *vl = &b->gverts[3 * (size_t)(in->elem_first[g] - in->elem_first[0])];
        uint32_t nv = 0;
        for (uint32_t k = 0; k < e->tcount; k++)
            for (int v = 0; v < 3; v++)
                vl[nv++] = b->canon[in->indices[3 * (size_t)e->tris[k] + v]];
        qsort(vl, nv, sizeof *vl, u32_cmp);
        uint32_t u = 0;
        for (uint32_t k = 0; k < nv; k++)
            if (u == 0 || vl[k] != vl[u - 1]) vl[u++] = vl[k];
        e->verts = vl;
        e->vcount = u;
        elem_geometry(b, b->rel, e);
    }
}

static sv_status base_init(base *b, const sv_bbc_input *in, const sv_bbc_options *opt,
                           sv_error *err)
{
    memset(b, 0, sizeof *b);
    b->in = in;
    b->opt = *opt;
    if (!b->opt.grid_theta) b->opt.grid_theta = 32;
    if (!b->opt.grid_phi) b->opt.grid_phi = 16;
    if (!b->opt.grid_rho) b->opt.grid_rho = 32;
    if (!b->opt.threads) b->opt.threads = 1;
    if (b->opt.grid_theta < 4 || b->opt.grid_theta > 4096 || b->opt.grid_theta % 2 ||
        b->opt.grid_phi < 2 || b->opt.grid_phi > 2048 || b->opt.grid_rho < 2 ||
        b->opt.grid_rho > 65536)
        return sv_fail(err, SV_ERR_INVALID,
                       "billboard cloud: grid %ux%ux%u out of range (θ even in [4, 4096], φ in [2, "
                       "2048], ρ in [2, 65536])",
                       b->opt.grid_theta, b->opt.grid_phi, b->opt.grid_rho);
    if (!(in->radius > 0) || !isfinite(in->radius))
        return sv_fail(err, SV_ERR_INVALID, "billboard cloud: bounding radius %g is not positive",
                       in->radius);
    if (!(opt->epsilon >= 0) || !isfinite(opt->epsilon))
        return sv_fail(err, SV_ERR_INVALID, "billboard cloud: epsilon %g is negative or not finite",
                       opt->epsilon);
    for (int c = 0; c < 3; c++)
        if (!isfinite(in->centre[c]))
            return sv_fail(err, SV_ERR_INVALID, "billboard cloud: centre is not finite");
    if (in->elem_count && (!in->elem_first || !in->elem_tris || !in->indices || !in->positions))
        return sv_fail(err, SV_ERR_INVALID, "billboard cloud: missing input arrays");
    b->R = in->radius;
    uint32_t vc = in->vertex_count;

    /* Element ranges, triangle and vertex indices, each triangle in one element. */
    uint8_t *seen = sv_calloc(in->triangle_count ? in->triangle_count : 1, 1);
    uint8_t *used = sv_calloc(vc ? vc : 1, 1);
    if (!seen || !used) {
        free(seen);
        free(used);
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
    }
    sv_status st = SV_OK;
    size_t total_tris = 0;
    for (uint32_t g = 0; g < in->elem_count && !st; g++) {
        if (in->elem_first[g + 1] < in->elem_first[g]) {
            st = sv_fail(err, SV_ERR_INVALID, "billboard cloud: element %u has a negative range",
                         g);
            break;
        }
        for (uint32_t k = in->elem_first[g]; k < in->elem_first[g + 1]; k++) {
            uint32_t t = in->elem_tris[k];
            if (t >= in->triangle_count) {
                st = sv_fail(err, SV_ERR_INVALID,
                             "billboard cloud: element %u names triangle %u of %u", g, t,
                             in->triangle_count);
                break;
            }
            if (seen[t]) {
                st = sv_fail(err, SV_ERR_INVALID, "billboard cloud: triangle %u is in two elements",
                             t);
                break;
            }
            seen[t] = 1;
            total_tris++;
            for (int v = 0; v < 3; v++) {
                uint32_t ix = in->indices[3 * (size_t)t + v];
                if (ix >= vc) {
                    st = sv_fail(err, SV_ERR_INVALID,
                                 "billboard cloud: triangle %u has vertex index %u of %u", t, ix,
                                 vc);
                    break;
                }
                used[ix] = 1;
            }
            if (st) break;
        }
        if (!st) b->have_part[group_part(b, g)] |= in->elem_first[g + 1] > in->elem_first[g];
    }
    free(seen);
    if (st) {
        free(used);
        return st;
    }
    b->rel = sv_calloc(vc ? vc : 1, 3 * sizeof(double));
    b->canon = sv_calloc(vc ? vc : 1, sizeof *b->canon);
    if (!b->rel || !b->canon) {
        free(used);
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (%u vertices)", vc);
    }
    uint32_t nused = 0;
    for (uint32_t v = 0; v < vc; v++) {
        b->canon[v] = v;
        for (int c = 0; c < 3; c++)
            b->rel[3 * (size_t)v + c] = in->positions[3 * (size_t)v + c] - in->centre[c];
        if (!used[v]) continue;
        nused++;
        for (int c = 0; c < 3; c++)
            if (!isfinite(in->positions[3 * (size_t)v + c])) {
                free(used);
                return sv_fail(err, SV_ERR_INVALID, "billboard cloud: vertex %u is not finite", v);
            }
    }
    /* Canonical vertices: equal positions weld together (§3.3.4 needs shared
     * vertices even where the source split them for normals or UVs). Only the
     * welded trunk pass needs them; otherwise every vertex is its own. */
    if (b->opt.weld && b->have_part[SV_PART_TRUNK]) {
        vkey *keys = sv_calloc(nused ? nused : 1, sizeof *keys);
        if (!keys) {
            free(used);
            return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
        }
        uint32_t m = 0;
        for (uint32_t v = 0; v < vc; v++)
            if (used[v])
                keys[m++] = (vkey){b->rel[3 * (size_t)v], b->rel[3 * (size_t)v + 1],
                                   b->rel[3 * (size_t)v + 2], v};
        qsort(keys, m, sizeof *keys, vkey_cmp);
        for (uint32_t k = 0, first = 0; k < m; k++) {
            if (keys[k].x != keys[first].x || keys[k].y != keys[first].y ||
                keys[k].z != keys[first].z)
                first = k;
            b->canon[keys[k].v] = keys[first].v;
        }
        free(keys);
    }
    free(used);

    /* Group geometry (does not depend on ε). */
    b->groups = sv_calloc(in->elem_count ? in->elem_count : 1, sizeof *b->groups);
    b->gverts = sv_calloc(total_tris ? total_tris : 1, 3 * sizeof *b->gverts);
    if (!b->groups || !b->gverts)
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
    sv_parallel_for(in->elem_count, in->elem_count >= PAR_MIN_SCAN ? b->opt.threads : 1, group_run,
                    b);

    /* The dual grid: cell-centre normals and the angular radius of each row. */
    b->nt = b->opt.grid_theta;
    b->np = b->opt.grid_phi;
    b->nr = b->opt.grid_rho;
    b->ncol = b->nt * b->np;
    b->dth = 2 * M_PI / b->nt;
    b->dph = M_PI / b->np;
    b->dirs = sv_calloc(b->ncol, 3 * sizeof(double));
    b->delta = sv_calloc(b->np, sizeof(double));
    if (!b->dirs || !b->delta) return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
    for (uint32_t j = 0; j < b->np; j++) {
        double ph0 = -HALF_PI + j * b->dph, ph1 = ph0 + b->dph, phc = ph0 + 0.5 * b->dph;
        double c[3];
        dir_of(0.5 * b->dth, phc, c);
        const double pts[8][2] = {{0, ph0},      {b->dth, ph0},       {0, ph1},
                                  {b->dth, ph1}, {0.5 * b->dth, ph0}, {0.5 * b->dth, ph1},
                                  {0, phc},      {b->dth, phc}};
        double dmax = 0;
        for (int k = 0; k < 8; k++) {
            double q[3];
            dir_of(pts[k][0], pts[k][1], q);
            double d = acos(fmax(-1.0, fmin(1.0, sv_dot3(c, q))));
            if (d > dmax) dmax = d;
        }
        b->delta[j] = dmax * 1.001;
    }
    for (uint32_t j = 0; j < b->np / 2; j++) b->delta[b->np - 1 - j] = b->delta[j];
    /* Cell centres; antipodal columns get exactly −n, so one evaluation of an
     * element serves both (column_add_pair) bit for bit. */
    for (uint32_t q = 0; q < b->ncol / 2; q++) {
        uint32_t c1, c2;
        pair_cols(b, q, &c1, &c2);
        uint32_t i = c1 % b->nt, j = c1 / b->nt;
        double *n1 = &b->dirs[3 * (size_t)c1], *n2 = &b->dirs[3 * (size_t)c2];
        dir_of((i + 0.5) * b->dth, -HALF_PI + (j + 0.5) * b->dph, n1);
        for (int c = 0; c < 3; c++) n2[c] = -n1[c];
    }
    return SV_OK;
}

/* Copies the chosen run into the public result: per pass, its primaries,
 * then its cardboard planes (those that fit the plane budget, best first). */
static sv_status emit(const base *b, const runout *r, uint32_t max_planes, sv_bbc_result *out,
                      sv_error *err)
{
    uint8_t *take = sv_calloc(r->ncb ? r->ncb : 1, 1);
    int32_t *map = sv_calloc(r->npl ? r->npl : 1, sizeof *map);
    uint32_t *order = sv_calloc(r->ncb ? r->ncb : 1, sizeof *order);
    if (!take || !map || !order) {
        free(take);
        free(map);
        free(order);
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
    }
    uint32_t room = max_planes ? (max_planes > r->npl ? max_planes - r->npl : 0) : UINT32_MAX;
    for (uint32_t k = 0; k < r->ncb; k++) order[k] = k;
    /* best coverage first, ties by index (insertion sort: few candidates) */
    for (uint32_t k = 1; k < r->ncb; k++) {
        uint32_t x = order[k], m = k;
        while (m > 0 && r->cb[order[m - 1]].coverage < r->cb[x].coverage) {
            order[m] = order[m - 1];
            m--;
        }
        order[m] = x;
    }
    uint32_t ncard = 0;
    for (uint32_t k = 0; k < r->ncb && ncard < room; k++, ncard++) take[order[k]] = 1;
    free(order);
    uint32_t total = r->npl + ncard;
    size_t ntris = 0;
    for (uint32_t k = 0; k < r->npl; k++) ntris += r->pl[k].count;
    for (uint32_t k = 0; k < r->ncb; k++)
        if (take[k]) ntris += r->cb[k].count;
    out->planes = sv_calloc(total ? total : 1, sizeof *out->planes);
    out->tris = sv_calloc(ntris ? ntris : 1, sizeof *out->tris);
    if (!out->planes || !out->tris || ntris > UINT32_MAX) {
        free(take);
        free(map);
        sv_bbc_result_free(out);
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory");
    }
    uint32_t np = 0, nt = 0;
    static const uint8_t parts[2] = {SV_PART_TRUNK, SV_PART_FOLIAGE};
    for (int pi = 0; pi < 2; pi++) {
        for (int card = 0; card < 2; card++) {
            const rplane *src = card ? r->cb : r->pl;
            uint32_t cnt = card ? r->ncb : r->npl;
            for (uint32_t k = 0; k < cnt; k++) {
                const rplane *s = &src[k];
                if (s->part != parts[pi] || (card && !take[k])) continue;
                sv_bbc_plane *d = &out->planes[np];
                memcpy(d->normal, s->n, sizeof d->normal);
                d->d = -(s->rho + sv_dot3(s->n, b->in->centre));
                d->part = s->part;
                d->origin = s->origin;
                d->tweaked = s->tweaked;
                d->cardboard_of = card ? map[s->of] : -1;
                d->first = nt;
                d->count = s->count;
                d->area = s->area;
                d->coverage = s->coverage;
                memcpy(&out->tris[nt], &r->tris[s->first], s->count * sizeof *out->tris);
                nt += s->count;
                if (!card) map[k] = (int32_t)np;
                np++;
            }
        }
    }
    free(take);
    free(map);
    out->plane_count = np;
    out->tri_count = nt;
    out->stats.primary_planes = r->npl;
    out->stats.cardboard_planes = ncard;
    out->stats.failsafe_planes = r->failsafe;
    out->stats.tweaked_planes = r->tweaked;
    out->stats.elements = r->elements;
    out->stats.split_elements = r->split;
    out->stats.welded_vertices = r->welded;
    out->stats.epsilon = r->eps;
    return SV_OK;
}

static void add_times(sv_bbc_stats *s, const runout *r)
{
    s->seconds_setup += r->t_setup;
    s->seconds_grid += r->t_grid;
    s->seconds_refine += r->t_refine;
    s->seconds_cardboard += r->t_card;
}

sv_status sv_bbc_select(const sv_bbc_input *in, const sv_bbc_options *opt, sv_bbc_result *out,
                        sv_error *err)
{
    memset(out, 0, sizeof *out);
    double t0 = sv_now();
    base b;
    sv_status st = base_init(&b, in, opt, err);
    if (st) {
        base_free(&b);
        return st;
    }
    uint32_t npass = (uint32_t)b.have_part[SV_PART_TRUNK] + (uint32_t)b.have_part[SV_PART_FOLIAGE];
    uint32_t maxp = opt->max_planes;
    if (maxp && maxp < npass) {
        base_free(&b);
        return sv_fail(err, SV_ERR_LIMIT,
                       "billboard cloud: max_planes %u is less than the %u passes (trunk, foliage)",
                       maxp, npass);
    }
    sv_bbc_stats times;
    memset(&times, 0, sizeof times);
    double setup = sv_now() - t0;
    uint32_t runs = 0;
    runout best, cur;
    memset(&best, 0, sizeof best);
    double eps = opt->epsilon;
    /* cardboard planes fill what the budget leaves: a run's planes then
     * depend on the budget beyond where it stops, so nothing is kept */
    sv_bbc_memo *memo = opt->cardboard ? NULL : opt->memo;
    uint64_t key = memo ? memo_key(in, opt) : 0;
    bool ran;
    st = run_eps_memo(&b, memo, key, eps, maxp, &best, &ran, err);
    runs += ran;
    if (!st) add_times(&times, &best);
    if (!st && best.exceeded) {
        /* max_planes: raise ε geometrically until the planes fit, then bisect
         * (geometric mean) twice towards the smallest ε that fits. Past 2R
         * everything fits in one plane per pass unless the angle limit keeps
         * faces apart: then that limit is lifted (90°). */
        double lo = eps, hi = eps > 0 ? eps : 1e-3 * b.R;
        for (int guard = 0;; guard++) {
            if (guard > 64) {
                st = sv_fail(err, SV_ERR_INTERNAL,
                             "billboard cloud: no epsilon meets max_planes %u", maxp);
                break;
            }
            hi = hi * 1.5;
            if (hi > 2 * b.R) {
                hi = 2 * b.R;
                if (b.opt.max_angle_deg < 90 && lo >= 2 * b.R) b.opt.max_angle_deg = 90;
            }
            st = run_eps_memo(&b, memo, key, hi, maxp, &cur, &ran, err);
            runs += ran;
            if (st) break;
            add_times(&times, &cur);
            if (!cur.exceeded) {
                runout_free(&best);
                best = cur;
                break;
            }
            runout_free(&cur);
            lo = hi;
        }
        for (int k = 0; k < 2 && !st; k++) {
            double mid = lo > 0 ? sqrt(lo * hi) : 0.5 * hi;
            if (!(mid > lo && mid < hi)) break;
            st = run_eps_memo(&b, memo, key, mid, maxp, &cur, &ran, err);
            runs += ran;
            if (st) break;
            add_times(&times, &cur);
            if (!cur.exceeded) {
                runout_free(&best);
                best = cur;
                hi = mid;
            } else {
                runout_free(&cur);
                lo = mid;
            }
        }
    }
    if (!st) st = emit(&b, &best, maxp, out, err);
    runout_free(&best);
    base_free(&b);
    if (st) {
        sv_bbc_result_free(out);
        return st;
    }
    out->stats.runs = runs;
    out->stats.seconds_setup = setup + times.seconds_setup;
    out->stats.seconds_grid = times.seconds_grid;
    out->stats.seconds_refine = times.seconds_refine;
    out->stats.seconds_cardboard = times.seconds_cardboard;
    out->stats.seconds_total = sv_now() - t0;
    return SV_OK;
}

sv_status sv_bbc_project(const sv_bbc_input *in, const sv_bbc_result *res, double **positions_out,
                         uint32_t **indices_out, uint32_t *vertex_count_out, sv_error *err)
{
    *positions_out = NULL;
    *indices_out = NULL;
    *vertex_count_out = 0;
    if ((uint64_t)in->triangle_count * 3 > UINT32_MAX)
        return sv_fail(err, SV_ERR_LIMIT, "billboard cloud: too many triangles to project");
    uint32_t nv = in->triangle_count * 3;
    double *pos = sv_calloc(nv ? nv : 1, 3 * sizeof(double));
    uint32_t *idx = sv_calloc(nv ? nv : 1, sizeof(uint32_t));
    if (!pos || !idx) {
        free(pos);
        free(idx);
        return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (projection)");
    }
    for (uint32_t t = 0; t < in->triangle_count; t++)
        for (int v = 0; v < 3; v++) {
            uint32_t src = in->indices[3 * (size_t)t + v];
            if (src >= in->vertex_count) {
                free(pos);
                free(idx);
                return sv_fail(err, SV_ERR_INVALID, "billboard cloud: vertex index %u out of range",
                               src);
            }
            memcpy(&pos[3 * (3 * (size_t)t + v)], &in->positions[3 * (size_t)src],
                   3 * sizeof(double));
            idx[3 * (size_t)t + v] = 3 * t + (uint32_t)v;
        }
    for (uint32_t k = 0; k < res->plane_count; k++) {
        const sv_bbc_plane *pl = &res->planes[k];
        if (pl->cardboard_of >= 0) continue;
        for (uint32_t i = 0; i < pl->count; i++) {
            uint32_t t = res->tris[pl->first + i];
            if (t >= in->triangle_count) continue;
            for (int v = 0; v < 3; v++) {
                double *x = &pos[3 * (3 * (size_t)t + v)];
                double d = sv_dot3(pl->normal, x) + pl->d;
                for (int c = 0; c < 3; c++) x[c] -= d * pl->normal[c];
            }
        }
    }
    *positions_out = pos;
    *indices_out = idx;
    *vertex_count_out = nv;
    return SV_OK;
}
