/* mesh.c — allocation and basic geometry of sv_mesh. */
#include "mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void sv_material_init(sv_material *m)
{
    memset(m, 0, sizeof *m);
    for (int i = 0; i < 4; i++) m->base_color[i] = 1.0f;
    m->base_texture = m->normal_texture = m->occlusion_texture = -1;
    m->alpha_mode = SV_ALPHA_OPAQUE;
    m->alpha_cutoff = 0.5f;
}

sv_mesh *sv_mesh_create(uint32_t vertex_count, uint32_t triangle_count, uint32_t material_count,
                        uint32_t image_count)
{
    sv_mesh *m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->vertex_count = vertex_count;
    m->triangle_count = triangle_count;
    m->material_count = material_count;
    m->image_count = image_count;
    m->positions = sv_calloc((size_t)vertex_count, 3 * sizeof(float));
    m->normals = sv_calloc((size_t)vertex_count, 3 * sizeof(float));
    m->uvs = sv_calloc((size_t)vertex_count, 2 * sizeof(float));
    m->indices = sv_calloc((size_t)triangle_count, 3 * sizeof(uint32_t));
    m->tri_material = sv_calloc((size_t)triangle_count, sizeof(uint32_t));
    m->materials = sv_calloc((size_t)material_count, sizeof(sv_material));
    m->images = sv_calloc((size_t)image_count, sizeof(sv_image));
    if (!m->positions || !m->normals || !m->uvs || !m->indices || !m->tri_material ||
        !m->materials || !m->images) {
        sv_mesh_destroy(m);
        return NULL;
    }
    for (uint32_t i = 0; i < material_count; i++) sv_material_init(&m->materials[i]);
    return m;
}

void sv_mesh_destroy(sv_mesh *m)
{
    if (!m) return;
    if (m->images)
        for (uint32_t i = 0; i < m->image_count; i++) sv_image_free(&m->images[i]);
    free(m->positions);
    free(m->normals);
    free(m->uvs);
    free(m->indices);
    free(m->tri_material);
    free(m->materials);
    free(m->images);
    free(m);
}

bool sv_mesh_bounds(const sv_mesh *m, double mn[3], double mx[3])
{
    for (int k = 0; k < 3; k++) {
        mn[k] = INFINITY;
        mx[k] = -INFINITY;
    }
    bool any = false;
    if (m->triangle_count) {
        for (size_t i = 0; i < (size_t)m->triangle_count * 3; i++) {
            const float *p = &m->positions[3 * (size_t)m->indices[i]];
            for (int k = 0; k < 3; k++) {
                if (p[k] < mn[k]) mn[k] = p[k];
                if (p[k] > mx[k]) mx[k] = p[k];
            }
            any = true;
        }
    } else {
        for (size_t v = 0; v < m->vertex_count; v++) {
            const float *p = &m->positions[3 * v];
            for (int k = 0; k < 3; k++) {
                if (p[k] < mn[k]) mn[k] = p[k];
                if (p[k] > mx[k]) mx[k] = p[k];
            }
            any = true;
        }
    }
    return any;
}

void sv_mesh_sphere(const sv_mesh *m, double c[3], double *r)
{
    double mn[3], mx[3];
    if (!sv_mesh_bounds(m, mn, mx)) {
        c[0] = c[1] = c[2] = 0;
        *r = 0;
        return;
    }
    double s = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (mn[k] + mx[k]);
        s += (mx[k] - mn[k]) * (mx[k] - mn[k]);
    }
    *r = 0.5 * sqrt(s);
}

void sv_mesh_frame_sphere(const sv_mesh *m, double c[3], double *r)
{
    double mn[3], mx[3];
    *r = 0;
    if (!sv_mesh_bounds(m, mn, mx)) {
        c[0] = c[1] = c[2] = 0;
        return;
    }
    for (int k = 0; k < 3; k++) c[k] = 0.5 * (mn[k] + mx[k]);
    double best = 0;
    for (size_t i = 0; i < (size_t)m->triangle_count * 3; i++) {
        const float *p = &m->positions[3 * (size_t)m->indices[i]];
        double d = 0;
        for (int k = 0; k < 3; k++) d += (p[k] - c[k]) * (p[k] - c[k]);
        if (d > best) best = d;
    }
    *r = sqrt(best);
}

