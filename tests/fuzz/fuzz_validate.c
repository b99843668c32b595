/* fuzz_validate.c — libFuzzer target: the mesh validator (core/geom/validate.c,
 * sv_validate) on a mesh whose counts, float bits (NaN, Inf, denormals),
 * indices and material indices all come from the fuzz bytes. It must reject or
 * repair, never crash; after SV_OK every index is in range, every position
 * finite and at least one triangle is left (validate.h's contract). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "validate.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint32_t take(const uint8_t **d, size_t *n)
{
    uint32_t v = 0;
    size_t k = *n < 4 ? *n : 4;
    memcpy(&v, *d, k);
    *d += k;
    *n -= k;
    return v;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 4) return 0;
    uint32_t nv = data[0] % 65, nt = data[1] % 65, nm = data[2] % 5;
    uint8_t flags = data[3];
    data += 4;
    size -= 4;
    sv_mesh *m = sv_mesh_create(nv, nt, nm, 0);
    if (!m) return 0;
    for (uint32_t i = 0; i < 3 * nv; i++) {
        uint32_t bits = take(&data, &size);
        /* small integers make real (and duplicate) triangles likely */
        float f;
        if (flags & 1) f = (float)(bits % 5);
        else memcpy(&f, &bits, sizeof f);
        m->positions[i] = f;
        if (flags & 2) memcpy(&m->normals[i], &bits, sizeof f);
    }
    for (uint32_t i = 0; i < 3 * nt; i++) {
        uint32_t v = take(&data, &size);
        m->indices[i] = (flags & 4) ? v : (nv ? v % (nv + 1) : v);
    }
    for (uint32_t i = 0; i < nt; i++) m->tri_material[i] = (flags & 8) ? take(&data, &size) % 6 : 0;
    sv_limits lim = {0};
    if (flags & 16) {
        lim.max_triangles = 8;
        lim.max_vertices = 16;
    }
    sv_validate_report rep;
    sv_error e = {0};
    sv_status st = sv_validate(m, &lim, &rep, &e);
    if (st == SV_OK) {
        if (m->triangle_count == 0) abort();
        for (uint32_t i = 0; i < 3 * m->triangle_count; i++)
            if (m->indices[i] >= m->vertex_count) abort();
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (m->material_count && m->tri_material[t] >= m->material_count) abort();
        for (uint32_t i = 0; i < 3 * m->vertex_count; i++)
            if (!isfinite(m->positions[i])) abort();
    } else if (e.message[0] == 0) {
        abort();
    }
    sv_mesh_destroy(m);
    return 0;
}
