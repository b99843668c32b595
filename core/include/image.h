/* image.h — images in memory; decoding of PNG and JPEG with libpng and
 * libjpeg (core/io/image_decode.c), of every other format through the
 * OpenImageIO plugin (libsvimage.so, built from core/io/image_oiio.cpp, the
 * only C++ file, which catches every exception and copies the text into
 * sv_error; loaded on first use by core/io/image_plugin.c), PNG encoding with
 * libpng (core/io/image_png.c).
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
 * 1024² textures were copied into every level's mesh (issue 20: 170 MB of
 * the ez-tree pine's peak). The count is atomic, so copies may be made and
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

/* Bytes per row. */
size_t sv_image_stride(const sv_image *img);

/* Halves img (2x2 box filter; colour weighted by alpha with 4 channels) until
 * neither side exceeds max_side; max_side 0 or a smaller image: unchanged.
 * An 8-bit RGBA image is sRGB colour (see top): its colour is averaged in
 * linear and encoded again; other images are averaged as stored.
 * Deterministic. On failure img is left as it was. */
sv_status sv_image_reduce(sv_image *img, uint32_t max_side, sv_error *err);

/* The exact sRGB EOTF (IEC 61966-2-1): c/12.92 up to 0.04045, else
 * ((c + 0.055)/1.055)^2.4, for c in [0, 1] (clamped). */
double sv_srgb_to_linear(double c);

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

/* Loads the decoding plugin now if it is not loaded yet (thread-safe, once;
 * the decoders call it). For a process about to enter the seccomp sandbox or
 * to fork jobs: dlopen and OIIO's initialisers then run before. SV_ERR_INTERNAL
 * naming the plugin and the loader's message when it cannot be loaded. */
sv_status sv_image_plugin_load(sv_error *err);

/* A symbol of the loaded plugin or of the libraries it pulled in (dlsym on
 * its handle: they are not in the global scope); NULL when the plugin is not
 * loaded or has no such symbol. */
void *sv_image_plugin_symbol(const char *name);

/* Decodes PNG/JPEG/TGA (anything OIIO reads from memory) into RGBA8, straight
 * alpha (255 where the image has none). `name` is only used for messages and
 * as a format hint. Images larger than max_size on a side (0: 16384) are
 * refused with SV_ERR_LIMIT. PNG and JPEG are decoded in process (the same
 * pixels as the plugin gives), the rest by the plugin. */
sv_status sv_image_decode_rgba8(const void *data, size_t size, const char *name, uint32_t max_size,
                                sv_image *out, sv_error *err);

/* As sv_image_decode_rgba8, and an image whose decode would take more than
 * max_bytes of memory (its decoded pixels at their stored depth and the RGBA8
 * result; 0: 1 GiB) is refused with SV_ERR_LIMIT before its pixels are
 * decoded: a small compressed file can hold a huge image. */
sv_status sv_image_decode_rgba8_within(const void *data, size_t size, const char *name,
                                       uint32_t max_size, uint64_t max_bytes, sv_image *out,
                                       sv_error *err);

/* Decodes the first channel of a PNG as 16 bits (8-bit PNGs are widened)
 * into a 1-channel 16-bit image (depth maps). SV_ERR_FORMAT for other formats. */
sv_status sv_image_decode_gray16(const void *data, size_t size, const char *name, uint32_t max_size,
                                 sv_image *out, sv_error *err);

/* The plugin's own decoders, as the two above for every format (PNG and
 * JPEG through OIIO too): the fallback for the formats image_decode.c does
 * not read, and the comparison in the tests. */
sv_status sv_image_plugin_decode_rgba8(const void *data, size_t size, const char *name,
                                       uint32_t max_size, sv_image *out, sv_error *err);
/* sv_image_plugin_decode_rgba8 with sv_image_decode_rgba8_within's max_bytes. */
sv_status sv_image_plugin_decode_rgba8_within(const void *data, size_t size, const char *name,
                                              uint32_t max_size, uint64_t max_bytes, sv_image *out,
                                              sv_error *err);
sv_status sv_image_plugin_decode_gray16(const void *data, size_t size, const char *name,
                                        uint32_t max_size, sv_image *out, sv_error *err);

/* Walks a PNG's chunk list (length, type, data, CRC) up to IEND without
 * decoding: SV_ERR_PARSE naming `name` when it is cut short (a clear message
 * before libpng reports a short read). d starts with the PNG signature. */
sv_status sv_png_check_chunks(const uint8_t *d, size_t n, const char *name, sv_error *err);

/* Writes img as PNG (8 or 16 bits) to path. Deterministic: same pixels, same bytes. */
sv_status sv_image_write_png(const sv_image *img, const char *path, sv_error *err);

/* Encodes img as PNG into a malloc'ed buffer (*out, *out_size; caller frees). */
sv_status sv_image_encode_png(const sv_image *img, uint8_t **out, size_t *out_size, sv_error *err);

/* A memo of encoded PNGs (issue 20: a bake encoded each atlas three times,
 * for its file, model.glb and its level's glb). While a memo is in use on
 * the calling thread (sv_png_memo_use), sv_image_encode_png and
 * sv_image_write_png give the bytes of an earlier encoding when the image
 * holds the same pixels (the same sv_image_alloc buffer, which the memo keeps
 * a shared copy of, and which nobody writes into once it has copies: see
 * sv_image_copy), instead of encoding them again: the same bytes, once.
 * Images whose pixels were not made by sv_image_alloc are encoded each time. */
typedef struct sv_png_memo sv_png_memo;

/* An empty memo; NULL when out of memory (callers then encode each time). */
sv_png_memo *sv_png_memo_create(void);

/* Releases the memo's bytes and its copies of the images. NULL is fine. The
 * memo must not be in use on any thread. */
void sv_png_memo_free(sv_png_memo *m);

/* Makes m (or NULL: none) the calling thread's memo; returns the previous. */
sv_png_memo *sv_png_memo_use(sv_png_memo *m);

/* How many encodings m has saved (calls answered from it). */
size_t sv_png_memo_reused(const sv_png_memo *m);

#endif
