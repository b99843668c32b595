/* trunk.c — trunk kept as a mesh at every LOD (Jakulin; Behrendt et al. keep
 * the trunk as geometry at near LODs), simplified with meshoptimizer's
 * meshopt_simplify, material by material so material borders stay intact. */
#include "trunk.h"

#include <math.h>
#include <meshoptimizer.h>
#include <stdlib.h>
#include <string.h>
#include <stdio.h>

/* New mesh with the trunk triangles of mesh (*sub NULL when there are none). */
static sv_status trunk_subset(const sv_mesh *mesh, const uint8_t *tri_part, sv_mesh **sub,
                              sv_error *err)
{
    *sub = NULL;
    uint32_t n = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) n += tri_part[t] == SV_PART_TRUNK;
    if (n == 0) return SV_OK;
    uint32_t *tris = malloc((size_t)n * sizeof *tris);
    if (!tris) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    n = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++)
        if (tri_part[t] == SV_PART_TRUNK) tris[n++] = t;
    sv_status st = sv_mesh_subset(mesh, tris, n, sub, err);
    free(tris);
    return st;
}

/* sv_trunk_mesh; *rel_error (when not NULL) = the largest meshopt result
 * error of the materials, relative to the trunk's extent (0 when nothing
 * was simplified). */
static sv_status trunk_mesh_err(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                                double max_error, sv_mesh **out, double *rel_error, sv_error *err)
{
    *out = NULL;
    if (rel_error) *rel_error = 0;
    sv_mesh *sub = NULL;
    sv_status st = trunk_subset(mesh, tri_part, &sub, err);
    if (st || !sub) return st;
    if (!(ratio < 1.0)) {
        *out = sub;
        return SV_OK;
    }
    if (ratio < 0) ratio = 0;
    double c[3], r;
    sv_mesh_sphere(sub, c, &r);
    /* meshoptimizer's target_error is relative to the mesh extent. */
    float rel = (max_error > 0 && r > 0) ? (float)(max_error / (2.0 * r)) : 1.0f;
    size_t ni = (size_t)sub->triangle_count * 3;
    unsigned int *src = malloc(ni * sizeof *src), *dst = malloc(ni * sizeof *dst);
    uint32_t *mat = malloc((size_t)sub->triangle_count * sizeof *mat);
    unsigned int *weld = malloc((size_t)sub->vertex_count * sizeof *weld);
    float *pu = sv_calloc(sub->vertex_count, 5 * sizeof(float));
    if (!src || !dst || !mat || !weld || !pu) {
        free(src);
        free(dst);
        free(mat);
        free(weld);
        free(pu);
        sv_mesh_destroy(sub);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    /* Many exporters (OBJ especially) give every face its own vertices, and
     * meshopt_simplify cannot collapse what is not connected: weld vertices
     * that share position and UV (normals may differ per face; meshoptimizer
     * handles the remaining UV seams itself). */
    for (uint32_t v = 0; v < sub->vertex_count; v++) {
        memcpy(&pu[5 * (size_t)v], &sub->positions[3 * (size_t)v], 3 * sizeof(float));
        memcpy(&pu[5 * (size_t)v + 3], &sub->uvs[2 * (size_t)v], 2 * sizeof(float));
    }
    size_t unique = meshopt_generateVertexRemap(weld, NULL, sub->vertex_count, pu,
                                                sub->vertex_count, 5 * sizeof(float));
    free(pu);
    /* Simplify on the compact welded buffer: meshoptimizer classifies vertices
     * that share a position as seams, so unreferenced duplicates must not be
     * in the vertex buffer it sees. rep[] maps compact vertices back. */
    unsigned int *rep = malloc(unique * sizeof *rep);
    float *cpos = malloc(unique * 3 * sizeof *cpos);
    if (!rep || !cpos) {
        free(rep);
        free(cpos);
        free(src);
        free(dst);
        free(mat);
        free(weld);
        sv_mesh_destroy(sub);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    for (uint32_t v = sub->vertex_count; v-- > 0;) rep[weld[v]] = v;
    meshopt_remapVertexBuffer(cpos, sub->positions, sub->vertex_count, 3 * sizeof(float), weld);
    for (size_t i = 0; i < ni; i++) sub->indices[i] = weld[sub->indices[i]];
    free(weld);
    size_t total = 0;
    for (uint32_t m = 0; m < sub->material_count; m++) {
        size_t k = 0;
        for (uint32_t t = 0; t < sub->triangle_count; t++)
            if (sub->tri_material[t] == m) {
                memcpy(&src[k], &sub->indices[3 * (size_t)t], 3 * sizeof *src);
                k += 3;
            }
        if (k == 0) continue;
        size_t target = (size_t)((double)(k / 3) * ratio) * 3;
        if (target < 3) target = 3;
        float result_error = 0;
        size_t got = meshopt_simplify(&dst[total], src, k, cpos, unique, 3 * sizeof(float), target,
                                      rel, 0, &result_error);
        if (rel_error && result_error > *rel_error) *rel_error = result_error;
        for (size_t i = 0; i < got / 3; i++) mat[total / 3 + i] = m;
        total += got;
    }
    free(src);
    free(cpos);
    for (size_t i = 0; i < total; i++) dst[i] = rep[dst[i]];
    free(rep);
    st = SV_OK;
    if (total == 0) {
        /* everything collapsed: no trunk at this LOD */
        free(dst);
        free(mat);
        sv_mesh_destroy(sub);
        return SV_OK;
    }
    memcpy(sub->indices, dst, total * sizeof *dst);
    memcpy(sub->tri_material, mat, (total / 3) * sizeof *mat);
    sub->triangle_count = (uint32_t)(total / 3);
    free(dst);
    free(mat);
    /* compact away unused vertices */
    uint32_t *all = malloc((size_t)sub->triangle_count * sizeof *all);
    if (!all) {
        sv_mesh_destroy(sub);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    for (uint32_t t = 0; t < sub->triangle_count; t++) all[t] = t;
    st = sv_mesh_subset(sub, all, sub->triangle_count, out, err);
    free(all);
    sv_mesh_destroy(sub);
    return st;
}

sv_status sv_trunk_mesh(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                        double max_error, sv_mesh **out, sv_error *err)
{
    return trunk_mesh_err(mesh, tri_part, ratio, max_error, out, NULL, err);
}

/* Welded by position, a simplified triangle's corner may stand for several
 * vertices (a UV seam: the same point with the bark's u = 0 and u = 1). Of
 * the first four candidates of each corner, picks the three whose UVs span
 * the smallest perimeter (first in order on ties): the triangle samples one
 * side of the seam instead of the whole texture across it. */
static void pick_uv_consistent(const sv_mesh *m, const unsigned int *tri, const uint32_t *first,
                               const uint32_t *cand, uint32_t best[3])
{
    uint32_t n[3];
    for (int c = 0; c < 3; c++) {
        n[c] = first[tri[c] + 1] - first[tri[c]];
        if (n[c] > 4) n[c] = 4;
        best[c] = cand[first[tri[c]]];
    }
    if (n[0] * n[1] * n[2] == 1) return;
    double bp = INFINITY;
    for (uint32_t a = 0; a < n[0]; a++)
        for (uint32_t b = 0; b < n[1]; b++)
            for (uint32_t c = 0; c < n[2]; c++) {
                uint32_t v[3] = {cand[first[tri[0]] + a], cand[first[tri[1]] + b],
                                 cand[first[tri[2]] + c]};
                double per = 0;
                for (int k = 0; k < 3; k++) {
                    const float *p = &m->uvs[2 * (size_t)v[k]],
                                *q = &m->uvs[2 * (size_t)v[(k + 1) % 3]];
                    per += hypot((double)p[0] - q[0], (double)p[1] - q[1]);
                }
                if (per < bp) {
                    bp = per;
                    memcpy(best, v, sizeof v);
                }
            }
}

/* One simplification pass over m held to max_triangles: vertices welded by
 * position only (UV seams would lock the borders that must collapse; at the
 * distance a capped trunk is drawn a texture seam is not visible), then
 * meshopt_simplify with relative error `rel`, or meshopt_simplifySloppy when
 * `sloppy` (its error limit `rel`, raised until the budget is met when
 * `raise`; rel 0 starts at 1e-3). With `partial` any reduction is applied
 * even above max_triangles (*done still says whether the budget was met). On
 * success m's
 * triangles are replaced in place (vertices keep their original attributes;
 * each triangle takes the material of the first original triangle using its
 * first vertex) and *done is true; otherwise m is unchanged. */
static sv_status simplify_welded(sv_mesh *m, uint32_t max_triangles, float rel, bool sloppy,
                                 bool raise, bool partial, bool *done, float *result_error,
                                 sv_error *err)
{
    *done = false;
    if (result_error) *result_error = 0;
    size_t ni = (size_t)m->triangle_count * 3;
    unsigned int *weld = malloc((size_t)m->vertex_count * sizeof *weld);
    unsigned int *src = malloc(ni * sizeof *src), *dst = malloc(ni * sizeof *dst);
    float *cpos = malloc((size_t)m->vertex_count * 3 * sizeof *cpos);
    unsigned int *rep = malloc((size_t)m->vertex_count * sizeof *rep);
    uint32_t *vmat = malloc((size_t)m->vertex_count * sizeof *vmat);
    uint32_t *first = NULL, *cand = NULL;
    sv_status st = SV_OK;
    if (!weld || !src || !dst || !cpos || !rep || !vmat) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    size_t unique = meshopt_generateVertexRemap(weld, m->indices, ni, m->positions, m->vertex_count,
                                                3 * sizeof(float));
    meshopt_remapVertexBuffer(cpos, m->positions, m->vertex_count, 3 * sizeof(float), weld);
    for (size_t i = 0; i < ni; i++) src[i] = weld[m->indices[i]];
    for (uint32_t v = m->vertex_count; v-- > 0;)
        if (weld[v] != ~0u) rep[weld[v]] = v; /* unreferenced after an earlier pass: ~0 */
    for (uint32_t t = m->triangle_count; t-- > 0;)
        for (int c = 0; c < 3; c++) vmat[m->indices[3 * (size_t)t + c]] = m->tri_material[t];
    size_t target = (size_t)max_triangles * 3, got = ni;
    if (!sloppy) {
        got = meshopt_simplify(dst, src, ni, cpos, unique, 3 * sizeof(float), target, rel, 0,
                               result_error);
    } else {
        float lim = rel > 0 ? rel : 1e-3f;
        for (int k = 0; k < (raise ? 16 : 1) && got > target; k++, lim *= 2)
            got = meshopt_simplifySloppy(dst, src, ni, cpos, unique, 3 * sizeof(float), target, lim,
                                         NULL);
    }
    uint32_t nt = (uint32_t)(got / 3);
    if (nt == 0 || nt >= m->triangle_count || (nt > max_triangles && !partial)) goto out;
    /* the vertices sharing each welded position (a UV seam has several) */
    first = calloc(unique + 1, sizeof *first);
    cand = malloc((size_t)m->vertex_count * sizeof *cand);
    if (!first || !cand) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    for (uint32_t v = 0; v < m->vertex_count; v++)
        if (weld[v] != ~0u) first[weld[v] + 1]++;
    for (size_t w = 0; w < unique; w++) first[w + 1] += first[w];
    for (uint32_t v = 0; v < m->vertex_count; v++)
        if (weld[v] != ~0u) cand[first[weld[v]]++] = v;
    for (size_t w = unique; w > 0; w--) first[w] = first[w - 1];
    first[0] = 0;
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t best[3];
        pick_uv_consistent(m, &dst[3 * (size_t)t], first, cand, best);
        memcpy(&m->indices[3 * (size_t)t], best, sizeof best);
        m->tri_material[t] = vmat[best[0]];
    }
    (void)rep;
    m->triangle_count = nt;
    *done = nt <= max_triangles;
out:
    free(weld), free(src), free(dst), free(cpos), free(rep), free(vmat), free(first), free(cand);
    return st;
}

/* sv_trunk_mesh, and when the topology or UV seams stop it above ratio × n
 * while max_error allows more: welded by position only, then vertex
 * clustering (meshopt_simplifySloppy) with its error limit held at the same
 * bound, each kept only if it gets closer to the target. Thin separate parts
 * (stems, twigs) that meshopt_simplify cannot remove go where they are below
 * the bound. */
static sv_status trunk_mesh_bounded(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                                    double max_error, sv_mesh **out, sv_error *err)
{
    sv_status st = sv_trunk_mesh(mesh, tri_part, ratio, max_error, out, err);
    if (st || !*out || !(ratio < 1) || !(max_error > 0)) return st;
    sv_mesh *m = *out;
    uint32_t n = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) n += tri_part[t] == SV_PART_TRUNK;
    uint32_t target = (uint32_t)fmax(1.0, floor(ratio * n + 0.5));
    if (m->triangle_count <= target + target / 4) return SV_OK;
    double c[3], r;
    sv_mesh_sphere(m, c, &r);
    if (!(r > 0)) return SV_OK;
    float rel = (float)fmin(max_error / (2.0 * r), 1.0);
    bool done = false;
    uint32_t before = m->triangle_count;
    if ((st = simplify_welded(m, target, rel, false, false, true, &done, NULL, err))) goto fail;
    if (!done && (st = simplify_welded(m, target, rel, true, false, true, &done, NULL, err)))
        goto fail;
    if (m->triangle_count == before) return SV_OK;
    uint32_t *all = malloc((size_t)m->triangle_count * sizeof *all);
    if (!all) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto fail;
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) all[t] = t;
    sv_mesh *o = NULL;
    st = sv_mesh_subset(m, all, m->triangle_count, &o, err); /* compacts the vertices */
    free(all);
    if (st) goto fail;
    sv_mesh_destroy(m);
    *out = o;
    return SV_OK;
fail:
    sv_mesh_destroy(m);
    *out = NULL;
    return st;
}

