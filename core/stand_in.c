/* stand_in.c — stand-in containers (LODs, quads) and quad geometry helpers.
 *
 * sv_quad_fit_points finds the minimum-area rectangle enclosing points projected
 * onto a plane: the convex hull by Andrew's monotone chain (A. M. Andrew, "Another
 * efficient algorithm for convex hulls in two dimensions", IPL 9(5), 1979), then
 * rotating calipers over the hull edges (G. Toussaint, "Solving geometric problems
 * with the rotating calipers", MELECON 1983): the minimum-area enclosing rectangle
 * has one side collinear with a hull edge (Freeman & Shapira, CACM 18(7), 1975).
 * The billboard-cloud paper (Behrendt et al. §3.3.7) textures such rectangles.
 *
 * Conventions chosen here (documented for every caller):
 *   - axis_u runs along the rectangle's longer side (the first hull edge wins
 *     exact area ties; with equal sides the edge direction is u); its sign is
 *     fixed so that its world component of largest magnitude is positive (the
 *     lowest axis wins ties); axis_v = normal × axis_u, so u × v = normal.
 *   - Degenerate inputs still give a usable rectangle: each half extent is at
 *     least 1e-3 × the longer half extent (collinear points, two points); when
 *     all points coincide (or n == 1) both half extents are 1e-6 × |centre|
 *     (1e-9 when the centre is the origin). n == 0 gives the plane's point
 *     nearest the origin as centre and zero extents.
 *   - Non-finite points are ignored. If the hull's scratch memory cannot be
 *     allocated the rectangle falls back to the bounding box in the plane basis.
 */
#include "stand_in.h"
#include "vec3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---------- containers ---------- */

static void quad_release(sv_quad *q)
{
    free(q->faces);
    free(q->bake_faces);
    q->faces = q->bake_faces = NULL;
}

void sv_stand_in_free(sv_stand_in *s)
{
    if (!s) return;
    for (uint32_t i = 0; i < s->lod_count; i++) {
        sv_lod_plan *l = &s->lods[i];
        for (uint32_t j = 0; j < l->quad_count; j++) quad_release(&l->quads[j]);
        free(l->quads);
        sv_mesh_destroy(l->geometry);
        free(l->select_data);
        free(l->payload);
    }
    free(s->lods);
    memset(s, 0, sizeof *s);
}

/* Capacity is implicit: the next power of two >= count (0 → 0), so arrays grow
 * geometrically without a capacity field. True when count needs a bigger block. */
static bool needs_growth(uint32_t count)
{
    return count == 0 || (count & (count - 1)) == 0;
}

sv_lod_plan *sv_stand_in_add_lod(sv_stand_in *s, const char *name)
{
    if (!s || s->lod_count == UINT32_MAX) return NULL;
    if (needs_growth(s->lod_count)) {
        size_t cap = s->lod_count ? (size_t)s->lod_count * 2 : 1, bytes;
        if (!sv_mul_size(cap, sizeof *s->lods, &bytes)) return NULL;
        sv_lod_plan *p = realloc(s->lods, bytes);
        if (!p) return NULL;
        s->lods = p;
    }
    sv_lod_plan *l = &s->lods[s->lod_count++];
    memset(l, 0, sizeof *l);
    l->trunk = SV_TRUNK_NONE;
    if (name) {
        size_t n = strlen(name);
        if (n >= sizeof l->name) n = sizeof l->name - 1;
        memcpy(l->name, name, n);
    }
    return l;
}

/* On failure the quad's arrays are freed as well: ownership always moves. */
sv_status sv_lod_add_quad(sv_lod_plan *lod, const sv_quad *q, sv_error *err)
{
    if (!lod || !q) return sv_fail(err, SV_ERR_INTERNAL, "sv_lod_add_quad: NULL argument");
    if (lod->quad_count == UINT32_MAX || needs_growth(lod->quad_count)) {
        size_t cap = lod->quad_count ? (size_t)lod->quad_count * 2 : 1, bytes;
        sv_quad *p = NULL;
        if (lod->quad_count != UINT32_MAX && sv_mul_size(cap, sizeof *lod->quads, &bytes))
            p = realloc(lod->quads, bytes);
        if (!p) {
            free(q->faces);
            free(q->bake_faces);
            return sv_fail(err, SV_ERR_NOMEM, "no memory for quad %u of LOD '%s'", lod->quad_count,
                           lod->name);
        }
        lod->quads = p;
    }
    lod->quads[lod->quad_count++] = *q;
    return SV_OK;
}

