/* classify.c — foliage vs trunk per material, and leaf elements.
 *
 * Leaf elements are the unit of Garcia, Sbert & Szirmay-Kalos, "Leaf cluster
 * impostors for tree rendering with parallax" (§2: each leaf is a planar element
 * with a centre and a normal). Their normals are averaged after flipping into one
 * half-space, as Behrendt et al., "Realistic real-time rendering of landscapes
 * using billboard clouds" §3.3.3 do for two-sided leaves, so back-to-back faces
 * do not cancel.
 *
 * Classification rules, per material, first match wins (the reason is recorded):
 *   1. Caller's lists (sv_classify_options): exact names (case-insensitive) first,
 *      then fnmatch globs (case-insensitive); the foliage list before the trunk list.
 *   2. Material evidence:
 *      a. alpha mode MASK or BLEND                              → foliage
 *      b. name contains a foliage word (FOLIAGE_WORDS below)   → foliage
 *      c. base texture with cut-out alpha: between 5% and 95% of its texels have
 *         alpha below the cutoff (alpha cards whose file format says nothing,
 *         e.g. an OBJ without map_d)                             → foliage
 *      d. name contains a trunk word (TRUNK_WORDS below)        → trunk
 *   3. Connected components (positions welded within 1e-5 × the bounding radius,
 *      each material on its own): a component is a "small flat piece" when its
 *      bounding-box diagonal is at most 1/4 of the tree's diameter, its area at
 *      most 5% of the mesh's area, and its normals agree (largest eigenvalue of
 *      Σ a·n nᵀ at least 0.6 of Σ a, i.e. one dominant direction). A material
 *      with more than half of its triangles in such pieces is foliage, otherwise
 *      trunk. Materials without triangles are trunk.
 * Pot, soil and ground count as trunk ("not foliage").
 */
#include "classify.h"
#include "eigen3.h"
#include "vec3.h"

#include <ctype.h>
#include <fnmatch.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const FOLIAGE_WORDS[] = {
    "leaf",        "leaves",     "foliage",     "needle", "twig",    "frond",
    "branch-card", "branchcard", "branch_card", "card",   "blossom", "petal",
    "flower",      "grass",      "fern",        "ivy",    NULL};
static const char *const TRUNK_WORDS[] = {"bark",  "trunk", "wood",  "stem", "branch", "root",
                                          "stump", "limb",  "pot",   "soil", "ground", "earth",
                                          "dirt",  "rock",  "stone", NULL};

#define WELD_REL_TOL 1e-5   /* weld tolerance, relative to the bounding radius */
#define SMALL_DIAG_REL 0.25 /* rule 3: piece diagonal <= this × tree diameter */
#define SMALL_AREA_REL 0.05 /* rule 3: piece area <= this × mesh area */
#define FLAT_COHERENCE 0.6  /* rule 3: λmax(Σ a n nᵀ) / Σ a */
#define ALPHA_CARD_MIN 0.05 /* rule 2c: transparent fraction range of a cut-out */
#define ALPHA_CARD_MAX 0.95
#define SPLIT_AREA 16.0     /* leaves: split pieces with area > 16 × median */
#define SPLIT_RADIUS 4.0    /* ... or radius > 4 × the median radius */
#define SPLIT_COHERENCE 0.8 /* ... or normals spread (crossed cards, needle tufts) */
#define SPLIT_MAX_DEPTH 48

/* ---------- small linear algebra ---------- */

/* Eigen-decomposition of the symmetric 3×3 matrix m (row-major) through the
 * shared Jacobi solver (eigen3.h): val[] descending, vec[i] the unit eigenvector
 * of val[i]. Non-finite input gives zero values and the identity basis. */
static void eigen_sym3(const double m[9], double val[3], double vec[3][3])
{
    double a[3][3], v[3], e[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) a[i][j] = m[3 * i + j];
    sv_eigen3_symmetric(a, v, e);
    for (int i = 0; i < 3; i++) {
        val[i] = v[2 - i];
        memcpy(vec[i], e[2 - i], sizeof vec[i]);
    }
}

static void tri_centroid(const sv_mesh *m, uint32_t t, double c[3])
{
    const uint32_t *ix = &m->indices[3 * (size_t)t];
    for (int k = 0; k < 3; k++)
        c[k] = ((double)m->positions[3 * (size_t)ix[0] + k] +
                (double)m->positions[3 * (size_t)ix[1] + k] +
                (double)m->positions[3 * (size_t)ix[2] + k]) /
               3.0;
}

/* ---------- welding (hash grid) and connected components ---------- */