sv_status sv_trunk_mesh_budget(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                               uint32_t max_triangles, double max_error, sv_mesh **out,
                               sv_error *err)
{
    *out = NULL;
    if (!max_triangles) return trunk_mesh_bounded(mesh, tri_part, ratio, max_error, out, err);
    uint32_t n = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) n += tri_part[t] == SV_PART_TRUNK;
    if (!n) return SV_OK;
    double r = (double)max_triangles / n;
    if (r > ratio) r = ratio;
    /* 1: within the error bound, material by material (sv_trunk_mesh) */
    sv_mesh *m = NULL;
    sv_status st = sv_trunk_mesh(mesh, tri_part, r, max_error, &m, err);
    if (st || !m || m->triangle_count <= max_triangles) {
        *out = m;
        return st;
    }
    /* 2: the budget wins over the bound: shape-preserving collapse without a
     * bound; 3: only then the sloppy clustering (it can cut thin parts) */
    bool done = false;
    if (!(st = simplify_welded(m, max_triangles, 1.0f, false, false, false, &done, NULL, err)) &&
        !done)
        st = simplify_welded(m, max_triangles, 0, true, true, false, &done, NULL, err);
    sv_mesh *o = NULL;
    if (!st && done) {
        uint32_t *all = malloc((size_t)m->triangle_count * sizeof *all);
        if (!all) {
            st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        } else {
            for (uint32_t t = 0; t < m->triangle_count; t++) all[t] = t;
            st = sv_mesh_subset(m, all, m->triangle_count, &o, err); /* compacts the vertices */
            free(all);
        }
    }
    sv_mesh_destroy(m);
    *out = st ? NULL : o;
    return st;
}

