/* slicing.c — the "slicing" method: Jakulin's slicings.
 *
 * Aleks Jakulin, "Interactive Vegetation Rendering with Slicing and Blending"
 * (Eurographics 2000; ../shared/papers/slicing-and-blending.txt, "Solution"):
 * the crown becomes several slicings, each a set of parallel textured slices;
 * a renderer draws the two slicings nearest the view and blends them ("render
 * two slicings at once, and use blending to smoothen the transitions"); the
 * limbs and the trunk stay a polygonal mesh. The paper's demo uses 6 slicings
 * of 5 slices each, for viewing "from distances of approximately 20 meters and
 * more", and notes artifacts from above that "additional slicings" remove:
 * hence the optional top slicing.
 *
 * Output: one LOD, "slicing". For each slicing (azimuthal ones first, then the
 * top one), one quad per non-empty slab, in slab order along the direction:
 *   - plane: the slab's mid-plane, normal = the slicing's direction, texture
 *     seen from +normal (and, double-sided, from behind: the slicing serves
 *     the opposite direction too — see slicing.h);
 *   - clip = true, slab = half the slab's thickness: the bake draws every
 *     foliage face and clips it at the slab's two planes (bake.c), so each
 *     slice shows exactly the foliage inside its slab;
 *   - rectangle: axis_v = +Y and axis_u horizontal for azimuthal slicings
 *     (axis_u = +X, axis_v = −Z for the top one), extents = the bounds of the
 *     foliage clipped to the slab (sv_slab_clip_triangle), plus 1e-5·R;
 *   - faces: the foliage triangles with a piece of positive area in the slab
 *     (a triangle cut by a boundary is listed in both slabs), face_area = the
 *     clipped area; parts = foliage; group = slicing index (top = S);
 *   - trunk: SV_TRUNK_SIMPLIFIED at trunk_ratio.
 * Slabs split the crown's extent along the direction, [lo, hi] = the foliage
 * vertices' projections widened by 1e-4·R on each side (the extreme leaves are
 * never exactly on a clip plane) and to at least 0.01·R (a planar crown still
 * gets slabs of positive thickness). The view selector (stand_in.h) and
 * planes.json's "slicing" object carry the blending rule (sv_slicing_blend).
 *
 * Settings (spec key "slicing"), all optional:
 *   "slicings":    integer in [1, 32] (default 6): azimuthal slicings, every
 *                  180°/S (the paper's 6 are 60° apart over 360°; a slicing
 *                  and its opposite share planes, so ours are 30° apart);
 *   "slices":      integer in [1, 64] (default 5) per slicing;
 *   "spacing":     "uniform" | "foliage" (default "uniform": on the 12 trees of
 *                  ../shared/data it gives the higher mean IoU at every size, most
 *                  at the smallest — docs/methods/slicing.md has the numbers);
 *   "top":         null (default: on when scene.viewer is aerial) or bool;
 *   "trunk_ratio": number in (0, 1] (default 0.25).
 */
#include "slicing.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "method_ops.h"
#include "vec3.h"

#define SL_MAX_ALL (SV_SLICING_MAX_SLICINGS + 1u)

/* ---------- pure geometry ---------- */

void sv_slicing_direction(uint32_t j, uint32_t count, double n[3])
{
    double s, c;
    if (count == 0 || j == 0) {
        s = 0;
        c = 1;
    } else if (2 * j == count) {
        s = 1;
        c = 0;
    } else {
        double th = M_PI * (double)j / (double)count;
        s = sin(th);
        c = cos(th);
    }
    n[0] = s;
    n[1] = 0;
    n[2] = c;
}

double sv_polygon_area(const double (*poly)[3], uint32_t n)
{
    if (n < 3) return 0;
    double acc[3] = {0, 0, 0};
    for (uint32_t i = 1; i + 1 < n; i++) {
        double a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = poly[i][k] - poly[0][k];
            b[k] = poly[i + 1][k] - poly[0][k];
        }
        acc[0] += a[1] * b[2] - a[2] * b[1];
        acc[1] += a[2] * b[0] - a[0] * b[2];
        acc[2] += a[0] * b[1] - a[1] * b[0];
    }
    return 0.5 * sqrt(sv_dot3(acc, acc));
}

