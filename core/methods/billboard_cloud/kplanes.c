/* kplanes.c — k-planes refinement of a billboard cloud's foliage planes.
 *
 * Décoret et al.'s greedy selection (greedy_planes.c, papers/billboard-cloud-forests.txt
 * §3.2) picks the densest planes for a validity distance ε; when a plane budget
 * forces ε up to a large fraction of the crown, the planes it picks are dense
 * but each leaf may sit far from the plane that draws it, and the flattened
 * crown no longer covers the screen where the tree does. This pass keeps the
 * greedy planes as a start and runs Lloyd's iteration for k planes (Bradley &
 * Mangasarian, "k-Plane Clustering", J. Global Optimization 16, 2000): every
 * foliage element (a leaf) goes to the plane nearest to it in the mean squared
 * distance of its area-weighted vertices, then every plane is refitted to its
 * leaves by total least squares (normal = eigenvector of the smallest eigenvalue
 * of their covariance). Each step lowers the total squared flattening distance,
 * which is what a viewer at any angle sees as leaves drawn off their place.
 * An emptied plane is reseeded on the leaf farthest from its plane.
 * Trunk-pass planes and cardboard planes are left as they are. Deterministic.
 */
#include "planes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"
#include "eigen3.h"
#include "parallel.h"

/* Elements × planes below which an assignment step runs on one thread
 * (creating a thread costs about as much; the bytes are the same). */
#define PAR_MIN_WORK 16384
#define PAR_MIN_TRIS 4096 /* triangles, for the moments and the areas */

typedef struct kp_mom {
    double w;       /* total weight (area) */
    double m[3];    /* Σ w x */
    double s[3][3]; /* Σ w x xᵀ */
} kp_mom;

static void mom_add(kp_mom *a, const kp_mom *b)
{
    a->w += b->w;
    for (int i = 0; i < 3; i++) {
        a->m[i] += b->m[i];
        for (int j = 0; j < 3; j++) a->s[i][j] += b->s[i][j];
    }
}

/* Total least-squares plane of the points (relative coordinates). */
static bool mom_fit(const kp_mom *a, double n[3], double *d)
{
    if (!(a->w > 0)) return false;
    double mu[3], cov[3][3];
    for (int i = 0; i < 3; i++) mu[i] = a->m[i] / a->w;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) cov[i][j] = a->s[i][j] / a->w - mu[i] * mu[j];
    double val[3], vec[3][3];
    if (!sv_eigen3_symmetric((const double(*)[3])cov, val, vec)) return false;
    memcpy(n, vec[0], 3 * sizeof(double));
    /* a stable sign: the largest component positive (planes are two-sided) */
    int big = 0;
    for (int i = 1; i < 3; i++)
        if (fabs(n[i]) > fabs(n[big])) big = i;
    if (n[big] < 0)
        for (int i = 0; i < 3; i++) n[i] = -n[i];
    *d = -(n[0] * mu[0] + n[1] * mu[1] + n[2] * mu[2]);
    return true;
}

/* A plane's cost as a linear form in an element's moments: the mean squared
 * distance of the element's weighted points from n·x + d = 0 is
 * (q·(s00, s11, s22, s01, s02, s12) + l·m + d²·w) / w with q the products
 * of n's components (off-diagonal ones doubled) and l = 2·d·n, so the
 * assignment's inner loop is ten multiply-adds a pair. */
typedef struct kp_form {
    double q[6], l[3], dd;
} kp_form;

static kp_form form_of(const double n[3], double d)
{
    kp_form f = {
        {n[0] * n[0], n[1] * n[1], n[2] * n[2], 2 * n[0] * n[1], 2 * n[0] * n[2], 2 * n[1] * n[2]},
        {2 * d * n[0], 2 * d * n[1], 2 * d * n[2]},
        d * d};
    return f;
}

/* One assignment step over elements [lo, hi) (an sv_parallel_for chunk):
 * writes asg[e] and cost[e] of its own elements and its count of changes. */
typedef struct ajob {
    const kp_mom *em;
    const kp_form *pf;
    const uint8_t *fol;
    uint32_t np;
    uint32_t *asg;
    double *cost;
    uint32_t changed[SV_PARALLEL_MAX];
} ajob;