/* ---------- quad geometry ---------- */

/* Deterministic orthonormal basis (b1, b2) of the plane with unit normal n:
 * b1 is the world axis least aligned with n, made orthogonal to n. */
static void plane_basis(const double n[3], double b1[3], double b2[3])
{
    int k = 0;
    for (int i = 1; i < 3; i++)
        if (fabs(n[i]) < fabs(n[k])) k = i;
    double ref[3] = {0, 0, 0};
    ref[k] = 1;
    double t = sv_dot3(ref, n);
    for (int i = 0; i < 3; i++) b1[i] = ref[i] - t * n[i];
    sv_normalize3(b1);
    sv_cross3(n, b1, b2);
}

typedef struct pt2 {
    double x, y;
} pt2;

static int pt2_cmp(const void *pa, const void *pb)
{
    const pt2 *a = pa, *b = pb;
    if (a->x != b->x) return a->x < b->x ? -1 : 1;
    if (a->y != b->y) return a->y < b->y ? -1 : 1;
    return 0;
}

static double turn(pt2 o, pt2 a, pt2 b)
{
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

/* Andrew's monotone chain on sorted points p[0..n): writes the hull
 * counter-clockwise into h (room for n+1) without collinear points; returns its
 * size (1 when all points coincide, 2 when they are collinear). */
static size_t hull_monotone(const pt2 *p, size_t n, pt2 *h)
{
    if (n == 0) return 0;
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        while (k >= 2 && turn(h[k - 2], h[k - 1], p[i]) <= 0) k--;
        h[k++] = p[i];
    }
    for (size_t i = n - 1, t = k + 1; i-- > 0;) {
        while (k >= t && turn(h[k - 2], h[k - 1], p[i]) <= 0) k--;
        h[k++] = p[i];
    }
    k--; /* the last point repeats the first */
    if (k == 0) return 1;
    if (k == 2 && h[0].x == h[1].x && h[0].y == h[1].y) return 1;
    return k;
}

typedef struct rect2 {
    pt2 e;         /* unit direction of the first side */
    double a0, a1; /* range along e */
    double b0, b1; /* range along perp(e) = (-e.y, e.x) */
} rect2;

static double along(pt2 p, pt2 d)
{
    return p.x * d.x + p.y * d.y;
}

/* Rotating calipers over a CCW hull h[0..m), m >= 3: the rectangle of minimum
 * area with one side on a hull edge. Three calipers (farthest along the edge,
 * farthest from it, least along it) only move forward, so this is O(m). */
static rect2 calipers(const pt2 *h, size_t m)
{
    rect2 best = {{1, 0}, 0, 0, 0, 0};
    double best_area = INFINITY;
    size_t j = 0, k = 0, l = 0;
    for (size_t i = 0; i < m; i++) {
        pt2 a = h[i], b = h[(i + 1) % m];
        pt2 e = {b.x - a.x, b.y - a.y};
        double len = sqrt(e.x * e.x + e.y * e.y);
        if (!(len > 0)) continue;
        e.x /= len;
        e.y /= len;
        pt2 p = {-e.y, e.x}; /* points into the hull */
        if (i == 0) {
            for (size_t t = 1; t < m; t++) {
                if (along(h[t], e) > along(h[j], e)) j = t;
                if (along(h[t], p) > along(h[k], p)) k = t;
                if (along(h[t], e) < along(h[l], e)) l = t;
            }
        } else {
            for (size_t s = 0; s < m && along(h[(j + 1) % m], e) > along(h[j], e); s++)
                j = (j + 1) % m;
            for (size_t s = 0; s < m && along(h[(k + 1) % m], p) > along(h[k], p); s++)
                k = (k + 1) % m;
            for (size_t s = 0; s < m && along(h[(l + 1) % m], e) < along(h[l], e); s++)
                l = (l + 1) % m;
        }
        double a0 = along(h[l], e), a1 = along(h[j], e);
        double b0 = along(a, p), b1 = along(h[k], p);
        double area = (a1 - a0) * (b1 - b0);
        if (area < best_area) {
            best_area = area;
            best.e = e;
            best.a0 = a0;
            best.a1 = a1;
            best.b0 = b0;
            best.b1 = b1;
        }
    }
    return best;
}

