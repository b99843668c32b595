/* billboard_cloud.c — the "billboard_cloud" method (method.h): Décoret et al.
 * 2003 with Behrendt et al.'s tree fixes (papers/billboard-cloud-forests.txt);
 * plane selection lives in greedy_planes.c (refined by kplanes.c), this file turns the classified mesh into
 * elements (one per leaf, one per other triangle), runs the selection per LOD
 * (incremental LODs, §3.3.8: each coarser LOD from the previous one's
 * billboards, i.e. its faces projected onto their planes, with a larger ε) and
 * turns planes into quads (rectangle = minimum-area rectangle of the projected
 * vertices of the faces a plane simplifies). See docs/methods/billboard_cloud.md.
 *
 * Settings (spec key "billboard_cloud"), all optional:
 *   "epsilon":     validity distance as a fraction of the bounding radius (0.14)
 *   "max_planes":  plane limit of the finest LOD (24); ε is raised to meet it
 *   "lods":        [24, 12, 6] (max_planes per LOD) or objects {"epsilon": e,
 *                  "max_planes": n} (at least one of them); default
 *                  [max_planes, max_planes/2, max_planes/4] (each at least 2)
 *   "grid":        [nθ, nφ, nρ] dual grid (32, 16, 32; nθ even)
 *   "horizontal_penalty": {"enabled": null|bool (null: on for scene.viewer
 *                  "ground"), "penalty": 0.6, "angle_deg": 50}
 *   "cardboard":   {"enabled": false, "coverage": 0.8}
 *   "tweak": true, "weld": true, "threads": 2 (1..16, same result for any),
 *   "miss_penalty": 0.5, "max_angle_deg": 75
 *   "refine":      k-planes iterations after the greedy selection (48; 0 = the
 *                  papers' planes as selected). Refined planes bake exactly the
 *                  leaves assigned to them (each leaf drawn once; see
 *                  kplanes.c and docs/methods/billboard_cloud.md)
 *   "trunk":       "mesh" (default: trunk and branches kept as geometry,
 *                  simplified to at most trunk_max_triangles) or "planes" (the
 *                  papers' separate trunk pass of billboards)
 *   "trunk_max_triangles": 200, or an array with one per LOD
 */
#include "billboard_cloud.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "planes.h"
#include "trunk.h"

/* ---------------------------------------------------------------- elements */

typedef struct bc_input {
    double *pos;
    uint32_t *etris, *efirst;
    uint8_t *epart;
    uint32_t ne;
} bc_input;

static void bc_input_free(bc_input *b)
{
    free(b->pos);
    free(b->etris);
    free(b->efirst);
    free(b->epart);
}

/* Twig triangles (trunk triangles the kept trunk leaves out) above which they
 * become elements a cell of SV_TWIG_CELL at a time instead of one a triangle:
 * many twig triangles as elements make the plane selection most of a bake,
 * and grouping them costs no accuracy there; few are kept one element a
 * triangle (the figures: docs/methods/billboard_cloud.md and
 * docs/benchmarks.md, "Figures moved out of the code"). */
#define BC_TWIG_GROUP_MIN 16384

/* One element per leaf (sv_leaves), one per other triangle. skip (may be
 * NULL): triangles to leave out (trunk triangles the kept trunk mesh already
 * draws); when given, the trunk triangles not skipped become foliage elements,
 * grouped by cells when there are more than BC_TWIG_GROUP_MIN. */
/* The twig triangles as foliage elements of one cell each (sv_twig_groups),
 * appended at *k / *ne; marks them used. */
static sv_status group_twigs(const sv_method_input *in, const uint8_t *part, const uint8_t *skip,
                             uint8_t *used, bc_input *b, uint32_t *k, uint32_t *ne, sv_error *err)
{
    sv_twigs tw;
    sv_status st = sv_twig_groups(in->mesh, part, skip, in->centre, in->radius, SV_TWIG_CELL, &tw,
                                  err);
    for (uint32_t g = 0; g < tw.groups && !st; g++) {
        b->efirst[*ne] = *k;
        b->epart[(*ne)++] = SV_PART_FOLIAGE;
        for (uint32_t j = tw.first[g]; j < tw.first[g + 1]; j++) {
            used[tw.tris[j]] = 1;
            b->etris[(*k)++] = tw.tris[j];
        }
    }
    sv_twigs_free(&tw);
    return st;
}