static void ajob_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    ajob *j = arg;
    const kp_mom *em = j->em;
    const kp_form *pf = j->pf;
    uint32_t changed = 0;
    for (uint32_t e = lo; e < hi; e++) {
        const kp_mom *m = &em[e];
        if (!(m->w > 0)) continue;
        const double S[6] = {m->s[0][0], m->s[1][1], m->s[2][2],
                             m->s[0][1], m->s[0][2], m->s[1][2]};
        uint32_t best = UINT32_MAX;
        double bc = INFINITY;
        for (uint32_t k = 0; k < j->np; k++) {
            if (!j->fol[k]) continue;
            const kp_form *f = &pf[k];
            double c = f->q[0] * S[0] + f->q[1] * S[1] + f->q[2] * S[2] + f->q[3] * S[3] +
                       f->q[4] * S[4] + f->q[5] * S[5] + f->l[0] * m->m[0] + f->l[1] * m->m[1] +
                       f->l[2] * m->m[2] + f->dd * m->w;
            if (c < bc) bc = c, best = k;
        }
        bc = bc > 0 ? bc / m->w : 0; /* the mean squared distance */
        changed += best != j->asg[e];
        j->asg[e] = best;
        j->cost[e] = bc;
    }
    j->changed[t] = changed;
}

/* Assigns every weighted element to its nearest foliage plane (ties: the
 * lower index); cost[e] = its mean squared distance. Returns how many
 * assignments changed. Each element's choice is its own, so the elements are
 * split between threads (parallel.h) and only the integer counts are added.
 * pf: room for np forms (scratch). */
static uint32_t assign_all(const kp_mom *em, uint32_t ne, const double *pn, const uint8_t *fol,
                           uint32_t np, uint32_t *asg, double *cost, kp_form *pf)
{
    for (uint32_t k = 0; k < np; k++) pf[k] = form_of(&pn[4 * k], pn[4 * k + 3]);
    ajob j = {.em = em, .pf = pf, .fol = fol, .np = np, .asg = asg, .cost = cost};
    uint32_t thr = (uint64_t)ne * np >= PAR_MIN_WORK ? SV_PARALLEL_DEFAULT : 1;
    uint32_t nch = sv_parallel_chunks(ne, thr);
    sv_parallel_for(ne, thr, ajob_run, &j);
    uint32_t changed = 0;
    for (uint32_t t = 0; t < nch; t++) changed += j.changed[t];
    return changed;
}

/* Moments of the foliage elements [lo, hi) (an sv_parallel_for chunk): em[e]
 * sums its own triangles in their order, so any split gives the same bytes. */
typedef struct mjob {
    const sv_bbc_input *in;
    kp_mom *em;
} mjob;

static void mjob_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    (void)t;
    const mjob *j = arg;
    const sv_bbc_input *in = j->in;
    const double *c0 = in->centre;
    for (uint32_t e = lo; e < hi; e++) {
        if (in->elem_part && in->elem_part[e] != SV_PART_FOLIAGE) continue;
        kp_mom *m = &j->em[e];
        for (uint32_t i = in->elem_first[e]; i < in->elem_first[e + 1]; i++) {
            uint32_t t3 = in->elem_tris[i];
            double p[3][3];
            for (int v = 0; v < 3; v++)
                for (int c = 0; c < 3; c++)
                    p[v][c] = in->positions[3 * (size_t)in->indices[3 * (size_t)t3 + v] + c] -
                              c0[c];
            double a[3], b[3], x[3];
            for (int c = 0; c < 3; c++) a[c] = p[1][c] - p[0][c], b[c] = p[2][c] - p[0][c];
            x[0] = a[1] * b[2] - a[2] * b[1];
            x[1] = a[2] * b[0] - a[0] * b[2];
            x[2] = a[0] * b[1] - a[1] * b[0];
            double w = 0.5 * sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) / 3.0;
            if (!(w > 0)) w = 1e-30;
            for (int v = 0; v < 3; v++) {
                m->w += w;
                for (int i2 = 0; i2 < 3; i2++) {
                    m->m[i2] += w * p[v][i2];
                    for (int k = 0; k < 3; k++) m->s[i2][k] += w * p[v][i2] * p[v][k];
                }
            }
        }
    }
}

/* Areas of the triangles tris[lo..hi) into area[lo..hi) (an sv_parallel_for
 * chunk); each plane then adds its own in order. */
typedef struct tjob {
    const sv_bbc_input *in;
    const uint32_t *tris;
    double *area;
} tjob;

static void tjob_run(void *arg, uint32_t t, uint32_t lo, uint32_t hi)
{
    (void)t;
    const tjob *j = arg;
    const sv_bbc_input *in = j->in;
    for (uint32_t i = lo; i < hi; i++) {
        uint32_t tr = j->tris[i];
        double p[3][3];
        for (int v = 0; v < 3; v++)
            for (int c = 0; c < 3; c++)
                p[v][c] = in->positions[3 * (size_t)in->indices[3 * (size_t)tr + v] + c];
        double a[3], b[3];
        for (int c = 0; c < 3; c++) a[c] = p[1][c] - p[0][c], b[c] = p[2][c] - p[0][c];
        double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2],
               z = a[0] * b[1] - a[1] * b[0];
        j->area[i] = 0.5 * sqrt(x * x + y * y + z * z);
    }
}