/* A trunk vertex's position and material, and the part it belongs to. */
typedef struct vkey {
    float p[3];
    uint32_t mat, part;
} vkey;

static int vkey_cmp(const void *a, const void *b)
{
    const vkey *x = a, *y = b;
    for (int i = 0; i < 3; i++)
        if (x->p[i] != y->p[i]) return x->p[i] < y->p[i] ? -1 : 1;
    return x->mat < y->mat ? -1 : x->mat > y->mat;
}

/* One connected part of the trunk (welded by position, within a material). */
typedef struct trunk_part {
    double area;
    uint32_t first, count; /* into the triangle list sorted by part */
    uint32_t min_tri;      /* ties broken by the first triangle: determinism */
} trunk_part;

static int part_cmp(const void *a, const void *b)
{
    const trunk_part *x = a, *y = b;
    if (x->area != y->area) return x->area > y->area ? -1 : 1;
    return x->min_tri < y->min_tri ? -1 : x->min_tri > y->min_tri;
}

static uint32_t uf_find(uint32_t *par, uint32_t a)
{
    while (par[a] != a) a = par[a] = par[par[a]];
    return a;
}

/* Simplifies the triangles tl[0..n) of sub (its indices welded by position +
 * UV + material into wb, rep[] mapping back) on a local vertex buffer, within
 * abs_err (world units; <= 0: towards `target` triangles without a bound,
 * then vertex clustering). Appends the result (sub's vertex ids) to out at
 * *total and returns the triangles added (0 when over `room`). */
