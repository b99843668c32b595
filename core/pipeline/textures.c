/* textures.c — the source's base-colour textures made safe for mipmaps
 * before anything is baked (docs/outputs.md "Textures").
 *
 * A texture whose transparent texels hold a colour unrelated to their
 * opaque neighbours (black, most often) draws its alpha-tested leaves
 * darker in an engine that mipmaps it, as the output files ask: each mip
 * level averages those texels in. sylva's renderer samples without mipmaps,
 * so the quad levels baked from it did not darken and the mesh levels that
 * keep the texture did. Dilating its colour outward (atlas.h,
 * sv_texture_dilate) before the bake makes every level, and sylva's own
 * renders, draw the same colour. Only textures every user of which is the
 * base colour of a MASK or BLEND material are touched (an OPAQUE material
 * draws its transparent texels' colour as it is), and only when the
 * dilation changes them: an unchanged texture keeps the input's own file.
 */
#include <stdlib.h>
#include <string.h>

#include "atlas.h"
#include "pipeline_internal.h"

sv_status svp_dilate_textures(sv_mesh *m, uint32_t passes, sv_error *err)
{
    for (uint32_t i = 0; i < m->image_count; i++) {
        bool alpha_use = false, other_use = false;
        for (uint32_t k = 0; k < m->material_count; k++) {
            const sv_material *mat = &m->materials[k];
            if (mat->normal_texture == (int32_t)i || mat->occlusion_texture == (int32_t)i)
                other_use = true;
            if (mat->base_texture == (int32_t)i) {
                if (mat->alpha_mode == SV_ALPHA_OPAQUE) other_use = true;
                else alpha_use = true;
            }
        }
        if (!alpha_use || other_use) continue;
        sv_image out;
        bool changed = false;
        sv_status st = sv_texture_dilate(&m->images[i], passes, &out, &changed, err);
        if (st != SV_OK) return st;
        if (!changed) continue;
        sv_image_free(&m->images[i]);
        m->images[i] = out;
    }
    return SV_OK;
}
