/* report.c — the JSON documents of a bake (docs/outputs.md): report.json
 * (what was imported and decided, effects, the chain, accuracy, times),
 * planes.json (every level's quads), the documents levels add through
 * their hooks (level.h: impostor.json), and
 * the mesh description `sylva-bake info` prints. Methods add their own keys
 * through their sv_method planes_json hook.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "method_ops.h"
#include "pipeline_internal.h"

static const char *alpha_name(sv_alpha_mode m)
{
    return m == SV_ALPHA_MASK ? "MASK" : m == SV_ALPHA_BLEND ? "BLEND" : "OPAQUE";
}

static cJSON *vec3_json(const double v[3])
{
    return cJSON_CreateDoubleArray(v, 3);
}

/* [x, y, z] with every digit of each double (%.17g; cJSON's own printing
 * may drop the last bits): the local frame's origin. */
static cJSON *origin_json(const double v[3])
{
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; a && k < 3; k++) {
        char num[32];
        snprintf(num, sizeof num, "%.17g", v[k]);
        cJSON_AddItemToArray(a, cJSON_CreateRaw(num));
    }
    return a;
}

/* The description `sylva-bake info` prints and report.json embeds. */
cJSON *svp_describe(const prepared *p)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "format", sv_format_name(p->info.format));
    cJSON_AddNumberToObject(j, "unit_scale", p->info.unit_scale);
    char up[2] = {p->info.up_axis ? p->info.up_axis : 'Y', 0};
    cJSON_AddStringToObject(j, "up", p->up_rotated ? (p->up.z_up > 0 ? "Z" : "-Z") : up);
    cJSON *uc = cJSON_AddObjectToObject(j, "up_check");
    cJSON_AddStringToObject(uc, "looks", p->up.z_up > 0 ? "Z" : p->up.z_up < 0 ? "-Z" : "Y");
    cJSON_AddBoolToObject(uc, "rotated", p->up_rotated);
    cJSON_AddStringToObject(uc, "reason", p->up.reason);
    const sv_units_guess *un = &p->units;
    cJSON *ck = cJSON_AddObjectToObject(j, "units_check");
    cJSON_AddNumberToObject(ck, "height", un->height);
    cJSON_AddNumberToObject(ck, "leaf_size", un->leaf_size);
    cJSON_AddNumberToObject(ck, "trunk_diameter", un->trunk_diameter);
    cJSON_AddBoolToObject(ck, "plausible", !un->implausible);
    if (un->implausible && un->factor > 0) {
        cJSON_AddStringToObject(ck, "likely_units", un->unit);
        cJSON_AddNumberToObject(ck, "likely_metres_per_unit", un->metres_per_unit);
    }
    if (un->implausible) cJSON_AddStringToObject(ck, "reason", un->reason);
    /* where the local frame of every written position is in the file */
    cJSON_AddItemToObject(j, "origin", origin_json(p->info.origin));
    cJSON *m = cJSON_AddObjectToObject(j, "mesh");
    cJSON_AddNumberToObject(m, "triangles", p->mesh->triangle_count);
    /* before validation removed degenerate and duplicate triangles */
    cJSON_AddNumberToObject(m, "imported_triangles",
                            (double)p->mesh->triangle_count + p->repairs.removed_degenerate +
                                p->repairs.removed_duplicate);
    cJSON_AddNumberToObject(m, "vertices", p->mesh->vertex_count);
    cJSON_AddNumberToObject(m, "materials", p->mesh->material_count);
    cJSON_AddNumberToObject(m, "textures", p->mesh->image_count);
    double mn[3], mx[3], sz[3];
    sv_mesh_bounds(p->mesh, mn, mx);
    for (int k = 0; k < 3; k++) sz[k] = mx[k] - mn[k];
    cJSON *b = cJSON_AddObjectToObject(j, "bounds");
    cJSON_AddItemToObject(b, "min", vec3_json(mn));
    cJSON_AddItemToObject(b, "max", vec3_json(mx));
    cJSON_AddItemToObject(b, "size", vec3_json(sz));
    cJSON_AddNumberToObject(b, "radius", p->radius);
    cJSON *c = cJSON_AddObjectToObject(j, "classification");
    cJSON_AddNumberToObject(c, "foliage_triangles", p->cls.foliage_triangles);
    cJSON_AddNumberToObject(c, "trunk_triangles", p->cls.trunk_triangles);
    cJSON *mats = cJSON_AddArrayToObject(c, "materials");
    for (uint32_t i = 0; i < p->mesh->material_count; i++) {
        const sv_material *mt = &p->mesh->materials[i];
        const sv_material_class *mc = &p->cls.materials[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", mt->name);
        cJSON_AddStringToObject(o, "part", mc->part == SV_PART_FOLIAGE ? "foliage" : "trunk");
        cJSON_AddNumberToObject(o, "triangles", mc->triangles);
        cJSON_AddStringToObject(o, "reason", mc->reason);
        cJSON_AddStringToObject(o, "alpha_mode", alpha_name(mt->alpha_mode));
        cJSON_AddBoolToObject(o, "textured", mt->base_texture >= 0);
        if (mt->texture_uri[0]) cJSON_AddStringToObject(o, "texture", mt->texture_uri);
        cJSON_AddItemToArray(mats, o);
    }
    cJSON *lv = cJSON_AddObjectToObject(j, "leaves");
    cJSON_AddNumberToObject(lv, "count", p->leaves.count);
    cJSON_AddNumberToObject(lv, "median_area", p->leaves.median_area);
    cJSON_AddNumberToObject(lv, "max_area", p->leaves.max_area);
    cJSON_AddNumberToObject(lv, "split", p->leaves.split);
    cJSON *rp = cJSON_AddObjectToObject(j, "repairs");
    cJSON_AddNumberToObject(rp, "removed_degenerate", p->repairs.removed_degenerate);
    cJSON_AddNumberToObject(rp, "removed_duplicate", p->repairs.removed_duplicate);
    cJSON_AddNumberToObject(rp, "fixed_normals", p->repairs.fixed_normals);
    cJSON_AddNumberToObject(rp, "unused_vertices", p->repairs.unused_vertices);
    cJSON *w = cJSON_AddArrayToObject(j, "warnings");
    char buf[sizeof p->info.warnings];
    memcpy(buf, p->info.warnings, sizeof buf);
    buf[sizeof buf - 1] = 0;
    for (char *save = NULL, *t = strtok_r(buf, "\n", &save); t; t = strtok_r(NULL, "\n", &save))
        cJSON_AddItemToArray(w, cJSON_CreateString(t));
    return j;
}