typedef struct cell_slot {
    int64_t x, y, z;
    uint32_t head; /* first representative vertex in the cell, UINT32_MAX = empty */
} cell_slot;

static uint64_t cell_hash(int64_t x, int64_t y, int64_t z)
{
    uint64_t h = (uint64_t)x * 0x9E3779B97F4A7C15ull;
    h ^= (uint64_t)y * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= (uint64_t)z * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    h ^= h >> 29;
    return h;
}

/* weld[v] = representative of v: the lowest-index earlier vertex within `tol`
 * (Euclidean) found in the 27 neighbouring cells of size tol, else v itself.
 * Vertices are visited in index order, so the result is deterministic. O(V). */
static sv_status weld_vertices(const sv_mesh *m, double tol, uint32_t **out, sv_error *err)
{
    uint32_t n = m->vertex_count;
    *out = NULL;
    uint32_t *weld = sv_calloc(n ? n : 1, sizeof *weld);
    uint32_t *next = sv_calloc(n ? n : 1, sizeof *next);
    size_t cap = 16;
    while (cap < 2 * (size_t)n) cap <<= 1;
    cell_slot *tab = sv_calloc(cap, sizeof *tab);
    if (!weld || !next || !tab) {
        free(weld);
        free(next);
        free(tab);
        return sv_fail(err, SV_ERR_NOMEM, "no memory to weld %u vertices", n);
    }
    for (size_t i = 0; i < cap; i++) tab[i].head = UINT32_MAX;
    double mn[3] = {INFINITY, INFINITY, INFINITY};
    for (uint32_t v = 0; v < n; v++)
        for (int k = 0; k < 3; k++)
            if (m->positions[3 * (size_t)v + k] < mn[k]) mn[k] = m->positions[3 * (size_t)v + k];
    double cell = tol > 0 ? tol : 1.0, tol2 = tol * tol;
    for (uint32_t v = 0; v < n; v++) {
        const float *p = &m->positions[3 * (size_t)v];
        int64_t c[3];
        for (int k = 0; k < 3; k++) c[k] = (int64_t)floor(((double)p[k] - mn[k]) / cell);
        uint32_t found = UINT32_MAX;
        for (int dx = -1; dx <= 1; dx++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dz = -1; dz <= 1; dz++) {
                    int64_t x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
                    size_t s = (size_t)(cell_hash(x, y, z) & (cap - 1));
                    while (tab[s].head != UINT32_MAX &&
                           (tab[s].x != x || tab[s].y != y || tab[s].z != z))
                        s = (s + 1) & (cap - 1);
                    for (uint32_t r = tab[s].head; r != UINT32_MAX; r = next[r]) {
                        if (r >= found) continue;
                        const float *q = &m->positions[3 * (size_t)r];
                        double d2 = 0;
                        for (int k = 0; k < 3; k++) {
                            double d = (double)p[k] - (double)q[k];
                            d2 += d * d;
                        }
                        if (d2 <= tol2) found = r;
                    }
                }
        if (found != UINT32_MAX) {
            weld[v] = found;
            continue;
        }
        weld[v] = v;
        size_t s = (size_t)(cell_hash(c[0], c[1], c[2]) & (cap - 1));
        while (tab[s].head != UINT32_MAX &&
               (tab[s].x != c[0] || tab[s].y != c[1] || tab[s].z != c[2]))
            s = (s + 1) & (cap - 1);
        if (tab[s].head == UINT32_MAX) {
            tab[s].x = c[0];
            tab[s].y = c[1];
            tab[s].z = c[2];
            next[v] = UINT32_MAX;
        } else {
            next[v] = tab[s].head;
        }
        tab[s].head = v;
    }
    free(next);
    free(tab);
    *out = weld;
    return SV_OK;
}

static uint32_t uf_find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

static void uf_union(uint32_t *parent, uint32_t a, uint32_t b)
{
    a = uf_find(parent, a);
    b = uf_find(parent, b);
    if (a == b) return;
    if (a < b) parent[b] = a;
    else parent[a] = b;
}

/* Connected components of the triangles t with include[t] != 0, joined through
 * shared welded vertices (and, when per_material, only within one material).
 * comp[t] = dense component id numbered by lowest triangle index, UINT32_MAX
 * for excluded triangles; *count receives the number of components. */
