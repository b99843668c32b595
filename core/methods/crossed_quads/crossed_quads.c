/* crossed_quads.c — the "cardboard" baseline: 2 or 3 vertical quads crossing on
 * the trunk axis, optionally one horizontal quad through the crown's middle.
 *
 * Behrendt et al., "Realistic real-time rendering of landscapes using billboard
 * clouds" §3.3.4 (cardboard planes) and the classic crossed-billboard tree; every
 * quad encloses the whole tree's projection and shows every face (slab = the
 * largest distance of any vertex from the plane), so each quad is a full
 * orthographic picture of the tree from its normal's direction.
 *
 * Settings (spec key "crossed_quads"):
 *   "planes":     2 or 3 (default 2): vertical quads at azimuths k·180°/planes,
 *                 k = 0.., the first facing +Z (normal +Z, axis_u +X, axis_v +Y);
 *   "horizontal": bool (default false): adds one quad with normal +Y at the
 *                 middle height of the foliage (of the whole tree without
 *                 foliage), rectangle by sv_quad_fit_points.
 * Trunk axis: the vertical line through the area-weighted centroid of the trunk
 * triangles' horizontal (x, z) coordinates; the bounding-box centre when the tree
 * has no trunk triangles of positive area.
 */
#include "crossed_quads.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Slab that contains every vertex: the largest |n·p + d|, with a relative margin
 * so rounding in the baker cannot drop the farthest face. */
static double slab_all(const sv_mesh *m, const sv_quad *q, double radius)
{
    double mx = 0;
    for (size_t i = 0; i < (size_t)m->triangle_count * 3; i++) {
        const float *p = &m->positions[3 * (size_t)m->indices[i]];
        double s = fabs(q->normal[0] * p[0] + q->normal[1] * p[1] + q->normal[2] * p[2] + q->d);
        if (s > mx) mx = s;
    }
    return mx + 1e-6 * radius;
}

/* Fills q's extents along its given axes (axis_u, axis_v set) as the bounding
 * rectangle of every vertex referenced by a triangle, centred on the plane. A
 * flat tree seen edge-on (a single card) has zero extent along u: it gets a
 * sliver of 1e-6·radius so the quad still has a renderable chart. */
static void fit_axes(const sv_mesh *m, sv_quad *q, const double origin[3], double radius)
{
    double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
    for (size_t i = 0; i < (size_t)m->triangle_count * 3; i++) {
        const float *p = &m->positions[3 * (size_t)m->indices[i]];
        double d[3] = {p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]};
        double u = d[0] * q->axis_u[0] + d[1] * q->axis_u[1] + d[2] * q->axis_u[2];
        double v = d[0] * q->axis_v[0] + d[1] * q->axis_v[1] + d[2] * q->axis_v[2];
        if (u < u0) u0 = u;
        if (u > u1) u1 = u;
        if (v < v0) v0 = v;
        if (v > v1) v1 = v;
    }
    double cu = 0.5 * (u0 + u1), cv = 0.5 * (v0 + v1);
    for (int k = 0; k < 3; k++) q->centre[k] = origin[k] + cu * q->axis_u[k] + cv * q->axis_v[k];
    q->half_u = 0.5 * (u1 - u0);
    q->half_v = 0.5 * (v1 - v0);
    if (!(q->half_u > 0)) q->half_u = 1e-6 * radius;
    if (!(q->half_v > 0)) q->half_v = 1e-6 * radius;
}

/* Every triangle index 0..T-1 (each quad shows the whole tree). */
static sv_status all_faces(const sv_mesh *m, sv_quad *q, double area, sv_error *err)
{
    q->face_count = m->triangle_count;
    q->faces = sv_calloc(m->triangle_count, sizeof *q->faces);
    if (!q->faces) return sv_fail(err, SV_ERR_NOMEM, "no memory for a quad's face list");
    for (uint32_t t = 0; t < m->triangle_count; t++) q->faces[t] = t;
    q->face_area = area;
    return SV_OK;
}