static uint32_t simplify_part(const sv_mesh *sub, const unsigned int *wb, const uint32_t *rep,
                              const uint32_t *tl, uint32_t n, double abs_err, uint32_t target,
                              uint32_t room, uint32_t *loc, unsigned int *lidx, float *lpos,
                              unsigned int *ldst, uint32_t *lrep, unsigned int *out, uint32_t *omat,
                              size_t *total)
{
    uint32_t nv = 0;
    for (uint32_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            unsigned int w = wb[sub->indices[3 * (size_t)tl[i] + c]];
            if (loc[w] == UINT32_MAX) {
                loc[w] = nv;
                lrep[nv] = rep[w];
                memcpy(&lpos[3 * (size_t)nv], &sub->positions[3 * (size_t)rep[w]],
                       3 * sizeof(float));
                nv++;
            }
            lidx[3 * (size_t)i + c] = loc[w];
        }
    for (uint32_t v = 0; v < nv; v++) loc[wb[lrep[v]]] = UINT32_MAX; /* reset for the next part */
    float scale = meshopt_simplifyScale(lpos, nv, 3 * sizeof(float));
    size_t got;
    if (abs_err > 0) {
        float rel = scale > 0 ? (float)fmin(abs_err / scale, 1.0) : 1.0f;
        got = meshopt_simplify(ldst, lidx, 3 * (size_t)n, lpos, nv, 3 * sizeof(float), 0, rel, 0,
                               NULL);
    } else {
        got = meshopt_simplify(ldst, lidx, 3 * (size_t)n, lpos, nv, 3 * sizeof(float),
                               3 * (size_t)target, 1.0f, 0, NULL);
        float lim = 1e-3f;
        for (int k = 0; k < 16 && got > 3 * (size_t)target; k++, lim *= 2)
            got = meshopt_simplifySloppy(ldst, lidx, 3 * (size_t)n, lpos, nv, 3 * sizeof(float),
                                         3 * (size_t)target, lim, NULL);
    }
    if (got / 3 > room || got == 0) return 0;
    for (size_t i = 0; i < got; i++) out[*total + i] = lrep[ldst[i]];
    for (size_t i = 0; i < got / 3; i++) omat[*total / 3 + i] = sub->tri_material[tl[0]];
    *total += got;
    return (uint32_t)(got / 3);
}

/* The trunk's connected parts (sapling's maple: 3,121 separate branches),
 * largest area first, each simplified alone within SV_TRUNK_PART_ERROR of
 * the trunk's extent, kept while they fit in `limit` triangles; a part that
 * does not fit is left out (the caller's quads draw it). The largest part
 * always gets in: when it does not fit within the bound it is simplified
 * without one (then vertex-clustered) towards the limit. */
#define SV_TRUNK_PART_ERROR (1.0 / 256.0)
#define SV_TRUNK_PART_BOUNDS 5 /* 1/256, 1/128, ..., 1/16 of the trunk's extent */

