/* leaf_clusters.c — the "leaf_clusters" method: leaf-cluster impostors.
 *
 * Garcia, Sbert, Szirmay-Kalos, "Leaf Cluster Impostors for Tree Rendering
 * with Parallax": leaves that lie nearly in one plane become one fixed (not
 * camera-facing) textured quad (§2), clustered by K-means on the error of
 * eq. 1 with planes refit by eq. 5 (cluster.c), organised in hierarchical
 * levels 32 → 16 → 8 with parent links for smooth LOD (§2.4).
 *
 * Output, one LOD per level, finest first, named "clusters<K>" after the
 * requested count; one quad per non-empty cluster:
 *   - plane: the cluster's eq. 5 plane, normal pointing away from the tree
 *     centre (in->centre on the back side; see cluster.h), texture seen from
 *     +normal, i.e. from outside the tree;
 *   - rectangle: minimum-area enclosing rectangle (sv_quad_fit_points) of ALL
 *     vertices of the cluster's leaf triangles (each distinct vertex once)
 *     projected onto the plane;
 *   - faces = bake_faces = the cluster's leaf triangles: an impostor shows
 *     exactly its own leaves (§2: "replace the whole group by a single
 *     impostor"), never a neighbour cluster's leaves that happen to lie near
 *     its plane, so no leaf is drawn twice;
 *   - slab: largest |distance| of those vertices to the plane (for the record:
 *     bake_faces decides what is baked); parts = foliage; group = level index;
 *     parent = the quad of the next coarser LOD this cluster merges into
 *     (-1 at the coarsest);
 *   - trunk: kept as the level's geometry (sv_trunk_kept): simplified to
 *     trunk_ratio per level (default 0.5, 0.25, 0.1, then 0.05) and at most
 *     trunk_max_triangles; with "twigs": true the trunk triangles the finest
 *     level's kept trunk does not draw (twigs the budget collapsed) join the
 *     clustering as one-triangle "leaves", so no branch is lost and none is
 *     drawn twice (Garcia et al. keep the trunk as geometry and say nothing
 *     of twigs). On by default since the kept trunk keeps whole parts
 *     (sv_trunk_mesh_parts): at 32 clusters, sveval, sapling maple 0.778 ->
 *     0.809, bush 0.780 -> 0.797, decorativePlant 0.919 -> 0.927, acacia
 *     0.869 -> 0.865 the one loss over 0.002 (docs/methods/leaf_clusters.md).
 *     The twig triangles are grouped into elements by a grid (twig_elements):
 *     one element per triangle made the clustering the slowest stage.
 *
 * Settings (spec key "leaf_clusters"), all optional:
 *   "clusters":      array of 1..8 integers in [1, 1024], strictly decreasing,
 *                    finest first (default [32, 16, 8]); one integer N = [N];
 *   "alpha_rel":     number in [0, 100] (default 0.0007): α = alpha_rel·R², R
 *                    the bounding-sphere radius (docs/methods/leaf_clusters.md
 *                    has the measurement behind the default);
 *   "area_weighted": bool (default true): weight each leaf's error by its area;
 *   "iterations":    integer in [1, 1000] (default 50): k-means iterations;
 *   "seed_tries":    integer in [1, 64] (default 4): k-means++ candidates per seed;
 *   "trunk_ratio":   array of numbers in (0, 1], one per level.
 *   "trunk_max_triangles": number or array (one per level), default 200: the
 *                    kept trunk is capped at this many triangles
 *                    (sv_trunk_mesh_budget), so a level's cost is its quads
 *                    plus at most this.
 *   "twigs":         bool (default true): see "trunk" above.
 */
#include "leaf_clusters.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cluster.h"
#include "trunk.h"

/* Builds the quad of cluster c of a level from its leaves' triangles. The
 * face list is the member leaves' triangles in leaf order. */