/* Sutherland–Hodgman against sign·(n·p − c) <= 0; returns the new count. */
static uint32_t clip_half(const double (*in)[3], uint32_t n, const double nrm[3], double c,
                          double sign, double (*out)[3])
{
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; i++) {
        const double *p = in[i], *q = in[(i + 1) % n];
        double dp = sign * (sv_dot3(nrm, p) - c), dq = sign * (sv_dot3(nrm, q) - c);
        if (dp <= 0) memcpy(out[m++], p, sizeof out[0]);
        if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) {
            double t = dp / (dp - dq);
            for (int k = 0; k < 3; k++) out[m][k] = p[k] + t * (q[k] - p[k]);
            m++;
        }
    }
    return m;
}

uint32_t sv_slab_clip_triangle(const double tri[3][3], const double n[3], double lo, double hi,
                               double out[5][3])
{
    /* A triangle clipped by two parallel planes has at most 5 vertices; the
     * intermediate polygon (one plane) at most 4. */
    double mid[5][3];
    uint32_t m = clip_half(tri, 3, n, lo, -1.0, mid);
    if (m < 3) return 0;
    m = clip_half((const double(*)[3])mid, m, n, hi, 1.0, out);
    if (m < 3 || !(sv_polygon_area((const double(*)[3])out, m) > 0)) return 0;
    return m;
}

void sv_slab_bounds_uniform(double lo, double hi, uint32_t k, double *bounds)
{
    if (k == 0) return;
    for (uint32_t i = 0; i <= k; i++) bounds[i] = lo + (hi - lo) * (double)i / (double)k;
    bounds[0] = lo;
    bounds[k] = hi;
}

/* Area of a triangle with vertex projections a <= b <= c below s (the area
 * density along the direction is a tent from a to c peaking at b). */
static double tent_cdf(double a, double b, double c, double area, double s)
{
    if (s <= a) return 0;
    if (s >= c) return area;
    if (s <= b) return area * (s - a) * (s - a) / ((c - a) * (b - a));
    return area * (1.0 - (c - s) * (c - s) / ((c - a) * (c - b)));
}

static void sort3(double v[3])
{
    double t;
    if (v[0] > v[1]) {
        t = v[0];
        v[0] = v[1];
        v[1] = t;
    }
    if (v[1] > v[2]) {
        t = v[1];
        v[1] = v[2];
        v[2] = t;
    }
    if (v[0] > v[1]) {
        t = v[0];
        v[0] = v[1];
        v[1] = t;
    }
}

