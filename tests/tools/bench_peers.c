/* bench_peers.c — our peers in simplification: meshoptimizer's meshopt_simplify and
 * meshopt_simplifySloppy (Debian's libmeshoptimizer-dev) at given triangle
 * counts, judged by the same evaluation as our bakes (evaluate.h, options
 * derived from the same spec exactly as core/pipeline/pipeline.c derives them).
 *
 * usage: bench_peers --spec SPEC.json --targets N[,N...] MESH [FILES...]
 * prints one JSON object on stdout:
 *   {"triangles": <original, after validation>, "evaluator_seconds": s,
 *    "results": [{"simplifier": "meshopt_simplify"|"meshopt_simplifySloppy",
 *                 "target": N, "triangles": got, "seconds": s,
 *                 "accuracy": [{"pixels", "iou_mean", "iou_worst", "color_error_mean",
 *                               "color_error_worst", "depth_error_mean",
 *                               "depth_error_worst"}...] | null}]}
 *
 * How a user would simplify a textured tree with meshoptimizer (as gltfpack
 * does per primitive): vertices welded by position and UV (OBJ exports give
 * every face its own vertices, and meshoptimizer cannot collapse what is not
 * connected; the remaining UV seams it handles itself), then each material's
 * triangles simplified on their own with the same ratio target/total, no
 * error bound (target_error 1 = the whole extent), so the count is what
 * limits the result. meshopt_simplify keeps the topology and may stop above
 * the target (the table reports what it reached); meshopt_simplifySloppy
 * merges vertices on a grid and reaches any count. Exit 1 with one line on
 * stderr on failure.
 */
#include <math.h>
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"

#define MAX_TARGETS 64

typedef enum { PEER_SIMPLIFY = 0, PEER_SLOPPY = 1 } peer_kind;
static const char *const peer_names[2] = {"meshopt_simplify", "meshopt_simplifySloppy"};

/* The welded, compact index buffer every simplification starts from. */
typedef struct welded {
    unsigned int *indices; /* 3 per triangle, compact vertex ids */
    float *positions;      /* 3 per compact vertex */
    unsigned int *rep;     /* compact vertex -> a source vertex with that position and UV */
    size_t unique;
} welded;

static void welded_free(welded *w)
{
    free(w->indices);
    free(w->positions);
    free(w->rep);
    memset(w, 0, sizeof *w);
}

static sv_status weld(const sv_mesh *m, welded *w, sv_error *err)
{
    memset(w, 0, sizeof *w);
    size_t ni = (size_t)m->triangle_count * 3;
    unsigned int *remap = sv_calloc(m->vertex_count, sizeof *remap);
    float *pu = sv_calloc(m->vertex_count, 5 * sizeof(float));
    w->indices = sv_calloc(ni, sizeof *w->indices);
    if (!remap || !pu || !w->indices) {
        free(remap);
        free(pu);
        welded_free(w);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory welding %u vertices", m->vertex_count);
    }
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        memcpy(&pu[5 * (size_t)v], &m->positions[3 * (size_t)v], 3 * sizeof(float));
        memcpy(&pu[5 * (size_t)v + 3], &m->uvs[2 * (size_t)v], 2 * sizeof(float));
    }
    /* only vertices that triangles use: unreferenced duplicates would count as seams */
    w->unique = meshopt_generateVertexRemap(remap, m->indices, ni, pu, m->vertex_count,
                                            5 * sizeof(float));
    free(pu);
    w->positions = sv_calloc(w->unique ? w->unique : 1, 3 * sizeof(float));
    w->rep = sv_calloc(w->unique ? w->unique : 1, sizeof *w->rep);
    if (!w->positions || !w->rep) {
        free(remap);
        welded_free(w);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory welding %u vertices", m->vertex_count);
    }
    meshopt_remapVertexBuffer(w->positions, m->positions, m->vertex_count, 3 * sizeof(float),
                              remap);
    for (uint32_t v = m->vertex_count; v-- > 0;)
        if (remap[v] != ~0u) w->rep[remap[v]] = v;
    meshopt_remapIndexBuffer(w->indices, m->indices, ni, remap);
    free(remap);
    return SV_OK;
}