static sv_status components(const sv_mesh *m, const uint32_t *weld, const uint8_t *include,
                            bool per_material, uint32_t *comp, uint32_t *count, sv_error *err)
{
    uint32_t T = m->triangle_count, V = m->vertex_count;
    uint32_t *parent = sv_calloc(T ? T : 1, sizeof *parent);
    uint32_t *owner = sv_calloc(V ? V : 1, sizeof *owner);
    uint32_t *stamp = sv_calloc(V ? V : 1, sizeof *stamp);
    uint32_t *order = sv_calloc(T ? T : 1, sizeof *order);
    uint32_t *start = sv_calloc((size_t)m->material_count + 2, sizeof *start);
    sv_status st = SV_OK;
    if (!parent || !owner || !stamp || !order || !start) {
        st = sv_fail(err, SV_ERR_NOMEM, "no memory for connected components of %u triangles", T);
        goto out;
    }
    /* Visit triangles grouped by material (counting sort) when per_material, so a
     * vertex's owner is always a triangle of the current material. */
    uint32_t groups = per_material ? m->material_count : 1;
    for (uint32_t t = 0; t < T; t++) {
        parent[t] = t;
        start[(per_material ? m->tri_material[t] : 0) + 1]++;
    }
    for (uint32_t g = 0; g < groups; g++) start[g + 1] += start[g];
    {
        uint32_t *cursor = sv_calloc((size_t)groups + 1, sizeof *cursor);
        if (!cursor) {
            st = sv_fail(err, SV_ERR_NOMEM, "no memory for connected components");
            goto out;
        }
        memcpy(cursor, start, (size_t)groups * sizeof *cursor);
        for (uint32_t t = 0; t < T; t++) order[cursor[per_material ? m->tri_material[t] : 0]++] = t;
        free(cursor);
    }
    for (uint32_t g = 0; g < groups; g++) {
        for (uint32_t i = start[g]; i < start[g + 1]; i++) {
            uint32_t t = order[i];
            if (!include[t]) continue;
            for (int j = 0; j < 3; j++) {
                uint32_t w = weld[m->indices[3 * (size_t)t + j]];
                if (stamp[w] != g + 1) {
                    stamp[w] = g + 1;
                    owner[w] = t;
                } else {
                    uf_union(parent, t, owner[w]);
                }
            }
        }
    }
    uint32_t n = 0;
    for (uint32_t t = 0; t < T; t++) {
        if (!include[t]) {
            comp[t] = UINT32_MAX;
            continue;
        }
        uint32_t r = uf_find(parent, t);
        comp[t] = (r == t) ? n++ : comp[r]; /* the root is the lowest index: seen first */
    }
    *count = n;
out:
    free(parent);
    free(owner);
    free(stamp);
    free(order);
    free(start);
    return st;
}

/* ---------- classification ---------- */

static void lower_copy(char *dst, size_t cap, const char *src)
{
    size_t i = 0;
    for (; src[i] && i + 1 < cap; i++) dst[i] = (char)tolower((unsigned char)src[i]);
    dst[i] = 0;
}

/* Index of the first caller pattern matching name (exact pass, then glob pass). */
static bool list_match(const char *name, const char *const *list, size_t n, bool glob,
                       const char **which)
{
    char lname[128], lpat[256];
    lower_copy(lname, sizeof lname, name);
    for (size_t i = 0; i < n; i++) {
        if (!list[i]) continue;
        lower_copy(lpat, sizeof lpat, list[i]);
        bool hit = glob ? fnmatch(lpat, lname, 0) == 0 : strcmp(lpat, lname) == 0;
        if (hit) {
            *which = list[i];
            return true;
        }
    }
    return false;
}

static const char *word_match(const char *name, const char *const *words)
{
    char lname[128];
    lower_copy(lname, sizeof lname, name);
    for (size_t i = 0; words[i]; i++)
        if (strstr(lname, words[i])) return words[i];
    return NULL;
}

/* Fraction of texels of image img with alpha below cutoff; -1 when the image
 * has no alpha channel or no pixels. */
static double transparent_fraction(const sv_image *img, double cutoff)
{
    if (!img || !img->data || img->channels != 4 || !img->width || !img->height) return -1;
    size_t n = (size_t)img->width * img->height, below = 0;
    if (img->bits == 8) {
        const uint8_t *p = img->data;
        double lim = cutoff * 255.0;
        for (size_t i = 0; i < n; i++) below += (double)p[4 * i + 3] < lim;
    } else if (img->bits == 16) {
        const uint16_t *p = img->data;
        double lim = cutoff * 65535.0;
        for (size_t i = 0; i < n; i++) below += (double)p[4 * i + 3] < lim;
    } else {
        return -1;
    }
    return (double)below / (double)n;
}

typedef struct comp_stats {
    double area;
    double mn[3], mx[3];
    double nn[6]; /* Σ a n nᵀ: xx xy xz yy yz zz */
} comp_stats;

