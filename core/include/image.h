/* image.h — images in memory. Decoding and encoding them (files, PNG,
 * JPEG, the OpenImageIO plugin) is io's: core/io/image_io.h.
 *
 * Pixels are stored row-major, top row first, interleaved channels, with either
 * 8 bits (uint8) or 16 bits (uint16, native endian) per channel.
 *
 * Colour, as glTF defines it: an 8-bit RGBA image is a base-colour texture,
 * its R, G, B sRGB-encoded and its alpha linear (straight, not premultiplied).
 * Whatever filters or averages colour decodes it to linear first and encodes
 * the result once (sv_srgb_decode8, sv_srgb_encode8). Other images (normal
 * maps RGB8, AO and depth maps with one channel, 16-bit images) are linear data.
 */
#ifndef SV_IMAGE_H
#define SV_IMAGE_H

#include "sv.h"

typedef struct sv_image {
    uint32_t width, height;
    uint32_t channels; /* 1..4 */
    uint32_t bits;     /* 8 or 16 */
    void *data;        /* width*height*channels*(bits/8) bytes, owned (with the
                          image's copies: sv_image_copy) */
    void *refs;        /* how many images own data (image.c); NULL: data was not
                          made by sv_image_alloc and is this image's alone */
} sv_image;

/* Allocates a zeroed image. Returns SV_ERR_NOMEM on overflow/failure. */
sv_status sv_image_alloc(sv_image *img, uint32_t w, uint32_t h, uint32_t channels, uint32_t bits,
                         sv_error *err);

/* Releases img's pixels (freed with their last owner) and zeroes the
 * struct. NULL is fine. */
void sv_image_free(sv_image *img);

/* dst (overwritten) becomes a copy of src that shares its pixels: a tree's
 * 1024² textures were copied into every level's mesh. The count is atomic, so copies may be made and
 * freed on any thread. Pixels of an image that has copies are read-only:
 * whoever changes an image makes new pixels (as sv_image_reduce does); no
 * code writes into an image after copying it (docs/design.md). src without
 * data gives a zeroed dst. Pixels not made by sv_image_alloc (refs NULL) are
 * copied instead, which can fail with SV_ERR_NOMEM. */
sv_status sv_image_copy(const sv_image *src, sv_image *dst, sv_error *err);

/* Keeps the encoded file img was decoded from (a copy of data, size bytes)
 * with its pixels, when it is a PNG or a JPEG (anything else: nothing kept,
 * SV_OK), so a writer can store the input's own bytes rather than encode the
 * pixels again (a 300 KB bark JPEG re-encoded was a 2 MB PNG). The file goes
 * with the pixels: copies (sv_image_copy) share it, new pixels (a reduced
 * image) have none. img's pixels must be those data decodes to, as
 * sv_image_decode_rgba8 gives them; img must come from sv_image_alloc (else
 * nothing is kept). SV_ERR_NOMEM when the copy cannot be made. */
sv_status sv_image_set_source(sv_image *img, const void *data, size_t size, sv_error *err);

/* True, with the file's bytes (owned by the image's pixels, valid while
 * they are) and its glTF mimeType ("image/png", "image/jpeg"), when img has
 * a source (sv_image_set_source) and its pixels are still the ones the file
 * decoded to (a hash of them is compared: pixels changed in place lose
 * their source). False otherwise; the outputs are untouched then. */
bool sv_image_source(const sv_image *img, const uint8_t **data, size_t *size, const char **mime);

/* FNV-1a over img's header (width, height, channels, bits) and pixels: the
 * same pixels give the same value (sv_image_source's check, texture file
 * names). */
uint64_t sv_image_pixel_hash(const sv_image *img);

/* Bytes per row. */
size_t sv_image_stride(const sv_image *img);

/* Halves img (2x2 box filter; colour weighted by alpha with 4 channels) until
 * neither side exceeds max_side; max_side 0 or a smaller image: unchanged.
 * An 8-bit RGBA image is sRGB colour (see top): its colour is averaged in
 * linear and encoded again; other images are averaged as stored.
 * Deterministic. On failure img is left as it was. */
sv_status sv_image_reduce(sv_image *img, uint32_t max_side, sv_error *err);

/* True, with *origin the sv_image_pixel_hash of the image it was made from,
 * when img's pixels are that image reduced by sv_image_reduce (through
 * several calls: the first one's) and are still the pixels it made. A file
 * holding that image can draw it instead, mipmapped (gltf_write.c, in a file
 * of several levels). */
bool sv_image_reduced_from(const sv_image *img, uint64_t *origin);

/* The exact sRGB EOTF (IEC 61966-2-1): c/12.92 up to 0.04045, else
 * ((c + 0.055)/1.055)^2.4, for c in [0, 1] (clamped). */
double sv_srgb_to_linear(double c);

/* A texel of an 8-bit image of c channels (GA, RGB or RGBA) as one colour
 * key: (255 − alpha) << 24 | R << 16 | G << 8 | B (grey: R = G = B; no alpha
 * channel: alpha 255), so that descending keys put translucent colours
 * first, the most transparent first. */
uint32_t sv_texel_key(const uint8_t *p, uint32_t c);

/* The distinct colours of img (8-bit, 2 to 4 channels; else 257) as
 * sv_texel_key keys, in descending order, into keys: their count, or 257 as
 * soon as there are more than 256 (an indexed PNG's palette holds 256). */
uint32_t sv_image_colours(const sv_image *img, uint32_t keys[256]);

/* The exact inverse (OETF): 12.92 l up to 0.0031308, else
 * 1.055 l^(1/2.4) − 0.055, for l in [0, 1] (clamped; NaN gives 0). */
double sv_linear_to_srgb(double l);

/* The linear value of an 8-bit sRGB code (a table: exactly
 * sv_srgb_to_linear(code / 255)). */
double sv_srgb_decode8(uint8_t code);

/* The 8-bit sRGB code of linear l: round(255 · sv_linear_to_srgb(l)), found
 * in a table of the code boundaries (no pow); l clamped to [0, 1], NaN → 0.
 * sv_srgb_encode8(sv_srgb_decode8(c)) == c for every c. */
uint8_t sv_srgb_encode8(double l);

/* sv_srgb_encode8(c / 65535.0) for every 16-bit linear code c, as a table
 * of 65536 bytes built once (thread-safe); for reading back 16-bit renders. */
const uint8_t *sv_srgb_encode16_table(void);

/* Walks a PNG's chunk list (length, type, data, CRC) up to IEND without
 * decoding: SV_ERR_PARSE naming `name` when it is cut short (a clear message
 * before libpng reports a short read). d starts with the PNG signature. */
sv_status sv_png_check_chunks(const uint8_t *d, size_t n, const char *name, sv_error *err);

#endif
