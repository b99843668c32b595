/* plausibility.c — size and up-axis checks of an imported tree (plausibility.h). */
#include "plausibility.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "classify.h"

void sv_detect_up(const sv_mesh *m, const uint8_t *tri_part, sv_up_guess *g)
{
    memset(g, 0, sizeof *g);
    double bmn[3], bmx[3];
    if (!m || !sv_mesh_bounds(m, bmn, bmx)) {
        snprintf(g->reason, sizeof g->reason, "empty mesh");
        return;
    }
    double e[3];
    for (int k = 0; k < 3; k++) e[k] = bmx[k] - bmn[k];
    g->height = e[1];
    double w = SV_UP_SLAB * fmax(e[0], fmax(e[1], e[2]));
    /* area of the trunk triangles reaching within w of the lowest Y, lowest Z, highest Z */
    double a_ylo = 0, a_zlo = 0, a_zhi = 0, total = 0;
    double tmn[3] = {INFINITY, INFINITY, INFINITY}, tmx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (tri_part && tri_part[t] != SV_PART_TRUNK) continue;
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int v = 0; v < 3; v++) {
            const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + v]];
            for (int k = 0; k < 3; k++) {
                lo[k] = fmin(lo[k], p[k]);
                hi[k] = fmax(hi[k], p[k]);
            }
        }
        for (int k = 0; k < 3; k++) {
            tmn[k] = fmin(tmn[k], lo[k]);
            tmx[k] = fmax(tmx[k], hi[k]);
        }
        double area = sv_tri_area(m, t);
        total += area;
        if (lo[1] - bmn[1] <= w) a_ylo += area;
        if (lo[2] - bmn[2] <= w) a_zlo += area;
        if (bmx[2] - hi[2] <= w) a_zhi += area;
    }
    if (!(total > 0)) {
        snprintf(g->reason, sizeof g->reason, "no trunk triangles: up axis not checked");
        return;
    }
    double ty = tmx[1] - tmn[1], tz = tmx[2] - tmn[2];
    double a_z = fmax(a_zlo, a_zhi);
    if (a_z > SV_UP_AREA_RATIO * a_ylo) {
        g->z_up = a_zlo >= a_zhi ? 1 : -1;
        snprintf(g->reason, sizeof g->reason,
                 "the trunk base sits at the %s Z: %.3g m^2 of trunk there, %.3g m^2 at the "
                 "lowest Y",
                 g->z_up > 0 ? "lowest" : "highest", a_z, a_ylo);
    } else if (a_ylo == 0 && e[2] >= SV_UP_LONG * e[1] && tz >= SV_UP_LONG * ty) {
        g->z_up = tmn[2] - bmn[2] <= bmx[2] - tmx[2] ? 1 : -1;
        snprintf(g->reason, sizeof g->reason,
                 "no trunk at the lowest Y, the bounding box is %.3g x longer in Z than in Y and "
                 "the trunk lies along Z",
                 e[1] > 0 ? e[2] / e[1] : INFINITY);
    } else {
        snprintf(g->reason, sizeof g->reason, "the trunk base sits at the lowest Y");
        return;
    }
    g->height = e[2];
}

void sv_mesh_rotate_up(sv_mesh *m, int z_up)
{
    if (!m || !z_up) return;
    float s = z_up > 0 ? 1.0f : -1.0f;
    for (size_t v = 0; v < m->vertex_count; v++) {
        float *arrs[2] = {&m->positions[3 * v], m->normals ? &m->normals[3 * v] : NULL};
        for (int a = 0; a < 2; a++) {
            float *p = arrs[a];
            if (!p) continue;
            float y = p[1], z = p[2];
            p[1] = s * z; /* +1: y' = z,  z' = -y;  -1: y' = -z, z' = y */
            p[2] = -s * y;
        }
    }
}

static void append(char *buf, size_t cap, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void append(char *buf, size_t cap, const char *fmt, ...)
{
    size_t len = strnlen(buf, cap);
    if (len + 2 >= cap) return;
    if (len) buf[len++] = '\n';
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf + len, cap - len, fmt, ap);
    va_end(ap);
}

void sv_plausibility_warnings(const sv_up_guess *g, double height, bool rotated, char *buf,
                              size_t cap)
{
    if (!buf || cap == 0) return;
    if (g && g->z_up && !rotated)
        append(buf, cap,
               "the tree looks %s (%s): it would bake lying down; set import.up to \"%s\" or "
               "\"auto\"",
               g->z_up > 0 ? "Z-up" : "upside down along Z", g->reason, g->z_up > 0 ? "Z" : "auto");
    if (height > SV_TALLEST_TREE_M)
        append(buf, cap,
               "the tree is %.4g m tall, taller than any tree (%.0f m): are the units right? "
               "set import.units (metres per unit)",
               height, SV_TALLEST_TREE_M);
    else if (height < SV_SMALLEST_TREE_M)
        append(buf, cap,
               "the tree is %.3g m tall, shorter than %.0f cm: are the units right? set "
               "import.units (e.g. \"cm\", \"mm\" or metres per unit)",
               height, 100 * SV_SMALLEST_TREE_M);
}
