/* image_oiio.cpp — the OpenImageIO shim behind image.h's decoders: from memory
 * to RGBA8, or a PNG's first channel to 16 bits. Built as its own shared
 * object, libsvimage.so, which image_plugin.c loads on the first decode (OIIO's
 * 261 libraries cost time and memory at every process start otherwise);
 * PNG encoding is libpng (image_png.c).
 *
 * The only C++ file in core. Every entry point is extern "C" and catches every
 * exception, copying its text into sv_error, so nothing C++ escapes to callers.
 *
 * Decoding never touches the file system: the bytes are handed to OIIO through
 * an IOMemReader (Filesystem::IOProxy), and the format is chosen from the magic
 * bytes (TGA, which has none, from the name's extension or its v2 footer). The
 * name the reader is given is synthetic, so a hostile texture name cannot make a
 * plugin open a local file. A format whose OIIO reader cannot read from an
 * IOProxy falls back to stb_image (Debian's libstb-dev), also from memory.
 *
 * Alpha is kept unassociated (straight), as PNG/TGA store it and as glTF expects:
 * OIIO is told "oiio:UnassociatedAlpha" both when reading and when writing, so it
 * neither premultiplies on read nor divides on write.
 */
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_NO_STDIO
#define STBI_NO_HDR
#define STBI_NO_LINEAR
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include <stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

extern "C" {
#include "image.h"
#include "image_io.h"
}

using namespace OIIO;

namespace
{

bool ends_with_ci(const char *s, const char *suffix)
{
    size_t n = std::strlen(s), m = std::strlen(suffix);
    if (m > n) return false;
    for (size_t i = 0; i < m; i++) {
        char a = s[n - m + i], b = suffix[i];
        if (a >= 'A' && a <= 'Z') a = (char)(a - 'A' + 'a');
        if (a != b) return false;
    }
    return true;
}

/* The image format from its bytes ("png", "jpeg", ...), or nullptr. */
const char *image_format(const uint8_t *d, size_t n, const char *name)
{
    if (n >= 8 && std::memcmp(d, "\x89PNG\r\n\x1a\n", 8) == 0) return "png";
    if (n >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF) return "jpeg";
    if (n >= 6 && (std::memcmp(d, "GIF87a", 6) == 0 || std::memcmp(d, "GIF89a", 6) == 0))
        return "gif";
    if (n >= 2 && d[0] == 'B' && d[1] == 'M') return "bmp";
    if (n >= 4 && (std::memcmp(d, "II*\0", 4) == 0 || std::memcmp(d, "MM\0*", 4) == 0))
        return "tiff";
    if (n >= 12 && std::memcmp(d, "RIFF", 4) == 0 && std::memcmp(d + 8, "WEBP", 4) == 0)
        return "webp";
    if (n >= 4 && std::memcmp(d, "8BPS", 4) == 0) return "psd";
    /* TGA has no magic: a v2 footer, or the name says so. */
    if (n >= 26 && std::memcmp(d + n - 18, "TRUEVISION-XFILE.", 17) == 0) return "tga";
    if (name && (ends_with_ci(name, ".tga") || ends_with_ci(name, ".targa"))) return "tga";
    return nullptr;
}

/* Expands n pixels of `ch` interleaved 8-bit channels into RGBA8. */
void expand_rgba8(const uint8_t *src, int ch, int alpha_channel, size_t n, uint8_t *dst)
{
    for (size_t i = 0; i < n; i++) {
        const uint8_t *s = src + i * (size_t)ch;
        uint8_t *o = dst + 4 * i;
        if (ch == 1) {
            o[0] = o[1] = o[2] = s[0];
            o[3] = 255;
        } else if (ch == 2) {
            o[0] = o[1] = o[2] = s[0];
            o[3] = s[1];
        } else {
            o[0] = s[0];
            o[1] = s[1];
            o[2] = s[2];
            o[3] = (ch >= 4) ? s[alpha_channel >= 0 && alpha_channel < ch ? alpha_channel : 3]
                             : 255;
        }
    }
}

/* w and h within max_size, and w × h × px_bytes (the memory the decode
 * takes a pixel) within max_bytes, before any pixel is decoded. */
sv_status check_size(int w, int h, uint32_t max_size, uint64_t px_bytes, uint64_t max_bytes,
                     const char *name, sv_error *err)
{
    if (w <= 0 || h <= 0)
        return sv_fail(err, SV_ERR_PARSE, "image '%s' has an empty size %dx%d", name, w, h);
    if ((uint32_t)w > max_size || (uint32_t)h > max_size)
        return sv_fail(err, SV_ERR_LIMIT, "image '%s' is %dx%d, over the %u texel limit per side",
                       name, w, h, max_size);
    uint64_t need = (uint64_t)w * (uint64_t)h * px_bytes;
    if (need > max_bytes)
        return sv_fail(err, SV_ERR_LIMIT,
                       "image '%s' is %dx%d: decoding it takes %llu bytes, over the %llu-byte "
                       "budget of a texture",
                       name, w, h, (unsigned long long)need, (unsigned long long)max_bytes);
    return SV_OK;
}

sv_status decode_stb(const uint8_t *data, size_t size, const char *name, uint32_t max_size,
                     uint64_t max_bytes, sv_image *out, sv_error *err)
{
    if (size > (size_t)INT_MAX)
        return sv_fail(err, SV_ERR_LIMIT, "image '%s' is too large to decode (%zu bytes)", name,
                       size);
    int w = 0, h = 0, c = 0;
    if (!stbi_info_from_memory(data, (int)size, &w, &h, &c))
        return sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s': %s", name,
                       stbi_failure_reason());
    sv_status st = check_size(w, h, max_size, 8, max_bytes, name, err); /* stb's copy and ours */
    if (st != SV_OK) return st;
    uint8_t *px = stbi_load_from_memory(data, (int)size, &w, &h, &c, 4);
    if (!px)
        return sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s': %s", name,
                       stbi_failure_reason());
    st = sv_image_alloc(out, (uint32_t)w, (uint32_t)h, 4, 8, err);
    if (st == SV_OK) std::memcpy(out->data, px, (size_t)w * (size_t)h * 4);
    stbi_image_free(px);
    return st;
}

