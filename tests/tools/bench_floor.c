/* bench_floor.c — the floor of a bake's time and the stage timings
 * `make bench` prints (docs/benchmarks.md).
 *
 * The floor is the least any baker must spend on a mesh: import it and
 * rasterise it once at the atlas's texel density. Here: sv_import + validate
 * (as core/pipeline/pipeline.c does), then an OSMesa context, the mesh upload and one
 * orthographic render of every triangle (front view, framing the bounding
 * sphere, lit as a static-lighting bake renders) at (2R / texel_size)² pixels.
 * A method's bake time divided by this is "how many meshes' worth of work".
 *
 * Stage timings (medians of --repeat runs): import of the mesh (the
 * ficus OBJ: the goal is "well under a second"), classification and leaf elements, and the
 * k-means of the leaf clusters (Garcia et al. §2: leaves into 32 planes, alpha_rel·R²,
 * area-weighted, seed 1 — the leaf_clusters defaults; "under 50 ms" on the
 * ficus), alone and with the 16 and 8 hierarchy levels.
 *
 * usage: bench_floor --spec SPEC.json --texel-size T[,T...] [--repeat N]
 *                    [--alpha-rel A] MESH [FILES...]
 * prints one JSON object on stdout; exit 1 with one line on stderr on failure.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "classify.h"
#include "cluster.h"

#define MAX_TEXELS 16
#define MAX_REPEAT 15

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int parse_list(const char *s, double *v, int *n)
{
    *n = 0;
    while (*s) {
        char *end = NULL;
        double x = strtod(s, &end);
        if (end == s || !(x > 0) || !isfinite(x) || *n == MAX_TEXELS) return -1;
        v[(*n)++] = x;
        s = end;
        if (*s == ',') s++;
        else if (*s) return -1;
    }
    return *n ? 0 : -1;
}

static const char usage[] = "usage: bench_floor --spec SPEC.json --texel-size T[,T...] "
                            "[--repeat N] [--alpha-rel A] MESH [FILES...]\n";

int main(int argc, char **argv)
{
    const char *spec_path = NULL, *texel_arg = NULL;
    int repeat = 3;
    double alpha_rel = 0.003; /* leaf_clusters default (docs/methods/leaf_clusters.md) */
    char *paths[BENCH_MAX_FILES];
    size_t np = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--spec") == 0 && i + 1 < argc) spec_path = argv[++i];
        else if (strcmp(argv[i], "--texel-size") == 0 && i + 1 < argc) texel_arg = argv[++i];
        else if (strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) repeat = atoi(argv[++i]);
        else if (strcmp(argv[i], "--alpha-rel") == 0 && i + 1 < argc) alpha_rel = atof(argv[++i]);
        else if (argv[i][0] == '-' || np == BENCH_MAX_FILES) {
            fputs(usage, stderr);
            return 2;
        } else paths[np++] = argv[i];
    }
    double texel[MAX_TEXELS];
    int nt = 0;
    if (!texel_arg || parse_list(texel_arg, texel, &nt) || np == 0 || repeat < 1 ||
        repeat > MAX_REPEAT || !(alpha_rel >= 0)) {
        fputs(usage, stderr);
        return 2;
    }

    sv_error err = {0};
    bench_files files;
    sv_spec spec;
    sv_mesh *mesh = NULL;
    sv_classification cls;
    sv_leaves leaves;
    sv_renderer *ren = NULL;
    int rc = 1;
    memset(&files, 0, sizeof files);
    memset(&spec, 0, sizeof spec);
    memset(&cls, 0, sizeof cls);
    memset(&leaves, 0, sizeof leaves);
    if (bench_spec_load(spec_path, &spec, &err)) goto out;
    if (bench_files_load(paths, np, &files, &err)) goto out;

    double t_imp[MAX_REPEAT], t_val[MAX_REPEAT], t_cls[MAX_REPEAT], t_leaf[MAX_REPEAT];
    double t_k32[MAX_REPEAT], t_klv[MAX_REPEAT];
    uint32_t n_leaves = 0, iterations = 0;
    for (int r = 0; r < repeat; r++) {
        sv_mesh_destroy(mesh);
        mesh = NULL;
        if (bench_import(&files, &spec, &mesh, &t_imp[r], &t_val[r], &err)) goto out;
        sv_classification_free(&cls);
        sv_leaves_free(&leaves);
        memset(&cls, 0, sizeof cls);
        memset(&leaves, 0, sizeof leaves);
        sv_classify_options co = {spec.foliage, spec.foliage_count, spec.trunk, spec.trunk_count};
        double t0 = sv_now();
        if (sv_classify(mesh, &co, &cls, &err)) goto out;
        double t1 = sv_now();
        if (sv_leaves_build(mesh, &cls, &leaves, &err)) goto out;
        double t2 = sv_now();
        t_cls[r] = t1 - t0;
        t_leaf[r] = t2 - t1;
        n_leaves = leaves.count;
        t_k32[r] = t_klv[r] = NAN;
        if (leaves.count == 0) continue;
        double c[3], rad;
        sv_mesh_sphere(mesh, c, &rad);
        static const uint32_t one[1] = {32}, three[3] = {32, 16, 8};
        for (int pass = 0; pass < 2; pass++) {
            sv_cluster_options o;
            memset(&o, 0, sizeof o);
            o.levels = pass ? three : one;
            o.level_count = pass ? 3 : 1;
            o.alpha = alpha_rel * rad * rad;
            o.area_weighted = true;
            o.seed = 1;
            o.centre = c;
            sv_clusters cl;
            double k0 = sv_now();
            if (sv_cluster_build(leaves.leaves, leaves.count, &o, &cl, &err)) goto out;
            double k1 = sv_now();
            iterations = cl.iterations;
            sv_clusters_free(&cl);
            if (pass) t_klv[r] = k1 - k0;
            else t_k32[r] = k1 - k0;
        }
    }
    double imp = median(t_imp, repeat), val = median(t_val, repeat);
    printf("{\"triangles\":%u,\"repeat\":%d,\"import_seconds\":%.5f,\"validate_seconds\":%.5f,"
           "\"classify_seconds\":%.5f,\"leaves_seconds\":%.5f,\"leaf_elements\":%u",
           mesh->triangle_count, repeat, imp, val, median(t_cls, repeat), median(t_leaf, repeat),
           n_leaves);
    if (n_leaves) {
        printf(",\"cluster32_seconds\":%.5f,\"cluster32_16_8_seconds\":%.5f,"
               "\"cluster_iterations\":%u",
               median(t_k32, repeat), median(t_klv, repeat), iterations);
    }

    /* the floor: one context, one upload, one render per texel size */
    double c[3], rad;
    sv_mesh_sphere(mesh, c, &rad);
    double t0 = sv_now();
    if (sv_renderer_create(8192, &ren, &err)) goto out;
    double t_ctx = sv_now() - t0;
    printf(",\"floor\":[");
    for (int i = 0; i < nt; i++) {
        double side = ceil(2.0 * rad / texel[i]);
        uint32_t max = sv_renderer_max_size(ren);
        uint32_t px = side > max ? max : side < 1 ? 1 : (uint32_t)side;
        sv_gpu_mesh *g = NULL;
        double u0 = sv_now();
        if (sv_gpu_mesh_upload(ren, mesh, &g, &err)) goto out;
        double u1 = sv_now();
        sv_camera cam;
        const double front[3] = {0, 0, 1};
        sv_eval_camera(c, rad, front, &cam);
        sv_render_options ro;
        memset(&ro, 0, sizeof ro);
        if (spec.scene.lighting == SV_LIGHTING_STATIC) {
            ro.shade = SV_SHADE_LIT;
            memcpy(ro.light_dir, spec.scene.light_dir, sizeof ro.light_dir);
        }
        sv_image img;
        memset(&img, 0, sizeof img);
        sv_status st = sv_render(ren, g, NULL, 0, &cam, &ro, px, px, &img, NULL, &err);
        double u2 = sv_now();
        sv_image_free(&img);
        sv_gpu_mesh_free(g);
        if (st) goto out;
        printf("%s{\"texel_size\":%.9g,\"pixels\":%u,\"context_seconds\":%.5f,"
               "\"upload_seconds\":%.5f,\"render_seconds\":%.5f,\"floor_seconds\":%.5f}",
               i ? "," : "", texel[i], px, t_ctx, u1 - u0, u2 - u1,
               imp + t_ctx + (u1 - u0) + (u2 - u1));
    }
    printf("]}\n");
    rc = 0;
out:
    if (rc) {
        fflush(stdout);
        fprintf(stderr, "bench_floor: %s\n", err.message[0] ? err.message : "failed");
    }
    sv_renderer_destroy(ren);
    sv_leaves_free(&leaves);
    sv_classification_free(&cls);
    sv_mesh_destroy(mesh);
    sv_spec_free(&spec);
    bench_files_free(&files);
    return rc;
}
