/* preview.h — preview.png of a LOD chain (docs/outputs.md): every kept level
 * beside the original, at a common size and at its switch size, labelled with
 * its triangles, texels and measured IoU. */
#ifndef SV_PREVIEW_H
#define SV_PREVIEW_H

#include "evaluate.h"
#include "render.h"

typedef struct sv_preview_level {
    const sv_gpu_mesh *gpu;   /* the level, uploaded to the same renderer */
    sv_eval_subset_fn select; /* per-view triangle choice (slicings); NULL = all */
    sv_eval_draw_fn draw;     /* non-NULL: drawn by this instead of gpu (impostors) */
    void *user;               /* for select or draw */
    const char *name;
    double pixels; /* switch size: bounding-sphere diameter in pixels */
    double triangles, texels;
    double iou;        /* mean IoU near the switch size, < 0 = not measured */
    double iou_pixels; /* the size that IoU was measured at */
} sv_preview_level;

/* Renders the original and levels[0..n) with cam (framing the tree's bounding
 * sphere in a square) and ro, and writes an RGB PNG to path: a top row of
 * tile × tile tiles (original, then each level), a second row with, per level,
 * the original and the level side by side at the level's switch size (clamped
 * to [4, tile/2 - 2] px, drawn at real size), and text lines under each column
 * (name, switch px, triangles, texels, IoU). Subsets: the heaviest one for the
 * camera's view direction. Background neutral grey. Deterministic for the same
 * inputs. tile in [64, 1024]. Errors from the renderer, SV_ERR_NOMEM, or the
 * PNG writer's. */
sv_status sv_preview_chain(sv_renderer *r, const sv_gpu_mesh *original,
                           const sv_preview_level *levels, uint32_t n, const sv_camera *cam,
                           const double view_dir[3], const sv_render_options *ro, uint32_t tile,
                           const char *path, sv_error *err);

#endif