sv_status svp_write_json(const char *dir, const char *name, cJSON *j, sv_error *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    char *s = cJSON_Print(j);
    if (!s) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    FILE *f = fopen(path, "wb");
    if (!f) {
        free(s);
        return sv_fail(err, SV_ERR_IO, "cannot write %s", path);
    }
    bool ok = fputs(s, f) >= 0 && fputc('\n', f) != EOF;
    ok = (fclose(f) == 0) && ok;
    free(s);
    return ok ? SV_OK : sv_fail(err, SV_ERR_IO, "cannot write %s", path);
}

/* report.json "lod_chain": composition, terms of λ used, r, skipped LODs. */
static cJSON *chain_json(const run *r, const chain *c)
{
    const sv_spec *s = &r->spec;
    cJSON *j = cJSON_CreateObject();
    cJSON_AddBoolToObject(j, "chain", s->lod_chain);
    cJSON_AddStringToObject(j, "coarsest", s->lod_coarsest[0] ? s->lod_coarsest : "none");
    cJSON_AddNumberToObject(j, "tolerance", s->lod_tolerance);
    cJSON_AddNumberToObject(j, "tolerance_pixels", s->lod_tolerance_pixels);
    cJSON_AddNumberToObject(j, "slack", s->lod_slack);
    cJSON_AddNumberToObject(j, "cost_ratio", s->lod_cost_ratio);
    cJSON_AddNumberToObject(j, "min_saving", s->lod_min_saving);
    cJSON_AddNumberToObject(j, "triangles_per_pixel", s->lod_triangles_per_pixel);
    if (c->levels_report) /* the chain hook's own part (its schedule's terms) */
        cJSON_AddItemToObject(j, c->levels_name, cJSON_Duplicate(c->levels_report, true));
    cJSON_AddItemToObject(j, "skipped", cJSON_Duplicate(c->skipped, true));
    return j;
}

/* The files of the bake carrying map k (svp_map_names: albedo, normal, ao,
 * depth): each level's atlas of that kind, as written. */
static cJSON *map_outputs(const bake_state *b, int k, uint32_t *count)
{
    cJSON *a = cJSON_CreateArray();
    *count = 0;
    for (uint32_t i = 0; i < b->si.lod_count; i++)
        if (b->lods[i].maps[k][0]) {
            cJSON_AddItemToArray(a, cJSON_CreateString(b->lods[i].maps[k]));
            (*count)++;
        }
    return a;
}