static sv_status build_elements(const sv_method_input *in, const uint8_t *skip, bc_input *b,
                                sv_error *err)
{
    const sv_mesh *m = in->mesh;
    uint32_t nt = m->triangle_count;
    memset(b, 0, sizeof *b);
    b->pos = sv_calloc(m->vertex_count ? m->vertex_count : 1, 3 * sizeof(double));
    b->etris = sv_calloc(nt ? nt : 1, sizeof *b->etris);
    b->efirst = sv_calloc((size_t)nt + 2, sizeof *b->efirst);
    b->epart = sv_calloc(nt ? nt : 1, 1);
    uint8_t *used = sv_calloc(nt ? nt : 1, 1);
    if (!b->pos || !b->etris || !b->efirst || !b->epart || !used) {
        free(used);
        return sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (%u triangles)", nt);
    }
    for (size_t i = 0; i < (size_t)m->vertex_count * 3; i++) b->pos[i] = m->positions[i];
    const uint8_t *part = in->cls ? in->cls->tri_part : NULL;
    uint32_t k = 0, ne = 0;
    if (in->leaves) {
        for (uint32_t l = 0; l < in->leaves->count; l++) {
            const sv_leaf *lf = &in->leaves->leaves[l];
            uint32_t start = k;
            for (uint32_t j = 0; j < lf->count; j++) {
                uint64_t at = (uint64_t)lf->first + j;
                if (at >= in->leaves->tri_count) break;
                uint32_t t = in->leaves->tris[at];
                if (t >= nt || used[t] || (part && part[t] != SV_PART_FOLIAGE)) continue;
                used[t] = 1;
                b->etris[k++] = t;
            }
            if (k > start) {
                b->efirst[ne] = start;
                b->epart[ne++] = SV_PART_FOLIAGE;
            }
        }
    }
    if (skip && part) {
        uint32_t twigs = 0;
        for (uint32_t t = 0; t < nt; t++) twigs += !used[t] && !skip[t] && part[t] == SV_PART_TRUNK;
        if (twigs > BC_TWIG_GROUP_MIN) {
            sv_status st = group_twigs(in, part, skip, used, b, &k, &ne, err);
            if (st) {
                free(used);
                return st;
            }
        }
    }
    for (uint32_t t = 0; t < nt; t++) {
        if (used[t] || (skip && skip[t])) continue;
        b->efirst[ne] = k;
        /* with the trunk kept as geometry, the branches it cannot hold are
         * drawn by the foliage planes like leaves */
        b->epart[ne++] = part && part[t] == SV_PART_TRUNK && !skip ? SV_PART_TRUNK
                                                                   : SV_PART_FOLIAGE;
        b->etris[k++] = t;
    }
    b->efirst[ne] = k;
    b->ne = ne;
    free(used);
    return SV_OK;
}

/* ---------------------------------------------------------------- quads */

static bool grow_points(double **pts, size_t *cap, size_t n)
{
    if (n <= *cap) return true;
    double *p = sv_calloc(n, 3 * sizeof(double));
    if (!p) return false;
    free(*pts);
    *pts = p;
    *cap = n;
    return true;
}