static sv_status cq_build(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                          sv_error *err)
{
    cq_settings cs;
    sv_status st = cq_parse(settings, &cs, err);
    if (st) return st;
    const sv_mesh *m = in->mesh;
    if (!m || m->triangle_count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE, "crossed_quads: the mesh has no triangles");
    const uint8_t *part = in->cls ? in->cls->tri_part : NULL;

    /* Trunk axis, crown middle and total area. */
    double ax = 0, az = 0, trunk_area = 0, total_area = 0;
    double fy0 = INFINITY, fy1 = -INFINITY;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        double a = sv_tri_area(m, t);
        total_area += a;
        const uint32_t *ix = &m->indices[3 * (size_t)t];
        bool foliage = part && part[t] == SV_PART_FOLIAGE;
        if (!foliage && part) {
            double cx = 0, cz = 0;
            for (int j = 0; j < 3; j++) {
                cx += m->positions[3 * (size_t)ix[j] + 0];
                cz += m->positions[3 * (size_t)ix[j] + 2];
            }
            /* Relative to the sphere centre, so far-off trees keep precision. */
            ax += a * (cx / 3 - in->centre[0]);
            az += a * (cz / 3 - in->centre[2]);
            trunk_area += a;
        }
        if (foliage)
            for (int j = 0; j < 3; j++) {
                double y = m->positions[3 * (size_t)ix[j] + 1];
                if (y < fy0) fy0 = y;
                if (y > fy1) fy1 = y;
            }
    }
    double axis[3] = {in->centre[0], in->centre[1], in->centre[2]};
    if (trunk_area > 0) {
        axis[0] += ax / trunk_area;
        axis[2] += az / trunk_area;
    }

    snprintf(out->method, sizeof out->method, "%s", CQ_NAME);
    sv_lod_plan *lod = sv_stand_in_add_lod(out, "crossed");
    if (!lod) return sv_fail(err, SV_ERR_NOMEM, "no memory for a LOD");
    lod->trunk = SV_TRUNK_NONE;

    for (long k = 0; k < cs.planes; k++) {
        double th = M_PI * (double)k / (double)cs.planes;
        sv_quad q;
        memset(&q, 0, sizeof q);
        /* Exact values at 0 and 90 degrees keep the common planes axis-aligned. */
        double s = (k == 0) ? 0 : sin(th), c = (k == 0) ? 1 : cos(th);
        if (2 * k == cs.planes) {
            s = 1;
            c = 0;
        }
        q.normal[0] = s;
        q.normal[2] = c;
        q.axis_v[1] = 1;
        /* u = v × n so that u × v = n. */
        q.axis_u[0] = c;
        q.axis_u[2] = -s;
        q.d = -(q.normal[0] * axis[0] + q.normal[2] * axis[2]);
        fit_axes(m, &q, axis, in->radius);
        q.slab = slab_all(m, &q, in->radius);
        q.parts = SV_PARTS_TRUNK | SV_PARTS_FOLIAGE;
        q.group = -1;
        q.parent = -1;
        if ((st = all_faces(m, &q, total_area, err))) return st;
        if ((st = sv_lod_add_quad(lod, &q, err))) return st;
    }
    if (cs.horizontal) {
        sv_quad q;
        memset(&q, 0, sizeof q);
        double y = (fy0 <= fy1) ? 0.5 * (fy0 + fy1) : in->centre[1];
        q.normal[1] = 1;
        q.d = -y;
        size_t n = (size_t)m->triangle_count * 3;
        double *pts = sv_calloc(n, 3 * sizeof *pts);
        if (!pts) return sv_fail(err, SV_ERR_NOMEM, "no memory for the horizontal quad");
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++)
                pts[3 * i + k] = m->positions[3 * (size_t)m->indices[i] + k];
        sv_quad_fit_points(&q, pts, n);
        free(pts);
        q.slab = slab_all(m, &q, in->radius);
        q.parts = SV_PARTS_TRUNK | SV_PARTS_FOLIAGE;
        q.group = -1;
        q.parent = -1;
        if ((st = all_faces(m, &q, total_area, err))) return st;
        if ((st = sv_lod_add_quad(lod, &q, err))) return st;
    }
    return SV_OK;
}

/* On failure the partial stand-in is freed (out is left zeroed). */
static sv_status cq_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                        sv_error *err)
{
    sv_status st = cq_build(in, settings, out, err);
    if (st) sv_stand_in_free(out);
    return st;
}

const sv_method_ops sv_method_crossed_quads_ops = {
    .method = &sv_method_crossed_quads,
    .run = cq_run,
};
