/* plausibility.c — size and up-axis checks of an imported tree (plausibility.h). */
#include "plausibility.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"

/* Position of triangle t's centroid along axis k. */
static double centroid_along(const sv_mesh *m, uint32_t t, int k)
{
    double c = 0;
    for (int v = 0; v < 3; v++) c += m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + k];
    return c / 3;
}

typedef struct pos_area {
    double pos, area;
} pos_area;

static int pos_cmp(const void *a, const void *b)
{
    const pos_area *x = a, *y = b;
    return (x->pos > y->pos) - (x->pos < y->pos);
}

/* Area-weighted median position along axis k of the trunk triangles'
 * centroids. NAN when there are none or on allocation failure. */
static double trunk_median(const sv_mesh *m, const uint8_t *tri_part, int k)
{
    pos_area *ta = malloc((size_t)m->triangle_count * sizeof *ta + 1);
    if (!ta) return NAN;
    uint32_t n = 0;
    double total = 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (tri_part && tri_part[t] != SV_PART_TRUNK) continue;
        double a = sv_tri_area(m, t);
        if (!(a > 0)) continue;
        ta[n++] = (pos_area){centroid_along(m, t, k), a};
        total += a;
    }
    double med = NAN;
    if (n) {
        qsort(ta, n, sizeof *ta, pos_cmp);
        double acc = 0;
        for (uint32_t i = 0; i < n && !isfinite(med); i++)
            if ((acc += ta[i].area) >= 0.5 * total) med = ta[i].pos;
    }
    free(ta);
    return med;
}

/* Whether triangle t's centroid lies within SV_UP_COLUMN x the box's longest
 * side (extents e) of the line along axis k through mid[]. */
static bool in_column(const sv_mesh *m, uint32_t t, int k, const double mid[3], const double e[3])
{
    int p = (k + 1) % 3, q = (k + 2) % 3;
    double rho = SV_UP_COLUMN * fmax(e[0], fmax(e[1], e[2]));
    double dp = centroid_along(m, t, p) - mid[p], dq = centroid_along(m, t, q) - mid[q];
    return dp * dp + dq * dq <= rho * rho;
}

/* The area-weighted share of the squared normal component along axis k of
 * the trunk triangles in the column along k through mid[] (in_column),
 * leaving out flat caps (|n . k| > SV_UP_CAP: soil, a pot's floor): how
 * much the trunk's surface there faces along k; half[0] for the part of the
 * column below mid[k], half[1] above it (NAN where there is none). Returns
 * the smaller of the two: the stem's half, where one tube runs along the
 * column, rather than the crown's, where branches cross it. */
static double column_share(const sv_mesh *m, const uint8_t *tri_part, int k, const double mid[3],
                           const double e[3], double half[2])
{
    double along[2] = {0, 0}, total[2] = {0, 0};
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if ((tri_part && tri_part[t] != SV_PART_TRUNK) || !in_column(m, t, k, mid, e)) continue;
        double nn[3];
        sv_tri_normal(m, t, nn);
        double a = sv_tri_area(m, t);
        if (!(a > 0) || fabs(nn[k]) > SV_UP_CAP) continue;
        int h = centroid_along(m, t, k) > mid[k];
        along[h] += a * nn[k] * nn[k];
        total[h] += a;
    }
    for (int h = 0; h < 2; h++) half[h] = total[h] > 0 ? along[h] / total[h] : NAN;
    return isfinite(half[0]) && isfinite(half[1]) ? fmin(half[0], half[1])
           : isfinite(half[0])                    ? half[0]
                                                  : half[1];
}

/* The trunk area of the column along Z through mid[] in the lowest and the
 * highest quarter of the column's extent along Z. */