static void set_reason(sv_material_class *mc, sv_part part, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void set_reason(sv_material_class *mc, sv_part part, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(mc->reason, sizeof mc->reason, fmt, ap);
    va_end(ap);
    mc->part = part;
}

/* Rule 3 for the materials with undecided[mi] set. */
static sv_status classify_by_components(const sv_mesh *m, const uint8_t *undecided,
                                        sv_material_class *mats, sv_error *err)
{
    uint32_t T = m->triangle_count, M = m->material_count;
    double centre[3], radius;
    sv_mesh_sphere(m, centre, &radius);
    uint32_t *weld = NULL, *comp = NULL, ncomp = 0;
    uint8_t *include = sv_calloc(T ? T : 1, 1);
    uint32_t *flat_tris = sv_calloc(M ? M : 1, sizeof *flat_tris);
    uint32_t *flat_pieces = sv_calloc(M ? M : 1, sizeof *flat_pieces);
    comp_stats *cs = NULL;
    uint8_t *small = NULL;
    comp = sv_calloc(T ? T : 1, sizeof *comp);
    sv_status st = SV_OK;
    if (!include || !comp || !flat_tris || !flat_pieces) {
        st = sv_fail(err, SV_ERR_NOMEM, "no memory for component analysis");
        goto out;
    }
    double total_area = 0;
    for (uint32_t t = 0; t < T; t++) {
        include[t] = undecided[m->tri_material[t]];
        total_area += sv_tri_area(m, t);
    }
    if ((st = weld_vertices(m, WELD_REL_TOL * radius, &weld, err))) goto out;
    if ((st = components(m, weld, include, true, comp, &ncomp, err))) goto out;
    cs = sv_calloc(ncomp ? ncomp : 1, sizeof *cs);
    small = sv_calloc(ncomp ? ncomp : 1, 1);
    if (!cs || !small) {
        st = sv_fail(err, SV_ERR_NOMEM, "no memory for %u components", ncomp);
        goto out;
    }
    for (uint32_t c = 0; c < ncomp; c++)
        for (int k = 0; k < 3; k++) {
            cs[c].mn[k] = INFINITY;
            cs[c].mx[k] = -INFINITY;
        }
    for (uint32_t t = 0; t < T; t++) {
        if (comp[t] == UINT32_MAX) continue;
        comp_stats *s = &cs[comp[t]];
        double a = sv_tri_area(m, t), n[3];
        sv_tri_normal(m, t, n);
        s->area += a;
        s->nn[0] += a * n[0] * n[0];
        s->nn[1] += a * n[0] * n[1];
        s->nn[2] += a * n[0] * n[2];
        s->nn[3] += a * n[1] * n[1];
        s->nn[4] += a * n[1] * n[2];
        s->nn[5] += a * n[2] * n[2];
        for (int j = 0; j < 3; j++) {
            const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + j]];
            for (int k = 0; k < 3; k++) {
                if (p[k] < s->mn[k]) s->mn[k] = p[k];
                if (p[k] > s->mx[k]) s->mx[k] = p[k];
            }
        }
    }
    for (uint32_t c = 0; c < ncomp; c++) {
        comp_stats *s = &cs[c];
        double diag = 0;
        for (int k = 0; k < 3; k++) diag += (s->mx[k] - s->mn[k]) * (s->mx[k] - s->mn[k]);
        diag = sqrt(diag);
        double mat[9] = {s->nn[0], s->nn[1], s->nn[2], s->nn[1], s->nn[3],
                         s->nn[4], s->nn[2], s->nn[4], s->nn[5]};
        double val[3], vec[3][3];
        eigen_sym3(mat, val, vec);
        bool flat = s->area > 0 && val[0] >= FLAT_COHERENCE * s->area;
        small[c] = flat && diag <= SMALL_DIAG_REL * 2 * radius &&
                   s->area <= SMALL_AREA_REL * total_area;
    }
    for (uint32_t t = 0; t < T; t++) {
        uint32_t c = comp[t];
        if (c == UINT32_MAX || !small[c]) continue;
        flat_tris[m->tri_material[t]]++;
        if (small[c] == 1) { /* count each piece once */
            flat_pieces[m->tri_material[t]]++;
            small[c] = 2;
        }
    }
    for (uint32_t mi = 0; mi < M; mi++) {
        if (!undecided[mi]) continue;
        sv_material_class *mc = &mats[mi];
        if (mc->triangles == 0) {
            set_reason(mc, SV_PART_TRUNK, "no triangles");
            continue;
        }
        double frac = (double)flat_tris[mi] / mc->triangles;
        if (frac > 0.5)
            set_reason(mc, SV_PART_FOLIAGE,
                       "components: %.0f%% of its triangles in %u small flat pieces", 100 * frac,
                       flat_pieces[mi]);
        else
            set_reason(mc, SV_PART_TRUNK,
                       "components: only %.0f%% of its triangles in small flat pieces", 100 * frac);
    }