/* Returns SV_OK, an error, or SV_ERR_FORMAT with *fallback set when OIIO has no
 * reader for the format that can read from memory. */
sv_status decode_oiio(const uint8_t *data, size_t size, const char *fmt, const char *name,
                      uint32_t max_size, uint64_t max_bytes, sv_image *out, bool *fallback,
                      sv_error *err, bool gray16 = false)
{
    *fallback = false;
    Filesystem::IOMemReader proxy(data, size);
    auto in = ImageInput::create(fmt, false, nullptr, nullptr);
    if (!in || !in->supports("ioproxy")) {
        *fallback = true;
        return SV_ERR_FORMAT;
    }
    if (!in->set_ioproxy(&proxy)) {
        *fallback = true;
        return SV_ERR_FORMAT;
    }
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    ImageSpec spec;
    /* A synthetic name: with the proxy set no plugin opens a file by it. */
    std::string synthetic = std::string("sylva-memory-image.") + fmt;
    if (!in->open(synthetic, spec, config)) {
        std::string e = in->geterror();
        return sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s' (%s): %s", name, fmt,
                       e.c_str());
    }
    int ch = spec.nchannels;
    /* OIIO's pixels at their stored type (a float TIFF: 16 bytes a pixel),
     * our 8-bit copy and the RGBA8 result */
    uint64_t px_bytes = (uint64_t)spec.pixel_bytes(true) + (uint64_t)(ch > 0 ? ch : 0) + 4;
    sv_status st = check_size(spec.width, spec.height, max_size, px_bytes, max_bytes, name, err);
    if (st != SV_OK) return st;
    if (ch < 1 || ch > 64)
        return sv_fail(err, SV_ERR_PARSE, "image '%s' has %d channels", name, ch);
    size_t npx = (size_t)spec.width * (size_t)spec.height, nbytes;
    if (!sv_mul_size(npx, (size_t)ch, &nbytes))
        return sv_fail(err, SV_ERR_NOMEM, "image '%s' size overflows", name);
    if (gray16) { /* the first channel, 16 bits */
        st = sv_image_alloc(out, (uint32_t)spec.width, (uint32_t)spec.height, 1, 16, err);
        if (st != SV_OK) return st;
        if (!in->read_image(0, 0, 0, 1, TypeDesc::UINT16, out->data)) {
            std::string e = in->geterror();
            sv_image_free(out);
            return sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s' (%s): %s", name, fmt,
                           e.c_str());
        }
        in->close();
        return SV_OK;
    }
    std::vector<uint8_t> buf(nbytes);
    if (!in->read_image(0, 0, 0, ch, TypeDesc::UINT8, buf.data())) {
        std::string e = in->geterror();
        return sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s' (%s): %s", name, fmt,
                       e.c_str());
    }
    in->close();
    st = sv_image_alloc(out, (uint32_t)spec.width, (uint32_t)spec.height, 4, 8, err);
    if (st != SV_OK) return st;
    expand_rgba8(buf.data(), ch, spec.alpha_channel, npx, (uint8_t *)out->data);
    return SV_OK;
}

} // namespace

