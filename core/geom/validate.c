/* validate.c — mesh validation and repair (see validate.h).
 *
 * Rejections name the element ("vertex 1234 has a NaN coordinate", "triangle 17
 * refers to vertex 90001 of 90000"). Repairs keep triangle order (so output is
 * deterministic) and are counted in the report:
 *  - zero-area triangles: two equal corners, or corners collinear to within float
 *    precision (|e1 × e2| <= 1e-7 · longest edge²; a triangle whose height is
 *    below 1e-7 of its length has no area a float can represent);
 *  - exact duplicates: the same three positions in the same cyclic order (any
 *    rotation). The reversed triangle is NOT a duplicate: back-to-back faces are
 *    how two-sided leaves are modelled. Found with a hash table in O(n).
 *  - vertex normals that are non-finite or zero are recomputed from the adjacent
 *    faces (area-weighted); other normals are renormalised to unit length.
 */
#include "validate.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Bit pattern of a float with -0 folded into +0, so equal positions compare equal. */
static uint32_t fbits(float f)
{
    if (f == 0.0f) f = 0.0f;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static int cmp_pos(const uint32_t *a, const uint32_t *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* Canonical key of triangle t: its three positions as bit patterns, rotated so
 * the smallest corner comes first (winding kept). */
static void tri_key(const sv_mesh *m, uint32_t t, uint32_t key[9])
{
    uint32_t c[3][3];
    for (int j = 0; j < 3; j++) {
        const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + j]];
        for (int k = 0; k < 3; k++) c[j][k] = fbits(p[k]);
    }
    int first = 0;
    for (int j = 1; j < 3; j++)
        if (cmp_pos(c[j], c[first]) < 0) first = j;
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++) key[3 * j + k] = c[(first + j) % 3][k];
}

static uint64_t hash_key(const uint32_t key[9])
{
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < 9; i++) {
        h ^= key[i];
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 32;
    }
    return h;
}

static bool degenerate(const sv_mesh *m, uint32_t t)
{
    const uint32_t *ix = &m->indices[3 * (size_t)t];
    const float *a = &m->positions[3 * (size_t)ix[0]];
    const float *b = &m->positions[3 * (size_t)ix[1]];
    const float *c = &m->positions[3 * (size_t)ix[2]];
    double e1[3], e2[3], e3[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)b[k] - a[k];
        e2[k] = (double)c[k] - a[k];
        e3[k] = (double)c[k] - b[k];
    }
    double n0 = e1[1] * e2[2] - e1[2] * e2[1];
    double n1 = e1[2] * e2[0] - e1[0] * e2[2];
    double n2 = e1[0] * e2[1] - e1[1] * e2[0];
    double cross = sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    double l1 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
    double l2 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
    double l3 = e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2];
    double lmax = fmax(l1, fmax(l2, l3));
    return cross == 0.0 || cross <= 1e-7 * lmax;
}

static sv_status check_limits(const sv_mesh *m, const sv_limits *l, sv_error *err)
{
    if (m->triangle_count > l->max_triangles)
        return sv_fail(err, SV_ERR_LIMIT, "mesh has %u triangles (limit %llu)", m->triangle_count,
                       (unsigned long long)l->max_triangles);
    if (m->vertex_count > l->max_vertices)
        return sv_fail(err, SV_ERR_LIMIT, "mesh has %u vertices (limit %llu)", m->vertex_count,
                       (unsigned long long)l->max_vertices);
    if (m->material_count > l->max_materials)
        return sv_fail(err, SV_ERR_LIMIT, "mesh has %u materials (limit %u)", m->material_count,
                       l->max_materials);
    for (uint32_t i = 0; i < m->image_count; i++)
        if (m->images[i].width > l->max_texture_size || m->images[i].height > l->max_texture_size)
            return sv_fail(err, SV_ERR_LIMIT, "image %u is %ux%u (limit %u per side)", i,
                           m->images[i].width, m->images[i].height, l->max_texture_size);
    return SV_OK;
}

static sv_status check_content(const sv_mesh *m, sv_error *err)
{
    for (uint32_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            float x = m->positions[3 * (size_t)v + k];
            if (isnan(x)) return sv_fail(err, SV_ERR_INVALID, "vertex %u has a NaN coordinate", v);
            if (isinf(x))
                return sv_fail(err, SV_ERR_INVALID, "vertex %u has an infinite coordinate", v);
        }
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        for (int j = 0; j < 3; j++) {
            uint32_t v = m->indices[3 * (size_t)t + j];
            if (v >= m->vertex_count)
                return sv_fail(err, SV_ERR_INVALID, "triangle %u refers to vertex %u of %u", t, v,
                               m->vertex_count);
        }
        if (m->tri_material[t] >= m->material_count)
            return sv_fail(err, SV_ERR_INVALID, "triangle %u refers to material %u of %u", t,
                           m->tri_material[t], m->material_count);
    }
    for (uint32_t i = 0; i < m->material_count; i++) {
        const sv_material *mt = &m->materials[i];
        const int32_t tex[3] = {mt->base_texture, mt->normal_texture, mt->occlusion_texture};
        for (int k = 0; k < 3; k++)
            if (tex[k] < -1 || (tex[k] >= 0 && (uint32_t)tex[k] >= m->image_count))
                return sv_fail(err, SV_ERR_INVALID,
                               "material %u ('%.100s') refers to image %d of %u", i, mt->name,
                               tex[k], m->image_count);
    }
    return SV_OK;
}