sv_status sv_slab_bounds_foliage(const double *proj, const double *area, size_t count, double lo,
                                 double hi, uint32_t k, double *bounds, sv_error *err)
{
    if (k == 0 || !(lo < hi) || !isfinite(lo) || !isfinite(hi))
        return sv_fail(err, SV_ERR_INVALID, "slicing: bad slab range [%g, %g] or %u slabs", lo, hi,
                       k);
    const uint32_t nb = SV_SLICING_FOLIAGE_BINS;
    double *hist = sv_calloc(nb, sizeof *hist);
    if (!hist) return sv_fail(err, SV_ERR_NOMEM, "slicing: no memory for the foliage histogram");
    double w = (hi - lo) / nb, total = 0;
    for (size_t t = 0; t < count; t++) {
        double A = area[t];
        if (!(A > 0) || !isfinite(A)) continue;
        double v[3] = {proj[3 * t], proj[3 * t + 1], proj[3 * t + 2]};
        sort3(v);
        double fa = floor((v[0] - lo) / w), fc = floor((v[2] - lo) / w);
        uint32_t ia = fa < 0 ? 0 : fa >= nb ? nb - 1 : (uint32_t)fa;
        uint32_t ic = fc < 0 ? 0 : fc >= nb ? nb - 1 : (uint32_t)fc;
        total += A;
        if (ia == ic || !(v[2] > v[0])) {
            hist[ia] += A;
            continue;
        }
        double prev = 0;
        for (uint32_t i = ia; i <= ic; i++) {
            double f = i == ic ? A : tent_cdf(v[0], v[1], v[2], A, lo + w * (i + 1));
            hist[i] += f - prev;
            prev = f;
        }
    }
    sv_slab_bounds_uniform(lo, hi, k, bounds);
    if (total > 0) {
        double cum = 0;
        uint32_t i = 0;
        for (uint32_t q = 1; q < k; q++) {
            double target = total * (double)q / (double)k;
            while (i + 1 < nb && cum + hist[i] < target) cum += hist[i++];
            double f = hist[i] > 0 ? (target - cum) / hist[i] : 0.5;
            if (f < 0) f = 0;
            if (f > 1) f = 1;
            bounds[q] = lo + w * ((double)i + f);
        }
    }
    free(hist);
    /* Keep slabs of positive thickness (see slicing.h). */
    double gap = (hi - lo) / (100.0 * k);
    for (uint32_t q = 1; q < k; q++)
        if (bounds[q] < bounds[q - 1] + gap) bounds[q] = bounds[q - 1] + gap;
    for (uint32_t q = k - 1; q >= 1; q--)
        if (bounds[q] > bounds[q + 1] - gap) bounds[q] = bounds[q + 1] - gap;
    bounds[0] = lo;
    bounds[k] = hi;
    return SV_OK;
}

uint32_t sv_slicing_blend(uint32_t slicings, bool top, const double view_dir[3], uint32_t idx[3],
                          double w[3])
{
    uint32_t S = slicings ? slicings : 1;
    double phi = 0;
    if (view_dir[0] != 0 || view_dir[2] != 0) phi = atan2(view_dir[0], view_dir[2]);
    if (phi < 0) phi += M_PI;
    if (phi >= M_PI) phi -= M_PI;
    double t = phi * (double)S / M_PI;
    double jf = floor(t), f = t - jf;
    uint32_t j = (uint32_t)jf % S;
    /* Snap rounding at the slicing directions themselves. */
    if (f < 1e-9) f = 0;
    if (f > 1 - 1e-9) {
        f = 0;
        j = (j + 1) % S;
    }
    double wt = 0;
    if (top) {
        double y = fabs(view_dir[1]);
        wt = y >= 1 ? 1.0 : asin(y) / (0.5 * M_PI);
        if (wt < 1e-9) wt = 0;
        if (wt > 1 - 1e-9) wt = 1;
    }
    uint32_t cand_i[3] = {j, (j + 1) % S, S};
    double cand_w[3] = {(1 - f) * (1 - wt), f * (1 - wt), wt};
    uint32_t n = 0;
    for (int c = 0; c < 3; c++) {
        if (!(cand_w[c] > 0)) continue;
        uint32_t e = 0;
        while (e < n && idx[e] != cand_i[c]) e++;
        if (e < n) {
            w[e] += cand_w[c];
            continue;
        }
        idx[n] = cand_i[c];
        w[n++] = cand_w[c];
    }
    /* Ascending indices (at most 3 entries). */
    for (uint32_t a = 0; a < n; a++)
        for (uint32_t b = a + 1; b < n; b++)
            if (idx[b] < idx[a]) {
                uint32_t ti = idx[a];
                idx[a] = idx[b];
                idx[b] = ti;
                double tw = w[a];
                w[a] = w[b];
                w[b] = tw;
            }
    if (n == 0) { /* unreachable: the weights sum to 1 */
        idx[0] = 0;
        w[0] = 1;
        n = 1;
    }
    return n;
}

/* ---------- the method ---------- */