static sv_status trunk_mesh_parts(const sv_mesh *mesh, const uint8_t *tri_part, uint32_t limit,
                                  sv_mesh *cand, sv_mesh **out, sv_error *err)
{
    *out = NULL;
    if (!limit) {
        *out = cand;
        return SV_OK;
    }
    sv_mesh *sub = NULL;
    sv_status st = trunk_subset(mesh, tri_part, &sub, err);
    if (st || !sub) { /* no trunk (the caller checked) or no memory */
        if (st) sv_mesh_destroy(cand);
        else *out = cand;
        return st;
    }
    uint32_t nv = sub->vertex_count, nt = sub->triangle_count;
    vkey *vk = NULL;
    double *parea = NULL, *drawn = NULL;
    float *key = malloc((size_t)nv * 6 * sizeof *key);
    unsigned int *wa = malloc((size_t)nv * sizeof *wa), *wb = malloc((size_t)nv * sizeof *wb);
    uint32_t *rep = malloc((size_t)nv * sizeof *rep), *par = malloc((size_t)nv * sizeof *par);
    uint32_t *tpart = malloc((size_t)nt * sizeof *tpart),
             *order = malloc((size_t)nt * sizeof *order);
    uint32_t *loc = malloc((size_t)nv * sizeof *loc), *lrep = malloc((size_t)nv * sizeof *lrep);
    unsigned int *lidx = malloc((size_t)nt * 3 * sizeof *lidx);
    unsigned int *ldst = malloc((size_t)nt * 3 * sizeof *ldst);
    unsigned int *oidx = malloc((size_t)(limit + 1) * 3 * sizeof *oidx);
    uint32_t *omat = malloc((size_t)(limit + 1) * sizeof *omat);
    unsigned int *boidx = malloc((size_t)(limit + 1) * 3 * sizeof *boidx);
    uint32_t *bomat = malloc((size_t)(limit + 1) * sizeof *bomat);
    float *lpos = malloc((size_t)nv * 3 * sizeof *lpos);
    trunk_part *parts = NULL;
    if (!key || !wa || !wb || !rep || !par || !tpart || !order || !loc || !lrep || !lidx || !ldst ||
        !oidx || !omat || !boidx || !bomat || !lpos) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    /* wa: position + material (the parts); wb: + UV (the vertices simplified) */
    for (uint32_t v = 0; v < nv; v++) {
        memcpy(&key[6 * (size_t)v], &sub->positions[3 * (size_t)v], 3 * sizeof(float));
        key[6 * (size_t)v + 3] = 0;
        memcpy(&key[6 * (size_t)v + 4], &sub->uvs[2 * (size_t)v], 2 * sizeof(float));
    }
    for (uint32_t t = 0; t < nt; t++)
        for (int c = 0; c < 3; c++)
            key[6 * (size_t)sub->indices[3 * (size_t)t + c] + 3] = (float)sub->tri_material[t];
    size_t ub = meshopt_generateVertexRemap(wb, NULL, nv, key, nv, 6 * sizeof(float));
    for (uint32_t v = 0; v < nv; v++) key[6 * (size_t)v + 4] = key[6 * (size_t)v + 5] = 0;
    meshopt_generateVertexRemap(wa, NULL, nv, key, nv, 6 * sizeof(float));
    for (uint32_t v = nv; v-- > 0;) rep[wb[v]] = v;
    for (uint32_t v = 0; v < nv; v++) par[v] = v, loc[v] = UINT32_MAX;
    (void)ub;
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t a = uf_find(par, wa[sub->indices[3 * (size_t)t]]);
        for (int c = 1; c < 3; c++) {
            uint32_t b = uf_find(par, wa[sub->indices[3 * (size_t)t + c]]);
            if (a == b) continue;
            if (b < a) { /* the smaller id is the root */
                par[a] = b;
                a = b;
            } else {
                par[b] = a;
            }
        }
    }
    /* parts numbered in order of their first triangle */
    uint32_t np = 0;
    for (uint32_t v = 0; v < nv; v++) lrep[v] = UINT32_MAX;
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t root = uf_find(par, wa[sub->indices[3 * (size_t)t]]);
        if (lrep[root] == UINT32_MAX) lrep[root] = np++;
        tpart[t] = lrep[root];
    }
    parts = sv_calloc(np, sizeof *parts);
    if (!parts) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    for (uint32_t t = nt; t-- > 0;) {
        trunk_part *q = &parts[tpart[t]];
        q->area += sv_tri_area(sub, t);
        q->count++;
        q->min_tri = t;
    }
    /* for judging cand: each vertex's part, found by position and material */
    vk = malloc((size_t)nv * sizeof *vk);
    parea = malloc((size_t)np * sizeof *parea);
    drawn = sv_calloc(np, sizeof *drawn);
    if (!vk || !parea || !drawn) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    for (uint32_t k = 0; k < np; k++) parea[k] = parts[k].area;
    for (uint32_t t = 0; t < nt; t++)
        for (int c = 0; c < 3; c++) {
            uint32_t v = sub->indices[3 * (size_t)t + c];
            memcpy(vk[v].p, &sub->positions[3 * (size_t)v], sizeof vk[v].p);
            vk[v].mat = sub->tri_material[t];
            vk[v].part = tpart[t];
        }
    qsort(vk, nv, sizeof *vk, vkey_cmp);
    for (uint32_t k = 0, f = 0; k < np; k++) parts[k].first = f, f += parts[k].count;
    for (uint32_t k = 0; k < np; k++) parts[k].count = 0;
    for (uint32_t t = 0; t < nt; t++) {
        trunk_part *q = &parts[tpart[t]];
        order[q->first + q->count++] = t;
    }
    qsort(parts, np, sizeof *parts, part_cmp);
    /* The bound that draws the most of the trunk as geometry: per part the
     * smaller of its simplified and its own area, summed (a part collapsed
     * to slivers counts for what it still draws). A pot that takes the whole
     * budget at the finest bound leaves the bonsai's trunk to the quads; at a
     * coarser one both fit. */
    double scale = meshopt_simplifyScale(sub->positions, nv, 3 * sizeof(float));
    size_t total = 0, best_total = 0;
    double best_credit = -1;
    for (int b = 0; b < SV_TRUNK_PART_BOUNDS; b++) {
        double abs_err = ldexp(SV_TRUNK_PART_ERROR, b) * scale, credit = 0;
        total = 0;
        for (uint32_t k = 0; k < np && total / 3 < limit; k++) {
            uint32_t room = limit - (uint32_t)(total / 3);
            size_t before = total;
            uint32_t got = simplify_part(sub, wb, rep, &order[parts[k].first], parts[k].count,
                                         abs_err, 0, room, loc, lidx, lpos, ldst, lrep, oidx, omat,
                                         &total);
            if (!got && k == 0) /* the largest part does not fit within the bound */
                simplify_part(sub, wb, rep, &order[parts[k].first], parts[k].count, 0, room, room,
                              loc, lidx, lpos, ldst, lrep, oidx, omat, &total);
            double drawn = 0;
            for (size_t i = before; i < total; i += 3) {
                const float *a = &sub->positions[3 * (size_t)oidx[i]];
                const float *c1 = &sub->positions[3 * (size_t)oidx[i + 1]];
                const float *c2 = &sub->positions[3 * (size_t)oidx[i + 2]];
                double u[3], w[3];
                for (int j = 0; j < 3; j++) u[j] = c1[j] - a[j], w[j] = c2[j] - a[j];
                double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2],
                       z = u[0] * w[1] - u[1] * w[0];
                drawn += 0.5 * sqrt(x * x + y * y + z * z);
            }
            credit += fmin(drawn, parts[k].area);
        }
        if (credit > best_credit * (1 + 1e-9)) {
            best_credit = credit;
            best_total = total;
            memcpy(boidx, oidx, total * sizeof *oidx);
            memcpy(bomat, omat, total / 3 * sizeof *omat);
        }
    }
    total = best_total;
    memcpy(oidx, boidx, total * sizeof *oidx);
    memcpy(omat, bomat, total / 3 * sizeof *omat);
    if (cand) {
        for (uint32_t t = 0; t < cand->triangle_count; t++) {
            vkey q;
            memcpy(q.p, &cand->positions[3 * (size_t)cand->indices[3 * (size_t)t]], sizeof q.p);
            q.mat = cand->tri_material[t];
            const vkey *hit = bsearch(&q, vk, nv, sizeof *vk, vkey_cmp);
            if (hit) drawn[hit->part] += sv_tri_area(cand, t);
        }
        double credit = 0;
        for (uint32_t k = 0; k < np; k++) credit += fmin(drawn[k], parea[k]);
        if (credit > best_credit) { /* the whole-trunk simplification draws more */
            *out = cand;
            cand = NULL;
            total = 0;
        }
    }
    if (total) {
        memcpy(sub->indices, oidx, total * sizeof *oidx);
        memcpy(sub->tri_material, omat, total / 3 * sizeof *omat);
        sub->triangle_count = (uint32_t)(total / 3);
        uint32_t *all = malloc((size_t)sub->triangle_count * sizeof *all);
        if (!all) {
            st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
            goto out;
        }
        for (uint32_t t = 0; t < sub->triangle_count; t++) all[t] = t;
        st = sv_mesh_subset(sub, all, sub->triangle_count, out, err); /* compacts the vertices */
        free(all);
    }
