/* warm_shaders.c — `sylva-bake warm-shaders DIR` and the per-bake cache
 * environment (see warm_shaders.h; docs/operations.md "Shader cache").
 *
 * Mesa 22.3's single-file cache keeps its DBs in
 * $MESA_SHADER_CACHE_DIR/mesa_shader_cache_sf/<driver sha>/<driver>/, and
 * names read-only DBs relative to that directory (docs/envvars.rst,
 * MESA_DISK_CACHE_READ_ONLY_FOZ_DBS). The depth below the cache dir is the
 * driver's business, so a read-only DB is named from the root: enough "../"
 * to climb from any directory of the per-job cache to "/" (".." at the root
 * stays there), then the DB's absolute path. A Mesa that lays its cache out
 * otherwise simply misses: the bake compiles, as it did before. */
#define _GNU_SOURCE /* mkdtemp, nftw's FTW_PHYS */
#include "warm_shaders.h"

#include <errno.h>
#include <ftw.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "image.h"
#include "image_io.h"
#include "import.h"
#include "method.h"
#include "pipeline.h"

#define CLIMB_SPARE 8 /* levels of the driver's own subfolders, and then some */

int sv_shader_cache_env(const char *db, const char *dir)
{
    char adir[PATH_MAX], ro[3 * PATH_MAX];
    bool ok = db && dir && db[0] == '/' && !strchr(db, ',') && realpath(dir, adir);
    if (ok) {
        size_t depth = CLIMB_SPARE, len = 0;
        for (const char *p = adir; *p; p++) depth += *p == '/';
        for (size_t i = 0; ok && i < depth; i++) {
            ok = len + 3 < sizeof ro;
            if (ok) memcpy(ro + len, "../", 3), len += 3;
        }
        ok = ok && len + strlen(db + 1) + 1 <= sizeof ro;
        if (ok) memcpy(ro + len, db + 1, strlen(db + 1) + 1);
    }
    if (!ok) {
        setenv("MESA_SHADER_CACHE_DISABLE", "true", 1);
        return 0;
    }
    unsetenv("MESA_SHADER_CACHE_DISABLE");
    setenv("MESA_SHADER_CACHE_DIR", adir, 1);
    setenv("MESA_DISK_CACHE_SINGLE_FILE", "1", 1);
    setenv("MESA_DISK_CACHE_READ_ONLY_FOZ_DBS", ro, 1);
    return 1;
}

/* ---- the built-in scene: a box trunk and alpha-cut leaf cards ---- */

#define LEAF_TEX 32
#define LEAF_CARDS 24