out:
    free(weld);
    free(comp);
    free(include);
    free(flat_tris);
    free(flat_pieces);
    free(cs);
    free(small);
    return st;
}

sv_status sv_classify(const sv_mesh *mesh, const sv_classify_options *opt, sv_classification *out,
                      sv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!mesh) return sv_fail(err, SV_ERR_INTERNAL, "sv_classify: NULL mesh");
    uint32_t T = mesh->triangle_count, M = mesh->material_count;
    for (uint32_t t = 0; t < T; t++)
        if (mesh->tri_material[t] >= M)
            return sv_fail(err, SV_ERR_INVALID, "triangle %u refers to material %u of %u", t,
                           mesh->tri_material[t], M);
    out->tri_part = sv_calloc(T ? T : 1, 1);
    out->materials = sv_calloc(M ? M : 1, sizeof *out->materials);
    uint8_t *undecided = sv_calloc(M ? M : 1, 1);
    double *img_frac = sv_calloc(mesh->image_count ? mesh->image_count : 1, sizeof(double));
    sv_status st = SV_OK;
    if (!out->tri_part || !out->materials || !undecided || !img_frac) {
        st = sv_fail(err, SV_ERR_NOMEM, "no memory to classify %u triangles", T);
        goto out;
    }
    out->material_count = M;
    for (uint32_t t = 0; t < T; t++) out->materials[mesh->tri_material[t]].triangles++;
    for (uint32_t i = 0; i < mesh->image_count; i++) img_frac[i] = -2; /* not computed */

    bool need_components = false;
    for (uint32_t mi = 0; mi < M; mi++) {
        const sv_material *mat = &mesh->materials[mi];
        sv_material_class *mc = &out->materials[mi];
        const char *which = NULL;
        if (opt) {
            bool done = false;
            for (int glob = 0; glob < 2 && !done; glob++) {
                if (list_match(mat->name, opt->foliage, opt->foliage_count, glob, &which)) {
                    set_reason(mc, SV_PART_FOLIAGE, "listed by caller as foliage ('%.100s')",
                               which);
                    done = true;
                } else if (list_match(mat->name, opt->trunk, opt->trunk_count, glob, &which)) {
                    set_reason(mc, SV_PART_TRUNK, "listed by caller as trunk ('%.100s')", which);
                    done = true;
                }
            }
            if (done) continue;
        }
        if (mat->alpha_mode == SV_ALPHA_MASK || mat->alpha_mode == SV_ALPHA_BLEND) {
            set_reason(mc, SV_PART_FOLIAGE, "alpha mode %s",
                       mat->alpha_mode == SV_ALPHA_MASK ? "MASK" : "BLEND");
            continue;
        }
        if ((which = word_match(mat->name, FOLIAGE_WORDS))) {
            set_reason(mc, SV_PART_FOLIAGE, "name contains '%s'", which);
            continue;
        }
        if (mat->base_texture >= 0 && (uint32_t)mat->base_texture < mesh->image_count) {
            int32_t ti = mat->base_texture;
            if (img_frac[ti] == -2) {
                double cutoff = mat->alpha_cutoff > 0 ? mat->alpha_cutoff : 0.5;
                img_frac[ti] = transparent_fraction(&mesh->images[ti], cutoff);
            }
            double f = img_frac[ti];
            if (f >= ALPHA_CARD_MIN && f <= ALPHA_CARD_MAX) {
                set_reason(mc, SV_PART_FOLIAGE,
                           "base texture has cut-out alpha (%.0f%% transparent texels)", 100 * f);
                continue;
            }
        }
        if ((which = word_match(mat->name, TRUNK_WORDS))) {
            set_reason(mc, SV_PART_TRUNK, "name contains '%s'", which);
            continue;
        }
        undecided[mi] = 1;
        need_components = true;
    }
    if (need_components && (st = classify_by_components(mesh, undecided, out->materials, err)))
        goto out;
    for (uint32_t t = 0; t < T; t++) {
        sv_part p = out->materials[mesh->tri_material[t]].part;
        out->tri_part[t] = (uint8_t)p;
        if (p == SV_PART_FOLIAGE) out->foliage_triangles++;
        else out->trunk_triangles++;
    }
out:
    free(undecided);
    free(img_frac);
    if (st) sv_classification_free(out);
    return st;
}

void sv_classification_free(sv_classification *c)
{
    if (!c) return;
    free(c->tri_part);
    free(c->materials);
    memset(c, 0, sizeof *c);
}