static void column_ends(const sv_mesh *m, const uint8_t *tri_part, const double mid[3],
                        const double e[3], double *lo_a, double *hi_a)
{
    double lo = INFINITY, hi = -INFINITY;
    *lo_a = *hi_a = 0;
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            if ((tri_part && tri_part[t] != SV_PART_TRUNK) || !in_column(m, t, 2, mid, e)) continue;
            double z = centroid_along(m, t, 2);
            if (pass == 0) {
                lo = fmin(lo, z);
                hi = fmax(hi, z);
            } else if (z <= lo + 0.25 * (hi - lo)) {
                *lo_a += sv_tri_area(m, t);
            } else if (z >= hi - 0.25 * (hi - lo)) {
                *hi_a += sv_tri_area(m, t);
            }
        }
}

/* The trunk area reaching within SV_UP_SLAB x the box's longest side of
 * the box's lowest Y (a[0]), lowest Z (a[1]) and highest Z (a[2]). */
static void extreme_slabs(const sv_mesh *m, const uint8_t *tri_part, const double bmn[3],
                          const double bmx[3], double a[3])
{
    double w = SV_UP_SLAB * fmax(bmx[0] - bmn[0], fmax(bmx[1] - bmn[1], bmx[2] - bmn[2]));
    a[0] = a[1] = a[2] = 0;
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
        double area = sv_tri_area(m, t);
        if (lo[1] - bmn[1] <= w) a[0] += area;
        if (lo[2] - bmn[2] <= w) a[1] += area;
        if (bmx[2] - hi[2] <= w) a[2] += area;
    }
}

/* -1: a > SV_UP_ROOT x b, +1: b > SV_UP_ROOT x a, 0: neither. */
static int which_end(double a, double b)
{
    return a > SV_UP_ROOT * b ? -1 : b > SV_UP_ROOT * a ? 1 : 0;
}