sv_status sv_bbc_kplanes(const sv_bbc_input *in, uint32_t iterations, uint32_t target_planes,
                         sv_bbc_result *res, sv_error *err)
{
    if (!res->plane_count) return SV_OK;
    for (uint32_t k = 0; k < res->plane_count; k++)
        if (res->planes[k].cardboard_of >= 0) return SV_OK; /* cardboards would go stale */
    uint32_t ne = in->elem_count, np = res->plane_count;
    /* room for the planes added to reach the budget */
    uint32_t grow = target_planes > np ? target_planes - np : 0;
    if (grow > ne) grow = ne;
    if (grow) {
        sv_bbc_plane *P = realloc(res->planes, (size_t)(np + grow) * sizeof *P);
        if (!P) return sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (k-planes)");
        res->planes = P;
    }
    uint32_t *elem_of = malloc((size_t)(in->triangle_count ? in->triangle_count : 1) *
                               sizeof *elem_of);
    kp_mom *em = sv_calloc(ne ? ne : 1, sizeof *em);
    kp_mom *pm = sv_calloc(np + grow, sizeof *pm);
    uint32_t *asg = malloc((size_t)(ne ? ne : 1) * sizeof *asg);
    double *pn = sv_calloc(np + grow, 4 * sizeof(double)); /* n[3], d per plane, relative coords */
    uint8_t *fol = sv_calloc(np + grow, 1);
    double *cost = sv_calloc(ne ? ne : 1, sizeof *cost);
    kp_form *pf = sv_calloc(np + grow, sizeof *pf);
    uint32_t *tris = NULL, *first = NULL;
    double *tarea = NULL;
    sv_status st = SV_OK;
    if (!elem_of || !em || !pm || !asg || !pn || !fol || !cost || !pf) {
        st = sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (k-planes)");
        goto out;
    }
    for (uint32_t t = 0; t < in->triangle_count; t++) elem_of[t] = UINT32_MAX;
    const double *c0 = in->centre;
    /* element moments from the original positions, relative to the centre */
    for (uint32_t e = 0; e < ne; e++) {
        asg[e] = UINT32_MAX;
        if (in->elem_part && in->elem_part[e] != SV_PART_FOLIAGE) continue;
        for (uint32_t i = in->elem_first[e]; i < in->elem_first[e + 1]; i++)
            elem_of[in->elem_tris[i]] = e;
    }
    mjob mj = {in, em};
    sv_parallel_for(ne, in->triangle_count >= PAR_MIN_TRIS ? SV_PARALLEL_DEFAULT : 1, mjob_run,
                    &mj);
    uint32_t nf = 0;
    for (uint32_t k = 0; k < np; k++) {
        const sv_bbc_plane *P = &res->planes[k];
        fol[k] = P->part == SV_PART_FOLIAGE;
        nf += fol[k];
        memcpy(&pn[4 * k], P->normal, 3 * sizeof(double));
        /* n·(x' + c0) + d = 0  →  n·x' + (d + n·c0) = 0 */
        pn[4 * k + 3] = P->d + P->normal[0] * c0[0] + P->normal[1] * c0[1] + P->normal[2] * c0[2];
    }
    if (!nf) goto out;
    /* Up to the plane budget: split the slab that draws a leaf worst, a new
     * plane parallel to that leaf's plane through the leaf (farthest-point
     * seeding, deterministic), one at a time with a reassignment between. */
    for (uint32_t added = 0; added <= grow; added++) {
        assign_all(em, ne, pn, fol, np, asg, cost, pf);
        if (added == grow) break;
        uint32_t far = UINT32_MAX;
        for (uint32_t e = 0; e < ne; e++)
            if (asg[e] != UINT32_MAX &&
                (far == UINT32_MAX || cost[e] * em[e].w > cost[far] * em[far].w))
                far = e;
        if (far == UINT32_MAX || !(cost[far] > 0)) break;
        const double *n = &pn[4 * asg[far]];
        double *q = &pn[4 * np];
        memcpy(q, n, 3 * sizeof(double));
        q[3] = -(n[0] * em[far].m[0] + n[1] * em[far].m[1] + n[2] * em[far].m[2]) / em[far].w;
        sv_bbc_plane *P = &res->planes[np];
        memset(P, 0, sizeof *P);
        P->part = SV_PART_FOLIAGE;
        P->origin = SV_BBC_REFINED;
        P->cardboard_of = -1;
        P->coverage = 1;
        fol[np] = 1;
        np++;
        nf++;
    }
    for (uint32_t e = 0; e < ne; e++) asg[e] = UINT32_MAX; /* the loop below counts moves */
    for (uint32_t it = 0; it <= iterations; it++) {
        uint32_t changed = assign_all(em, ne, pn, fol, np, asg, cost, pf);
        if (it == iterations || (it > 0 && !changed)) break;
        /* refit */
        memset(pm, 0, (size_t)np * sizeof *pm);
        for (uint32_t e = 0; e < ne; e++)
            if (asg[e] != UINT32_MAX) mom_add(&pm[asg[e]], &em[e]);
        for (uint32_t k = 0; k < np; k++) {
            if (!fol[k]) continue;
            if (mom_fit(&pm[k], &pn[4 * k], &pn[4 * k + 3])) continue;
            /* empty: reseed on the leaf drawn farthest from its plane */
            uint32_t far = UINT32_MAX;
            for (uint32_t e = 0; e < ne; e++)
                if (asg[e] != UINT32_MAX && (far == UINT32_MAX || cost[e] > cost[far])) far = e;
            if (far == UINT32_MAX || !mom_fit(&em[far], &pn[4 * k], &pn[4 * k + 3])) continue;
            cost[far] = 0;
        }
    }
    /* rebuild the face lists: trunk planes keep theirs, foliage planes get their leaves */
    tris = malloc((size_t)(res->tri_count ? res->tri_count : 1) * sizeof *tris);
    first = sv_calloc((size_t)np + 1, sizeof *first);
    uint32_t *cnt = sv_calloc(np, sizeof *cnt);
    if (!tris || !first || !cnt) {
        free(cnt);
        st = sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (k-planes)");
        goto out;
    }
    uint32_t *tri_plane = elem_of; /* reuse: plane of each triangle */
    for (uint32_t k = 0; k < np; k++) {
        const sv_bbc_plane *P = &res->planes[k];
        for (uint32_t i = 0; i < P->count; i++) {
            uint32_t t = res->tris[P->first + i];
            uint32_t e = elem_of[t];
            uint32_t to = fol[k] && e != UINT32_MAX && asg[e] != UINT32_MAX ? asg[e] : k;
            tri_plane[t] = to; /* each triangle is in exactly one primary plane */
            cnt[to]++;
        }
    }
    for (uint32_t k = 0; k < np; k++) first[k + 1] = first[k] + cnt[k];
    memset(cnt, 0, (size_t)np * sizeof *cnt);
    for (uint32_t k = 0; k < np; k++) {
        const sv_bbc_plane *P = &res->planes[k];
        for (uint32_t i = 0; i < P->count; i++) {
            uint32_t t = res->tris[P->first + i];
            uint32_t to = tri_plane[t];
            tris[first[to] + cnt[to]++] = t;
        }
    }
    free(cnt);
    /* triangle areas (on the threads), then each foliage plane's total in
     * its triangles' order, as one thread added them */
    tarea = malloc((size_t)(res->tri_count ? res->tri_count : 1) * sizeof *tarea);
    if (!tarea) {
        st = sv_fail(err, SV_ERR_NOMEM, "billboard cloud: out of memory (k-planes)");
        goto out;
    }
    tjob tj = {in, tris, tarea};
    sv_parallel_for(res->tri_count, res->tri_count >= PAR_MIN_TRIS ? SV_PARALLEL_DEFAULT : 1,
                    tjob_run, &tj);
    /* planes in the original order, empty ones dropped */
    uint32_t w = 0;
    for (uint32_t k = 0; k < np; k++) {
        sv_bbc_plane P = res->planes[k];
        P.first = first[k];
        P.count = first[k + 1] - first[k];
        if (!P.count) continue;
        if (fol[k]) {
            memcpy(P.normal, &pn[4 * k], 3 * sizeof(double));
            P.d = pn[4 * k + 3] - (P.normal[0] * c0[0] + P.normal[1] * c0[1] + P.normal[2] * c0[2]);
            P.area = 0;
            for (uint32_t i = 0; i < P.count; i++) P.area += tarea[P.first + i];
        }
        res->planes[w++] = P;
    }
    res->plane_count = w;
    res->stats.primary_planes = w; /* no cardboard planes here */
    free(res->tris);
    res->tris = tris;
    tris = NULL;
out:
    free(tarea);
    free(tris);
    free(first);
    free(elem_of);
    free(em);
    free(pm);
    free(asg);
    free(pn);
    free(fol);
    free(cost);
    free(pf);
    return st;
}