/* Removes degenerate and duplicate triangles in place, keeping order. */
static sv_status remove_bad_triangles(sv_mesh *m, sv_validate_report *r, sv_error *err)
{
    size_t cap = 16;
    while (cap < 2 * (size_t)m->triangle_count) cap *= 2;
    uint32_t *table = malloc(cap * sizeof *table);
    if (!table) return sv_fail(err, SV_ERR_NOMEM, "cannot allocate a %zu-slot hash table", cap);
    memset(table, 0xFF, cap * sizeof *table);
    uint32_t kept = 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (degenerate(m, t)) {
            r->removed_degenerate++;
            continue;
        }
        uint32_t key[9], other[9];
        tri_key(m, t, key);
        size_t slot = (size_t)hash_key(key) & (cap - 1);
        bool dup = false;
        /* Table entries are indices of kept triangles, in their compacted slots
         * (< kept <= t), so reading them back is always valid. */
        while (table[slot] != UINT32_MAX) {
            tri_key(m, table[slot], other);
            if (memcmp(key, other, sizeof key) == 0) {
                dup = true;
                break;
            }
            slot = (slot + 1) & (cap - 1);
        }
        if (dup) {
            r->removed_duplicate++;
            continue;
        }
        if (kept != t) {
            memmove(&m->indices[3 * (size_t)kept], &m->indices[3 * (size_t)t],
                    3 * sizeof(uint32_t));
            m->tri_material[kept] = m->tri_material[t];
        }
        table[slot] = kept++;
    }
    free(table);
    m->triangle_count = kept;
    return SV_OK;
}

static sv_status repair_normals(sv_mesh *m, sv_validate_report *r, sv_error *err)
{
    uint8_t *used = sv_calloc(m->vertex_count, 1);
    double *acc = sv_calloc(m->vertex_count, 3 * sizeof(double));
    if (!used || !acc) {
        free(used);
        free(acc);
        return sv_fail(err, SV_ERR_NOMEM, "cannot allocate normals for %u vertices",
                       m->vertex_count);
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        double n[3];
        sv_tri_normal(m, t, n);
        double area = sv_tri_area(m, t);
        for (int j = 0; j < 3; j++) {
            uint32_t v = m->indices[3 * (size_t)t + j];
            used[v] = 1;
            for (int k = 0; k < 3; k++) acc[3 * (size_t)v + k] += n[k] * area;
        }
    }
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        if (!used[v]) r->unused_vertices++;
        float *q = &m->normals[3 * (size_t)v];
        double l = sqrt((double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2]);
        if (isfinite(l) && l > 0) {
            if (fabs(l - 1.0) > 1e-4)
                for (int k = 0; k < 3; k++) q[k] = (float)(q[k] / l);
            continue;
        }
        r->fixed_normals++;
        double *a = &acc[3 * (size_t)v];
        double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (int k = 0; k < 3; k++) q[k] = (la > 0) ? (float)(a[k] / la) : (k == 1 ? 1.0f : 0.0f);
    }
    free(used);
    free(acc);
    return SV_OK;
}

sv_status sv_validate(sv_mesh *mesh, const sv_limits *limits, sv_validate_report *report,
                      sv_error *err)
{
    sv_validate_report local;
    if (!report) report = &local;
    memset(report, 0, sizeof *report);
    if (!mesh) return sv_fail(err, SV_ERR_INTERNAL, "sv_validate: mesh is NULL");
    sv_limits l = sv_limits_resolve(limits ? *limits : (sv_limits){0});
    sv_status st = check_limits(mesh, &l, err);
    if (st != SV_OK) return st;
    if (mesh->triangle_count == 0) return sv_fail(err, SV_ERR_INVALID, "mesh has no triangles");
    if ((st = check_content(mesh, err)) != SV_OK) return st;
    if ((st = remove_bad_triangles(mesh, report, err)) != SV_OK) return st;
    if (mesh->triangle_count == 0)
        return sv_fail(
            err, SV_ERR_INVALID,
            "mesh has no triangles left after removing %u zero-area and %u duplicate ones",
            report->removed_degenerate, report->removed_duplicate);
    return repair_normals(mesh, report, err);
}
