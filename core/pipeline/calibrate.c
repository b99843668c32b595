/* calibrate.c — alpha cutoffs and atlas sizes, after the bake: each quad
 * level's atlas cutoff chosen against the original's coverage (after
 * Behrendt et al. §3.3.7), and the atlases of levels drawn only small
 * reduced to what their switch size shows. Also the small
 * evaluator both share with the chain's score callback.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline_internal.h"

/* Alpha calibration (Behrendt et al. §3.3.7 threshold the baked
 * coverage "to keep the look of density", but a fixed threshold inflates or
 * thins the crown depending on leaf size, texel size and how far leaves were
 * flattened). The atlas keeps each texel's covered fraction as alpha; the
 * cutoff of the atlas material is chosen per level as the one whose alpha-
 * tested render best matches the original's coverage (mean soft IoU) at
 * SV_CALIB_PIXELS over SV_CALIB_VIEWS views placed by scene.viewer. Every
 * cutoff (k + 0.5) / 255 is judged, all from one render a view: a sample is
 * covered at a cutoff exactly when the largest alpha drawn there reaches it
 * (render.h SV_SHADE_ALPHA_MAX, evaluate.h sv_evaluate_cutoffs). Until
 * the last re-measurement (docs/accuracy.md): a grid of 0.1 refined three times, 15
 * renders a view at 128²; the one render allows 256², sveval's resolution,
 * at the same cost (docs/accuracy.md "Alpha calibration"). */
#define SV_CALIB_PIXELS 64u
#define SV_CALIB_VIEWS 8u

/* The calibration's views at one size px: SV_CALIB_VIEWS views placed by
 * scene.viewer, rendered at render² and box-filtered down to px. */
static void calib_options(const run *r, uint32_t px, uint32_t render, sv_eval_options *eo)
{
    memset(eo, 0, sizeof *eo);
    eo->viewer = r->spec.scene.viewer;
    eo->view_count = SV_CALIB_VIEWS;
    eo->sizes[0] = px;
    eo->size_count = 1;
    eo->supersample = render / px;
}

/* The chain's score callback renders at 128² (at 64 px: a quarter of
 * the pixels of a supersample of 4). A cutoff is chosen at 256², the
 * resolution sveval judges coverage at (4 × 4 samples per pixel at 64 px):
 * at 128² the blocks of 2 × 2 samples favour fatter texels (thin twigs and
 * leaf edges cover a sample more easily), and the cutoffs it picked were
 * lower than the best one at 256² (sapling maple, 20 planes: 0.1375 against
 * about 0.2; docs/accuracy.md "Alpha calibration"). */
#define SV_SCORE_RENDER 128u
#define SV_CALIB_RENDER 256u

sv_status svp_small_evaluator(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, uint32_t render,
                              sv_evaluator **out, sv_error *err)
{
    sv_eval_options eo;
    calib_options(r, SV_CALIB_PIXELS, render, &eo);
    if (r->calib_ev && memcmp(&r->calib_opt, &eo, sizeof eo) != 0) {
        sv_evaluator_destroy(r->calib_ev);
        r->calib_ev = NULL;
    }
    if (!r->calib_ev) {
        sv_status st = sv_evaluator_create(ren, r->p.mesh, gsrc, &eo, &r->calib_ev, err);
        if (st) return st;
        r->calib_opt = eo;
    }
    *out = r->calib_ev;
    return SV_OK;
}

/* The chain's candidates (sv_chain_score_fn): mean IoU at 64 px, 8 views. */
sv_status svp_chain_score(void *user, const sv_mesh *level, double *score, sv_error *err)
{
    score_ctx *c = user;
    sv_evaluator *ev = NULL;
    sv_status st = svp_small_evaluator(c->r, c->ren, c->gsrc, SV_SCORE_RENDER, &ev, err);
    if (st) return st;
    sv_gpu_mesh *g = NULL;
    if ((st = sv_gpu_mesh_upload(c->ren, level, &g, err))) return st;
    sv_eval_result er;
    st = sv_evaluate(ev, g, &er, err);
    sv_gpu_mesh_free(g);
    if (st) return st;
    *score = er.sizes[0].mean.iou;
    sv_eval_result_free(&er);
    return SV_OK;
}

