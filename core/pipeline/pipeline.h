/* pipeline.h — the whole bake, offline: import → validate → classify → method →
 * bake → pack → evaluate → write (DESIGN.md "The core pipeline").
 *
 * Used by `sylva-bake bake` (standalone, or as the daemon's worker). Outputs in
 * out_dir: model.glb, lod<i>_<name>.glb per level, planes.json, report.json,
 * preview.png and the atlas PNGs.
 * Everything but report.json's "times" object is byte-identical for the same
 * input files and spec.
 */
#ifndef SV_PIPELINE_H
#define SV_PIPELINE_H

#include "import.h"

/* Progress: stage name and overall fraction in [0, 1]. Return false to cancel. */
typedef bool (*sv_progress_fn)(void *user, const char *stage, double fraction);
/* A target search (docs/spec.md "target") starts try k of at most `most`
 * (the bisections' bound; the search often needs fewer); k = 0 once the
 * search is over and the chosen setting is baked for the outputs. */
typedef void (*sv_search_fn)(void *user, int k, int most);

typedef struct sv_bake_request {
    const sv_file *files; /* files[0] is the main mesh */
    size_t file_count;
    const char *spec_json; /* may be NULL or empty: "{}" */
    size_t spec_len;
    const char *out_dir;     /* must exist */
    sv_progress_fn progress; /* may be NULL */
    void *user;
    sv_search_fn search; /* may be NULL; called with user */
} sv_bake_request;

/* Runs the bake. On failure nothing but partial files may remain in out_dir
 * and err names the problem (its status says whether the input was at fault). */
sv_status sv_pipeline_run(const sv_bake_request *req, sv_error *err);

/* Imports, validates and classifies, then writes a description of the mesh
 * (triangles, vertices, materials with classification and reasons, bounds,
 * units, leaf statistics, repairs) as JSON into *json_out (malloc'ed).
 * spec_json may carry "import" and "classify" settings. */
sv_status sv_pipeline_info(const sv_file *files, size_t count, const char *spec_json,
                           size_t spec_len, char **json_out, sv_error *err);

#endif
