/* bench_util.h — helpers shared by the benchmark tools (tests/tools/bench_*.c):
 * reading the files of an upload, parsing a bake spec, importing a mesh the way
 * the pipeline does (core/pipeline/pipeline.c prepare: import with the spec's units and
 * up axis, then validate), and the evaluation options the pipeline derives
 * from the spec, so a peer is judged by exactly the evaluation our bakes get.
 * Header-only (static functions): each tool is one translation unit.
 */
#ifndef SV_BENCH_UTIL_H
#define SV_BENCH_UTIL_H

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evaluate.h"
#include "import.h"
#include "spec.h"
#include "validate.h"

#define BENCH_MAX_FILES 64

typedef struct bench_files {
    sv_file files[BENCH_MAX_FILES];
    void *data[BENCH_MAX_FILES];
    size_t count;
} bench_files;

/* Reads a whole file into *out (malloc'ed, NUL-terminated for JSON). */
static inline sv_status bench_read_file(const char *path, void **out, size_t *size, sv_error *err)
{
    *out = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return sv_fail(err, SV_ERR_IO, "cannot open %s: %s", path, strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n - 1, f);
        if (n < cap - 1) break;
        char *nb = cap > SIZE_MAX / 2 ? NULL : realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    bool bad = ferror(f) != 0;
    fclose(f);
    if (!buf) return sv_fail(err, SV_ERR_NOMEM, "out of memory reading %s", path);
    if (bad) {
        free(buf);
        return sv_fail(err, SV_ERR_IO, "read error on %s", path);
    }
    buf[n] = 0;
    *out = buf;
    *size = n;
    return SV_OK;
}

static inline void bench_files_free(bench_files *b)
{
    if (!b) return;
    for (size_t i = 0; i < b->count; i++) free(b->data[i]);
    memset(b, 0, sizeof *b);
}

/* Loads paths[0..n): the main mesh first, then its companions (base names). */
static inline sv_status bench_files_load(char **paths, size_t n, bench_files *b, sv_error *err)
{
    memset(b, 0, sizeof *b);
    if (n == 0) return sv_fail(err, SV_ERR_INVALID, "no mesh file given");
    if (n > BENCH_MAX_FILES) return sv_fail(err, SV_ERR_LIMIT, "at most %d files", BENCH_MAX_FILES);
    for (size_t i = 0; i < n; i++) {
        size_t size = 0;
        sv_status st = bench_read_file(paths[i], &b->data[i], &size, err);
        if (st) {
            bench_files_free(b);
            return st;
        }
        const char *s = strrchr(paths[i], '/');
        b->files[i].name = s ? s + 1 : paths[i];
        b->files[i].data = b->data[i];
        b->files[i].size = size;
        b->count++;
    }
    return SV_OK;
}

/* Parses the spec file at path (NULL: "{}"). */
static inline sv_status bench_spec_load(const char *path, sv_spec *spec, sv_error *err)
{
    memset(spec, 0, sizeof *spec);
    if (!path) return sv_spec_parse("{}", 2, spec, err);
    void *txt = NULL;
    size_t len = 0;
    sv_status st = bench_read_file(path, &txt, &len, err);
    if (st) return st;
    st = sv_spec_parse(txt, len, spec, err);
    free(txt);
    return st;
}

/* Import and validation as the pipeline does them; *seconds receives the
 * wall time of the import alone and *validate_seconds of the validation
 * (either may be NULL). */
static inline sv_status bench_import(const bench_files *b, const sv_spec *spec, sv_mesh **out,
                                     double *seconds, double *validate_seconds, sv_error *err)
{
    *out = NULL;
    sv_import_options io;
    memset(&io, 0, sizeof io);
    io.unit_scale = spec->unit_scale;
    io.up_axis = spec->up_axis;
    double t0 = sv_now();
    sv_status st = sv_import(b->files, b->count, &io, out, NULL, err);
    double t1 = sv_now();
    if (seconds) *seconds = t1 - t0;
    if (st) return st;
    st = sv_validate(*out, &io.limits, NULL, err);
    if (validate_seconds) *validate_seconds = sv_now() - t1;
    if (st) {
        sv_mesh_destroy(*out);
        *out = NULL;
    }
    return st;
}

/* The evaluation options core/pipeline/pipeline.c builds from a spec (static lighting:
 * both renders lit by the scene's light). */
static inline void bench_eval_options(const sv_spec *spec, sv_eval_options *eo)
{
    memset(eo, 0, sizeof *eo);
    eo->view_count = spec->eval_views;
    eo->viewer = spec->scene.viewer;
    if (spec->scene.lighting == SV_LIGHTING_STATIC) {
        eo->render.shade = SV_SHADE_LIT;
        memcpy(eo->render.light_dir, spec->scene.light_dir, sizeof eo->render.light_dir);
    }
    eo->supersample = spec->eval_supersample;
    eo->size_count = spec->eval_size_count;
    memcpy(eo->sizes, spec->eval_sizes, sizeof(uint32_t) * spec->eval_size_count);
}

/* Prints a JSON string literal (the tools' messages are plain ASCII/UTF-8). */
static inline void bench_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') fprintf(f, "\\%c", c);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

#endif