/* ---------- leaf elements ---------- */

typedef struct piece_stats {
    double area;
    double centre[3];
    double radius;
    double nval[3], nvec[3][3]; /* eigen of Σ a n nᵀ */
    double cval[3], cvec[3][3]; /* eigen of the area-weighted centroid covariance */
    double normal[3];
} piece_stats;

/* Stats of the triangles tris[0..n): area-weighted centre, flipped-average
 * normal (each triangle normal flipped into the half-space of the dominant
 * eigenvector of Σ a n nᵀ before summing; the sum's sign follows the unflipped
 * area-weighted majority, and, on an exact tie, has its largest-magnitude
 * component positive), radius, and the two eigen-decompositions. Centroids are
 * taken relative to the first vertex so far-off coordinates lose no precision. */
static void piece_compute(const sv_mesh *m, const uint32_t *tris, uint32_t n, piece_stats *ps)
{
    memset(ps, 0, sizeof *ps);
    double ref[3];
    for (int k = 0; k < 3; k++)
        ref[k] = m->positions[3 * (size_t)m->indices[3 * (size_t)tris[0]] + k];
    double nn[6] = {0}, sum_c[3] = {0}, plain_c[3] = {0}, raw_n[3] = {0};
    double area = 0;
    for (uint32_t i = 0; i < n; i++) {
        double a = sv_tri_area(m, tris[i]), nv[3], c[3];
        sv_tri_normal(m, tris[i], nv);
        tri_centroid(m, tris[i], c);
        for (int k = 0; k < 3; k++) {
            c[k] -= ref[k];
            sum_c[k] += a * c[k];
            plain_c[k] += c[k];
            raw_n[k] += a * nv[k];
        }
        area += a;
        nn[0] += a * nv[0] * nv[0];
        nn[1] += a * nv[0] * nv[1];
        nn[2] += a * nv[0] * nv[2];
        nn[3] += a * nv[1] * nv[1];
        nn[4] += a * nv[1] * nv[2];
        nn[5] += a * nv[2] * nv[2];
    }
    double cl[3];
    for (int k = 0; k < 3; k++) cl[k] = area > 0 ? sum_c[k] / area : plain_c[k] / n;
    double nm[9] = {nn[0], nn[1], nn[2], nn[1], nn[3], nn[4], nn[2], nn[4], nn[5]};
    eigen_sym3(nm, ps->nval, ps->nvec);
    const double *e = ps->nvec[0];
    double cov[6] = {0}, flip_n[3] = {0}, r2 = 0;
    for (uint32_t i = 0; i < n; i++) {
        double a = sv_tri_area(m, tris[i]), nv[3], c[3];
        sv_tri_normal(m, tris[i], nv);
        double s = sv_dot3(nv, e) < 0 ? -1 : 1;
        for (int k = 0; k < 3; k++) flip_n[k] += s * a * nv[k];
        tri_centroid(m, tris[i], c);
        for (int k = 0; k < 3; k++) c[k] -= ref[k] + cl[k];
        double w = area > 0 ? a : 1;
        cov[0] += w * c[0] * c[0];
        cov[1] += w * c[0] * c[1];
        cov[2] += w * c[0] * c[2];
        cov[3] += w * c[1] * c[1];
        cov[4] += w * c[1] * c[2];
        cov[5] += w * c[2] * c[2];
        for (int j = 0; j < 3; j++) {
            const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)tris[i] + j]];
            double d2 = 0;
            for (int k = 0; k < 3; k++) {
                double d = (double)p[k] - ref[k] - cl[k];
                d2 += d * d;
            }
            if (d2 > r2) r2 = d2;
        }
    }
    double cm[9] = {cov[0], cov[1], cov[2], cov[1], cov[3], cov[4], cov[2], cov[4], cov[5]};
    eigen_sym3(cm, ps->cval, ps->cvec);
    double l = sqrt(sv_dot3(flip_n, flip_n));
    if (l > 0) {
        for (int k = 0; k < 3; k++) ps->normal[k] = flip_n[k] / l;
    } else {
        memcpy(ps->normal, e, sizeof ps->normal);
        if (!(sv_dot3(e, e) > 0)) ps->normal[1] = 1;
    }
    double maj = sv_dot3(raw_n, ps->normal);
    double tie = 1e-9 * (area > 0 ? area : 1);
    bool flip;
    if (fabs(maj) > tie) {
        flip = maj < 0;
    } else {
        int big = 0;
        for (int k = 1; k < 3; k++)
            if (fabs(ps->normal[k]) > fabs(ps->normal[big]) * (1 + 1e-9)) big = k;
        flip = ps->normal[big] < 0;
    }
    if (flip)
        for (int k = 0; k < 3; k++) ps->normal[k] = -ps->normal[k];
    ps->area = area;
    for (int k = 0; k < 3; k++) ps->centre[k] = ref[k] + cl[k];
    ps->radius = sqrt(r2);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