/* Axis-aligned rectangle (in the 2D basis) of p[0..n). */
static rect2 box2(const pt2 *p, size_t n)
{
    rect2 r = {{1, 0}, INFINITY, -INFINITY, INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++) {
        if (p[i].x < r.a0) r.a0 = p[i].x;
        if (p[i].x > r.a1) r.a1 = p[i].x;
        if (p[i].y < r.b0) r.b0 = p[i].y;
        if (p[i].y > r.b1) r.b1 = p[i].y;
    }
    return r;
}

void sv_quad_fit_points(sv_quad *q, const double *points, size_t n)
{
    double nrm[3] = {q->normal[0], q->normal[1], q->normal[2]};
    sv_normalize3(nrm);
    double b1[3], b2[3];
    plane_basis(nrm, b1, b2);

    /* Origin: the mean of the points projected onto the plane (keeps the 2D
     * coordinates small when the tree sits far from the world origin). */
    double m[3] = {0, 0, 0};
    size_t used = 0;
    for (size_t i = 0; i < n; i++) {
        const double *p = &points[3 * i];
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        for (int k = 0; k < 3; k++) m[k] += p[k];
        used++;
    }
    if (used)
        for (int k = 0; k < 3; k++) m[k] /= (double)used;
    double off = sv_dot3(nrm, m) + q->d;
    double o[3];
    for (int k = 0; k < 3; k++) o[k] = m[k] - off * nrm[k];

    rect2 r = {{1, 0}, 0, 0, 0, 0};
    if (used) {
        pt2 *p = NULL, *h = NULL;
        size_t bytes;
        if (sv_mul_size(used + 1, sizeof(pt2), &bytes)) {
            p = malloc(bytes);
            h = malloc(bytes);
        }
        size_t c = 0;
        /* Without scratch memory, accumulate the bounding box directly. */
        rect2 fallback = {{1, 0}, INFINITY, -INFINITY, INFINITY, -INFINITY};
        for (size_t i = 0; i < n; i++) {
            const double *s = &points[3 * i];
            if (!isfinite(s[0]) || !isfinite(s[1]) || !isfinite(s[2])) continue;
            double dv[3] = {s[0] - o[0], s[1] - o[1], s[2] - o[2]};
            pt2 v = {sv_dot3(dv, b1), sv_dot3(dv, b2)};
            if (p) {
                p[c++] = v;
            } else {
                rect2 one = box2(&v, 1);
                if (one.a0 < fallback.a0) fallback.a0 = one.a0;
                if (one.a1 > fallback.a1) fallback.a1 = one.a1;
                if (one.b0 < fallback.b0) fallback.b0 = one.b0;
                if (one.b1 > fallback.b1) fallback.b1 = one.b1;
            }
        }
        if (p && h) {
            qsort(p, c, sizeof *p, pt2_cmp);
            size_t hm = hull_monotone(p, c, h);
            if (hm >= 3) {
                r = calipers(h, hm);
            } else if (hm == 2) {
                pt2 e = {h[1].x - h[0].x, h[1].y - h[0].y};
                double len = sqrt(e.x * e.x + e.y * e.y);
                e.x /= len;
                e.y /= len;
                pt2 pp = {-e.y, e.x};
                r.e = e;
                r.a0 = along(h[0], e);
                r.a1 = along(h[1], e);
                r.b0 = r.b1 = along(h[0], pp);
            } else {
                r = box2(p, 1); /* all points coincide */
            }
        } else {
            r = p ? box2(p, c) : fallback;
        }
        free(p);
        free(h);
    }

    /* Longer side → u. */
    pt2 pe = {-r.e.y, r.e.x};
    double len_e = r.a1 - r.a0, len_p = r.b1 - r.b0;
    double cx = 0.5 * (r.a0 + r.a1), cy = 0.5 * (r.b0 + r.b1);
    pt2 c2 = {r.e.x * cx + pe.x * cy, r.e.y * cx + pe.y * cy};
    pt2 u2 = len_e >= len_p ? r.e : pe;
    double hu = 0.5 * (len_e >= len_p ? len_e : len_p);
    double hv = 0.5 * (len_e >= len_p ? len_p : len_e);

    double u[3];
    for (int k = 0; k < 3; k++) {
        u[k] = u2.x * b1[k] + u2.y * b2[k];
        q->centre[k] = o[k] + c2.x * b1[k] + c2.y * b2[k];
    }
    sv_normalize3(u);
    int big = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(u[k]) > fabs(u[big])) big = k;
    if (u[big] < 0)
        for (int k = 0; k < 3; k++) u[k] = -u[k];
    memcpy(q->axis_u, u, sizeof u);
    sv_cross3(nrm, u, q->axis_v);
    memcpy(q->normal, nrm, sizeof nrm);

    if (used) {
        double min_half = 1e-3 * hu;
        if (!(hu > 0)) {
            min_half = 1e-6 * sqrt(sv_dot3(q->centre, q->centre));
            if (!(min_half > 0)) min_half = 1e-9;
        }
        if (hu < min_half) hu = min_half;
        if (hv < min_half) hv = min_half;
    }
    q->half_u = hu;
    q->half_v = hv;
}

