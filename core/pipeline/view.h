/* view.h — one evaluation view of a finished bake's level: what
 * `sylva-bake view` draws, so a runtime (the viewer page's shaders, an
 * engine) can be compared with the evaluator pixel for pixel. */
#ifndef SV_VIEW_H
#define SV_VIEW_H

#include "sv.h"

/* Renders level `lod` (its name in report.json) of the bake in out_dir as
 * the evaluator does: the orthographic camera of sv_eval_camera framing
 * report.json's evaluation.frame sphere from unit direction dir (towards the
 * viewer; normalised here), size × size pixels, one sample per pixel, unlit
 * albedo; octahedral levels through the C reference runtime (impostor.json,
 * their albedo and depth atlases), every other level from its
 * lod<i>_<name>.glb with all its triangles (view-dependent slicings are
 * drawn whole). Writes an RGBA PNG to png_path: alpha 255 where drawn, 0
 * elsewhere. SV_ERR_INVALID for a missing level or bad arguments, the
 * reader's or renderer's errors otherwise. */
sv_status sv_view_render(const char *out_dir, const char *lod, const double dir[3], uint32_t size,
                         const char *png_path, sv_error *err);

#endif