static sv_status make_quad(const sv_mesh *m, const sv_leaves *lv, const sv_cluster_level *level,
                           uint32_t c, uint32_t ntris, int32_t group, sv_quad *q, double *pts,
                           uint32_t *stamp, uint32_t mark, sv_error *err)
{
    memset(q, 0, sizeof *q);
    const sv_cluster_plane *p = &level->planes[c];
    for (int j = 0; j < 3; j++) q->normal[j] = p->normal[j];
    q->d = p->d;
    q->faces = sv_calloc(ntris, sizeof *q->faces);
    q->bake_faces = sv_calloc(ntris, sizeof *q->bake_faces);
    if (!q->faces || !q->bake_faces) {
        free(q->faces);
        free(q->bake_faces);
        return sv_fail(err, SV_ERR_NOMEM, LC_NAME ": no memory for the faces of cluster %u", c);
    }
    uint32_t k = 0;
    size_t np = 0; /* distinct vertices: a vertex shared by several faces is one point */
    double slab = 0.0, area = 0.0;
    for (uint32_t i = 0; i < lv->count; i++) {
        if (level->assign[i] != c) continue;
        const sv_leaf *leaf = &lv->leaves[i];
        for (uint32_t t = 0; t < leaf->count; t++) {
            uint32_t tri = lv->tris[leaf->first + t];
            q->faces[k] = q->bake_faces[k] = tri;
            area += sv_tri_area(m, tri);
            for (int v = 0; v < 3; v++) {
                uint32_t vi = m->indices[3 * (size_t)tri + v];
                if (stamp[vi] == mark) continue;
                stamp[vi] = mark;
                const float *pos = &m->positions[3 * (size_t)vi];
                double *out = &pts[3 * np++];
                for (int j = 0; j < 3; j++) out[j] = pos[j];
                double dist = fabs(out[0] * q->normal[0] + out[1] * q->normal[1] +
                                   out[2] * q->normal[2] + q->d);
                if (dist > slab) slab = dist;
            }
            k++;
        }
    }
    q->face_count = q->bake_face_count = k;
    q->face_area = area;
    q->slab = slab;
    q->clip = false;
    q->parts = SV_PARTS_FOLIAGE;
    q->group = group;
    q->parent = level->parent[c];
    sv_quad_fit_points(q, pts, np);
    return SV_OK;
}

static sv_status check_leaves(const sv_mesh *m, const sv_leaves *lv, sv_error *err)
{
    for (uint32_t i = 0; i < lv->count; i++) {
        const sv_leaf *l = &lv->leaves[i];
        if (l->first > lv->tri_count || l->count > lv->tri_count - l->first)
            return sv_fail(err, SV_ERR_INTERNAL,
                           LC_NAME ": leaf %u's triangles lie outside the list", i);
        for (uint32_t t = 0; t < l->count; t++)
            if (lv->tris[l->first + t] >= m->triangle_count)
                return sv_fail(err, SV_ERR_INTERNAL, LC_NAME ": leaf %u names triangle %u of %u", i,
                               lv->tris[l->first + t], m->triangle_count);
    }
    return SV_OK;
}

/* The trunk triangles the kept trunk leaves out (skip[t] == 0), as leaf
 * elements for the clustering, grouped by a grid of cells SV_TWIG_CELL of the
 * bounding radius (sv_twig_groups; the sapling maple leaves ~100k twig
 * triangles: one element each made the clustering the slowest stage and a
 * target search 4x one bake). An element's normal is its triangles'
 * area-weighted normal, or, where they cancel (a twig's tube), the
 * horizontal direction away from the tree's centre. Appended to ext (room
 * for one element per triangle). */