/* The cutoffs a written material may have: [0.1, 0.9]. A cutoff near 0
 * passes any texel a leaf touched, so once an engine averages alpha into
 * its mipmaps (as the glTF sampler asks) every quad fills; near 1 the
 * leaves vanish the same way. Where coverage needs a cutoff outside, the
 * atlas's alpha is scaled instead (preserve_coverage). Bytes k of the
 * cutoffs (k + 0.5) / 255. */
#define SV_CUTOFF_MIN_BYTE 25u  /* 0.1 */
#define SV_CUTOFF_MAX_BYTE 229u /* 0.9 */

/* Calibrates the atlas material's cutoff of one quad level (its mesh's
 * first material, when alpha-tested): every cutoff (k + 0.5) / 255 in
 * [0.1, 0.9] judged from one render a view (sv_evaluate_cutoffs), the best
 * one kept (the lowest of equals). */
static sv_status calibrate_level(sv_evaluator *ev, sv_renderer *ren, lod_out *l, sv_error *err)
{
    sv_mesh *m = l->baked.mesh;
    if (!m || !m->triangle_count) return SV_OK;
    sv_material *mat = &m->materials[m->tri_material[0]];
    if (mat->alpha_mode != SV_ALPHA_MASK) return SV_OK;
    sv_gpu_mesh *g = NULL;
    sv_status st = sv_gpu_mesh_upload(ren, m, &g, err);
    if (st) return st;
    double iou[255];
    mat->alpha_cutoff = 0; /* swept */
    st = sv_evaluate_cutoffs(ev, g, iou, err);
    sv_gpu_mesh_free(g);
    uint32_t best = SV_CUTOFF_MIN_BYTE;
    for (uint32_t k = SV_CUTOFF_MIN_BYTE + 1; k <= SV_CUTOFF_MAX_BYTE && !st; k++)
        if (iou[k] > iou[best]) best = k;
    l->alpha_cutoff = (best + 0.5) / 255.0;
    mat->alpha_cutoff = (float)l->alpha_cutoff;
    l->calib_iou = iou[best];
    return st;
}

/* Alpha of texel i of an RGBA image, 0..1. */
static double texel_alpha(const sv_image *im, size_t i)
{
    return im->bits == 16 ? ((const uint16_t *)im->data)[4 * i + 3] / 65535.0
                          : ((const uint8_t *)im->data)[4 * i + 3] / 255.0;
}

/* Fraction of im's texels whose alpha × scale exceeds cutoff. */
static double covered_fraction(const sv_image *im, double scale, double cutoff)
{
    size_t n = (size_t)im->width * im->height, c = 0;
    for (size_t i = 0; i < n; i++) c += texel_alpha(im, i) * scale > cutoff;
    return n ? (double)c / (double)n : 0;
}

/* Coverage-preserving alpha (Castaño 2010, "Computing Alpha Mipmaps"): a
 * box-filtered atlas's alpha is the mean coverage of the texels it merges,
 * so at one cutoff sparse leaves fade and dense ones fill. The reduced
 * atlas's alpha is scaled (clamped to 1) so that the fraction of its texels
 * above 0.5 is `target`, the fraction the full atlas had above its own
 * cutoff; the cutoff is then calibrated again around it. The scale is found
 * by bisection in log2 over [1/64, 64]. */
static void preserve_coverage(sv_image *im, double target)
{
    if (!im->data || im->channels != 4 || !(target > 0)) return;
    double lo = -6, hi = 6; /* log2 scale: covered fraction grows with it */
    for (int k = 0; k < 40; k++) {
        double m = 0.5 * (lo + hi);
        if (covered_fraction(im, exp2(m), 0.5) < target) lo = m;
        else hi = m;
    }
    double scale = exp2(hi);
    size_t n = (size_t)im->width * im->height;
    for (size_t i = 0; i < n; i++) {
        double a = fmin(1.0, texel_alpha(im, i) * scale);
        if (im->bits == 16) ((uint16_t *)im->data)[4 * i + 3] = (uint16_t)floor(a * 65535.0 + 0.5);
        else ((uint8_t *)im->data)[4 * i + 3] = (uint8_t)floor(a * 255.0 + 0.5);
    }
}

