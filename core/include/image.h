/* image.h — images in memory; decoding through the OpenImageIO plugin
 * (libsvimage.so, built from core/io/image_oiio.cpp, the only C++ file, which
 * catches every exception and copies the text into sv_error; loaded on first
 * use by core/io/image_plugin.c), PNG encoding with libpng (core/io/image_png.c).
 *
 * Pixels are stored row-major, top row first, interleaved channels, with either
 * 8 bits (uint8) or 16 bits (uint16, native endian) per channel.
 */
#ifndef SV_IMAGE_H
#define SV_IMAGE_H

#include "sv.h"

typedef struct sv_image {
    uint32_t width, height;
    uint32_t channels; /* 1..4 */
    uint32_t bits;     /* 8 or 16 */
    void *data;        /* width*height*channels*(bits/8) bytes, owned */
} sv_image;

/* Allocates a zeroed image. Returns SV_ERR_NOMEM on overflow/failure. */
sv_status sv_image_alloc(sv_image *img, uint32_t w, uint32_t h, uint32_t channels, uint32_t bits,
                         sv_error *err);

/* Frees img->data and zeroes the struct. NULL is fine. */
void sv_image_free(sv_image *img);

/* Bytes per row. */
size_t sv_image_stride(const sv_image *img);

/* Halves img (2x2 box filter; colour weighted by alpha with 4 channels) until
 * neither side exceeds max_side; max_side 0 or a smaller image: unchanged.
 * Deterministic. On failure img is left as it was. */
sv_status sv_image_reduce(sv_image *img, uint32_t max_side, sv_error *err);

/* Loads the decoding plugin now if it is not loaded yet (thread-safe, once;
 * the decoders call it). For a process about to enter the seccomp sandbox or
 * to fork jobs: dlopen and OIIO's initialisers then run before. SV_ERR_INTERNAL
 * naming the plugin and the loader's message when it cannot be loaded. */
sv_status sv_image_plugin_load(sv_error *err);

/* A symbol of the loaded plugin or of the libraries it pulled in (dlsym on
 * its handle: they are not in the global scope); NULL when the plugin is not
 * loaded or has no such symbol. */
void *sv_image_plugin_symbol(const char *name);

/* Decodes PNG/JPEG/TGA (anything OIIO reads from memory) into RGBA8.
 * `name` is only used for messages and as a format hint. Images larger than
 * max_size on a side are refused with SV_ERR_LIMIT. */
sv_status sv_image_decode_rgba8(const void *data, size_t size, const char *name, uint32_t max_size,
                                sv_image *out, sv_error *err);

/* Decodes the first channel of a PNG as 16 bits (8-bit PNGs are widened)
 * into a 1-channel 16-bit image (depth maps). SV_ERR_FORMAT for other formats. */
sv_status sv_image_decode_gray16(const void *data, size_t size, const char *name, uint32_t max_size,
                                 sv_image *out, sv_error *err);

/* Writes img as PNG (8 or 16 bits) to path. Deterministic: same pixels, same bytes. */
sv_status sv_image_write_png(const sv_image *img, const char *path, sv_error *err);

/* Encodes img as PNG into a malloc'ed buffer (*out, *out_size; caller frees). */
sv_status sv_image_encode_png(const sv_image *img, uint8_t **out, size_t *out_size, sv_error *err);

#endif