void sv_detect_up(const sv_mesh *m, const uint8_t *tri_part, sv_up_guess *g)
{
    memset(g, 0, sizeof *g);
    double bmn[3], bmx[3];
    if (!m || !sv_mesh_bounds(m, bmn, bmx)) {
        snprintf(g->reason, sizeof g->reason, "empty mesh");
        return;
    }
    g->height = bmx[1] - bmn[1];
    double e[3], mid[3];
    for (int k = 0; k < 3; k++) {
        e[k] = bmx[k] - bmn[k];
        mid[k] = trunk_median(m, tri_part, k);
    }
    if (!isfinite(mid[0])) {
        snprintf(g->reason, sizeof g->reason, "no trunk triangles: up axis not checked");
        return;
    }
    /* The trunk's axis (tube walls face away from it), in a column along Y
     * and one along Z through the trunk's median point. */
    double hy[2], hz[2];
    double sy = column_share(m, tri_part, 1, mid, e, hy),
           sz = column_share(m, tri_part, 2, mid, e, hz);
    g->normal_y = sy;
    g->normal_z = sz;
    double py = isfinite(sy) ? 100 * sy : 0, pz = isfinite(sz) ? 100 * sz : 0;
    int axis = 0; /* 1: Y, 2: Z, 0: unclear; a column with no trunk but caps in it
                     (a flat cut-out seen edge on) leaves the other to decide */
    if (isfinite(sy) && isfinite(sz))
        axis = sz >= SV_UP_RATIO * sy ? 1 : sy >= SV_UP_RATIO * sz ? 2 : 0;
    else if (isfinite(sy)) axis = sy < SV_UP_TUBE_SHARE ? 1 : 0;
    else if (isfinite(sz)) axis = sz < SV_UP_TUBE_SHARE ? 2 : 0;
    /* Its root: the stem's thicker end (the column's trunk area in its lowest
     * and highest quarter along Z), and where the trunk meets the box's
     * extremes (the base sits at one). */
    double lo_a, hi_a, slab[3];
    column_ends(m, tri_part, mid, e, &lo_a, &hi_a);
    extreme_slabs(m, tri_part, bmn, bmx, slab);
    int thick = which_end(lo_a, hi_a), end = 0;
    if (e[2] > 0 && fmax(slab[1], slab[2]) > SV_UP_SLAB_RATIO * slab[0])
        end = slab[1] >= slab[2] ? -1 : 1;
    if (axis == 1 && !(end && thick == end)) {
        snprintf(g->reason, sizeof g->reason,
                 "the trunk runs along Y (in columns through it %.0f %% of its surface faces along "
                 "Y, %.0f %% along Z)",
                 py, pz);
        return;
    }
    if (axis == 1) { /* both root signals contradict the axis */
        g->unsure = true;
        snprintf(g->reason, sizeof g->reason,
                 "the trunk runs along Y (in columns through it %.0f %% of its surface faces along "
                 "Y, %.0f %% along Z) but its thicker end and most of it at the box's extremes "
                 "are at the %s Z",
                 py, pz, end < 0 ? "lowest" : "highest");
        return;
    }
    int root = 0; /* -1: lowest Z, +1: highest Z */
    if (axis == 2) root = thick ? (end && end != thick ? 0 : thick) : end;
    else if (end && (!thick || thick == end)) root = end; /* unclear axis: the extremes, */
    /* unless the stem's thickness says the other end */
    else if (slab[0] > 0 && !end) {
        snprintf(g->reason, sizeof g->reason,
                 "the trunk's direction is unclear (in columns through it %.0f %% of its surface "
                 "faces along Y, %.0f %% along Z) but its base sits at the lowest Y",
                 py, pz);
        return;
    }
    if (!root) {
        g->unsure = true;
        snprintf(g->reason, sizeof g->reason,
                 "%s (in columns through it %.0f %% of its surface faces along Y, %.0f %% along "
                 "Z); its lowest and highest quarter along Z hold %.3g and %.3g m^2, the lowest "
                 "Y, lowest Z and highest Z %.3g, %.3g and %.3g m^2",
                 axis == 2 ? "the trunk runs along Z but its root is unclear"
                           : "the trunk's direction is unclear",
                 py, pz, lo_a, hi_a, slab[0], slab[1], slab[2]);
        return;
    }
    g->z_up = root < 0 ? 1 : -1;
    g->height = e[2];
    snprintf(g->reason, sizeof g->reason,
             "the trunk %s (in columns through it %.0f %% of its surface faces along Y, %.0f %% "
             "along Z) and its root is at the %s Z (its quarters there hold %.3g against %.3g "
             "m^2)",
             axis == 2 ? "runs along Z" : "may run along Z", py, pz,
             root < 0 ? "lowest" : "highest", root < 0 ? lo_a : hi_a, root < 0 ? hi_a : lo_a);
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

void sv_point_rotate_up(double p[3], int z_up)
{
    if (!p || !z_up) return;
    double s = z_up > 0 ? 1.0 : -1.0, y = p[1], z = p[2];
    p[1] = s * z;
    p[2] = -s * y + 0.0; /* no -0 in the outputs */
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
    else if (g && g->z_up)
        append(buf, cap,
               "import.up \"auto\" rotated the tree upright: it looked %s (%s); set import.up "
               "to \"Y\" to keep the file's axis",
               g->z_up > 0 ? "Z-up" : "upside down along Z", g->reason);
    else if (g && g->unsure)
        append(buf, cap,
               "the up axis could not be told from the trunk (%s): the file's axis was kept; "
               "set import.up if the tree lies down",
               g->reason);
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

/* ---- units ---- */

/* The area-weighted median of n (value, weight) pairs (sorted in place). */
static double weighted_median(pos_area *v, uint32_t n)
{
    double total = 0, acc = 0;
    for (uint32_t i = 0; i < n; i++) total += v[i].area;
    qsort(v, n, sizeof *v, pos_cmp);
    for (uint32_t i = 0; i < n; i++)
        if ((acc += v[i].area) >= 0.5 * total) return v[i].pos;
    return NAN;
}

/* The trunk's diameter near the base (sv_check_units); 0 when not measured. */
static double trunk_diameter(const sv_mesh *m, const uint8_t *tri_part, double ymin, double h)
{
    pos_area *r = malloc((size_t)m->triangle_count * sizeof *r + 1);
    if (!r) return 0;
    double lo = ymin + 0.02 * h, hi = ymin + 0.15 * h, c[2] = {0, 0}, total = 0;
    uint32_t n = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            if (tri_part && tri_part[t] != SV_PART_TRUNK) continue;
            double ylo = INFINITY, yhi = -INFINITY, nn[3];
            for (int v = 0; v < 3; v++) {
                double y = m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + 1];
                ylo = fmin(ylo, y), yhi = fmax(yhi, y);
            }
            if (yhi < lo || ylo > hi) continue; /* (a low-poly stem's triangles span it) */
            sv_tri_normal(m, t, nn);
            double a = sv_tri_area(m, t);
            if (!(a > 0) || fabs(nn[1]) > 0.5) continue; /* a wall, not a cap or soil */
            double x = centroid_along(m, t, 0), z = centroid_along(m, t, 2);
            if (pass == 0) c[0] += a * x, c[1] += a * z, total += a;
            else r[n++] = (pos_area){hypot(x - c[0], z - c[1]), a};
        }
        if (!(total > 0)) break;
        if (pass == 0) c[0] /= total, c[1] /= total;
    }
    double d = n ? 2 * weighted_median(r, n) : 0;
    free(r);
    return isfinite(d) ? d : 0;
}