void sv_tri_cross(const sv_mesh *m, uint32_t t, double n[3])
{
    const uint32_t *ix = &m->indices[3 * (size_t)t];
    const float *a = &m->positions[3 * (size_t)ix[0]];
    const float *b = &m->positions[3 * (size_t)ix[1]];
    const float *c = &m->positions[3 * (size_t)ix[2]];
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)b[k] - a[k];
        e2[k] = (double)c[k] - a[k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

double sv_tri_area(const sv_mesh *m, uint32_t t)
{
    double n[3];
    sv_tri_cross(m, t, n);
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

void sv_tri_normal(const sv_mesh *m, uint32_t t, double n[3])
{
    sv_tri_cross(m, t, n);
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (l > 0 && isfinite(l)) {
        n[0] /= l;
        n[1] /= l;
        n[2] /= l;
    } else {
        n[0] = n[1] = n[2] = 0;
    }
}

void sv_mesh_compute_normals(sv_mesh *m)
{
    double *acc = sv_calloc(m->vertex_count, 3 * sizeof(double));
    if (!acc) return;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        double n[3];
        sv_tri_cross(m, t, n); /* length = 2 × area: area weighting for free */
        for (int j = 0; j < 3; j++) {
            uint32_t v = m->indices[3 * (size_t)t + j];
            for (int k = 0; k < 3; k++) acc[3 * (size_t)v + k] += n[k];
        }
    }
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        double *a = &acc[3 * (size_t)v];
        double l = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (int k = 0; k < 3; k++)
            m->normals[3 * (size_t)v + k] = (l > 0) ? (float)(a[k] / l) : (k == 1 ? 1.0f : 0.0f);
    }
    free(acc);
}