namespace
{

/* The decoders' shared frame: argument checks, the format from the bytes,
 * PNG chunk check, and no C++ exception escaping. gray16: the first channel
 * of a PNG at 16 bits; else RGBA8 from any format (stb as the fallback). */
sv_status decode_any(const void *data, size_t size, const char *name, uint32_t max_size,
                     uint64_t max_bytes, sv_image *out, sv_error *err, bool gray16)
{
    if (!out) return sv_fail(err, SV_ERR_INTERNAL, "image decode: out is NULL");
    std::memset(out, 0, sizeof *out);
    if (!name) name = "(unnamed)";
    if (!data || size == 0) return sv_fail(err, SV_ERR_PARSE, "image '%s' is empty", name);
    if (max_size == 0) max_size = 16384;
    if (max_bytes == 0) max_bytes = (uint64_t)1 << 30;
    try {
        const uint8_t *d = (const uint8_t *)data;
        const char *fmt = image_format(d, size, name);
        if (!fmt)
            return sv_fail(err, SV_ERR_FORMAT,
                           "image '%s' is not a recognised image format (PNG, JPEG, TGA, BMP, "
                           "GIF, TIFF, WebP, PSD)",
                           name);
        if (gray16 && std::strcmp(fmt, "png") != 0)
            return sv_fail(err, SV_ERR_FORMAT, "image '%s' is not a PNG", name);
        if (std::strcmp(fmt, "png") == 0) {
            sv_status st = sv_png_check_chunks(d, size, name, err);
            if (st != SV_OK) return st;
        }
        bool fallback = false;
        sv_status st = decode_oiio(d, size, fmt, name, max_size, max_bytes, out, &fallback, err,
                                   gray16);
        if (st != SV_OK && fallback && !gray16)
            st = decode_stb(d, size, name, max_size, max_bytes, out, err);
        if (st != SV_OK) sv_image_free(out);
        return st;
    } catch (const std::exception &e) {
        sv_image_free(out);
        return sv_fail(err, SV_ERR_INTERNAL, "decoding image '%s' threw: %s", name, e.what());
    } catch (...) {
        sv_image_free(out);
        return sv_fail(err, SV_ERR_INTERNAL, "decoding image '%s' threw an unknown exception",
                       name);
    }
}

} // namespace

/* The plugin's entry points (image_plugin.c finds them by name): as
 * sv_image_decode_rgba8 and sv_image_decode_gray16 in image.h. */
extern "C" __attribute__((visibility("default"))) sv_status sv_plugin_decode_rgba8(
    const void *data, size_t size, const char *name, uint32_t max_size, sv_image *out,
    sv_error *err)
{
    return decode_any(data, size, name, max_size, 0, out, err, false);
}

extern "C" __attribute__((visibility("default"))) sv_status sv_plugin_decode_rgba8_within(
    const void *data, size_t size, const char *name, uint32_t max_size, uint64_t max_bytes,
    sv_image *out, sv_error *err)
{
    return decode_any(data, size, name, max_size, max_bytes, out, err, false);
}

extern "C" __attribute__((visibility("default"))) sv_status sv_plugin_decode_gray16(
    const void *data, size_t size, const char *name, uint32_t max_size, sv_image *out,
    sv_error *err)
{
    return decode_any(data, size, name, max_size, 0, out, err, true);
}