typedef struct span {
    uint32_t start, count, depth;
} span;

typedef struct leaf_sort {
    sv_leaf leaf;
    uint32_t key; /* lowest triangle index */
} leaf_sort;

static int cmp_leaf(const void *a, const void *b)
{
    uint32_t x = ((const leaf_sort *)a)->key, y = ((const leaf_sort *)b)->key;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return (n & 1) ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Growable array of leaves (capacity explicit here, private). */
typedef struct leaf_vec {
    leaf_sort *v;
    uint32_t n, cap;
} leaf_vec;

static bool leaf_push(leaf_vec *lv, uint32_t start, uint32_t count)
{
    if (lv->n == lv->cap) {
        uint32_t cap = lv->cap ? lv->cap * 2 : 64;
        size_t bytes;
        if (cap < lv->cap || !sv_mul_size(cap, sizeof *lv->v, &bytes)) return false;
        leaf_sort *p = realloc(lv->v, bytes);
        if (!p) return false;
        lv->v = p;
        lv->cap = cap;
    }
    memset(&lv->v[lv->n], 0, sizeof lv->v[lv->n]);
    lv->v[lv->n].leaf.first = start;
    lv->v[lv->n].leaf.count = count;
    lv->n++;
    return true;
}

/* Stable partition of w[0..n) by side[i] (0 first, then 1) through tmp.
 * Returns the size of the first group. */
static uint32_t partition(uint32_t *w, uint32_t n, const uint8_t *side, uint32_t *tmp)
{
    uint32_t a = 0, b = 0;
    for (uint32_t i = 0; i < n; i++)
        if (!side[i]) w[a++] = w[i];
        else tmp[b++] = w[i];
    memcpy(w + a, tmp, (size_t)b * sizeof *w);
    return a;
}

sv_status sv_leaves_build(const sv_mesh *mesh, const sv_classification *c, sv_leaves *out,
                          sv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!mesh || !c || !c->tri_part)
        return sv_fail(err, SV_ERR_INTERNAL, "sv_leaves_build: NULL mesh or classification");
    uint32_t T = mesh->triangle_count, F = 0;
    for (uint32_t t = 0; t < T; t++) F += c->tri_part[t] == SV_PART_FOLIAGE;
    if (F == 0) return SV_OK; /* no foliage: no leaves, not an error */

    sv_status st = SV_OK;
    uint32_t *weld = NULL, *comp = NULL, ncomp = 0, *work = NULL, *tmp = NULL, *cstart = NULL;
    uint8_t *include = NULL, *side = NULL;
    double *areas = NULL, *radii = NULL;
    span *stack = NULL;
    leaf_vec lv = {0};
    double centre[3], radius;
    sv_mesh_sphere(mesh, centre, &radius);

    include = sv_calloc(T, 1);
    comp = sv_calloc(T, sizeof *comp);
    work = sv_calloc(F, sizeof *work);
    tmp = sv_calloc(F, sizeof *tmp);
    side = sv_calloc(F, 1);
    stack = sv_calloc((size_t)SPLIT_MAX_DEPTH + 2, sizeof *stack);
    if (!include || !comp || !work || !tmp || !side || !stack) goto nomem;
    for (uint32_t t = 0; t < T; t++) include[t] = c->tri_part[t] == SV_PART_FOLIAGE;
    if ((st = weld_vertices(mesh, WELD_REL_TOL * radius, &weld, err))) goto out;
    if ((st = components(mesh, weld, include, false, comp, &ncomp, err))) goto out;

    /* Group triangles by component (counting sort keeps ascending order inside). */
    cstart = sv_calloc((size_t)ncomp + 1, sizeof *cstart);
    areas = sv_calloc(ncomp, sizeof *areas);
    radii = sv_calloc(ncomp, sizeof *radii);
    if (!cstart || !areas || !radii) goto nomem;
    for (uint32_t t = 0; t < T; t++)
        if (comp[t] != UINT32_MAX) cstart[comp[t] + 1]++;
    for (uint32_t i = 0; i < ncomp; i++) cstart[i + 1] += cstart[i];
    {
        uint32_t *cursor = sv_calloc(ncomp, sizeof *cursor);
        if (!cursor) goto nomem;
        memcpy(cursor, cstart, (size_t)ncomp * sizeof *cursor);
        for (uint32_t t = 0; t < T; t++)
            if (comp[t] != UINT32_MAX) work[cursor[comp[t]]++] = t;
        free(cursor);
    }

    /* A typical leaf: the median component. */
    piece_stats ps;
    for (uint32_t i = 0; i < ncomp; i++) {
        piece_compute(mesh, work + cstart[i], cstart[i + 1] - cstart[i], &ps);
        areas[i] = ps.area;
        radii[i] = ps.radius;
    }
    double med_area = median(areas, ncomp), med_radius = median(radii, ncomp);
    out->median_area = med_area;

    /* Split pieces far larger than a typical leaf, or with spread normals, until
     * each is leaf-sized and nearly flat: by normal direction when the normals
     * spread (crossed cards), else by the plane through the centroid orthogonal
     * to the longest axis. */
    for (uint32_t ci = 0; ci < ncomp; ci++) {
        uint32_t top = 0, before = lv.n;
        stack[top++] = (span){cstart[ci], cstart[ci + 1] - cstart[ci], 0};
        while (top) {
            span s = stack[--top];
            uint32_t *w = work + s.start;
            bool emit = s.count <= 1 || s.depth >= SPLIT_MAX_DEPTH;
            uint32_t first = 0;
            if (!emit) {
                piece_compute(mesh, w, s.count, &ps);
                bool big = ps.area > SPLIT_AREA * med_area || ps.radius > SPLIT_RADIUS * med_radius;
                bool spread = ps.area > 0 && ps.nval[0] < SPLIT_COHERENCE * ps.area;
                if (!big && !spread) {
                    emit = true;
                } else {
                    for (uint32_t i = 0; i < s.count; i++) {
                        if (spread) {
                            double nv[3];
                            sv_tri_normal(mesh, w[i], nv);
                            side[i] = fabs(sv_dot3(nv, ps.nvec[0])) < fabs(sv_dot3(nv, ps.nvec[1]));
                        } else {
                            double cc[3];
                            tri_centroid(mesh, w[i], cc);
                            for (int k = 0; k < 3; k++) cc[k] -= ps.centre[k];
                            side[i] = sv_dot3(cc, ps.cvec[0]) >= 0;
                        }
                    }
                    first = partition(w, s.count, side, tmp);
                    emit = first == 0 || first == s.count;
                }
            }
            if (emit) {
                if (!leaf_push(&lv, s.start, s.count)) goto nomem;
                continue;
            }
            stack[top++] = (span){s.start + first, s.count - first, s.depth + 1};
            stack[top++] = (span){s.start, first, s.depth + 1};
        }
        if (lv.n - before > 1) out->split++;
    }

    /* Deterministic order: triangles ascending inside a leaf, leaves by their
     * lowest triangle; then compute each leaf's final stats. */
    for (uint32_t i = 0; i < lv.n; i++) {
        sv_leaf *L = &lv.v[i].leaf;
        qsort(work + L->first, L->count, sizeof *work, cmp_u32);
        lv.v[i].key = work[L->first];
    }
    qsort(lv.v, lv.n, sizeof *lv.v, cmp_leaf);
    out->leaves = sv_calloc(lv.n, sizeof *out->leaves);
    out->tris = sv_calloc(F, sizeof *out->tris);
    if (!out->leaves || !out->tris) goto nomem;
    uint32_t at = 0;
    for (uint32_t i = 0; i < lv.n; i++) {
        sv_leaf L = lv.v[i].leaf;
        memcpy(out->tris + at, work + L.first, (size_t)L.count * sizeof *work);
        piece_compute(mesh, out->tris + at, L.count, &ps);
        sv_leaf *o = &out->leaves[i];
        memcpy(o->centre, ps.centre, sizeof o->centre);
        memcpy(o->normal, ps.normal, sizeof o->normal);
        o->area = ps.area;
        o->radius = ps.radius;
        o->first = at;
        o->count = L.count;
        if (ps.area > out->max_area) out->max_area = ps.area;
        at += L.count;
    }
    out->count = lv.n;
    out->tri_count = F;
    goto out;
nomem:
    st = sv_fail(err, SV_ERR_NOMEM, "no memory for leaf elements of %u foliage triangles", F);
out:
    free(weld);
    free(comp);
    free(include);
    free(work);
    free(tmp);
    free(side);
    free(stack);
    free(cstart);
    free(areas);
    free(radii);
    free(lv.v);
    if (st) sv_leaves_free(out);
    return st;
}

void sv_leaves_free(sv_leaves *l)
{
    if (!l) return;
    free(l->leaves);
    free(l->tris);
    memset(l, 0, sizeof *l);
}
