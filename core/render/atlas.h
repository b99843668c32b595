/* atlas.h — chart packing (stb_rect_pack) and the texel filters of quad baking:
 * the median/threshold downsampler and colour dilation (billboard-cloud paper
 * §3.3.7). Used by core/render/bake.c; exposed for tests.
 *
 * Texel coordinates: x right, y down, (0,0) the top-left texel of the atlas.
 */
#ifndef SV_ATLAS_H
#define SV_ATLAS_H

#include "sv.h"
#include "image.h"

typedef struct sv_chart {
    /* input */
    uint32_t w, h; /* chart size in texels, >= 1 */
    /* output */
    uint32_t x, y; /* top-left texel of the chart itself (its padding lies around it) */
} sv_chart;

/* Packs charts[0..n) into a width × height atlas, each chart reserving
 * w+padding × h+padding texels, so two charts are at least `padding` texels
 * apart (and charts keep padding/2 texels from the atlas border). Deterministic
 * (stable sort, no qsort). Returns true when every chart fits; x,y are then set.
 * Returns false (x,y unspecified) when they do not fit or memory runs out. */
bool sv_atlas_pack(sv_chart *charts, uint32_t n, uint32_t width, uint32_t height, uint32_t padding);

/* Packs into the smallest power-of-two atlas with sides <= max_side: the
 * smallest square that fits, then half its height if that still fits.
 * Returns false when even max_side × max_side is too small. */
bool sv_atlas_fit(sv_chart *charts, uint32_t n, uint32_t padding, uint32_t max_side,
                  uint32_t *width, uint32_t *height);

/* Size in texels of a chart of half extents (half_u, half_v) at `texel` world
 * units per texel: ceil(2 half / texel), at least 1 (saturates at UINT32_MAX/4). */
void sv_chart_size(double half_u, double half_v, double texel, uint32_t *w, uint32_t *h);

/* The finest texel size (world units per texel) at which charts of half
 * extents half[2i], half[2i+1] (i < n) pack into max_side × max_side with
 * `padding`: binary search on the density with the real packer.
 * SV_ERR_LIMIT when not even 1-texel charts fit. */
sv_status sv_atlas_choose_texel(const double *half, uint32_t n, uint32_t padding, uint32_t max_side,
                                double *texel, sv_error *err);

/* Downsamples an RGBA8 image of (w·s) × (h·s) samples whose alpha is coverage
 * (0 = empty) into w × h texels (dst, RGBA8, caller storage): a texel is opaque
 * (alpha 255) when the fraction of covered samples in its s×s block is
 * >= alpha_threshold, and then each colour channel is the median of that
 * channel over the covered samples (the lower median for even counts);
 * otherwise the texel is (0,0,0,0). Binary alpha: no sorting needed to draw.
 * alpha_threshold <= 0 selects coverage alpha instead: every texel with at
 * least one covered sample gets the median colour and alpha = the covered
 * fraction (rounded to 8 bits, at least 1), for a renderer's alpha test at a
 * cutoff chosen by calibration (calibrate.c). */
void sv_downsample_median(const uint8_t *src, uint32_t w, uint32_t h, uint32_t s,
                          double alpha_threshold, uint8_t *dst);

/* Downsamples linear RGBA16 samples (render.h's `linear` colour; alpha 0 =
 * empty) into w × h RGBA16 texels with the same coverage test and alpha as
 * sv_downsample_median (opaque 65535; coverage alpha the 8-bit value × 257).
 * Colour: the per-channel median of the covered samples (the paper's filter:
 * a texel shows a colour its samples have, not a blur of them), scaled by one
 * factor so that its Rec. 709 luminance is the mean luminance of the covered
 * samples (light is conserved: the median alone of linear colour is biased
 * dark, texture values skewing dark in linear light and even counts taking
 * the lower median). A median of luminance 0 gives the plain mean. Results
 * are clamped to 65535. Deterministic. */
void sv_downsample_colour16(const uint16_t *src, uint32_t w, uint32_t h, uint32_t s,
                            double alpha_threshold, uint16_t *dst);

/* The same for one float channel (e.g. depth) where a finite value is covered:
 * the median of the finite samples, or INFINITY below the threshold. */
void sv_downsample_median_f32(const float *src, uint32_t w, uint32_t h, uint32_t s,
                              double alpha_threshold, float *dst);

/* Colour dilation: `passes` times, every texel whose mask is 0 and that has a
 * neighbour (8-connected) with a value takes the rounded mean of those
 * neighbours and gains a value; then texels still without one take the mean of
 * all valued texels, so mipmaps never bleed black. Only the first
 * fill_channels channels are written (alpha is left untouched). mask has
 * w*h bytes, nonzero = has a value; it is not modified. img: 8 or 16 bits.
 * With 4 channels and fill_channels 3 (RGBA colour) the means weigh each
 * texel of the mask by its alpha (texels filled by earlier passes weigh 1):
 * pass linear colour, never sRGB bytes (image.h), for a premultiplied mean.
 * SV_ERR_NOMEM on allocation failure (img unchanged). */
sv_status sv_dilate(sv_image *img, const uint8_t *mask, uint32_t fill_channels, uint32_t passes,
                    sv_error *err);

/* Colour for the transparent texels of a baked atlas. lin: RGBA16, linear
 * colour, straight alpha. Every texel whose alpha rounds to 0 in 8 bits (as
 * the written atlas will hold it) takes, in linear light, the alpha-weighted
 * mean colour of the smallest block of the mip pyramid (2^k × 2^k, aligned)
 * above it that holds alpha (pull-push, as sv_texture_dilate), so a straight
 * mip average sees about the colour a premultiplied one would, and the fill
 * is constant over blocks, which a PNG encoder packs well (docs/outputs.md
 * "Sizes"). Other texels and every alpha are untouched; an image that is not
 * RGBA16, or is all clear or all covered, is left as it is. SV_ERR_NOMEM on
 * allocation failure. Deterministic. */
sv_status sv_atlas_fill(sv_image *lin, sv_error *err);

/* Colour for the transparent texels of a base-colour texture (RGBA8, sRGB
 * colour, straight alpha; image.h), so an engine's bilinear filter and mip
 * levels do not blend their colour into the texels it draws: a texture
 * black where it is transparent (the Scopia bush's leaf) draws its leaves
 * darker with each mip level. The texels with alpha 0 take, in linear
 * light, the alpha-weighted mean colour of the smallest block of the mip
 * pyramid (2^k × 2^k, aligned) above them that holds alpha (pull-push), so
 * a straight mip average sees about the colour a premultiplied one would;
 * every other byte, alpha included, is the input's (the atlases' ring
 * dilation, sv_dilate, carried a leaf's darker antialiased edge outward:
 * the bush's mipmapped leaves stayed 7 % dark). Sets *out to that image (a
 * new one) and *changed to true
 * only when it changes what an engine draws: at least one in 100 of the
 * transparent texels within `passes` texels of a texel with alpha changes
 * by more than 8 of 255 in a channel (an input dilated by its author keeps
 * its bytes, and so its own file: docs/outputs.md "Textures"). Otherwise
 * *out is left zeroed and *changed false: an image that is not RGBA8, has
 * no transparent texel or no texel with alpha, or passes 0. A texture of at
 * most 256 colours stays within 256: each filled texel takes the visible
 * colour nearest its fill (an indexed PNG stays indexed, docs/outputs.md
 * "Textures"). SV_ERR_NOMEM on allocation failure. Deterministic. */
sv_status sv_texture_dilate(const sv_image *src, uint32_t passes, sv_image *out, bool *changed,
                            sv_error *err);

#endif