out:
    free(key), free(wa), free(wb), free(rep), free(par), free(tpart), free(order), free(loc);
    free(lrep), free(lidx), free(ldst), free(oidx), free(omat), free(boidx), free(bomat);
    free(lpos), free(parts), free(vk), free(parea), free(drawn);
    sv_mesh_destroy(sub);
    sv_mesh_destroy(cand);
    return st;
}

sv_status sv_trunk_mesh_parts(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                              uint32_t max_triangles, sv_mesh **out, sv_error *err)
{
    *out = NULL;
    uint32_t n = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) n += tri_part[t] == SV_PART_TRUNK;
    if (!n) return SV_OK;
    double lim = fmin((double)max_triangles, fmax(1.0, floor(ratio * n + 0.5)));
    /* A: material by material, welded by position and UV (seams kept) */
    sv_mesh *a = NULL;
    double ea = 0;
    sv_status st = trunk_mesh_err(mesh, tri_part, lim / n, 0, &a, &ea, err);
    if (st || !a || n <= (uint32_t)lim) {
        *out = a;
        return st;
    }
    /* B: the whole trunk at once, welded by position: the error decides where
     * the triangles go across materials (decorativePlant's pot kept 31 of
     * 200 by its share of the count and crumpled); it can dissolve whole thin
     * parts (the maple's stem went with its twigs) */
    sv_mesh *m = NULL, *cand = NULL;
    if ((st = sv_trunk_mesh(mesh, tri_part, 1.0, 0, &m, err))) {
        sv_mesh_destroy(a);
        return st;
    }
    bool done = false;
    float eb = 0;
    if ((st = simplify_welded(m, (uint32_t)lim, 1.0f, false, false, false, &done, &eb, err))) {
        sv_mesh_destroy(m);
        sv_mesh_destroy(a);
        return st;
    }
    if (done) {
        uint32_t *all = malloc((size_t)m->triangle_count * sizeof *all);
        if (!all) {
            sv_mesh_destroy(m);
            sv_mesh_destroy(a);
            return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        }
        for (uint32_t t = 0; t < m->triangle_count; t++) all[t] = t;
        st = sv_mesh_subset(m, all, m->triangle_count, &cand, err); /* compacts the vertices */
        free(all);
    }
    sv_mesh_destroy(m);
    if (st) {
        sv_mesh_destroy(a);
        return st;
    }
    /* both within the budget: the smaller deviation (meshopt's result error,
     * both relative to the trunk's extent) */
    if (a->triangle_count <= (uint32_t)lim) {
        if (cand && (double)eb < ea) {
            sv_mesh_destroy(a);
            *out = cand;
        } else {
            sv_mesh_destroy(cand);
            *out = a;
        }
        return SV_OK;
    }
    sv_mesh_destroy(a);
    /* 3: the parts, largest first; the candidate that draws more of the trunk wins */
    return trunk_mesh_parts(mesh, tri_part, (uint32_t)lim, cand, out, err);
}