/* Quads of one LOD from a selection result. mark: vertex_count zeroed entries. */
static sv_status add_quads(const sv_method_input *in, const sv_bbc_result *r, bool refined,
                           sv_lod_plan *lod, uint32_t *mark, sv_error *err)
{
    const sv_mesh *m = in->mesh;
    double *pts = NULL;
    size_t cap = 0;
    sv_status st = SV_OK;
    for (uint32_t k = 0; k < r->plane_count && !st; k++) {
        const sv_bbc_plane *p = &r->planes[k];
        sv_quad q;
        memset(&q, 0, sizeof q);
        memcpy(q.normal, p->normal, sizeof q.normal);
        q.d = p->d;
        q.parts = p->part == SV_PART_TRUNK ? SV_PARTS_TRUNK : SV_PARTS_FOLIAGE;
        q.group = p->cardboard_of;
        q.parent = -1;
        q.face_area = p->cardboard_of < 0 ? p->area : 0;
        /* unique vertices of the plane's faces, original positions */
        size_t n = 0;
        if (!grow_points(&pts, &cap, (size_t)p->count * 3)) {
            st = sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (quad points)");
            break;
        }
        /* refined planes hold their leaves wherever k-planes put them: the
         * slab is what they need, not ε */
        double slab = refined ? 0 : r->stats.epsilon;
        for (uint32_t i = 0; i < p->count; i++) {
            uint32_t t = r->tris[p->first + i];
            for (int v = 0; v < 3; v++) {
                uint32_t ix = m->indices[3 * (size_t)t + v];
                if (mark[ix] == k + 1) continue;
                mark[ix] = k + 1;
                const float *x = &m->positions[3 * (size_t)ix];
                for (int c = 0; c < 3; c++) pts[3 * n + c] = x[c];
                double d = fabs(q.normal[0] * x[0] + q.normal[1] * x[1] + q.normal[2] * x[2] + q.d);
                if (d > slab) slab = d;
                n++;
            }
        }
        /* Every assigned face inside the slab, even when welding or an
         * incremental LOD moved it up to ε further (margin for rounding). */
        q.slab = slab + 1e-6 * in->radius;
        sv_quad_fit_points(&q, pts, n);
        uint32_t *list = sv_calloc(p->count ? p->count : 1, sizeof *list);
        if (!list) {
            st = sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (quad faces)");
            break;
        }
        memcpy(list, &r->tris[p->first], (size_t)p->count * sizeof *list);
        if (p->cardboard_of < 0) {
            q.faces = list;
            q.face_count = p->count;
            if (refined) { /* each leaf drawn by its own plane only */
                q.bake_faces = sv_calloc(p->count ? p->count : 1, sizeof *list);
                if (!q.bake_faces) {
                    free(list);
                    st = sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (quad faces)");
                    break;
                }
                memcpy(q.bake_faces, list, (size_t)p->count * sizeof *list);
                q.bake_face_count = p->count;
            }
        } else {
            q.bake_faces = list; /* a cardboard plane shows its primary's faces, simplifies none */
            q.bake_face_count = p->count;
        }
        st = sv_lod_add_quad(lod, &q, err); /* takes the list, even on failure */
    }
    free(pts);
    /* reset marks for the next LOD */
    memset(mark, 0, (size_t)m->vertex_count * sizeof *mark);
    return st;
}

/* parent of every quad of `fine` (from result rf): the primary plane of the
 * coarser result rc that received most of its faces' area. */
static sv_status link_parents(const sv_mesh *m, const sv_bbc_result *rf, const sv_bbc_result *rc,
                              sv_lod_plan *fine, sv_error *err)
{
    uint32_t *tri_plane = sv_calloc(m->triangle_count ? m->triangle_count : 1, sizeof *tri_plane);
    double *acc = sv_calloc(rc->plane_count ? rc->plane_count : 1, sizeof *acc);
    if (!tri_plane || !acc) {
        free(tri_plane);
        free(acc);
        return sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (LOD links)");
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) tri_plane[t] = UINT32_MAX;
    for (uint32_t k = 0; k < rc->plane_count; k++) {
        if (rc->planes[k].cardboard_of >= 0) continue;
        for (uint32_t i = 0; i < rc->planes[k].count; i++)
            tri_plane[rc->tris[rc->planes[k].first + i]] = k;
    }
    for (uint32_t k = 0; k < rf->plane_count && k < fine->quad_count; k++) {
        const sv_bbc_plane *p = &rf->planes[k];
        if (p->cardboard_of >= 0) continue;
        memset(acc, 0, (size_t)rc->plane_count * sizeof *acc);
        for (uint32_t i = 0; i < p->count; i++) {
            uint32_t t = rf->tris[p->first + i];
            if (tri_plane[t] != UINT32_MAX) acc[tri_plane[t]] += sv_tri_area(m, t);
        }
        int32_t best = -1;
        for (uint32_t c = 0; c < rc->plane_count; c++)
            if (rc->planes[c].cardboard_of < 0 && (best < 0 || acc[c] > acc[best]))
                best = (int32_t)c;
        fine->quads[k].parent = best;
    }
    for (uint32_t k = 0; k < rf->plane_count && k < fine->quad_count; k++)
        if (rf->planes[k].cardboard_of >= 0)
            fine->quads[k].parent = fine->quads[rf->planes[k].cardboard_of].parent;
    free(tri_plane);
    free(acc);
    return SV_OK;
}