/* Sets the atlas material's cutoff of every quad level baked with coverage
 * alpha (levels drawn view-dependently keep 0.5). */
sv_status svp_calibrate_cutoffs(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc,
                                const sv_stand_in *si, lod_out *lods, sv_error *err)
{
    bool any = false;
    for (uint32_t i = 0; i < si->lod_count; i++)
        any |= si->lods[i].quad_count > 0 && !si->lods[i].select;
    if (!any) return SV_OK;
    sv_evaluator *ev = NULL;
    sv_status st = svp_small_evaluator(r, ren, gsrc, SV_CALIB_RENDER, &ev, err);
    for (uint32_t i = 0; i < si->lod_count && !st; i++)
        if (si->lods[i].quad_count && !si->lods[i].select)
            st = calibrate_level(ev, ren, &lods[i], err);
    return st;
}

/* Atlases sized by where a level is drawn. A level after
 * the first is never drawn taller than its switch size S, where one texel
 * of tree_h / (S × SV_ATLAS_TEXELS_PER_PIXEL) is enough; its maps (baked at
 * bake.texel_pixels, 256 texels per tree height by default) are box-filtered
 * down by powers of two to that (colour weighted by alpha; the UV rectangles
 * are fractions of the atlas and stay) and, with coverage alpha, its cutoff
 * is calibrated again at the size it is drawn at, after its alpha is scaled
 * to keep the coverage the full atlas had (preserve_coverage). The first
 * level is drawn at any size and keeps its atlas. A reduced level is marked
 * (lod_out.reduced) for the pipeline to measure it again: the report gives
 * the accuracy of what is written. */
#define SV_ATLAS_MIN_SIDE 16u
/* The smallest screen size a shrunk level's cutoff is calibrated at. */
#define SV_CALIB_MIN_PIXELS 16u

sv_status svp_shrink_atlases(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, sv_stand_in *si,
                             lod_out *lods, double tree_h, bool calibrate, sv_error *err)
{
    sv_evaluator *ev = NULL;
    uint32_t ev_px = 0;
    sv_status st = SV_OK;
    for (uint32_t i = 1; i < si->lod_count && !st; i++) {
        lod_out *l = &lods[i];
        sv_baked_lod *b = &l->baked;
        if (!b->albedo.data || !(b->texel_size > 0) || !(l->switch_pixels > 0) || !b->mesh)
            continue;
        double want = tree_h / (l->switch_pixels * SV_ATLAS_TEXELS_PER_PIXEL);
        uint32_t side = b->albedo.width > b->albedo.height ? b->albedo.width : b->albedo.height;
        uint32_t other = b->albedo.width + b->albedo.height - side;
        int k = 0;
        while (b->texel_size * ldexp(1.0, k + 1) <= want && (other >> (k + 1)) >= SV_ATLAS_MIN_SIDE)
            k++;
        sv_lod_plan *lp = &si->lods[i];
        if (k && lp->ops && lp->ops->shrink) k = lp->ops->shrink(lp, k); /* an impostor's frames */
        if (!k) continue;
        sv_image *maps[4] = {&b->albedo, &b->normal, &b->ao, &b->depth};
        bool rescale = calibrate && lp->quad_count && !lp->select && l->alpha_cutoff > 0 &&
                       b->albedo.channels == 4;
        double target = rescale ? covered_fraction(&b->albedo, 1.0, l->alpha_cutoff) : 0;
        for (int m = 0; m < 4 && !st; m++)
            if (maps[m]->data) st = sv_image_reduce(maps[m], side >> k, err);
        if (!st && rescale) preserve_coverage(&b->albedo, target);
        l->reduced = true;
        sv_mesh *mesh = b->mesh;
        sv_material *mat = &mesh->materials[mesh->tri_material[0]];
        int32_t idx[3] = {mat->base_texture, mat->normal_texture, mat->occlusion_texture};
        for (int m = 0; m < 3 && !st; m++) {
            if (idx[m] < 0 || (uint32_t)idx[m] >= mesh->image_count || !maps[m]->data) continue;
            sv_image_free(&mesh->images[idx[m]]);
            st = sv_image_copy(maps[m], &mesh->images[idx[m]], err);
        }
        b->texel_size = ldexp(b->texel_size, k);
        if (!st && calibrate && si->lods[i].quad_count && !si->lods[i].select) {
            /* at the size the level is drawn at most (a power of two in
             * [16, 64]): judged at 64 px, a 16 px level's cutoff was chosen
             * for blocks it never shows */
            uint32_t px = SV_CALIB_MIN_PIXELS;
            while (px < SV_CALIB_PIXELS && px < l->switch_pixels) px *= 2;
            sv_eval_options eo;
            calib_options(r, px, SV_CALIB_RENDER, &eo);
            if (!ev || ev_px != px) {
                sv_evaluator_destroy(ev);
                ev = NULL;
                st = sv_evaluator_create(ren, r->p.mesh, gsrc, &eo, &ev, err);
                ev_px = px;
            }
            if (!st) st = calibrate_level(ev, ren, l, err);
        }
    }
    sv_evaluator_destroy(ev);
    return st;
}