/* Squared distance from p to triangle abc (Ericson, Real-Time Collision
 * Detection §5.1.5, closest point by Voronoi regions). */
static double point_tri_dist2(const double p[3], const double a[3], const double b[3],
                              const double c[3])
{
    double ab[3], ac[3], ap[3], q[3];
    for (int i = 0; i < 3; i++) ab[i] = b[i] - a[i], ac[i] = c[i] - a[i], ap[i] = p[i] - a[i];
#define D3(x, y) ((x)[0] * (y)[0] + (x)[1] * (y)[1] + (x)[2] * (y)[2])
    double d1 = D3(ab, ap), d2 = D3(ac, ap);
    if (d1 <= 0 && d2 <= 0) {
        memcpy(q, a, sizeof q);
    } else {
        double bp[3], cp[3];
        for (int i = 0; i < 3; i++) bp[i] = p[i] - b[i], cp[i] = p[i] - c[i];
        double d3 = D3(ab, bp), d4 = D3(ac, bp), d5 = D3(ab, cp), d6 = D3(ac, cp);
        double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
        if (d3 >= 0 && d4 <= d3) {
            memcpy(q, b, sizeof q);
        } else if (d6 >= 0 && d5 <= d6) {
            memcpy(q, c, sizeof q);
        } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
            double v = d1 / (d1 - d3);
            for (int i = 0; i < 3; i++) q[i] = a[i] + v * ab[i];
        } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
            double w = d2 / (d2 - d6);
            for (int i = 0; i < 3; i++) q[i] = a[i] + w * ac[i];
        } else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
            double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            for (int i = 0; i < 3; i++) q[i] = b[i] + w * (c[i] - b[i]);
        } else {
            double den = va + vb + vc;
            double v = den != 0 ? vb / den : 0, w = den != 0 ? vc / den : 0;
            for (int i = 0; i < 3; i++) q[i] = a[i] + ab[i] * v + ac[i] * w;
        }
    }
#undef D3
    double d = 0;
    for (int i = 0; i < 3; i++) d += (p[i] - q[i]) * (p[i] - q[i]);
    return d;
}

#define SV_KEPT_FRAC 0.01

/* A uniform grid over the kept triangles, each listed in every cell its box
 * (grown by the distance limit) touches: a trunk triangle is then tested only
 * against the kept triangles listed in the cell of its centroid (the loop
 * over all kept triangles for every trunk triangle was 7 % of a default
 * bake of a 150k-triangle tree). */
#define KEPT_GRID 16

typedef struct kept_grid {
    double lo[3], cell[3];
    uint32_t *first; /* KEPT_GRID³ + 1 offsets into tris */
    uint32_t *tris;
} kept_grid;

static void cell_range(const kept_grid *g, const double lo[3], const double hi[3], int a[3],
                       int b[3])
{
    for (int i = 0; i < 3; i++) {
        double x0 = (lo[i] - g->lo[i]) / g->cell[i], x1 = (hi[i] - g->lo[i]) / g->cell[i];
        a[i] = x0 < 0 ? 0 : x0 >= KEPT_GRID ? KEPT_GRID - 1 : (int)x0;
        b[i] = x1 < 0 ? 0 : x1 >= KEPT_GRID ? KEPT_GRID - 1 : (int)x1;
    }
}

static void kept_tri_box(const sv_mesh *k, uint32_t u, double grow, double lo[3], double hi[3])
{
    for (int i = 0; i < 3; i++) lo[i] = INFINITY, hi[i] = -INFINITY;
    for (int v = 0; v < 3; v++)
        for (int i = 0; i < 3; i++) {
            double x = k->positions[3 * (size_t)k->indices[3 * (size_t)u + v] + i];
            lo[i] = fmin(lo[i], x - grow);
            hi[i] = fmax(hi[i], x + grow);
        }
}

