/* image_jpeg.c — JPEG encoding of opaque colour images with libjpeg(-turbo),
 * for the glTF files' base-colour textures whose alpha channel is unused
 * (docs/outputs.md "Sizes").
 *
 * JPEG (ITU-T T.81, baseline sequential DCT) through libjpeg's compressor:
 * jpeg_set_defaults (4:2:0 chroma, JFIF header), jpeg_set_quality with
 * baseline tables, the exact integer DCT (JDCT_ISLOW) and optimised Huffman
 * tables. Nothing in the stream depends on the time or the machine: the same
 * pixels give the same bytes.
 */
#include "image.h"
#include "image_io.h"

#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>

typedef struct jerr {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
    char msg[JMSG_LENGTH_MAX];
} jerr;

static void on_error(j_common_ptr c)
{
    jerr *e = (jerr *)c->err;
    c->err->format_message(c, e->msg);
    longjmp(e->jump, 1);
}

bool sv_image_opaque_colour(const sv_image *img, uint32_t *colour_channels)
{
    if (!img || !img->data || img->bits != 8 || img->channels < 1 || img->channels > 4)
        return false;
    uint32_t c = img->channels;
    size_t n = (size_t)img->width * img->height;
    const uint8_t *p = img->data;
    bool colour = false;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *v = p + i * c;
        if ((c == 2 || c == 4) && v[c - 1] != 255) return false;
        if (c >= 3 && (v[0] != v[1] || v[0] != v[2])) colour = true;
    }
    *colour_channels = colour ? 3 : 1;
    return true;
}

sv_status sv_image_encode_jpeg(const sv_image *img, int quality, uint8_t **out, size_t *out_size,
                               sv_error *err)
{
    uint32_t cc;
    *out = NULL;
    *out_size = 0;
    if (quality < 1 || quality > 100 || !sv_image_opaque_colour(img, &cc) || !img->width ||
        !img->height || img->width > JPEG_MAX_DIMENSION || img->height > JPEG_MAX_DIMENSION)
        return sv_fail(err, SV_ERR_INTERNAL,
                       "JPEG encoding: needs an opaque 8-bit image of at most %d px a side and a "
                       "quality in [1, 100]",
                       (int)JPEG_MAX_DIMENSION);
    uint8_t *row = malloc((size_t)img->width * cc);
    if (!row) return sv_fail(err, SV_ERR_NOMEM, "JPEG encoding: out of memory");
    struct jpeg_compress_struct cinfo;
    jerr je;
    unsigned char *mem = NULL;
    unsigned long mem_size = 0;
    cinfo.err = jpeg_std_error(&je.mgr);
    je.mgr.error_exit = on_error;
    if (setjmp(je.jump)) {
        jpeg_destroy_compress(&cinfo);
        free(mem);
        free(row);
        return sv_fail(err, SV_ERR_INTERNAL, "JPEG encoding: %s", je.msg);
    }
    jpeg_create_compress(&cinfo);
    jpeg_mem_dest(&cinfo, &mem, &mem_size);
    cinfo.image_width = img->width;
    cinfo.image_height = img->height;
    cinfo.input_components = (int)cc;
    cinfo.in_color_space = cc == 3 ? JCS_RGB : JCS_GRAYSCALE;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, quality, TRUE);
    cinfo.dct_method = JDCT_ISLOW;
    cinfo.optimize_coding = TRUE;
    jpeg_start_compress(&cinfo, TRUE);
    uint32_t c = img->channels;
    const uint8_t *p = img->data;
    while (cinfo.next_scanline < cinfo.image_height) {
        const uint8_t *s = p + (size_t)cinfo.next_scanline * img->width * c;
        for (uint32_t x = 0; x < img->width; x++)
            memcpy(row + (size_t)x * cc, s + (size_t)x * c, cc);
        JSAMPROW r = row;
        jpeg_write_scanlines(&cinfo, &r, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    free(row);
    *out = mem;
    *out_size = mem_size;
    return SV_OK;
}