/* Simplifies every material of m to about target triangles in total; *out is
 * a new mesh (NULL when everything collapsed). */
static sv_status simplify(const sv_mesh *m, const welded *w, peer_kind kind, uint32_t target,
                          sv_mesh **out, sv_error *err)
{
    *out = NULL;
    size_t ni = (size_t)m->triangle_count * 3;
    unsigned int *src = sv_calloc(ni, sizeof *src), *dst = sv_calloc(ni, sizeof *dst);
    uint32_t *mat = sv_calloc(m->triangle_count, sizeof *mat);
    if (!src || !dst || !mat) {
        free(src);
        free(dst);
        free(mat);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    double ratio = (double)target / m->triangle_count;
    size_t total = 0;
    for (uint32_t mi = 0; mi < m->material_count; mi++) {
        size_t k = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (m->tri_material[t] == mi) {
                memcpy(&src[k], &w->indices[3 * (size_t)t], 3 * sizeof *src);
                k += 3;
            }
        if (k == 0) continue;
        size_t want = (size_t)floor((double)(k / 3) * ratio + 0.5) * 3;
        if (want == 0) continue; /* this material's share rounds to nothing */
        size_t got = kind == PEER_SIMPLIFY
                         ? meshopt_simplify(&dst[total], src, k, w->positions, w->unique,
                                            3 * sizeof(float), want, 1.0f, 0, NULL)
                         : meshopt_simplifySloppy(&dst[total], src, k, w->positions, w->unique,
                                                  3 * sizeof(float), want, 1.0f, NULL);
        for (size_t i = 0; i < got / 3; i++) mat[total / 3 + i] = mi;
        total += got;
    }
    free(src);
    sv_status st = SV_OK;
    if (total > 0) {
        for (size_t i = 0; i < total; i++) dst[i] = w->rep[dst[i]];
        /* a view of m with the new triangles; subset copies what they use */
        sv_mesh view = *m;
        view.indices = dst;
        view.tri_material = mat;
        view.triangle_count = (uint32_t)(total / 3);
        uint32_t *all = sv_calloc(view.triangle_count, sizeof *all);
        if (!all) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        else {
            for (uint32_t t = 0; t < view.triangle_count; t++) all[t] = t;
            st = sv_mesh_subset(&view, all, view.triangle_count, out, err);
            free(all);
        }
    }
    free(dst);
    free(mat);
    return st;
}

static void print_accuracy(const sv_eval_result *r)
{
    printf("[");
    for (uint32_t k = 0; k < r->size_count; k++) {
        const sv_eval_size *z = &r->sizes[k];
        printf("%s{\"pixels\":%u,\"iou_mean\":%.6f,\"iou_worst\":%.6f,\"color_error_mean\":%.6f,"
               "\"color_error_worst\":%.6f,\"depth_error_mean\":%.6f,\"depth_error_worst\":%.6f}",
               k ? "," : "", z->pixels, z->mean.iou, z->worst.iou, z->mean.color_error,
               z->worst.color_error, z->mean.depth_error, z->worst.depth_error);
    }
    printf("]");
}

static int parse_targets(const char *s, uint32_t *t, size_t *n)
{
    *n = 0;
    while (*s) {
        char *end = NULL;
        unsigned long v = strtoul(s, &end, 10);
        if (end == s || v == 0 || v > 100000000ul || *n == MAX_TARGETS) return -1;
        t[(*n)++] = (uint32_t)v;
        s = end;
        if (*s == ',') s++;
        else if (*s) return -1;
    }
    return *n ? 0 : -1;
}

int main(int argc, char **argv)
{
    const char *spec_path = NULL, *targets_arg = NULL;
    char *paths[BENCH_MAX_FILES];
    size_t np = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--spec") == 0 && i + 1 < argc) spec_path = argv[++i];
        else if (strcmp(argv[i], "--targets") == 0 && i + 1 < argc) targets_arg = argv[++i];
        else if (argv[i][0] == '-' || np == BENCH_MAX_FILES) {
            fprintf(stderr,
                    "usage: bench_peers --spec SPEC.json --targets N[,N...] MESH [FILES...]\n");
            return 2;
        } else paths[np++] = argv[i];
    }
    uint32_t targets[MAX_TARGETS];
    size_t nt = 0;
    if (!targets_arg || parse_targets(targets_arg, targets, &nt) || np == 0) {
        fprintf(stderr, "usage: bench_peers --spec SPEC.json --targets N[,N...] MESH [FILES...]\n");
        return 2;
    }

    sv_error err = {0};
    bench_files files;
    sv_spec spec;
    sv_mesh *mesh = NULL;
    welded w = {0};
    sv_renderer *ren = NULL;
    sv_gpu_mesh *gsrc = NULL;
    sv_evaluator *ev = NULL;
    int rc = 1;
    memset(&files, 0, sizeof files);
    memset(&spec, 0, sizeof spec);
    if (bench_spec_load(spec_path, &spec, &err)) goto out;
    if (bench_files_load(paths, np, &files, &err)) goto out;
    if (bench_import(&files, &spec, &mesh, NULL, NULL, &err)) goto out;
    if (weld(mesh, &w, &err)) goto out;
    if (sv_renderer_create(8192, &ren, &err)) goto out;
    if (sv_gpu_mesh_upload(ren, mesh, &gsrc, &err)) goto out;
    sv_eval_options eo;
    bench_eval_options(&spec, &eo);
    double t0 = sv_now();
    if (sv_evaluator_create(ren, mesh, gsrc, &eo, &ev, &err)) goto out;
    printf("{\"triangles\":%u,\"evaluator_seconds\":%.4f,\"results\":[", mesh->triangle_count,
           sv_now() - t0);
    bool first = true;
    for (size_t i = 0; i < nt; i++) {
        for (int kind = PEER_SIMPLIFY; kind <= PEER_SLOPPY; kind++) {
            sv_mesh *s = NULL;
            double ts = sv_now();
            if (simplify(mesh, &w, (peer_kind)kind, targets[i], &s, &err)) goto out;
            double secs = sv_now() - ts;
            printf("%s{\"simplifier\":\"%s\",\"target\":%u,\"triangles\":%u,\"seconds\":%.5f,"
                   "\"accuracy\":",
                   first ? "" : ",", peer_names[kind], targets[i], s ? s->triangle_count : 0, secs);
            first = false;
            if (!s) {
                printf("null}");
                continue;
            }
            sv_gpu_mesh *g = NULL;
            sv_eval_result r;
            memset(&r, 0, sizeof r);
            sv_status st = sv_gpu_mesh_upload(ren, s, &g, &err);
            if (!st) st = sv_evaluate(ev, g, &r, &err);
            if (!st) print_accuracy(&r);
            sv_eval_result_free(&r);
            sv_gpu_mesh_free(g);
            sv_mesh_destroy(s);
            if (st) goto out;
            printf("}");
            fflush(stdout);
        }
    }
    printf("]}\n");
    rc = 0;
out:
    if (rc) {
        fflush(stdout);
        fprintf(stderr, "bench_peers: %s\n", err.message[0] ? err.message : "failed");
    }
    sv_evaluator_destroy(ev);
    sv_gpu_mesh_free(gsrc);
    sv_renderer_destroy(ren);
    welded_free(&w);
    sv_mesh_destroy(mesh);
    sv_spec_free(&spec);
    bench_files_free(&files);
    return rc;
}