void sv_quad_corners(const sv_quad *q, double corners[4][3])
{
    static const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            corners[i][k] = q->centre[k] + su[i] * q->half_u * q->axis_u[k] +
                            sv[i] * q->half_v * q->axis_v[k];
}

/* ---------- the flattening bound ---------- */

static const uint32_t *quad_faces(const sv_quad *q, uint32_t *count)
{
    *count = q->bake_faces ? q->bake_face_count : q->face_count;
    return q->bake_faces ? q->bake_faces : q->faces;
}

sv_status sv_lod_flatten(const sv_mesh *src, const sv_lod_plan *lod, sv_mesh **out, sv_error *err)
{
    *out = NULL;
    uint64_t nt = 0;
    for (uint32_t q = 0; q < lod->quad_count; q++) {
        uint32_t n;
        quad_faces(&lod->quads[q], &n);
        nt += n;
    }
    if (nt > UINT32_MAX / 3)
        return sv_fail(err, SV_ERR_LIMIT, "flattening bound: %llu faces are too many",
                       (unsigned long long)nt);
    sv_mesh *m = sv_mesh_create((uint32_t)(3 * nt), (uint32_t)nt, src->material_count,
                                src->image_count);
    if (!m) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_status st = sv_mesh_copy_looks(src, m, err);
    if (st) {
        sv_mesh_destroy(m);
        return st;
    }
    uint32_t t = 0;
    for (uint32_t q = 0; q < lod->quad_count; q++) {
        const sv_quad *Q = &lod->quads[q];
        uint32_t n;
        const uint32_t *fs = quad_faces(Q, &n);
        for (uint32_t f = 0; f < n; f++, t++) {
            for (int c = 0; c < 3; c++) {
                uint32_t v = src->indices[3 * fs[f] + c], o = 3 * t + (uint32_t)c;
                double p[3] = {src->positions[3 * v], src->positions[3 * v + 1],
                               src->positions[3 * v + 2]};
                double dist = sv_dot3(Q->normal, p) + Q->d;
                for (int a = 0; a < 3; a++) {
                    m->positions[3 * o + a] = (float)(p[a] - dist * Q->normal[a]);
                    m->normals[3 * o + a] = src->normals[3 * v + a];
                }
                m->uvs[2 * o] = src->uvs[2 * v];
                m->uvs[2 * o + 1] = src->uvs[2 * v + 1];
                m->indices[3 * t + c] = o;
            }
            m->tri_material[t] = src->tri_material[fs[f]];
        }
    }
    *out = m;
    return SV_OK;
}