sv_status sv_mesh_subset(const sv_mesh *src, const uint32_t *tris, uint32_t count, sv_mesh **out,
                         sv_error *err)
{
    *out = NULL;
    uint32_t *remap = malloc(((size_t)src->vertex_count + 1) * sizeof *remap);
    if (!remap) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    memset(remap, 0xff, ((size_t)src->vertex_count + 1) * sizeof *remap);
    uint32_t nv = 0;
    for (uint32_t i = 0; i < count; i++)
        for (int j = 0; j < 3; j++) {
            uint32_t v = src->indices[3 * (size_t)tris[i] + j];
            if (remap[v] == UINT32_MAX) remap[v] = nv++;
        }
    sv_mesh *m = sv_mesh_create(nv, count, src->material_count, src->image_count);
    if (!m) {
        free(remap);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    for (uint32_t v = 0; v < src->vertex_count; v++) {
        uint32_t w = remap[v];
        if (w == UINT32_MAX) continue;
        memcpy(&m->positions[3 * (size_t)w], &src->positions[3 * (size_t)v], 3 * sizeof(float));
        memcpy(&m->normals[3 * (size_t)w], &src->normals[3 * (size_t)v], 3 * sizeof(float));
        memcpy(&m->uvs[2 * (size_t)w], &src->uvs[2 * (size_t)v], 2 * sizeof(float));
    }
    for (uint32_t i = 0; i < count; i++) {
        for (int j = 0; j < 3; j++)
            m->indices[3 * (size_t)i + j] = remap[src->indices[3 * (size_t)tris[i] + j]];
        m->tri_material[i] = src->tri_material[tris[i]];
    }
    free(remap);
    sv_status st = sv_mesh_copy_looks(src, m, err);
    if (st) {
        sv_mesh_destroy(m);
        return st;
    }
    *out = m;
    return SV_OK;
}

sv_status sv_mesh_copy_looks(const sv_mesh *src, sv_mesh *dst, sv_error *err)
{
    memcpy(dst->materials, src->materials, src->material_count * sizeof *dst->materials);
    for (uint32_t i = 0; i < src->image_count; i++) {
        sv_status st = sv_image_copy(&src->images[i], &dst->images[i], err);
        if (st) return st;
    }
    return SV_OK;
}

sv_status sv_mesh_merge(const sv_mesh *a, const sv_mesh *b, sv_mesh **out, sv_error *err)
{
    static const sv_mesh empty = {0};
    if (!a) a = &empty;
    if (!b) b = &empty;
    *out = NULL;
    uint64_t nv = (uint64_t)a->vertex_count + b->vertex_count;
    uint64_t nt = (uint64_t)a->triangle_count + b->triangle_count;
    if (nv > UINT32_MAX || nt > UINT32_MAX)
        return sv_fail(err, SV_ERR_LIMIT, "merged mesh too large");
    sv_mesh *m = sv_mesh_create((uint32_t)nv, (uint32_t)nt, a->material_count + b->material_count,
                                a->image_count + b->image_count);
    if (!m) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    const sv_mesh *parts[2] = {a, b};
    uint32_t vo = 0, to = 0, mo = 0, io = 0;
    for (int k = 0; k < 2; k++) {
        const sv_mesh *s = parts[k];
        if (s->vertex_count) {
            memcpy(&m->positions[3 * (size_t)vo], s->positions,
                   3 * sizeof(float) * s->vertex_count);
            memcpy(&m->normals[3 * (size_t)vo], s->normals, 3 * sizeof(float) * s->vertex_count);
            memcpy(&m->uvs[2 * (size_t)vo], s->uvs, 2 * sizeof(float) * s->vertex_count);
        }
        for (size_t i = 0; i < 3 * (size_t)s->triangle_count; i++)
            m->indices[3 * (size_t)to + i] = s->indices[i] + vo;
        for (uint32_t t = 0; t < s->triangle_count; t++)
            m->tri_material[to + t] = s->tri_material[t] + mo;
        for (uint32_t i = 0; i < s->material_count; i++) {
            sv_material mt = s->materials[i];
            if (mt.base_texture >= 0) mt.base_texture += (int32_t)io;
            if (mt.normal_texture >= 0) mt.normal_texture += (int32_t)io;
            if (mt.occlusion_texture >= 0) mt.occlusion_texture += (int32_t)io;
            m->materials[mo + i] = mt;
        }
        for (uint32_t i = 0; i < s->image_count; i++) {
            sv_status st = sv_image_copy(&s->images[i], &m->images[io + i], err);
            if (st) {
                sv_mesh_destroy(m);
                return st;
            }
        }
        vo += s->vertex_count;
        to += s->triangle_count;
        mo += s->material_count;
        io += s->image_count;
    }
    *out = m;
    return SV_OK;
}

static bool same_bytes(const void *a, const void *b, size_t n)
{
    return n == 0 || a == b || (a && b && memcmp(a, b, n) == 0);
}

bool sv_mesh_draws_same(const sv_mesh *a, const sv_mesh *b)
{
    if (!a || !b) return a == b;
    if (a->vertex_count != b->vertex_count || a->triangle_count != b->triangle_count ||
        a->material_count != b->material_count || a->image_count != b->image_count)
        return false;
    size_t nv = a->vertex_count, nt = a->triangle_count;
    if (!same_bytes(a->positions, b->positions, 3 * nv * sizeof(float)) ||
        !same_bytes(a->normals, b->normals, 3 * nv * sizeof(float)) ||
        !same_bytes(a->uvs, b->uvs, 2 * nv * sizeof(float)) ||
        !same_bytes(a->indices, b->indices, 3 * nt * sizeof(uint32_t)) ||
        !same_bytes(a->tri_material, b->tri_material, nt * sizeof(uint32_t)))
        return false;
    for (uint32_t i = 0; i < a->material_count; i++) {
        const sv_material *x = &a->materials[i], *y = &b->materials[i];
        if (memcmp(x->base_color, y->base_color, sizeof x->base_color) != 0 ||
            x->base_texture != y->base_texture || x->normal_texture != y->normal_texture ||
            x->occlusion_texture != y->occlusion_texture || x->alpha_mode != y->alpha_mode ||
            x->alpha_cutoff != y->alpha_cutoff || x->double_sided != y->double_sided ||
            x->unlit != y->unlit)
            return false;
    }
    for (uint32_t i = 0; i < a->image_count; i++) {
        const sv_image *x = &a->images[i], *y = &b->images[i];
        if (x->width != y->width || x->height != y->height || x->channels != y->channels ||
            x->bits != y->bits || !same_bytes(x->data, y->data, sv_image_stride(x) * x->height))
            return false;
    }
    return true;
}
