/* toy.c — the build half of the toy method (method_ops.h): one LOD of a
 * single vertical quad facing +Z through the middle of the mesh's bounding
 * box, as large as the box's x-y face, showing every face (the crossed quads'
 * first plane, core/methods/crossed_quads/crossed_quads.c, alone). */
#include "method_ops.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static sv_status toy_build(const sv_method_input *in, sv_stand_in *out, sv_error *err)
{
    const sv_mesh *m = in->mesh;
    if (!m || m->triangle_count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE, "toy: the mesh has no triangles");
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], m->positions[3 * (size_t)v + k]);
            hi[k] = fmax(hi[k], m->positions[3 * (size_t)v + k]);
        }
    sv_quad q;
    memset(&q, 0, sizeof q);
    q.normal[2] = 1;
    q.axis_u[0] = 1;
    q.axis_v[1] = 1;
    for (int k = 0; k < 3; k++) q.centre[k] = 0.5 * (lo[k] + hi[k]);
    q.d = -q.centre[2];
    q.half_u = fmax(0.5 * (hi[0] - lo[0]), 1e-6 * in->radius);
    q.half_v = fmax(0.5 * (hi[1] - lo[1]), 1e-6 * in->radius);
    q.slab = 0.5 * (hi[2] - lo[2]) + 1e-6 * in->radius; /* every face */
    q.parts = SV_PARTS_TRUNK | SV_PARTS_FOLIAGE;
    q.group = q.parent = -1;
    q.face_count = m->triangle_count;
    q.faces = sv_calloc(m->triangle_count, sizeof *q.faces);
    if (!q.faces) return sv_fail(err, SV_ERR_NOMEM, "toy: no memory for the face list");
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        q.faces[t] = t;
        q.face_area += sv_tri_area(m, t);
    }
    snprintf(out->method, sizeof out->method, "toy");
    sv_lod_plan *lod = sv_stand_in_add_lod(out, "toy");
    if (!lod) {
        free(q.faces);
        return sv_fail(err, SV_ERR_NOMEM, "toy: no memory for a LOD");
    }
    lod->trunk = SV_TRUNK_NONE;
    return sv_lod_add_quad(lod, &q, err);
}

/* On failure the partial stand-in is freed. */
static sv_status toy_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                         sv_error *err)
{
    (void)settings; /* toy_check refused every key */
    sv_status st = toy_build(in, out, err);
    if (st) sv_stand_in_free(out);
    return st;
}

extern const sv_method sv_method_toy;
const sv_method_ops sv_method_toy_ops = {.method = &sv_method_toy, .run = toy_run};