/* What the view selector and sv_slicing_describe need; lives in select_data
 * (one malloc'ed block, freed by sv_stand_in_free). */
typedef struct sl_layout {
    uint32_t slicings; /* azimuthal */
    bool top;
    uint32_t slices;
    sv_slice_spacing spacing;
    uint32_t first[SL_MAX_ALL], count[SL_MAX_ALL]; /* quads of slicing j (top = slicings) */
    double dir[SL_MAX_ALL][3];
    double bounds[SL_MAX_ALL][SV_SLICING_MAX_SLICES + 1]; /* n·x of the slab planes */
} sl_layout;

static uint32_t sl_select(const sv_lod_plan *lod, const double view_dir[3],
                          uint32_t *const sets[SV_MAX_VIEW_SETS], uint32_t counts[SV_MAX_VIEW_SETS],
                          double weights[SV_MAX_VIEW_SETS])
{
    const sl_layout *L = lod->select_data;
    if (!L) return 0;
    uint32_t idx[3];
    double w[3];
    uint32_t n = sv_slicing_blend(L->slicings, L->top, view_dir, idx, w);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t s = idx[i];
        counts[i] = 0;
        for (uint32_t q = 0; q < L->count[s]; q++) sets[i][counts[i]++] = L->first[s] + q;
        weights[i] = w[i];
    }
    return n;
}

static const char *spacing_name(sv_slice_spacing s)
{
    return s == SV_SPACING_FOLIAGE ? "foliage" : "uniform";
}