/* A measure of the units check: its value as read, its plausible range and
 * a typical value with its spread (log scale), metres. */
typedef struct measure {
    const char *what;
    double v, lo, hi, typical, spread;
} measure;

/* How far the sizes a factor f gives are from the typical ones: the sum of
 * their squared log distances, each over its spread. */
static double atypical(const measure *ms, int n, double f)
{
    double s = 0;
    for (int i = 0; i < n; i++) {
        if (!(ms[i].v > 0)) continue;
        double d = (log(f * ms[i].v) - log(ms[i].typical)) / ms[i].spread;
        s += d * d;
    }
    return s;
}

void sv_check_units(const sv_mesh *m, const uint8_t *tri_part, const sv_leaves *leaves,
                    double unit_scale, double height, sv_units_guess *u)
{
    memset(u, 0, sizeof *u);
    double scale = unit_scale > 0 ? unit_scale : 1;
    u->factor = 1;
    u->metres_per_unit = scale;
    u->height = height;
    double mn[3], mx[3];
    if (m && sv_mesh_bounds(m, mn, mx) && height > 0)
        u->trunk_diameter = trunk_diameter(m, tri_part, mn[1], mx[1] - mn[1]);
    bool cards = false;
    /* elements of more than SV_UNITS_MASS_TRIS triangles are foliage masses
     * (a conifer's), not leaves: their size says nothing of the units */
    if (leaves && leaves->count && leaves->median_area > 0 &&
        leaves->tri_count <= SV_UNITS_MASS_TRIS * (uint64_t)leaves->count) {
        u->leaf_size = sqrt(leaves->median_area);
        cards = leaves->tri_count <= 4 * (uint64_t)leaves->count; /* quads, not modelled leaves */
    }
    measure ms[3] = {
        {"tall", u->height, SV_UNITS_H_MIN, SV_UNITS_H_MAX, SV_UNITS_H_TYPICAL, 1.5},
        {"across its median leaf element", u->leaf_size, SV_UNITS_L_MIN, SV_UNITS_L_MAX,
         cards ? SV_UNITS_CARD_TYPICAL : SV_UNITS_LEAF_TYPICAL, 1.0},
        {"across its trunk near the base", u->trunk_diameter, SV_UNITS_D_MIN, SV_UNITS_D_MAX,
         SV_UNITS_D_TYPICAL, 2.0},
    };
    double flo = 0, fhi = INFINITY; /* the factors that bring every measure in range */
    char what[200] = "";
    for (int i = 0; i < 3; i++) {
        if (!(ms[i].v > 0) || !isfinite(ms[i].v)) {
            ms[i].v = 0;
            continue;
        }
        flo = fmax(flo, ms[i].lo / ms[i].v);
        fhi = fmin(fhi, ms[i].hi / ms[i].v);
        if (ms[i].v < ms[i].lo || ms[i].v > ms[i].hi) {
            size_t l = strlen(what);
            snprintf(what + l, sizeof what - l, "%s%.3g m %s", l ? ", " : "", ms[i].v, ms[i].what);
        }
    }
    if (!what[0]) return; /* plausible as read */
    u->implausible = true;
    u->factor = 0;
    /* The unit: of m, cm, mm and 0.1 m (ez-tree's and other generators' units
     * come near it) the one in range whose sizes are the most typical; only
     * when none is in range, in, ft or another power of ten of a metre. */
    static const struct {
        const char *name;
        double metres;
    } common[] = {{"m", 1}, {"cm", 0.01}, {"mm", 0.001}, {"0.1", 0.1}};
    double best = INFINITY;
    for (int phase = 0; phase < 2 && u->factor == 0; phase++) {
        int n = phase == 0 ? 4 : 2 + 13;
        for (int k = 0; k < n; k++) {
            double metres;
            char name[24];
            if (phase == 0) {
                metres = common[k].metres;
                snprintf(name, sizeof name, "%s", common[k].name);
            } else if (k < 2) {
                metres = k == 0 ? 0.0254 : 0.3048;
                snprintf(name, sizeof name, "%s", k == 0 ? "in" : "ft");
            } else {
                int e = k - 2 - 6; /* 1e-6 .. 1e6 (import.units' range); the common
                                      ones are phase 0's */
                if (e >= -3 && e <= 0) continue;
                metres = pow(10, e);
                snprintf(name, sizeof name, "%g", metres);
            }
            double f = metres / scale;
            if (!(flo <= fhi) || f < flo || f > fhi || fabs(f - 1) < 1e-9) continue;
            double score = atypical(ms, 3, f);
            if (score < best) {
                best = score;
                u->factor = f;
                snprintf(u->unit, sizeof u->unit, "%s", name);
            }
        }
    }
    if (u->factor > 0) {
        u->metres_per_unit = scale * u->factor;
        size_t l = (size_t)snprintf(u->reason, sizeof u->reason,
                                    "read at %g m a unit the tree is %s; at %g m a unit it "
                                    "would be %.3g m tall",
                                    scale, what, u->metres_per_unit, u->factor * u->height);
        if (u->leaf_size > 0 && l < sizeof u->reason)
            l += (size_t)snprintf(u->reason + l, sizeof u->reason - l,
                                  ", its leaf elements %.3g m across", u->factor * u->leaf_size);
        if (u->trunk_diameter > 0 && l < sizeof u->reason)
            snprintf(u->reason + l, sizeof u->reason - l, ", its trunk %.3g m",
                     u->factor * u->trunk_diameter);
    } else {
        u->metres_per_unit = 0;
        snprintf(u->reason, sizeof u->reason,
                 "read at %g m a unit the tree is %s, and no unit makes its height, leaves and "
                 "trunk all plausible",
                 scale, what);
    }
}

void sv_units_warning(const sv_units_guess *u, char *buf, size_t cap)
{
    if (!u || !u->implausible || !buf || cap == 0) return;
    bool named = u->unit[0] >= 'a' && u->unit[0] <= 'z'; /* a name; else metres per unit */
    if (u->factor > 0)
        append(buf, cap,
               "the units look wrong: %s; if so, pass --units %s (spec \"import\": {\"units\": "
               "%s%s%s})",
               u->reason, u->unit, named ? "\"" : "", u->unit, named ? "\"" : "");
    else
        append(buf, cap, "the size looks wrong: %s; check --units (spec \"import\": {\"units\"})",
               u->reason);
}