static sv_status twig_elements(const sv_mesh *m, const uint8_t *part, const uint8_t *skip,
                               const sv_method_input *in, sv_leaves *ext, sv_error *err)
{
    sv_twigs twigs;
    sv_status st = sv_twig_groups(m, part, skip, in->centre, in->radius, SV_TWIG_CELL, &twigs, err);
    const uint32_t *tw = twigs.tris;
    for (uint32_t g = 0; g < twigs.groups && !st; g++) {
        uint32_t a = twigs.first[g], b = twigs.first[g + 1];
        sv_leaf *f = &ext->leaves[ext->count++];
        memset(f, 0, sizeof *f);
        double nsum[3] = {0, 0, 0};
        f->first = ext->tri_count;
        for (uint32_t j = a; j < b; j++) {
            uint32_t t = tw[j];
            double ar = sv_tri_area(m, t), nn[3];
            sv_tri_normal(m, t, nn);
            for (int i = 0; i < 3; i++) {
                double x = 0;
                for (int v = 0; v < 3; v++)
                    x += m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + i] / 3.0;
                f->centre[i] += ar * x;
                nsum[i] += ar * nn[i];
            }
            f->area += ar;
            ext->tris[ext->tri_count++] = t;
        }
        f->count = b - a;
        for (int i = 0; i < 3; i++) f->centre[i] = f->area > 0 ? f->centre[i] / f->area : 0;
        if (!(f->area > 0)) { /* degenerate triangles only: the first one's centroid */
            for (int i = 0; i < 3; i++) {
                f->centre[i] = 0;
                for (int v = 0; v < 3; v++)
                    f->centre[i] +=
                        m->positions[3 * (size_t)m->indices[3 * (size_t)tw[a] + v] + i] / 3.0;
            }
        }
        double len = sqrt(nsum[0] * nsum[0] + nsum[1] * nsum[1] + nsum[2] * nsum[2]);
        if (len < 0.3 * f->area || !(len > 0)) { /* a tube: away from the tree's centre */
            nsum[0] = f->centre[0] - in->centre[0], nsum[1] = 0,
            nsum[2] = f->centre[2] - in->centre[2];
            len = sqrt(nsum[0] * nsum[0] + nsum[2] * nsum[2]);
            if (!(len > 0)) nsum[0] = 1, len = 1;
        }
        for (int i = 0; i < 3; i++) f->normal[i] = nsum[i] / len;
        for (uint32_t j = a; j < b; j++)
            for (int v = 0; v < 3; v++) {
                const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)tw[j] + v]];
                double d = sqrt((p[0] - f->centre[0]) * (p[0] - f->centre[0]) +
                                (p[1] - f->centre[1]) * (p[1] - f->centre[1]) +
                                (p[2] - f->centre[2]) * (p[2] - f->centre[2]));
                if (d > f->radius) f->radius = d;
            }
    }
    sv_twigs_free(&twigs);
    return st;
}

