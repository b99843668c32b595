/* image_plugin.c — texture decoding through the OpenImageIO plugin, loaded on
 * first use (see image.h): the formats other than PNG and JPEG, which
 * image_decode.c reads with libpng and libjpeg.
 *
 * Debian's OpenImageIO links 261 shared libraries (OpenVDB, GDAL, Poppler,
 * ...): linked into sylva-bake they cost time and memory at every process
 * start (docs/benchmarks.md, "Figures moved out of the code"), before any work, and most processes never decode an image
 * (`info` and `check-spec`, untextured trees, the tests' hostile inputs; PNG
 * encoding is libpng, image_png.c). So the OIIO shim (image_oiio.cpp) is
 * built as its own shared object, libsvimage.so, and dlopen'ed here the first
 * time a texture or depth map is decoded; `sylva-bake bake --sandbox` and the
 * worker zygote load it ahead (sv_image_plugin_load) when a job may need it.
 *
 * Where: $SYLVA_IMAGE_PLUGIN when set (a path), else next to the running
 * executable: DIR/libsvimage.so (the build tree: build/sylva-bake),
 * DIR/../libsvimage.so (build/tests/, build/tools/), DIR/../lib/sylva/libsvimage.so
 * (installed: PREFIX/bin and PREFIX/lib/sylva).
 */
#include "image.h"
#include "image_io.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef sv_status (*decode_fn)(const void *, size_t, const char *, uint32_t, sv_image *,
                               sv_error *);

typedef sv_status (*decode_within_fn)(const void *, size_t, const char *, uint32_t, uint64_t,
                                      sv_image *, sv_error *);

static pthread_once_t once = PTHREAD_ONCE_INIT;
static decode_fn decode_rgba8, decode_gray16;
static decode_within_fn decode_rgba8_within;
static void *handle;
static char load_error[400];

/* Tries one path; true when the plugin and both entry points are there. */
static bool try_open(const char *path)
{
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        snprintf(load_error, sizeof load_error, "%s", dlerror());
        return false;
    }
    decode_fn a = (decode_fn)(uintptr_t)dlsym(h, "sv_plugin_decode_rgba8");
    decode_fn b = (decode_fn)(uintptr_t)dlsym(h, "sv_plugin_decode_gray16");
    decode_within_fn c = (decode_within_fn)(uintptr_t)dlsym(h, "sv_plugin_decode_rgba8_within");
    if (!a || !b || !c) {
        snprintf(load_error, sizeof load_error, "%s has no sv_plugin_decode_* entry points", path);
        dlclose(h);
        return false;
    }
    decode_rgba8 = a;
    decode_gray16 = b;
    decode_rgba8_within = c;
    handle = h;
    return true;
}

static void load_once(void)
{
    const char *env = getenv("SYLVA_IMAGE_PLUGIN");
    if (env && *env) {
        try_open(env);
        return;
    }
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) {
        snprintf(load_error, sizeof load_error, "cannot find the running executable");
        return;
    }
    exe[n] = 0;
    char *slash = strrchr(exe, '/');
    if (slash) *slash = 0;
    static const char *const rel[] = {"/libsvimage.so", "/../libsvimage.so",
                                      "/../lib/sylva/libsvimage.so"};
    char path[PATH_MAX + 64], first_error[sizeof load_error] = "";
    for (size_t i = 0; i < sizeof rel / sizeof rel[0]; i++) {
        snprintf(path, sizeof path, "%s%s", exe, rel[i]);
        if (access(path, R_OK) != 0) continue;
        if (try_open(path)) return;
        if (!first_error[0]) memcpy(first_error, load_error, sizeof first_error);
    }
    if (first_error[0]) memcpy(load_error, first_error, sizeof load_error);
    else
        snprintf(
            load_error, sizeof load_error,
            "libsvimage.so is neither beside %.200s nor in ../lib/sylva (set SYLVA_IMAGE_PLUGIN)",
            exe);
}

sv_status sv_image_plugin_load(sv_error *err)
{
    pthread_once(&once, load_once);
    if (decode_rgba8) return SV_OK;
    return sv_fail(err, SV_ERR_INTERNAL,
                   "the image decoder (OpenImageIO plugin) cannot be loaded: %s", load_error);
}

void *sv_image_plugin_symbol(const char *name)
{
    return handle ? dlsym(handle, name) : NULL;
}

sv_status sv_image_plugin_decode_rgba8(const void *data, size_t size, const char *name,
                                       uint32_t max_size, sv_image *out, sv_error *err)
{
    if (out) memset(out, 0, sizeof *out);
    sv_status st = sv_image_plugin_load(err);
    return st != SV_OK ? st : decode_rgba8(data, size, name, max_size, out, err);
}

sv_status sv_image_plugin_decode_rgba8_within(const void *data, size_t size, const char *name,
                                              uint32_t max_size, uint64_t max_bytes, sv_image *out,
                                              sv_error *err)
{
    if (out) memset(out, 0, sizeof *out);
    sv_status st = sv_image_plugin_load(err);
    return st != SV_OK ? st : decode_rgba8_within(data, size, name, max_size, max_bytes, out, err);
}

sv_status sv_image_plugin_decode_gray16(const void *data, size_t size, const char *name,
                                        uint32_t max_size, sv_image *out, sv_error *err)
{
    if (out) memset(out, 0, sizeof *out);
    sv_status st = sv_image_plugin_load(err);
    return st != SV_OK ? st : decode_gray16(data, size, name, max_size, out, err);
}