static sv_status bc_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                        sv_error *err)
{
    bc_settings s;
    sv_status st = bc_parse(settings, &s, err);
    if (st) return st;
    const sv_mesh *m = in->mesh;
    if (!m || !m->triangle_count)
        return sv_fail(err, SV_ERR_UNBAKEABLE, BC_NAME ": the mesh has no triangles");
    if (!(in->radius > 0) || !isfinite(in->radius))
        return sv_fail(err, SV_ERR_UNBAKEABLE, BC_NAME ": bounding radius %g is not positive",
                       in->radius);
    bc_input b;
    uint8_t *skip = NULL;
    sv_mesh *tm = NULL;
    if (s.trunk_mesh) {
        if (!(skip = sv_calloc(m->triangle_count, 1)))
            return sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory");
        if ((st = sv_trunk_kept(m, in->cls ? in->cls->tri_part : NULL, in->radius, 1.0,
                                (uint32_t)s.trunk_max[0], &tm, skip, err))) {
            free(skip);
            return st;
        }
    }
    if ((st = build_elements(in, skip, &b, err))) {
        bc_input_free(&b);
        sv_mesh_destroy(tm);
        free(skip);
        return st;
    }
    sv_bbc_input bi;
    memset(&bi, 0, sizeof bi);
    bi.positions = b.pos;
    bi.vertex_count = m->vertex_count;
    bi.indices = m->indices;
    bi.triangle_count = m->triangle_count;
    bi.elem_tris = b.etris;
    bi.elem_first = b.efirst;
    bi.elem_part = b.epart;
    bi.elem_count = b.ne;
    memcpy(bi.centre, in->centre, sizeof bi.centre);
    bi.radius = in->radius;

    sv_bbc_options o;
    sv_bbc_options_init(&o);
    o.grid_theta = (uint32_t)s.grid[0];
    o.grid_phi = (uint32_t)s.grid[1];
    o.grid_rho = (uint32_t)s.grid[2];
    o.miss_penalty = s.miss_penalty;
    o.max_angle_deg = s.max_angle;
    o.horizontal_penalty = s.hp_enabled < 0 ? (in->scene && in->scene->viewer == SV_VIEWER_GROUND)
                                            : s.hp_enabled == 1;
    o.horizontal_value = s.hp_penalty;
    o.horizontal_angle_deg = s.hp_angle;
    o.tweak = s.tweak;
    o.weld = s.weld;
    o.cardboard = s.cb_enabled;
    o.cardboard_coverage = s.cb_coverage;
    o.threads = (uint32_t)s.threads;
    /* a target search's tries share what the ε searches learnt (planes.h) */
    o.memo = sv_memo_slot(in->memo, BC_NAME ".eps", sv_bbc_memo_create, sv_bbc_memo_free);

    memset(out, 0, sizeof *out);
    snprintf(out->method, sizeof out->method, "%s", BC_NAME);
    uint32_t *mark = sv_calloc(m->vertex_count ? m->vertex_count : 1, sizeof *mark);
    sv_bbc_result prev, cur;
    memset(&prev, 0, sizeof prev);
    memset(&cur, 0, sizeof cur);
    sv_bbc_input lin = bi;
    double *ppos = NULL;
    uint32_t *pidx = NULL;
    double prev_eps = 0;
    if (!mark) st = sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory");
    for (int L = 0; L < s.lod_count && !st; L++) {
        const bc_lod *l = &s.lods[L];
        double eps;
        if (L == 0) {
            eps = (l->epsilon > 0 ? l->epsilon : s.epsilon) * in->radius;
        } else {
            /* §3.3.8: the previous LOD's billboards (faces projected onto
             * their planes) are the input, with a larger ε. */
            eps = l->epsilon > 0 ? fmax(l->epsilon * in->radius, prev_eps) : 1.5 * prev_eps;
            double *np = NULL;
            uint32_t *ni = NULL, nv = 0;
            if ((st = sv_bbc_project(&lin, &prev, &np, &ni, &nv, err))) break;
            free(ppos);
            free(pidx);
            ppos = np;
            pidx = ni;
            lin.positions = ppos;
            lin.indices = pidx;
            lin.vertex_count = nv;
        }
        if (L > 0 && s.trunk_mesh) {
            /* this level's own trunk budget: elements anew (the positions stay
             * the previous level's projections) */
            bc_input nb;
            if ((st = sv_trunk_kept(m, in->cls ? in->cls->tri_part : NULL, in->radius, 1.0,
                                    (uint32_t)s.trunk_max[L], &tm, skip, err)))
                break;
            if ((st = build_elements(in, skip, &nb, err))) {
                bc_input_free(&nb);
                break;
            }
            free(b.etris), free(b.efirst), free(b.epart);
            b.etris = nb.etris, b.efirst = nb.efirst, b.epart = nb.epart, b.ne = nb.ne;
            free(nb.pos);
            bi.elem_tris = lin.elem_tris = b.etris;
            bi.elem_first = lin.elem_first = b.efirst;
            bi.elem_part = lin.elem_part = b.epart;
            bi.elem_count = lin.elem_count = b.ne;
        }
        o.epsilon = eps;
        o.max_planes = (uint32_t)l->max_planes;
        o.weld = s.weld && L == 0; /* coarser LODs start from projected faces: nothing shared */
        if ((st = sv_bbc_select(&lin, &o, &cur, err))) break;
        bool refined = s.refine > 0 && !s.cb_enabled;
        /* the plane budget is a target once refined: the greedy pass may stop
         * short of it at its ε, and more planes flatten less */
        if (refined &&
            (st = sv_bbc_kplanes(&bi, (uint32_t)s.refine, (uint32_t)l->max_planes, &cur, err)))
            break;
        char name[32];
        snprintf(name, sizeof name, "lod%d", L);
        sv_lod_plan *lod = sv_stand_in_add_lod(out, name);
        if (!lod) {
            st = sv_fail(err, SV_ERR_NOMEM, BC_NAME ": out of memory (LOD)");
            break;
        }
        if (s.trunk_mesh) { /* drawn as is; the pipeline adds no trunk of its own */
            lod->trunk = SV_TRUNK_NONE;
            lod->geometry = tm;
            tm = NULL;
        }
        if ((st = add_quads(in, &cur, refined, lod, mark, err))) break;
        if (L > 0 && (st = link_parents(m, &prev, &cur, &out->lods[L - 1], err))) break;
        prev_eps = cur.stats.epsilon;
        sv_bbc_result_free(&prev);
        prev = cur;
        memset(&cur, 0, sizeof cur);
    }
    sv_bbc_result_free(&prev);
    sv_bbc_result_free(&cur);
    free(ppos);
    free(pidx);
    free(mark);
    bc_input_free(&b);
    sv_mesh_destroy(tm);
    free(skip);
    if (st) sv_stand_in_free(out);
    return st;
}

const sv_method_ops sv_method_billboard_cloud_ops = {
    .method = &sv_method_billboard_cloud,
    .run = bc_run,
};