static sv_status lc_build(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                          sv_error *err)
{
    lc_settings s;
    sv_status st = lc_parse(settings, &s, err);
    if (st) return st;
    const sv_mesh *m = in->mesh;
    const sv_leaves *lv = in->leaves;
    if (!m) return sv_fail(err, SV_ERR_INTERNAL, LC_NAME ": no mesh");
    if (!lv || lv->count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE,
                       LC_NAME ": the tree has no leaf elements (no foliage was classified)");
    if (!(in->radius > 0) || !isfinite(in->radius))
        return sv_fail(err, SV_ERR_UNBAKEABLE, LC_NAME ": bounding radius %g is not positive",
                       in->radius);
    if ((st = check_leaves(m, lv, err))) return st;

    /* the kept trunk of the finest level, and the twigs it leaves out as
     * one-triangle leaves appended to a copy of the leaf set */
    const uint8_t *part = in->cls ? in->cls->tri_part : NULL;
    sv_leaves ext = *lv;
    ext.leaves = NULL;
    ext.tris = NULL;
    sv_mesh *tm0 = NULL;
    uint8_t *skip = sv_calloc(m->triangle_count ? m->triangle_count : 1, 1);
    if (!skip) return sv_fail(err, SV_ERR_NOMEM, LC_NAME ": out of memory");
    if (part && (st = sv_trunk_kept(m, part, in->radius, s.trunk_ratio[0], (uint32_t)s.trunk_max[0],
                                    &tm0, skip, err))) {
        free(skip);
        return st;
    }
    uint32_t twigs = 0;
    for (uint32_t t = 0; s.twigs && part && t < m->triangle_count; t++)
        twigs += part[t] == SV_PART_TRUNK && !skip[t];
    ext.leaves = sv_calloc((size_t)lv->count + twigs, sizeof *ext.leaves);
    ext.tris = sv_calloc((size_t)lv->tri_count + twigs + 1, sizeof *ext.tris);
    if (!ext.leaves || !ext.tris) {
        free(ext.leaves), free(ext.tris), free(skip);
        sv_mesh_destroy(tm0);
        return sv_fail(err, SV_ERR_NOMEM, LC_NAME ": out of memory");
    }
    memcpy(ext.leaves, lv->leaves, (size_t)lv->count * sizeof *ext.leaves);
    memcpy(ext.tris, lv->tris, (size_t)lv->tri_count * sizeof *ext.tris);
    if (twigs && (st = twig_elements(m, part, skip, in, &ext, err))) {
        free(ext.leaves), free(ext.tris), free(skip);
        sv_mesh_destroy(tm0);
        return st;
    }
    free(skip);
    lv = &ext;

    sv_cluster_options co = {
        .levels = s.levels,
        .level_count = s.level_count,
        .alpha = s.alpha_rel * in->radius * in->radius,
        .area_weighted = s.area_weighted,
        .max_iterations = (uint32_t)s.iterations,
        .seed_tries = (uint32_t)s.seed_tries,
        .seed = in->seed,
        .centre = in->centre,
    };
    sv_clusters cl;
    if ((st = sv_cluster_build(lv->leaves, lv->count, &co, &cl, err))) {
        free(ext.leaves), free(ext.tris);
        sv_mesh_destroy(tm0);
        return st;
    }

    snprintf(out->method, sizeof out->method, "%s", LC_NAME);
    uint32_t *tris = NULL, mark = 0;
    double *pts = NULL;
    uint32_t *stamp = sv_calloc(m->vertex_count,
                                sizeof *stamp); /* vertex → last quad that took it */
    if (!stamp) {
        sv_clusters_free(&cl);
        free(ext.leaves), free(ext.tris);
        sv_mesh_destroy(tm0);
        return sv_fail(err, SV_ERR_NOMEM, LC_NAME ": no memory for %u vertices", m->vertex_count);
    }
    for (uint32_t l = 0; l < cl.level_count && st == SV_OK; l++) {
        const sv_cluster_level *level = &cl.levels[l];
        char name[32];
        snprintf(name, sizeof name, "clusters%u", s.levels[l]);
        sv_lod_plan *lod = sv_stand_in_add_lod(out, name);
        if (!lod) {
            st = sv_fail(err, SV_ERR_NOMEM, LC_NAME ": no memory for LOD %s", name);
            break;
        }
        /* the trunk as the level's own geometry; the pipeline adds none */
        lod->trunk = SV_TRUNK_NONE;
        lod->trunk_ratio = s.trunk_ratio[l]; /* for the record: the kept geometry's ratio */
        lod->trunk_max_triangles = (uint32_t)s.trunk_max[l];
        if (l == 0) {
            lod->geometry = tm0;
            tm0 = NULL;
        } else if (part &&
                   (st = sv_trunk_mesh_parts(m, part, s.trunk_ratio[l], (uint32_t)s.trunk_max[l],
                                             &lod->geometry, err))) {
            break;
        }
        /* triangles per cluster, and room for the largest cluster's vertices */
        free(tris);
        tris = sv_calloc(level->count, sizeof *tris);
        if (!tris) {
            st = sv_fail(err, SV_ERR_NOMEM, LC_NAME ": no memory for level %u", l);
            break;
        }
        uint32_t most = 0;
        for (uint32_t i = 0; i < lv->count; i++) tris[level->assign[i]] += lv->leaves[i].count;
        for (uint32_t c = 0; c < level->count; c++)
            if (tris[c] > most) most = tris[c];
        size_t nvert;
        if (!sv_mul_size(most, 3, &nvert)) {
            st = sv_fail(err, SV_ERR_NOMEM, LC_NAME ": cluster too large");
            break;
        }
        free(pts);
        pts = sv_calloc(nvert, 3 * sizeof *pts);
        if (!pts) {
            st = sv_fail(err, SV_ERR_NOMEM, LC_NAME ": no memory for %u triangles", most);
            break;
        }
        for (uint32_t c = 0; c < level->count && st == SV_OK; c++) {
            sv_quad q;
            st = make_quad(m, lv, level, c, tris[c], (int32_t)l, &q, pts, stamp, ++mark, err);
            if (st == SV_OK) st = sv_lod_add_quad(lod, &q, err);
        }
    }
    free(tris);
    free(pts);
    free(stamp);
    sv_clusters_free(&cl);
    free(ext.leaves), free(ext.tris);
    sv_mesh_destroy(tm0);
    return st;
}

/* On failure the partial stand-in is freed (out is left zeroed). */
static sv_status lc_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                        sv_error *err)
{
    sv_status st = lc_build(in, settings, out, err);
    if (st) sv_stand_in_free(out);
    return st;
}

const sv_method_ops sv_method_leaf_clusters_ops = {
    .method = &sv_method_leaf_clusters,
    .run = lc_run,
};
