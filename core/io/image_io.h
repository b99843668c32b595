/* image_io.h — images in and out of bytes and files (image.h holds them in
 * memory): decoding of PNG and JPEG with libpng and libjpeg
 * (core/io/image_decode.c), of every other format through the OpenImageIO
 * plugin (libsvimage.so, built from core/io/image_oiio.cpp, the only C++
 * file, which catches every exception and copies the text into sv_error;
 * loaded on first use by core/io/image_plugin.c), PNG encoding with libpng
 * (core/io/image_png.c). Methods never include it: the pipeline reads and
 * writes their images (docs/design.md, "Source layout").
 */
#ifndef SV_IMAGE_IO_H
#define SV_IMAGE_IO_H

#include "image.h"

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

/* Writes img as PNG (8 or 16 bits) to path. Deterministic: same pixels, same bytes. */
sv_status sv_image_write_png(const sv_image *img, const char *path, sv_error *err);

/* Encodes img as PNG into a malloc'ed buffer (*out, *out_size; caller frees). */
sv_status sv_image_encode_png(const sv_image *img, uint8_t **out, size_t *out_size, sv_error *err);

/* True when img is 8-bit and its alpha channel (if any) is 255 everywhere;
 * *colour_channels is then 3, or 1 when every texel is grey. */
bool sv_image_opaque_colour(const sv_image *img, uint32_t *colour_channels);

/* Encodes an image sv_image_opaque_colour accepts as a baseline JPEG
 * (image_jpeg.c: 4:2:0, the integer DCT, optimised Huffman tables; grey
 * images as one channel) at quality in [1, 100] into a malloc'ed buffer
 * (*out, *out_size; caller frees with free()). Deterministic. SV_ERR_INTERNAL
 * for an image it does not accept, SV_ERR_NOMEM. */
sv_status sv_image_encode_jpeg(const sv_image *img, int quality, uint8_t **out, size_t *out_size,
                               sv_error *err);

/* A memo of encoded PNGs (a bake encodes each atlas for its file,
 * model.glb and its level's glb). While a memo is in use on
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