/* report.json "effects": each effect the scene can call for, whether the
 * outputs hold it ("done" when at least one does) and why, and for the maps
 * the files that carry them ("outputs"). The scene decides the quad levels'
 * maps; an octahedral level always carries a depth map (its runtime's
 * parallax reads it), whatever the scene says. */
static cJSON *effects_json(const sv_spec *s, const bake_state *b)
{
    const sv_bake_options *bo = &b->bo;
    cJSON *a = cJSON_CreateArray();
    uint32_t n_alb = 0, n_nrm = 0, n_ao = 0, n_dep = 0;
    cJSON *alb = map_outputs(b, 0, &n_alb), *nrm = map_outputs(b, 1, &n_nrm),
          *ao = map_outputs(b, 2, &n_ao), *dep = map_outputs(b, 3, &n_dep);
    cJSON *lit = bo->lit ? cJSON_Duplicate(alb, true) : cJSON_CreateArray();
    /* the motion term is a term of the chain's own levels' schedule */
    const sv_method *sched = sv_method_chain_levels();
    char motion_why[96];
    snprintf(motion_why, sizeof motion_why, "scene.camera_speed > 0 (used by %s)",
             sched ? sched->name : "no method");
    const char *dep_why =
        bo->depth_map ? (n_dep ? "scene.shadows is true"
                               : "scene.shadows is true, but no level "
                                 "here has an atlas to carry one")
        : n_dep       ? "scene.shadows is false: no quad level has one; every octahedral impostor "
                        "carries one all the same (its runtime's parallax reads it)"
                      : "scene.shadows is false";
    const char *nrm_why =
        bo->normal_map ? (n_nrm ? "scene.lighting is dynamic"
                                : "scene.lighting is dynamic, but no level here has an atlas to "
                                  "carry one (mesh levels keep their own materials)")
        : bo->lit      ? "scene.lighting is static: no normal map needed"
                       : "scene.lighting is unlit: no normal map needed";
    const char *ao_why =
        bo->ao_map ? (n_ao ? "scene.ambient_occlusion is true"
                           : "scene.ambient_occlusion is true, but no level here bakes one "
                             "(mesh and octahedral levels have no AO map)")
                   : "scene.ambient_occlusion is false";
    struct {
        const char *name;
        bool done;
        const char *why;
        cJSON *outputs; /* NULL: not a map */
    } e[] = {
        {"albedo", true,
         n_alb ? "always baked (mesh levels keep their own textures)"
               : "mesh levels only: each keeps its own textures",
         alb},
        {"lit_albedo", bo->lit && n_alb,
         bo->lit ? "scene.lighting is static: light baked into the albedo atlases"
         : bo->normal_map
             ? "scene.lighting is dynamic: the engine lights the normal map"
             : "scene.lighting is unlit: the albedo keeps the material's own brightness",
         lit},
        {"normal_map", n_nrm > 0, nrm_why, nrm},
        {"ambient_occlusion", n_ao > 0, ao_why, ao},
        {"depth_map", n_dep > 0, dep_why, dep},
        {"horizontal_plane_penalty", s->scene.viewer == SV_VIEWER_GROUND,
         s->scene.viewer == SV_VIEWER_GROUND ? "scene.viewer is ground (used by billboard_cloud)"
                                             : "scene.viewer is not ground",
         NULL},
        {"motion_term", s->scene.camera_speed > 0,
         s->scene.camera_speed > 0 ? motion_why : "no camera motion in the scene", NULL},
    };
    for (size_t i = 0; i < sizeof e / sizeof e[0]; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "effect", e[i].name);
        cJSON_AddStringToObject(o, "status", e[i].done ? "done" : "skipped");
        cJSON_AddStringToObject(o, "reason", e[i].why);
        if (e[i].outputs) cJSON_AddItemToObject(o, "outputs", e[i].outputs);
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

cJSON *svp_accuracy_json(const sv_eval_result *e)
{
    cJSON *a = cJSON_CreateArray();
    for (uint32_t k = 0; k < e->size_count; k++) {
        const sv_eval_size *z = &e->sizes[k];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "pixels", z->pixels);
        cJSON_AddNumberToObject(o, "iou_mean", z->mean.iou);
        cJSON_AddNumberToObject(o, "iou_worst", z->worst.iou);
        cJSON_AddNumberToObject(o, "color_error_mean", z->mean.color_error);
        cJSON_AddNumberToObject(o, "color_error_worst", z->worst.color_error);
        cJSON_AddNumberToObject(o, "depth_error_mean", z->mean.depth_error);
        cJSON_AddNumberToObject(o, "depth_error_worst", z->worst.depth_error);
        cJSON_AddNumberToObject(o, "lum_ratio", z->lum_ratio);
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

/* planes.json's quad q of a LOD: its plane, corners, atlas rectangle and faces. */
static cJSON *quad_json(const sv_quad *qu, const float *uv)
{
    cJSON *qo = cJSON_CreateObject();
    cJSON_AddItemToObject(qo, "normal", vec3_json(qu->normal));
    cJSON_AddNumberToObject(qo, "d", qu->d);
    double c[4][3];
    sv_quad_corners(qu, c);
    cJSON *ca = cJSON_AddArrayToObject(qo, "corners");
    for (int k = 0; k < 4; k++) cJSON_AddItemToArray(ca, vec3_json(c[k]));
    double uvd[4] = {uv[0], uv[1], uv[2], uv[3]};
    cJSON_AddItemToObject(qo, "uv", cJSON_CreateDoubleArray(uvd, 4));
    cJSON_AddNumberToObject(qo, "faces", qu->face_count);
    cJSON_AddNumberToObject(qo, "face_area", qu->face_area);
    cJSON_AddStringToObject(qo, "part",
                            qu->parts == SV_PARTS_TRUNK     ? "trunk"
                            : qu->parts == SV_PARTS_FOLIAGE ? "foliage"
                                                            : "all");
    if (qu->group >= 0) cJSON_AddNumberToObject(qo, "group", qu->group);
    if (qu->parent >= 0) cJSON_AddNumberToObject(qo, "parent", qu->parent);
    return qo;
}

/* planes.json's entry of LOD i; the method that made it adds its own keys
 * (sv_method planes_json: slicings, the octahedral proxy quad). */
static cJSON *planes_lod_json(const run *r, const bake_state *b, uint32_t i)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    const lod_out *l = &b->lods[i];
    const sv_baked_lod *bk = &l->baked;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", lp->name);
    cJSON_AddStringToObject(o, "file", l->file);
    cJSON_AddStringToObject(o, "node", l->node);
    cJSON_AddNumberToObject(o, "screen_coverage", l->coverage);
    cJSON_AddNumberToObject(o, "switch_pixels", l->switch_pixels);
    cJSON_AddNumberToObject(
        o, "switch_distance",
        sv_scene_distance_for_pixels(&r->spec.scene, b->tree_h, l->switch_pixels));
    cJSON_AddNumberToObject(o, "texel_size", bk->texel_size);
    cJSON *at = cJSON_AddObjectToObject(o, "atlas");
    cJSON_AddNumberToObject(at, "width", bk->albedo.width);
    cJSON_AddNumberToObject(at, "height", bk->albedo.height);
    for (int k = 0; k < 4; k++)
        if (l->maps[k][0]) cJSON_AddStringToObject(at, svp_map_names[k], l->maps[k]);
    cJSON_AddNumberToObject(o, "kept_triangles", bk->mesh->triangle_count - 2 * bk->quad_count);
    cJSON *qa = cJSON_AddArrayToObject(o, "quads");
    for (uint32_t q = 0; q < lp->quad_count; q++)
        cJSON_AddItemToArray(qa, quad_json(&lp->quads[q], &bk->uv_rects[4 * (size_t)q]));
    const sv_method_ops *m = sv_method_ops_find(b->ch.info[i].source);
    if (m && m->planes_json) m->planes_json(lp, bk, r->p.mesh->triangle_count, o, qa);
    return o;
}

/* True when LOD i adds an entry to a document (sv_level_ops doc_file) that
 * no earlier LOD adds to: the first of that document's levels. */
static bool first_of_doc(const sv_stand_in *si, uint32_t i)
{
    const sv_level_ops *ops = si->lods[i].ops;
    if (!ops || !ops->doc_entry) return false;
    for (uint32_t j = 0; j < i; j++) {
        const sv_level_ops *o = si->lods[j].ops;
        if (o && o->doc_entry && strcmp(o->doc_file, ops->doc_file) == 0) return false;
    }
    return true;
}

/* The documents levels add beside planes.json (level.h doc_file, e.g.
 * impostor.json): {"schema", "lods": [each such level's doc_entry, in chain
 * order]}, one file per name. */
static sv_status write_level_docs(const run *r, const bake_state *b, sv_error *err)
{
    const sv_stand_in *si = &b->si;
    sv_status st = SV_OK;
    for (uint32_t i = 0; i < si->lod_count && !st; i++) {
        if (!first_of_doc(si, i)) continue;
        const sv_level_ops *ops = si->lods[i].ops;
        cJSON *doc = cJSON_CreateObject();
        cJSON_AddStringToObject(doc, "schema", ops->doc_schema);
        cJSON_AddItemToObject(doc, "origin", origin_json(r->p.info.origin));
        cJSON *entries = cJSON_AddArrayToObject(doc, "lods");
        for (uint32_t k = i; k < si->lod_count; k++) {
            const sv_lod_plan *lp = &si->lods[k];
            if (!lp->ops || !lp->ops->doc_entry || strcmp(lp->ops->doc_file, ops->doc_file) != 0)
                continue;
            const lod_out *l = &b->lods[k];
            sv_level_names names = {lp->name, l->node, l->maps};
            cJSON_AddItemToArray(entries, lp->ops->doc_entry(lp, &names));
        }
        st = svp_write_json(r->req->out_dir, ops->doc_file, doc, err);
        cJSON_Delete(doc);
    }
    return st;
}

sv_status svp_write_planes(const run *r, const bake_state *b, sv_error *err)
{
    const sv_stand_in *si = &b->si;
    cJSON *planes = cJSON_CreateObject();
    cJSON_AddStringToObject(planes, "schema", "sylva.planes/1");
    cJSON_AddStringToObject(planes, "method", si->method[0] ? si->method : r->spec.method);
    cJSON_AddStringToObject(planes, "units", "m");
    cJSON_AddStringToObject(planes, "up", "+Y");
    cJSON_AddItemToObject(planes, "origin", origin_json(r->p.info.origin));
    cJSON *pl = cJSON_AddArrayToObject(planes, "lods");
    for (uint32_t i = 0; i < si->lod_count; i++) cJSON_AddItemToArray(pl, planes_lod_json(r, b, i));
    sv_status st = svp_write_json(r->req->out_dir, "planes.json", planes, err);
    cJSON_Delete(planes);
    return st ? st : write_level_docs(r, b, err);
}

/* report.json "lods" entry of LOD i. */
static cJSON *report_lod_json(const run *r, const bake_state *b, uint32_t i)
{
    const chain *ch = &b->ch;
    const lod_out *l = &b->lods[i];
    const sv_baked_lod *bk = &l->baked;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", b->si.lods[i].name);
    cJSON_AddStringToObject(o, "file", l->file);
    cJSON_AddStringToObject(o, "node", l->node);
    cJSON_AddStringToObject(o, "source", ch->info[i].source);
    const sv_lod_plan *lp = &b->si.lods[i];
    if (lp->ops && lp->ops->report) lp->ops->report(lp, o); /* the level's own fields */
    cJSON_AddNumberToObject(o, "trunk_max_error", ch->info[i].trunk_error);
    cJSON_AddNumberToObject(o, "quads", bk->quad_count);
    cJSON_AddNumberToObject(o, "triangles", bk->mesh->triangle_count);
    cJSON_AddNumberToObject(o, "texels", (double)bk->albedo.width * bk->albedo.height);
    cJSON_AddNumberToObject(o, "texel_size", bk->texel_size);
    cJSON_AddNumberToObject(o, "supersample", bk->supersample);
    if (l->colour_scale > 0) cJSON_AddNumberToObject(o, "colour_scale", l->colour_scale);
    if (l->alpha_cutoff > 0) {
        cJSON_AddNumberToObject(o, "alpha_cutoff", l->alpha_cutoff);
        cJSON_AddNumberToObject(o, "alpha_calibration_iou", l->calib_iou);
    }
    cJSON_AddNumberToObject(o, "switch_pixels", l->switch_pixels);
    cJSON_AddNumberToObject(
        o, "switch_distance",
        sv_scene_distance_for_pixels(&r->spec.scene, b->tree_h, l->switch_pixels));
    cJSON_AddNumberToObject(o, "screen_coverage", l->coverage);
    cJSON_AddBoolToObject(o, "meets_tolerance", l->meets_tolerance);
    if (l->evaluated) cJSON_AddItemToObject(o, "accuracy", svp_accuracy_json(&l->eval));
    if (l->bound_measured)
        cJSON_AddItemToObject(o, "flattening_bound", svp_accuracy_json(&l->bound));
    return o;
}

/* report.json "scene": the distances used and where they came from. */
static cJSON *scene_json(const sv_spec *spec)
{
    cJSON *so = cJSON_CreateObject();
    double dd[2] = {spec->scene.distance_min, spec->scene.distance_max};
    cJSON_AddItemToObject(so, "distance", cJSON_CreateDoubleArray(dd, 2));
    cJSON_AddStringToObject(
        so, "distance_source",
        spec->scene.distance_auto
            ? "auto: from where the tree fills the screen's height to 100 times smaller"
            : "given in the spec (scene.distance)");
    cJSON_AddNumberToObject(so, "screen_height", spec->scene.screen_height);
    cJSON_AddNumberToObject(so, "fov_deg", spec->scene.fov_y_deg);
    return so;
}

/* report.json "evaluation": its settings and the sphere every view frames
 * (evaluate.h), so a viewer reproduces a view. */
static cJSON *evaluation_json(const run *r, const bake_state *b)
{
    const sv_spec *spec = &r->spec;
    cJSON *ev_o = cJSON_CreateObject();
    cJSON_AddBoolToObject(ev_o, "enabled", spec->evaluate);
    cJSON_AddNumberToObject(ev_o, "views", spec->eval_views);
    cJSON_AddNumberToObject(ev_o, "supersample", spec->eval_supersample);
    cJSON_AddNumberToObject(ev_o, "small_render", spec->eval_small_render);
    cJSON_AddNumberToObject(ev_o, "lod_tolerance", spec->lod_tolerance);
    cJSON_AddNumberToObject(ev_o, "lod_tolerance_pixels", spec->lod_tolerance_pixels);
    cJSON *fo = cJSON_AddObjectToObject(ev_o, "frame");
    double fcc[3] = {b->fc[0], b->fc[1], b->fc[2]};
    cJSON_AddItemToObject(fo, "centre", cJSON_CreateDoubleArray(fcc, 3));
    cJSON_AddNumberToObject(fo, "radius", b->fr > 0 ? b->fr : r->p.radius);
    return ev_o;
}

/* report.json "times", last: the only part that differs between identical
 * bakes. Closes the write stage first. */
static cJSON *times_json(run *r)
{
    svp_progress(r, ST_WRITE, 1);
    r->times[ST_WRITE] += sv_now() - r->t0;
    r->t0 = sv_now();
    cJSON *t = cJSON_CreateObject();
    double total = 0;
    for (int k = 0; k < ST_COUNT; k++) {
        cJSON_AddNumberToObject(t, svp_stage_names[k], round(r->times[k] * 1e4) / 1e4);
        total += r->times[k];
    }
    if (r->target_times) {
        /* the search's tries, before the bake above (not in "total") */
        cJSON_AddItemToObject(t, "target_tries", r->target_times);
        r->target_times = NULL;
    }
    cJSON_AddNumberToObject(t, "total", round(total * 1e4) / 1e4);
    return t;
}

sv_status svp_write_report(run *r, const bake_state *b, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    cJSON *report = cJSON_CreateObject();
    cJSON_AddStringToObject(report, "schema", "sylva.report/1");
    cJSON_AddStringToObject(report, "generator", "sylva " SV_VERSION);
    cJSON_AddItemToObject(report, "input", svp_describe(&r->p));
    cJSON *mo = cJSON_AddObjectToObject(report, "method");
    cJSON_AddStringToObject(mo, "name", spec->method);
    cJSON_AddItemToObject(mo, "settings",
                          spec->settings ? cJSON_Duplicate(spec->settings, true)
                                         : cJSON_CreateObject());
    cJSON_AddNumberToObject(mo, "seed", (double)spec->seed);
    cJSON_AddItemToObject(report, "effects", effects_json(spec, b));
    cJSON_AddItemToObject(report, "scene", scene_json(spec));
    cJSON *rl = cJSON_AddArrayToObject(report, "lods");
    for (uint32_t i = 0; i < b->si.lod_count; i++)
        cJSON_AddItemToArray(rl, report_lod_json(r, b, i));
    cJSON_AddItemToObject(report, "lod_chain", chain_json(r, &b->ch));
    cJSON_AddItemToObject(report, "evaluation", evaluation_json(r, b));
    if (r->target_json) {
        cJSON_AddItemToObject(report, "target", r->target_json);
        r->target_json = NULL;
    }
    cJSON_AddItemToObject(report, "times", times_json(r));
    sv_status st = svp_write_json(r->req->out_dir, "report.json", report, err);
    cJSON_Delete(report);
    return st;
}