static char *scene_obj(void)
{
    size_t cap = 8192, len = 0;
    char *s = malloc(cap);
    if (!s) return NULL;
#define PUT(...) (len += (size_t)snprintf(s + len, cap - len, __VA_ARGS__))
    PUT("mtllib warm.mtl\no trunk\nusemtl bark\n");
    /* a square trunk 0.2 wide, 2 tall: 8 corners, 4 sides */
    for (int k = 0; k < 8; k++)
        PUT("v %.2f %.2f %.2f\n", (k & 1) ? 0.1 : -0.1, (k & 4) ? 2.0 : 0.0, (k & 2) ? 0.1 : -0.1);
    static const int side[4][4] = {{1, 2, 6, 5}, {2, 4, 8, 6}, {4, 3, 7, 8}, {3, 1, 5, 7}};
    for (int f = 0; f < 4; f++)
        PUT("f %d %d %d\nf %d %d %d\n", side[f][0], side[f][1], side[f][2], side[f][0], side[f][2],
            side[f][3]);
    PUT("o leaves\nusemtl leaf\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    /* cards on a golden-angle spiral around the crown, each facing outwards */
    for (int i = 0; i < LEAF_CARDS && len + 512 < cap; i++) {
        double a = 2.39996 * i, y = 2.0 + (double)i / LEAF_CARDS;
        double cx = 0.8 * cos(a), cz = 0.8 * sin(a), tx = -sin(a) * 0.15, tz = cos(a) * 0.15;
        PUT("v %.3f %.3f %.3f\nv %.3f %.3f %.3f\nv %.3f %.3f %.3f\nv %.3f %.3f %.3f\n", cx - tx, y,
            cz - tz, cx + tx, y, cz + tz, cx + tx, y + 0.3, cz + tz, cx - tx, y + 0.3, cz - tz);
        int v = 9 + 4 * i;
        PUT("f %d/1 %d/2 %d/3\nf %d/1 %d/3 %d/4\n", v, v + 1, v + 2, v, v + 2, v + 3);
    }
#undef PUT
    return s;
}

static const char scene_mtl[] = "newmtl bark\nKd 0.35 0.25 0.15\n"
                                "newmtl leaf\nKd 1 1 1\nmap_Kd leaf.png\n";

/* A leaf: green, opaque inside a disc, transparent outside. */
static int leaf_png(uint8_t **png, size_t *n)
{
    sv_image img;
    sv_error e = {0};
    if (sv_image_alloc(&img, LEAF_TEX, LEAF_TEX, 4, 8, &e) != SV_OK) return -1;
    uint8_t *p = img.data;
    for (int y = 0; y < LEAF_TEX; y++)
        for (int x = 0; x < LEAF_TEX; x++, p += 4) {
            double dx = x + 0.5 - LEAF_TEX / 2.0, dy = y + 0.5 - LEAF_TEX / 2.0;
            p[0] = 60, p[1] = (uint8_t)(120 + 3 * x), p[2] = 40;
            p[3] = dx * dx + dy * dy < LEAF_TEX * LEAF_TEX / 5.0 ? 255 : 0;
        }
    sv_status st = sv_image_encode_png(&img, png, n, &e);
    sv_image_free(&img);
    return st == SV_OK ? 0 : -1;
}

static int remove_entry(const char *path, const struct stat *sb, int type, struct FTW *ftw)
{
    (void)sb, (void)type, (void)ftw;
    return remove(path);
}

static char found_db[PATH_MAX];

static int find_db(const char *path, const struct stat *sb, int type, struct FTW *ftw)
{
    (void)sb;
    const char *suffix = "foz_cache.foz";
    if (type == FTW_F && strcmp(path + ftw->base, suffix) == 0) {
        snprintf(found_db, sizeof found_db, "%.*s", (int)(strlen(path) - 4), path);
        return 1;
    }
    return 0;
}

int sv_warm_shaders_main(int argc, char **argv)
{
    if (argc != 1) {
        fprintf(stderr, "usage: sylva-bake warm-shaders DIR\n");
        return 2;
    }
    char dir[PATH_MAX], out[PATH_MAX + 16];
    if ((mkdir(argv[0], 0755) != 0 && errno != EEXIST) || !realpath(argv[0], dir)) {
        fprintf(stderr, "sylva-bake warm-shaders: %s: %s\n", argv[0], strerror(errno));
        return 1;
    }
    unsetenv("MESA_SHADER_CACHE_DISABLE");
    unsetenv("MESA_DISK_CACHE_READ_ONLY_FOZ_DBS");
    setenv("MESA_SHADER_CACHE_DIR", dir, 1);
    setenv("MESA_DISK_CACHE_SINGLE_FILE", "1", 1);

    char *obj = scene_obj();
    uint8_t *png = NULL;
    size_t png_n = 0;
    if (!obj || leaf_png(&png, &png_n) != 0) {
        fprintf(stderr, "sylva-bake warm-shaders: out of memory building the scene\n");
        free(obj);
        return 1;
    }
    sv_file files[3] = {{"warm.obj", (const uint8_t *)obj, strlen(obj)},
                        {"warm.mtl", (const uint8_t *)scene_mtl, sizeof scene_mtl - 1},
                        {"leaf.png", png, png_n}};
    /* the default chain, dynamic light (normal maps), and every method on its own */
    size_t nm = 0;
    const sv_method *const *methods = sv_method_list(&nm);
    int failed = 0;
    for (size_t k = 0; k < nm + 2; k++) {
        /* few views, one size, a 4 x 4 impostor grid, 64-texel atlases
         * and no FBX files: the states are what is compiled, not the
         * pixels (the atlas size and the FBX export were a third of the
         * warm-up's 2.5 s, which every daemon start pays). One pass is
         * enough: bakes of the shared trees then compile nothing
         * (tests/integration/shader_cache.sh checks a synthetic tree; the
         * aspen, the bush and the demo oak were checked too; the bonsai
         * compiles some shaders with or without these settings) */
        char spec[384];
        const char *cheap = "\"evaluate\": {\"views\": 4, \"sizes\": [64]}, "
                            "\"octahedral\": {\"grid\": 4}, \"bake\": {\"max_atlas\": 64}, "
                            "\"output\": {\"fbx\": false}";
        if (k == 0) snprintf(spec, sizeof spec, "{%s}", cheap);
        else if (k == 1)
            snprintf(spec, sizeof spec, "{%s, \"scene\": {\"lighting\": \"dynamic\"}}", cheap);
        else
            snprintf(spec, sizeof spec, "{%s, \"method\": \"%s\", \"lod\": {\"chain\": false}}",
                     cheap, methods[k - 2]->name);
        snprintf(out, sizeof out, "%s/out-XXXXXX", dir);
        if (!mkdtemp(out)) {
            failed = 1;
            break;
        }
        sv_error e = {0};
        sv_bake_request req = {files, 3, spec, strlen(spec), out, NULL, NULL, NULL};
        if (sv_pipeline_run(&req, &e) != SV_OK) {
            fprintf(stderr, "sylva-bake warm-shaders: %s: %s\n", spec, e.message);
            failed = 1;
        }
        nftw(out, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    }
    free(obj);
    free(png);
    found_db[0] = 0;
    nftw(dir, find_db, 16, FTW_PHYS);
    if (failed || !found_db[0]) {
        fprintf(stderr, "sylva-bake warm-shaders: %s\n",
                failed ? "a bake of the built-in scene failed"
                       : "Mesa wrote no single-file cache (foz_cache.foz)");
        return 1;
    }
    printf("%s\n", found_db);
    return 0;
}
