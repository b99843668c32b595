/* image.c — allocation of in-memory images (the decoders live in image_oiio.cpp). */
#include "image.h"

#include <stdlib.h>
#include <string.h>

sv_status sv_image_alloc(sv_image *img, uint32_t w, uint32_t h, uint32_t channels,
                         uint32_t bits, sv_error *err)
{
    if (!img) return sv_fail(err, SV_ERR_INTERNAL, "sv_image_alloc: image is NULL");
    memset(img, 0, sizeof *img);
    if (channels < 1 || channels > 4)
        return sv_fail(err, SV_ERR_INTERNAL, "image with %u channels (1..4 allowed)", channels);
    if (bits != 8 && bits != 16)
        return sv_fail(err, SV_ERR_INTERNAL, "image with %u bits per channel (8 or 16 allowed)", bits);
    size_t row, n;
    if (!sv_mul_size((size_t)w, (size_t)channels * (bits / 8), &row) ||
        !sv_mul_size(row, (size_t)h, &n))
        return sv_fail(err, SV_ERR_NOMEM, "image %ux%u with %u channels overflows size_t", w, h,
                       channels);
    void *data = calloc(n ? n : 1, 1);
    if (!data)
        return sv_fail(err, SV_ERR_NOMEM, "cannot allocate a %ux%u image (%zu bytes)", w, h, n);
    img->width = w;
    img->height = h;
    img->channels = channels;
    img->bits = bits;
    img->data = data;
    return SV_OK;
}

void sv_image_free(sv_image *img)
{
    if (!img) return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

size_t sv_image_stride(const sv_image *img)
{
    return (size_t)img->width * img->channels * (img->bits / 8);
}