static sv_status kept_grid_build(const sv_mesh *k, double grow, kept_grid *g, sv_error *err)
{
    memset(g, 0, sizeof *g);
    double mn[3], mx[3];
    if (!sv_mesh_bounds(k, mn, mx)) return SV_OK;
    for (int i = 0; i < 3; i++) {
        g->lo[i] = mn[i] - grow;
        g->cell[i] = fmax((mx[i] - mn[i] + 2 * grow) / KEPT_GRID, 1e-12);
    }
    const size_t ncell = (size_t)KEPT_GRID * KEPT_GRID * KEPT_GRID;
    g->first = sv_calloc(ncell + 1, sizeof *g->first);
    if (!g->first) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t u = 0; u < k->triangle_count; u++) {
            double lo[3], hi[3];
            int a[3], b[3];
            kept_tri_box(k, u, grow, lo, hi);
            cell_range(g, lo, hi, a, b);
            for (int z = a[2]; z <= b[2]; z++)
                for (int y = a[1]; y <= b[1]; y++)
                    for (int x = a[0]; x <= b[0]; x++) {
                        size_t c = ((size_t)z * KEPT_GRID + (size_t)y) * KEPT_GRID + (size_t)x;
                        if (pass == 0) g->first[c + 1]++;
                        else g->tris[g->first[c]++] = u;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++) g->first[c + 1] += g->first[c];
            g->tris = sv_calloc(g->first[ncell] ? g->first[ncell] : 1, sizeof *g->tris);
            if (!g->tris) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        }
    }
    /* the fill pass advanced every start to the next cell's: shift back */
    for (size_t c = ncell; c > 0; c--) g->first[c] = g->first[c - 1];
    g->first[0] = 0;
    return SV_OK;
}

sv_status sv_trunk_kept(const sv_mesh *m, const uint8_t *part, double radius, double ratio,
                        uint32_t budget, sv_mesh **tm, uint8_t *skip, sv_error *err)
{
    memset(skip, 0, m->triangle_count);
    *tm = NULL;
    if (!part) return SV_OK;
    sv_status st = sv_trunk_mesh_parts(m, part, ratio, budget, tm, err);
    if (st || !*tm) return st;
    const sv_mesh *k = *tm;
    double lim = SV_KEPT_FRAC * radius;
    kept_grid g;
    if ((st = kept_grid_build(k, lim, &g, err))) {
        free(g.first), free(g.tris);
        sv_mesh_destroy(*tm);
        *tm = NULL;
        return st;
    }
    double lim2 = lim * lim;
    for (uint32_t t = 0; t < m->triangle_count && g.first; t++) {
        if (part[t] != SV_PART_TRUNK) continue;
        double c[3] = {0, 0, 0};
        for (int v = 0; v < 3; v++)
            for (int i = 0; i < 3; i++)
                c[i] += m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + i] / 3.0;
        int a[3], b[3];
        cell_range(&g, c, c, a, b);
        size_t cell = ((size_t)a[2] * KEPT_GRID + (size_t)a[1]) * KEPT_GRID + (size_t)a[0];
        for (uint32_t q = g.first[cell]; q < g.first[cell + 1] && !skip[t]; q++) {
            uint32_t u = g.tris[q];
            double p[3][3];
            for (int v = 0; v < 3; v++)
                for (int i = 0; i < 3; i++)
                    p[v][i] = k->positions[3 * (size_t)k->indices[3 * (size_t)u + v] + i];
            if (point_tri_dist2(c, p[0], p[1], p[2]) <= lim2) skip[t] = 1;
        }
    }
    free(g.first);
    free(g.tris);
    return SV_OK;
}

/* ---- twigs: the trunk triangles the kept trunk leaves out, by cell ---- */

typedef struct twig_key {
    uint64_t cell;
    uint32_t t;
} twig_key;

static int twig_key_cmp(const void *a, const void *b)
{
    const twig_key *x = a, *y = b;
    if (x->cell != y->cell) return x->cell < y->cell ? -1 : 1;
    return x->t < y->t ? -1 : x->t > y->t;
}

sv_status sv_twig_groups(const sv_mesh *m, const uint8_t *part, const uint8_t *skip,
                         const double centre[3], double radius, double cell_frac, sv_twigs *out,
                         sv_error *err)
{
    memset(out, 0, sizeof *out);
    uint32_t n = 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) n += part[t] == SV_PART_TRUNK && !skip[t];
    twig_key *k = malloc((size_t)(n ? n : 1) * sizeof *k);
    out->tris = malloc((size_t)(n ? n : 1) * sizeof *out->tris);
    out->first = malloc(((size_t)n + 1) * sizeof *out->first);
    if (!k || !out->tris || !out->first) {
        free(k);
        sv_twigs_free(out);
        return sv_fail(err, SV_ERR_NOMEM, "twigs: out of memory (%u triangles)", n);
    }
    double cell = cell_frac * radius, lo[3];
    for (int i = 0; i < 3; i++) lo[i] = centre[i] - radius;
    n = 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (part[t] != SV_PART_TRUNK || skip[t]) continue;
        uint64_t c = 0;
        for (int i = 0; i < 3; i++) {
            double x = 0;
            for (int v = 0; v < 3; v++)
                x += m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + i] / 3.0;
            double q = floor((x - lo[i]) / cell);
            c = c * 4096 + (uint64_t)(q < 0 ? 0 : q > 4095 ? 4095 : q);
        }
        k[n].cell = c;
        k[n++].t = t;
    }
    qsort(k, n, sizeof *k, twig_key_cmp);
    uint32_t g = 0;
    for (uint32_t a = 0; a < n; a++) {
        if (a == 0 || k[a].cell != k[a - 1].cell) out->first[g++] = a;
        out->tris[a] = k[a].t;
    }
    out->first[g] = n;
    out->count = n;
    out->groups = g;
    free(k);
    return SV_OK;
}

void sv_twigs_free(sv_twigs *tw)
{
    if (!tw) return;
    free(tw->tris);
    free(tw->first);
    memset(tw, 0, sizeof *tw);
}