/* img's colour × f in linear light into a new image (alpha kept); RGBA8 or
 * RGB8 only (else *out is left zeroed). */
static sv_status scaled_image(const sv_image *img, double f, sv_image *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!img->data || img->bits != 8 || img->channels < 3) return SV_OK;
    sv_status st = sv_image_alloc(out, img->width, img->height, img->channels, 8, err);
    if (st) return st;
    uint8_t lut[256];
    for (int c = 0; c < 256; c++) lut[c] = sv_srgb_encode8(sv_srgb_decode8((uint8_t)c) * f);
    const uint8_t *src = img->data;
    uint8_t *dst = out->data;
    uint32_t ch = img->channels;
    for (size_t i = 0, len = (size_t)img->width * img->height * ch; i < len; i += ch) {
        for (uint32_t k = 0; k < 3; k++) dst[i + k] = lut[src[i + k]];
        if (ch == 4) dst[i + 3] = src[i + 3];
    }
    return SV_OK;
}

sv_status svp_scale_mesh_colour(sv_mesh *m, double f, sv_error *err)
{
    if (!m || !m->material_count) return SV_OK;
    /* an image is scaled when a material sampling it cannot take f in its
     * factor (glTF clamps the factor to 1) */
    bool *scale = sv_calloc(m->image_count ? m->image_count : 1, sizeof *scale);
    if (!scale) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; i < m->material_count; i++) {
        const sv_material *mt = &m->materials[i];
        int32_t t = mt->base_texture;
        if (t < 0 || (uint32_t)t >= m->image_count) continue;
        for (int k = 0; k < 3; k++)
            if (mt->base_color[k] * f > 1.0) scale[t] = true;
    }
    sv_status st = SV_OK;
    for (uint32_t t = 0; t < m->image_count && !st; t++) {
        if (!scale[t]) continue;
        sv_image n;
        if ((st = scaled_image(&m->images[t], f, &n, err)) || !n.data) {
            scale[t] = false; /* not 8-bit colour: its materials take f in the factor */
            continue;
        }
        sv_image_free(&m->images[t]);
        st = sv_image_copy(&n, &m->images[t], err);
        sv_image_free(&n);
    }
    for (uint32_t i = 0; i < m->material_count && !st; i++) {
        sv_material *mt = &m->materials[i];
        int32_t t = mt->base_texture;
        if (t >= 0 && (uint32_t)t < m->image_count && scale[t]) continue;
        for (int k = 0; k < 3; k++) mt->base_color[k] = (float)fmin(1.0, mt->base_color[k] * f);
    }
    free(scale);
    return st;
}

sv_status svp_scale_atlas(sv_baked_lod *b, double f, sv_error *err)
{
    sv_image *a = &b->albedo;
    if (!a->data || a->channels != 4 || a->bits != 8) return SV_OK;
    sv_image n;
    sv_status st = scaled_image(a, f, &n, err);
    if (st) return st;
    sv_mesh *m = b->mesh;
    int32_t t = m && m->triangle_count ? m->materials[m->tri_material[0]].base_texture : -1;
    if (t >= 0 && (uint32_t)t < m->image_count) {
        sv_image_free(&m->images[t]);
        st = sv_image_copy(&n, &m->images[t], err);
    }
    sv_image_free(a);
    if (!st) st = sv_image_copy(&n, a, err);
    sv_image_free(&n);
    return st;
}