cJSON *sv_slicing_describe(const sv_lod_plan *lod)
{
    if (!lod || lod->select != sl_select || !lod->select_data) return NULL;
    const sl_layout *L = lod->select_data;
    cJSON *o = cJSON_CreateObject();
    if (!o) return NULL;
    bool ok = true;
    char rule[512];
    snprintf(rule, sizeof rule,
             "v = unit view direction (either sign). phi = atan2(v.x, v.z) mod 180 deg "
             "(0 if v is vertical); t = phi / azimuth_step_deg; j = floor(t), f = t - j: "
             "azimuthal slicing j gets 1 - f, slicing (j + 1) mod %u gets f%s. "
             "Draw each chosen slicing's quads with its weight (alpha x weight, or dithered); "
             "the trunk mesh always.",
             L->slicings,
             L->top ? "; with the top slicing, e = asin(|v.y|): both are scaled by "
                      "1 - e/90 deg and the top slicing gets e/90 deg"
                    : "");
    ok = ok && cJSON_AddStringToObject(o, "blending", rule);
    ok = ok && cJSON_AddNumberToObject(o, "azimuth_period_deg", 180);
    ok = ok && cJSON_AddNumberToObject(o, "azimuth_step_deg", 180.0 / L->slicings);
    ok = ok && cJSON_AddNumberToObject(o, "azimuthal_slicings", L->slicings);
    ok = ok && cJSON_AddBoolToObject(o, "top", L->top);
    ok = ok && cJSON_AddNumberToObject(o, "slices", L->slices);
    ok = ok && cJSON_AddStringToObject(o, "spacing", spacing_name(L->spacing));
    cJSON *arr = ok ? cJSON_AddArrayToObject(o, "slicings") : NULL;
    ok = arr != NULL;
    uint32_t all = L->slicings + (L->top ? 1u : 0u);
    for (uint32_t s = 0; ok && s < all; s++) {
        cJSON *e = cJSON_CreateObject();
        ok = e && cJSON_AddItemToArray(arr, e);
        if (!ok) {
            cJSON_Delete(e);
            break;
        }
        bool is_top = s == L->slicings;
        ok = cJSON_AddNumberToObject(e, "group", s) &&
             cJSON_AddStringToObject(e, "kind", is_top ? "top" : "azimuth") &&
             cJSON_AddItemToObject(e, "direction", cJSON_CreateDoubleArray(L->dir[s], 3));
        if (ok && !is_top)
            ok = cJSON_AddNumberToObject(e, "azimuth_deg", 180.0 * s / L->slicings) != NULL;
        cJSON *qa = ok ? cJSON_AddArrayToObject(e, "quads") : NULL;
        ok = qa != NULL;
        for (uint32_t q = 0; ok && q < L->count[s]; q++)
            ok = cJSON_AddItemToArray(qa, cJSON_CreateNumber(L->first[s] + q));
        if (ok)
            ok = cJSON_AddItemToObject(e, "slab_bounds",
                                       cJSON_CreateDoubleArray(L->bounds[s], (int)L->slices + 1));
    }
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

/* Scratch shared by the slicings of one run. */
typedef struct sl_work {
    const sv_mesh *m;
    const double *centre;
    double radius;
    uint32_t *tris; /* foliage triangles of positive area */
    uint32_t nt;
    double *proj;          /* 3 per foliage triangle, relative to centre */
    double *area;          /* per foliage triangle */
    uint16_t *kmin, *kmax; /* slabs with a piece of positive area (kmin > kmax: none) */
    uint8_t parts;
} sl_work;

static void tri_rel(const sl_work *w, uint32_t t, double p[3][3])
{
    for (int j = 0; j < 3; j++) {
        const float *v = &w->m->positions[3 * (size_t)w->m->indices[3 * (size_t)t + j]];
        for (int k = 0; k < 3; k++) p[j][k] = (double)v[k] - w->centre[k];
    }
}

/* Builds slicing s (direction n, axes u, v) into lod; records it in L. */
static sv_status build_slicing(sl_work *w, const sl_settings *cs, uint32_t s, const double n[3],
                               const double u[3], const double v[3], sv_lod_plan *lod, sl_layout *L,
                               sv_error *err)
{
    const uint32_t K = (uint32_t)cs->slices;
    double lo = INFINITY, hi = -INFINITY;
    for (uint32_t i = 0; i < w->nt; i++) {
        double p[3][3];
        tri_rel(w, w->tris[i], p);
        for (int j = 0; j < 3; j++) {
            double x = sv_dot3(n, p[j]);
            w->proj[3 * (size_t)i + j] = x;
            if (x < lo) lo = x;
            if (x > hi) hi = x;
        }
    }
    double min_ext = 0.01 * w->radius;
    if (hi - lo < min_ext) {
        double c = 0.5 * (lo + hi);
        lo = c - 0.5 * min_ext;
        hi = c + 0.5 * min_ext;
    }
    lo -= 1e-4 * w->radius;
    hi += 1e-4 * w->radius;
    double *b = L->bounds[s];
    sv_status st = SV_OK;
    if (cs->spacing == SV_SPACING_FOLIAGE)
        st = sv_slab_bounds_foliage(w->proj, w->area, w->nt, lo, hi, K, b, err);
    else sv_slab_bounds_uniform(lo, hi, K, b);
    if (st) return st;

    /* Clip every foliage triangle into the slabs it spans. */
    double sarea[SV_SLICING_MAX_SLICES], u0[SV_SLICING_MAX_SLICES], u1[SV_SLICING_MAX_SLICES],
        v0[SV_SLICING_MAX_SLICES], v1[SV_SLICING_MAX_SLICES];
    uint32_t nf[SV_SLICING_MAX_SLICES];
    for (uint32_t k = 0; k < K; k++) {
        sarea[k] = 0;
        nf[k] = 0;
        u0[k] = v0[k] = INFINITY;
        u1[k] = v1[k] = -INFINITY;
    }
    for (uint32_t i = 0; i < w->nt; i++) {
        double p[3][3];
        tri_rel(w, w->tris[i], p);
        double pmin = fmin(w->proj[3 * (size_t)i],
                           fmin(w->proj[3 * (size_t)i + 1], w->proj[3 * (size_t)i + 2]));
        double pmax = fmax(w->proj[3 * (size_t)i],
                           fmax(w->proj[3 * (size_t)i + 1], w->proj[3 * (size_t)i + 2]));
        uint32_t k = 0;
        while (k + 1 < K && b[k + 1] < pmin) k++;
        w->kmin[i] = UINT16_MAX;
        w->kmax[i] = 0;
        for (; k < K && b[k] <= pmax; k++) {
            double poly[5][3];
            uint32_t c = sv_slab_clip_triangle((const double(*)[3])p, n, b[k], b[k + 1], poly);
            if (c == 0) continue;
            sarea[k] += sv_polygon_area((const double(*)[3])poly, c);
            nf[k]++;
            if (w->kmin[i] == UINT16_MAX) w->kmin[i] = (uint16_t)k;
            w->kmax[i] = (uint16_t)k;
            for (uint32_t j = 0; j < c; j++) {
                double a = sv_dot3(poly[j], u), e = sv_dot3(poly[j], v);
                if (a < u0[k]) u0[k] = a;
                if (a > u1[k]) u1[k] = a;
                if (e < v0[k]) v0[k] = e;
                if (e > v1[k]) v1[k] = e;
            }
        }
    }

    L->first[s] = lod->quad_count;
    L->count[s] = 0;
    memcpy(L->dir[s], n, sizeof L->dir[s]);
    double nc = sv_dot3(n, w->centre), margin = 1e-5 * w->radius;
    for (uint32_t k = 0; k < K; k++) {
        if (nf[k] == 0) continue;
        sv_quad q;
        memset(&q, 0, sizeof q);
        double mid = 0.5 * (b[k] + b[k + 1]);
        double cu = 0.5 * (u0[k] + u1[k]), cv = 0.5 * (v0[k] + v1[k]);
        memcpy(q.normal, n, sizeof q.normal);
        memcpy(q.axis_u, u, sizeof q.axis_u);
        memcpy(q.axis_v, v, sizeof q.axis_v);
        q.d = -(mid + nc);
        for (int j = 0; j < 3; j++) q.centre[j] = w->centre[j] + mid * n[j] + cu * u[j] + cv * v[j];
        q.half_u = 0.5 * (u1[k] - u0[k]) + margin;
        q.half_v = 0.5 * (v1[k] - v0[k]) + margin;
        q.slab = 0.5 * (b[k + 1] - b[k]);
        q.clip = true;
        q.parts = w->parts;
        q.group = (int32_t)s;
        q.parent = -1;
        q.face_area = sarea[k];
        q.faces = sv_calloc(nf[k], sizeof *q.faces);
        if (!q.faces) return sv_fail(err, SV_ERR_NOMEM, SL_NAME ": no memory for a slice's faces");
        for (uint32_t i = 0; i < w->nt; i++)
            if (w->kmin[i] <= k && k <= w->kmax[i] && w->kmin[i] != UINT16_MAX)
                q.faces[q.face_count++] = w->tris[i];
        /* kmin..kmax may include a slab the triangle only touches: keep the
         * record exact (faces = those with a piece of positive area). */
        uint32_t keep = 0;
        for (uint32_t i = 0; i < q.face_count; i++) {
            double p[3][3], poly[5][3];
            tri_rel(w, q.faces[i], p);
            if (sv_slab_clip_triangle((const double(*)[3])p, n, b[k], b[k + 1], poly))
                q.faces[keep++] = q.faces[i];
        }
        q.face_count = keep;
        if ((st = sv_lod_add_quad(lod, &q, err))) return st;
        L->count[s]++;
    }
    return SV_OK;
}

static sv_status sl_build(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                          sv_error *err)
{
    sl_settings cs;
    sv_status st = sl_parse(settings, &cs, err);
    if (st) return st;
    const sv_mesh *m = in->mesh;
    if (!m || m->triangle_count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE, SL_NAME ": the mesh has no triangles");
    const uint8_t *part = in->cls ? in->cls->tri_part : NULL;
    bool top = cs.top < 0 ? (in->scene && in->scene->viewer == SV_VIEWER_AERIAL) : cs.top == 1;

    sl_work w;
    memset(&w, 0, sizeof w);
    w.m = m;
    w.centre = in->centre;
    w.radius = in->radius > 0 ? in->radius : 1.0;
    w.parts = part ? SV_PARTS_FOLIAGE : 0;
    sl_layout *L = NULL;
    w.tris = sv_calloc(m->triangle_count, sizeof *w.tris);
    w.proj = sv_calloc(m->triangle_count, 3 * sizeof *w.proj);
    w.area = sv_calloc(m->triangle_count, sizeof *w.area);
    w.kmin = sv_calloc(m->triangle_count, sizeof *w.kmin);
    w.kmax = sv_calloc(m->triangle_count, sizeof *w.kmax);
    L = sv_calloc(1, sizeof *L);
    if (!w.tris || !w.proj || !w.area || !w.kmin || !w.kmax || !L) {
        st = sv_fail(err, SV_ERR_NOMEM, SL_NAME ": no memory for %u triangles", m->triangle_count);
        goto out;
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (part && part[t] != SV_PART_FOLIAGE) continue;
        double a = sv_tri_area(m, t);
        if (!(a > 0) || !isfinite(a)) continue;
        w.area[w.nt] = a;
        w.tris[w.nt++] = t;
    }
    if (w.nt == 0) {
        st = sv_fail(err, SV_ERR_UNBAKEABLE,
                     SL_NAME ": no foliage triangles to slice (classification found only trunk)");
        goto out;
    }

    snprintf(out->method, sizeof out->method, "%s", SL_NAME);
    sv_lod_plan *lod = sv_stand_in_add_lod(out, "slicing");
    if (!lod) {
        st = sv_fail(err, SV_ERR_NOMEM, SL_NAME ": no memory for a LOD");
        goto out;
    }
    lod->trunk = part ? SV_TRUNK_SIMPLIFIED : SV_TRUNK_NONE;
    lod->trunk_ratio = cs.trunk_ratio;
    L->slicings = (uint32_t)cs.slicings;
    L->slices = (uint32_t)cs.slices;
    L->spacing = cs.spacing;
    L->top = top;
    for (uint32_t s = 0; s < L->slicings && st == SV_OK; s++) {
        double n[3], v[3] = {0, 1, 0};
        sv_slicing_direction(s, L->slicings, n);
        double u[3] = {n[2], 0, -n[0]}; /* u = v × n, so u × v = n */
        st = build_slicing(&w, &cs, s, n, u, v, lod, L, err);
    }
    if (st == SV_OK && top) {
        const double n[3] = {0, 1, 0}, u[3] = {1, 0, 0}, v[3] = {0, 0, -1};
        st = build_slicing(&w, &cs, L->slicings, n, u, v, lod, L, err);
    }
    if (st == SV_OK) {
        lod->select = sl_select;
        lod->select_data = L;
        L = NULL;
    }
out:
    free(L);
    free(w.tris);
    free(w.proj);
    free(w.area);
    free(w.kmin);
    free(w.kmax);
    return st;
}

/* On failure the partial stand-in is freed (out is left zeroed). */
static sv_status sl_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                        sv_error *err)
{
    sv_status st = sl_build(in, settings, out, err);
    if (st) sv_stand_in_free(out);
    return st;
}

/* method.h planes_json: each slicing's direction, quads and the blending rule
 * (sv_slicing_describe). */
static void sl_planes_json(const sv_lod_plan *lod, const struct sv_baked_lod *baked,
                           uint32_t source_triangles, cJSON *entry, cJSON *quads)
{
    (void)baked;
    (void)source_triangles;
    (void)quads;
    cJSON *slicing = sv_slicing_describe(lod);
    if (slicing) cJSON_AddItemToObject(entry, "slicing", slicing);
}

const sv_method_ops sv_method_slicing_ops = {
    .method = &sv_method_slicing,
    .run = sl_run,
    .planes_json = sl_planes_json,
};
