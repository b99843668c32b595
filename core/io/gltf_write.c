/* gltf_write.c — glTF 2.0 binary writer with an MSFT_lod chain.
 *
 * Implements the Khronos glTF 2.0 specification (§3.6 buffers/bufferViews/
 * accessors, §3.7 meshes, §3.9 materials, §4.4 GLB container) and the MSFT_lod
 * vendor extension (node-level LODs, extras.MSFT_screencoverage). See gltf.h.
 *
 * Identical vertices are merged before writing (write_mesh).
 *
 * The JSON is built with cJSON (insertion-ordered, so output is deterministic)
 * and every binary piece is appended to one buffer at 4-byte aligned offsets.
 */
#include "gltf.h"

#include <math.h>
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */
#define GL_FLOAT 5126
#define GL_BYTE 5120
#define GL_SHORT 5122
#define GL_UNSIGNED_SHORT 5123
#define GL_UNSIGNED_INT 5125
#define GL_ARRAY_BUFFER 34962
#define GL_ELEMENT_ARRAY_BUFFER 34963

/* A buffer view of plain (not meshopt-encoded) geometry, for later
 * accessors whose data is a prefix of its bytes (shared_view). */
typedef struct data_view {
    size_t offset, bytes, stride;
    int target, view;
} data_view;

/* One distinct image stored in the file, with the texture that samples it. */
typedef struct unique_image {
    const sv_image *img;
    uint64_t hash;
    int texture;
} unique_image;

typedef struct writer {
    cJSON *root;
    cJSON *nodes, *meshes, *materials, *textures, *images, *accessors, *views;
    uint8_t *bin;
    size_t bin_len, bin_cap;
    cJSON *samplers;
    unique_image *uniq;
    size_t uniq_count, uniq_cap;
    data_view *dv;
    size_t dv_count, dv_cap;
    sv_error *err;
    sv_status last; /* status of the last failure, for helpers that return an index */
    /* the level being written: how its geometry is stored */
    sv_gltf_compress compress;
    bool quantized;      /* some accessor uses KHR_mesh_quantization's types */
    bool meshopt;        /* some view is EXT_meshopt_compression-encoded */
    size_t fallback_len; /* the placeholder buffer's length (buffer 1) */
    bool several;        /* the file holds several levels (write_mesh) */
} writer;

static sv_status nomem(writer *w)
{
    return w->last = sv_fail(w->err, SV_ERR_NOMEM, "glTF writer: out of memory");
}

/* Appends size bytes (data may be NULL for zeros), padding the buffer to a
 * multiple of 4 afterwards so every buffer view starts 4-byte aligned. */
static sv_status bin_append(writer *w, const void *data, size_t size, size_t *offset)
{
    size_t padded = (size + 3) & ~(size_t)3;
    if (padded < size || w->bin_len > SIZE_MAX - padded) return nomem(w);
    size_t need = w->bin_len + padded;
    if (need > 0xFFFFFFF0u)
        return w->last = sv_fail(w->err, SV_ERR_LIMIT,
                                 "glTF writer: binary chunk would exceed 4 GiB");
    if (need > w->bin_cap) {
        size_t cap = w->bin_cap ? w->bin_cap : 4096;
        while (cap < need) cap *= 2;
        uint8_t *nb = realloc(w->bin, cap);
        if (!nb) return nomem(w);
        w->bin = nb;
        w->bin_cap = cap;
    }
    *offset = w->bin_len;
    if (size) {
        if (data) memcpy(w->bin + w->bin_len, data, size);
        else memset(w->bin + w->bin_len, 0, size);
    }
    memset(w->bin + w->bin_len + size, 0, padded - size);
    w->bin_len = need;
    return SV_OK;
}

static bool add_int(cJSON *obj, const char *key, double v)
{
    return cJSON_AddNumberToObject(obj, key, v) != NULL;
}

static const char *type_name(uint32_t components)
{
    static const char *const names[5] = {NULL, "SCALAR", "VEC2", "VEC3", "VEC4"};
    return components <= 4 ? names[components] : NULL;
}

/* Adds a buffer view over bytes already appended; returns its index or -1. */
static int add_view(writer *w, size_t offset, size_t length, int target)
{
    cJSON *v = cJSON_CreateObject();
    if (!v) return -1;
    bool ok = add_int(v, "buffer", 0) && add_int(v, "byteOffset", (double)offset) &&
              add_int(v, "byteLength", (double)length);
    if (ok && target) ok = add_int(v, "target", target);
    if (!ok) {
        cJSON_Delete(v);
        return -1;
    }
    cJSON_AddItemToArray(w->views, v);
    return cJSON_GetArraySize(w->views) - 1;
}

/* A buffer view already written whose bytes begin with `bytes` bytes of
 * `data`, of the same target and element stride, or -1. Levels of one file
 * share data this way: a stochastic level's leaves are the first leaves of
 * the level before it in the same order (docs/methods/stochastic.md), so
 * their UVs, normals and indices are a prefix of that level's
 * (docs/outputs.md "Sizes"). glTF requires byteStride on a vertex view two
 * accessors use: it is added. -2 when out of memory. */
static int shared_view(writer *w, const void *data, size_t bytes, size_t stride, int target)
{
    for (size_t i = 0; bytes && i < w->dv_count; i++) {
        const data_view *d = &w->dv[i];
        if (d->target != target || d->stride != stride || d->bytes < bytes ||
            memcmp(w->bin + d->offset, data, bytes) != 0)
            continue;
        cJSON *v = cJSON_GetArrayItem(w->views, d->view);
        if (target == GL_ARRAY_BUFFER && v && !cJSON_GetObjectItemCaseSensitive(v, "byteStride")) {
            cJSON *n = cJSON_CreateNumber((double)stride);
            if (!n) return nomem(w), -2;
            cJSON *t = cJSON_DetachItemFromObjectCaseSensitive(v, "target");
            cJSON_AddItemToObject(v, "byteStride", n);
            if (t) cJSON_AddItemToObject(v, "target", t);
        }
        return d->view;
    }
    return -1;
}

/* Appends count elements of stride bytes (vertex data: target
 * GL_ARRAY_BUFFER; or triangle indices of stride 2 or 4, vertex_count the
 * vertices they index) as a new buffer view; returns its index or -1 with
 * w->err set. With SV_GLTF_MESHOPT the bytes in the binary chunk are
 * meshoptimizer's encoding (EXT_meshopt_compression "ATTRIBUTES" or
 * "TRIANGLES", bitstream versions 0 and 1) and the view's own range is in
 * the placeholder buffer 1. */
static int add_data_view(writer *w, const void *data, size_t count, size_t stride, int target,
                         size_t vertex_count)
{
    size_t bytes = count * stride, off;
    bool vertex = target == GL_ARRAY_BUFFER;
    uint8_t *enc = NULL;
    size_t enc_len = 0;
    if (w->compress != SV_GLTF_MESHOPT) {
        int shared = shared_view(w, data, bytes, stride, target);
        if (shared != -1) return shared < 0 ? -1 : shared;
    }
    if (w->compress == SV_GLTF_MESHOPT && count) {
        size_t bound = vertex ? meshopt_encodeVertexBufferBound(count, stride)
                              : meshopt_encodeIndexBufferBound(count, vertex_count);
        unsigned int *idx = NULL;
        if (!(enc = malloc(bound))) return nomem(w), -1;
        if (vertex) {
            meshopt_encodeVertexVersion(0);
            enc_len = meshopt_encodeVertexBuffer(enc, bound, data, count, stride);
        } else {
            if (!(idx = malloc(count * sizeof *idx))) {
                free(enc);
                return nomem(w), -1;
            }
            for (size_t i = 0; i < count; i++)
                idx[i] = stride == 2 ? ((const uint16_t *)data)[i] : ((const uint32_t *)data)[i];
            meshopt_encodeIndexVersion(1);
            enc_len = meshopt_encodeIndexBuffer(enc, bound, idx, count);
            free(idx);
        }
        if (!enc_len) {
            free(enc);
            w->last = sv_fail(w->err, SV_ERR_INTERNAL, "glTF writer: meshopt encoding failed");
            return -1;
        }
    }
    bool compressed = enc != NULL;
    sv_status st = compressed ? bin_append(w, enc, enc_len, &off)
                              : bin_append(w, data, bytes, &off);
    free(enc);
    if (st != SV_OK) return -1;
    cJSON *v = cJSON_CreateObject();
    if (!v) return nomem(w), -1;
    bool ok;
    if (compressed) {
        cJSON *x = cJSON_CreateObject(), *m = NULL;
        ok = x && (m = cJSON_AddObjectToObject(x, "EXT_meshopt_compression")) &&
             add_int(m, "buffer", 0) && add_int(m, "byteOffset", (double)off) &&
             add_int(m, "byteLength", (double)enc_len) &&
             add_int(m, "byteStride", (double)stride) && add_int(m, "count", (double)count) &&
             cJSON_AddStringToObject(m, "mode", vertex ? "ATTRIBUTES" : "TRIANGLES");
        ok = ok && add_int(v, "buffer", 1) && add_int(v, "byteOffset", (double)w->fallback_len) &&
             add_int(v, "byteLength", (double)bytes);
        if (ok && vertex) ok = add_int(v, "byteStride", (double)stride);
        ok = ok && add_int(v, "target", target);
        if (ok) cJSON_AddItemToObject(v, "extensions", x);
        else cJSON_Delete(x);
        w->fallback_len += (bytes + 3) & ~(size_t)3;
        w->meshopt = true;
    } else {
        ok = add_int(v, "buffer", 0) && add_int(v, "byteOffset", (double)off) &&
             add_int(v, "byteLength", (double)bytes);
        /* quantized elements are padded to 4 bytes: the stride says so */
        if (ok && vertex && w->compress != SV_GLTF_FLOAT)
            ok = add_int(v, "byteStride", (double)stride);
        if (ok) ok = add_int(v, "target", target);
    }
    if (!ok) {
        cJSON_Delete(v);
        return nomem(w), -1;
    }
    cJSON_AddItemToArray(w->views, v);
    int index = cJSON_GetArraySize(w->views) - 1;
    if (!compressed && bytes) {
        if (w->dv_count == w->dv_cap) {
            size_t cap = w->dv_cap ? 2 * w->dv_cap : 16;
            data_view *nd = realloc(w->dv, cap * sizeof *nd);
            if (!nd) return nomem(w), -1;
            w->dv = nd;
            w->dv_cap = cap;
        }
        w->dv[w->dv_count++] = (data_view){off, bytes, stride, target, index};
    }
    return index;
}

/* Adds an accessor over buffer view `view`; returns its index or -1 (error
 * recorded in w->err). min/max (may be NULL) have `components` entries. */
static int add_accessor_on(writer *w, int view, int component_type, bool normalized, size_t count,
                           uint32_t components, const double *mn, const double *mx)
{
    cJSON *a = view < 0 ? NULL : cJSON_CreateObject();
    if (!a) {
        if (view >= 0) nomem(w);
        return -1;
    }
    bool ok = add_int(a, "bufferView", view) && add_int(a, "componentType", component_type) &&
              (!normalized || cJSON_AddTrueToObject(a, "normalized")) &&
              add_int(a, "count", (double)count) &&
              cJSON_AddStringToObject(a, "type", type_name(components)) != NULL;
    if (ok && mn && mx) {
        cJSON *jmn = cJSON_AddArrayToObject(a, "min");
        cJSON *jmx = cJSON_AddArrayToObject(a, "max");
        ok = jmn && jmx;
        for (uint32_t k = 0; ok && k < components; k++) {
            cJSON *x = cJSON_CreateNumber(mn[k]), *y = cJSON_CreateNumber(mx[k]);
            ok = x && y;
            if (x) cJSON_AddItemToArray(jmn, x);
            if (y) cJSON_AddItemToArray(jmx, y);
        }
    }
    if (!ok) {
        cJSON_Delete(a);
        nomem(w);
        return -1;
    }
    cJSON_AddItemToArray(w->accessors, a);
    return cJSON_GetArraySize(w->accessors) - 1;
}

/* Appends count elements of `components` components (stride bytes each) as
 * a new buffer view (add_data_view) and an accessor over it; returns the
 * accessor's index or -1 (error recorded in w->err). */
static int add_accessor(writer *w, const void *data, size_t stride, int component_type,
                        bool normalized, size_t count, uint32_t components, int target,
                        size_t vertex_count, const double *mn, const double *mx)
{
    int view = add_data_view(w, data, count, stride, target, vertex_count);
    return add_accessor_on(w, view, component_type, normalized, count, components, mn, mx);
}

/* Shortest decimal that reads back as the same float, so material factors read
 * as 0.8 rather than 0.800000011920929. Deterministic. */
static double short_float(float f)
{
    char buf[32];
    for (int prec = 6; prec <= 9; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, (double)f);
        double d = strtod(buf, NULL);
        if ((float)d == f) return d;
    }
    return (double)f;
}

/* FNV-1a over the image header and pixels: a dedup key only (collisions are
 * resolved by comparing bytes). */
static uint64_t image_hash(const sv_image *img, size_t bytes)
{
    uint32_t head[4] = {img->width, img->height, img->channels, img->bits};
    return sv_fnv1a(sv_fnv1a(1469598103934665603ull, head, sizeof head), img->data, bytes);
}

static bool image_bytes(const sv_image *img, size_t *bytes)
{
    size_t n;
    return img->bits % 8 == 0 && sv_mul_size(img->width, img->height, &n) &&
           sv_mul_size(n, (size_t)img->channels * (img->bits / 8), bytes);
}

/* JPEG quality of the opaque colour textures the bake made (docs/outputs.md
 * "Sizes" has the colour error it costs). */
#define SV_GLTF_JPEG_QUALITY 90

/* Returns the texture index for image `img` (adding image, texture and the
 * shared sampler on first use), or -1 with w->err set. A texture the bake
 * made is PNG, or JPEG when it is a colour (base colour, occlusion; not a
 * normal map, whose vectors JPEG's blocks would bend) that uses no alpha. */
static int texture_for(writer *w, const sv_image *img, bool colour)
{
    size_t bytes;
    if (!img->data || !img->width || !img->height || img->channels < 1 || img->channels > 4 ||
        (img->bits != 8 && img->bits != 16) || !image_bytes(img, &bytes)) {
        w->last = sv_fail(w->err, SV_ERR_INVALID,
                          "glTF writer: a material refers to an empty or malformed image");
        return -1;
    }
    uint64_t h = image_hash(img, bytes);
    for (size_t i = 0; i < w->uniq_count; i++) {
        const sv_image *o = w->uniq[i].img;
        if (w->uniq[i].hash == h && o->width == img->width && o->height == img->height &&
            o->channels == img->channels && o->bits == img->bits &&
            memcmp(o->data, img->data, bytes) == 0)
            return w->uniq[i].texture;
    }
    /* in a file of several levels, a texture a coarser level reduced (its
     * trunk's bark) is the one it was reduced from when the file holds that
     * one already: mipmapped, it draws the same texels at the sizes the
     * level is drawn, and the file and the engine's memory hold one copy */
    uint64_t origin;
    if (w->several && sv_image_reduced_from(img, &origin))
        for (size_t i = 0; i < w->uniq_count; i++) {
            const sv_image *o = w->uniq[i].img;
            if (w->uniq[i].hash == origin &&
                (uint64_t)o->width * img->height == (uint64_t)o->height * img->width)
                return w->uniq[i].texture;
        }
    if (w->uniq_count == w->uniq_cap) {
        size_t cap = w->uniq_cap ? 2 * w->uniq_cap : 8;
        unique_image *nu = realloc(w->uniq, cap * sizeof *nu);
        if (!nu) {
            nomem(w);
            return -1;
        }
        w->uniq = nu;
        w->uniq_cap = cap;
    }
    /* a texture the bake did not change: the input's own file (a JPEG stays
     * a JPEG); anything else: PNG */
    const uint8_t *src = NULL;
    size_t src_size = 0, off;
    const char *mime = "image/png";
    sv_status st;
    uint32_t cc;
    if (sv_image_source(img, &src, &src_size, &mime)) {
        st = bin_append(w, src, src_size, &off);
    } else if (colour && sv_image_opaque_colour(img, &cc)) {
        uint8_t *jpg = NULL;
        mime = "image/jpeg";
        if ((w->last = sv_image_encode_jpeg(img, SV_GLTF_JPEG_QUALITY, &jpg, &src_size, w->err)) !=
            SV_OK)
            return -1;
        st = bin_append(w, jpg, src_size, &off);
        free(jpg);
    } else {
        uint8_t *png = NULL;
        mime = "image/png";
        if ((w->last = sv_image_encode_png(img, &png, &src_size, w->err)) != SV_OK) return -1;
        st = bin_append(w, png, src_size, &off);
        free(png);
    }
    if (st != SV_OK) return -1;
    int view = add_view(w, off, src_size, 0);
    cJSON *ji = view < 0 ? NULL : cJSON_CreateObject();
    cJSON *jt = cJSON_CreateObject();
    if (cJSON_GetArraySize(w->samplers) == 0) {
        cJSON *s = cJSON_CreateObject();
        if (!s || !add_int(s, "magFilter", 9729) /* LINEAR */ ||
            !add_int(s, "minFilter", 9987) /* LINEAR_MIPMAP_LINEAR */) {
            cJSON_Delete(s);
            jt = (cJSON_Delete(jt), NULL);
        } else {
            cJSON_AddItemToArray(w->samplers, s);
        }
    }
    if (!ji || !jt || !add_int(ji, "bufferView", view) ||
        !cJSON_AddStringToObject(ji, "mimeType", mime) || !add_int(jt, "sampler", 0) ||
        !add_int(jt, "source", cJSON_GetArraySize(w->images))) {
        cJSON_Delete(ji);
        cJSON_Delete(jt);
        nomem(w);
        return -1;
    }
    cJSON_AddItemToArray(w->images, ji);
    cJSON_AddItemToArray(w->textures, jt);
    int tex = cJSON_GetArraySize(w->textures) - 1;
    w->uniq[w->uniq_count++] = (unique_image){img, h, tex};
    return tex;
}

static bool add_texture_ref(cJSON *obj, const char *key, int tex)
{
    cJSON *t = cJSON_AddObjectToObject(obj, key);
    return t && add_int(t, "index", tex);
}

/* Returns the glTF material index for material mi of mesh (identical materials
 * are shared), or -1 with w->err set. */
static int material_for(writer *w, const sv_mesh *mesh, uint32_t mi)
{
    const sv_material *m = &mesh->materials[mi];
    int32_t refs[3] = {m->base_texture, m->normal_texture, m->occlusion_texture};
    int tex[3];
    for (int k = 0; k < 3; k++) {
        tex[k] = -1;
        if (refs[k] < 0) continue;
        if ((uint32_t)refs[k] >= mesh->image_count) {
            w->last = sv_fail(w->err, SV_ERR_INVALID,
                              "glTF writer: material '%s' refers to image %d of %u", m->name,
                              (int)refs[k], mesh->image_count);
            return -1;
        }
        tex[k] = texture_for(w, &mesh->images[refs[k]], k != 1);
        if (tex[k] < 0) return -1;
    }
    cJSON *j = cJSON_CreateObject();
    bool ok = j != NULL;
    if (ok && m->name[0]) ok = cJSON_AddStringToObject(j, "name", m->name) != NULL;
    cJSON *pbr = ok ? cJSON_AddObjectToObject(j, "pbrMetallicRoughness") : NULL;
    ok = pbr != NULL;
    cJSON *bc = ok ? cJSON_AddArrayToObject(pbr, "baseColorFactor") : NULL;
    ok = bc != NULL;
    for (int k = 0; ok && k < 4; k++) {
        float c = m->base_color[k];
        if (!(c >= 0.0f)) c = 0.0f; /* also NaN */
        if (c > 1.0f) c = 1.0f;
        cJSON *x = cJSON_CreateNumber(short_float(c));
        ok = x != NULL;
        if (x) cJSON_AddItemToArray(bc, x);
    }
    if (ok && tex[0] >= 0) ok = add_texture_ref(pbr, "baseColorTexture", tex[0]);
    if (ok) ok = add_int(pbr, "metallicFactor", 0) && add_int(pbr, "roughnessFactor", 1);
    if (ok && tex[1] >= 0) ok = add_texture_ref(j, "normalTexture", tex[1]);
    if (ok && tex[2] >= 0) ok = add_texture_ref(j, "occlusionTexture", tex[2]);
    if (ok) {
        const char *mode = m->alpha_mode == SV_ALPHA_MASK    ? "MASK"
                           : m->alpha_mode == SV_ALPHA_BLEND ? "BLEND"
                                                             : "OPAQUE";
        ok = cJSON_AddStringToObject(j, "alphaMode", mode) != NULL;
        if (ok && m->alpha_mode == SV_ALPHA_MASK) {
            float c = m->alpha_cutoff;
            if (!(c >= 0.0f)) c = 0.5f;
            ok = cJSON_AddNumberToObject(j, "alphaCutoff", short_float(c)) != NULL;
        }
    }
    if (ok && m->double_sided) ok = cJSON_AddTrueToObject(j, "doubleSided") != NULL;
    if (ok && m->unlit) { /* baked static light: engines must not light it again */
        cJSON *ext = cJSON_AddObjectToObject(j, "extensions");
        ok = ext && cJSON_AddObjectToObject(ext, "KHR_materials_unlit") != NULL;
    }
    if (!ok) {
        cJSON_Delete(j);
        nomem(w);
        return -1;
    }
    int n = cJSON_GetArraySize(w->materials);
    for (int i = 0; i < n; i++)
        if (cJSON_Compare(cJSON_GetArrayItem(w->materials, i), j, true)) {
            cJSON_Delete(j);
            return i;
        }
    cJSON_AddItemToArray(w->materials, j);
    return n;
}

/* Checks what the file needs to be valid: indices and material ids in range,
 * finite positions, well-formed extra attributes. */
static sv_status check_lod(const sv_gltf_lod *l, uint32_t i, sv_error *err)
{
    const sv_mesh *m = l->mesh;
    if (!m) return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u has no mesh", i);
    for (int k = 0; k < 3; k++)
        if (!isfinite(l->translation[k]))
            return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u translation is not finite", i);
    if (m->triangle_count && (!m->indices || !m->tri_material || !m->positions))
        return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u mesh lacks arrays", i);
    for (size_t t = 0; t < (size_t)m->triangle_count; t++) {
        for (int k = 0; k < 3; k++)
            if (m->indices[3 * t + k] >= m->vertex_count)
                return sv_fail(err, SV_ERR_INVALID,
                               "glTF writer: LOD %u triangle %zu uses vertex %u of %u", i, t,
                               m->indices[3 * t + k], m->vertex_count);
        if (m->tri_material[t] >= m->material_count)
            return sv_fail(err, SV_ERR_INVALID,
                           "glTF writer: LOD %u triangle %zu uses material %u of %u", i, t,
                           m->tri_material[t], m->material_count);
    }
    if (m->triangle_count)
        for (size_t v = 0; v < (size_t)m->vertex_count * 3; v++)
            if (!isfinite(m->positions[v]))
                return sv_fail(err, SV_ERR_INVALID,
                               "glTF writer: LOD %u vertex %zu has a non-finite position", i,
                               v / 3);
    if (!(l->screen_coverage >= 0.0 && l->screen_coverage <= 1.0))
        return sv_fail(err, SV_ERR_INVALID,
                       "glTF writer: LOD %u screen coverage %g is not in [0,1]", i,
                       l->screen_coverage);
    if (l->attribute_count && !l->attributes)
        return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u attributes missing", i);
    for (uint32_t a = 0; a < l->attribute_count; a++) {
        const sv_gltf_attribute *at = &l->attributes[a];
        if (!at->name || at->name[0] != '_' || strlen(at->name) > 63 || at->components < 1 ||
            at->components > 4 || (!at->data && m->vertex_count))
            return sv_fail(err, SV_ERR_INVALID,
                           "glTF writer: LOD %u attribute %u must be named '_...' with 1-4 "
                           "components and data",
                           i, a);
        for (uint32_t b = 0; b < a; b++)
            if (strcmp(l->attributes[b].name, at->name) == 0)
                return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u attribute %s given twice",
                               i, at->name);
        for (size_t v = 0; v < (size_t)m->vertex_count * at->components; v++)
            if (!isfinite(at->data[v]))
                return sv_fail(err, SV_ERR_INVALID,
                               "glTF writer: LOD %u attribute %s is not finite", i, at->name);
    }
    return SV_OK;
}

/* A unit component as a normalized signed byte, as glTF decodes it:
 * max(q / 127, -1) (glTF 2.0 §3.11, accessor data normalization). */
static int8_t quantize_snorm8(float v)
{
    if (!(v >= -1.0f)) v = -1.0f; /* also NaN */
    if (v > 1.0f) v = 1.0f;
    return (int8_t)lround((double)v * 127.0);
}

/* A value of [0, 1] as a normalized unsigned 16-bit integer: q / 65535. */
static uint16_t quantize_unorm16(float v)
{
    return (uint16_t)lround((double)v * 65535.0);
}

/* KHR_mesh_quantization's positions: each coordinate p stored as the 16-bit
 * integer round((p - off) / scale), off the bounds' centre and scale the
 * largest half extent / 32767 (one scale for the three axes, so the node's
 * uniform scale keeps normals' directions); the node's translation adds off
 * and its scale is scale. Elements are padded to 8 bytes. */
static int16_t *quantize_positions(const float *p, size_t nv, const double mn[3],
                                   const double mx[3], double off[3], double *scale, double qmn[3],
                                   double qmx[3])
{
    double half = 0;
    for (int k = 0; k < 3; k++) {
        off[k] = nv ? 0.5 * (mn[k] + mx[k]) : 0;
        if (nv && 0.5 * (mx[k] - mn[k]) > half) half = 0.5 * (mx[k] - mn[k]);
        qmn[k] = 32767, qmx[k] = -32767;
    }
    *scale = half > 0 ? half / 32767.0 : 1.0;
    int16_t *q = malloc((nv ? nv : 1) * 4 * sizeof *q);
    if (!q) return NULL;
    for (size_t v = 0; v < nv; v++) {
        for (int k = 0; k < 3; k++) {
            double x = round(((double)p[3 * v + k] - off[k]) / *scale);
            if (x < -32767) x = -32767;
            if (x > 32767) x = 32767;
            q[4 * v + k] = (int16_t)x;
            if (x < qmn[k]) qmn[k] = x;
            if (x > qmx[k]) qmx[k] = x;
        }
        q[4 * v + 3] = 0;
    }
    return q;
}

/* Writes the vertex accessors of one LOD into `attrs` (a JSON object). With
 * quantized positions, *qscale is their scale and qoff their offset (the
 * node's transform undoes them); else *qscale is 0. */
static sv_status write_vertices(writer *w, const sv_gltf_lod *l, cJSON *attrs, double qoff[3],
                                double *qscale)
{
    const sv_mesh *m = l->mesh;
    size_t nv = m->vertex_count, bytes3, bytes2;
    bool quant = w->compress != SV_GLTF_FLOAT;
    *qscale = 0;
    if (!sv_mul_size(nv, 4 * sizeof(float), &bytes3) ||
        !sv_mul_size(nv, 2 * sizeof(float), &bytes2))
        return nomem(w);
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < nv; v++)
        for (int k = 0; k < 3; k++) {
            double p = m->positions[3 * v + k];
            if (p < mn[k]) mn[k] = p;
            if (p > mx[k]) mx[k] = p;
        }
    int acc;
    if (quant && !l->attribute_count) {
        /* extra attributes (a stochastic level's leaf centres) are in the
         * positions' space: positions stay float there */
        double qmn[3], qmx[3], sc;
        int16_t *q = quantize_positions(m->positions, nv, mn, mx, qoff, &sc, qmn, qmx);
        if (!q) return nomem(w);
        acc = add_accessor(w, q, 8, GL_SHORT, false, nv, 3, GL_ARRAY_BUFFER, 0, qmn, qmx);
        free(q);
        *qscale = sc;
        w->quantized = true;
    } else {
        acc = add_accessor(w, m->positions, 3 * sizeof(float), GL_FLOAT, false, nv, 3,
                           GL_ARRAY_BUFFER, 0, mn, mx);
    }
    if (acc < 0) return w->last;
    if (!add_int(attrs, "POSITION", acc)) return nomem(w);
    if (m->normals) {
        /* glTF requires unit normals; renormalise (zero → +Y) in double. */
        float *n = malloc(bytes3 ? bytes3 : 1);
        int8_t *qn = (int8_t *)n; /* quantized: 4 bytes a normal, in place */
        if (!n) return nomem(w);
        for (size_t v = 0; v < nv; v++) {
            double x = m->normals[3 * v], y = m->normals[3 * v + 1], z = m->normals[3 * v + 2];
            double len = sqrt(x * x + y * y + z * z);
            if (!(len > 1e-20) || !isfinite(len)) {
                x = 0, y = 1, z = 0, len = 1;
            }
            if (quant) {
                qn[4 * v] = quantize_snorm8((float)(x / len));
                qn[4 * v + 1] = quantize_snorm8((float)(y / len));
                qn[4 * v + 2] = quantize_snorm8((float)(z / len));
                qn[4 * v + 3] = 0;
            } else {
                n[3 * v] = (float)(x / len);
                n[3 * v + 1] = (float)(y / len);
                n[3 * v + 2] = (float)(z / len);
            }
        }
        acc = quant ? add_accessor(w, n, 4, GL_BYTE, true, nv, 3, GL_ARRAY_BUFFER, 0, NULL, NULL)
                    : add_accessor(w, n, 3 * sizeof(float), GL_FLOAT, false, nv, 3, GL_ARRAY_BUFFER,
                                   0, NULL, NULL);
        if (quant) w->quantized = true;
        free(n);
        if (acc < 0) return w->last;
        if (!add_int(attrs, "NORMAL", acc)) return nomem(w);
    }
    if (m->uvs) {
        bool unit = quant;
        for (size_t v = 0; unit && v < 2 * nv; v++)
            if (!(m->uvs[v] >= 0.0f && m->uvs[v] <= 1.0f)) unit = false;
        if (unit) {
            /* UVs in [0, 1]: normalized 16-bit integers (steps of 1/65535) */
            uint16_t *qu = malloc(bytes2 ? bytes2 : 1);
            if (!qu) return nomem(w);
            for (size_t v = 0; v < 2 * nv; v++) qu[v] = quantize_unorm16(m->uvs[v]);
            acc = add_accessor(w, qu, 4, GL_UNSIGNED_SHORT, true, nv, 2, GL_ARRAY_BUFFER, 0, NULL,
                               NULL);
            free(qu);
            w->quantized = true;
        } else {
            acc = add_accessor(w, m->uvs, 2 * sizeof(float), GL_FLOAT, false, nv, 2,
                               GL_ARRAY_BUFFER, 0, NULL, NULL);
        }
        if (acc < 0) return w->last;
        if (!add_int(attrs, "TEXCOORD_0", acc)) return nomem(w);
    }
    for (uint32_t a = 0; a < l->attribute_count; a++) {
        const sv_gltf_attribute *at = &l->attributes[a];
        size_t bytes;
        if (!sv_mul_size(nv, at->components * sizeof(float), &bytes)) return nomem(w);
        acc = add_accessor(w, at->data, at->components * sizeof(float), GL_FLOAT, false, nv,
                           at->components, GL_ARRAY_BUFFER, 0, NULL, NULL);
        if (acc < 0) return w->last;
        if (!add_int(attrs, at->name, acc)) return nomem(w);
    }
    return SV_OK;
}

/* Writes one glTF mesh for LOD l: shared vertex accessors, one primitive per
 * material used (ascending material index), triangles in input order. */
static sv_status write_welded(writer *w, const sv_gltf_lod *l, const char *name, int *mesh_index,
                              double qoff[3], double *qscale, cJSON *into);

/* A level's vertex arrays through a remap (meshopt_remapVertexBuffer:
 * vertex i goes to remap[i], none where remap[i] is ~0u), into new arrays
 * of `count` vertices; the mesh and the level that draw them are in o->m and
 * o->l (indices and materials still m's and l's: the caller sets them). */
typedef struct remapped {
    float *pos, *nrm, *uv, *ad[8];
    sv_gltf_attribute at[8];
    sv_mesh m;
    sv_gltf_lod l;
} remapped;

static void remapped_free(remapped *o)
{
    for (int a = 0; a < 8; a++) free(o->ad[a]);
    free(o->uv);
    free(o->nrm);
    free(o->pos);
    memset(o, 0, sizeof *o);
}

/* o gets l's positions, `normals` and `uvs` (either may be NULL: left out)
 * and extra attributes through remap; SV_ERR_NOMEM (o freed) on failure. */
static sv_status remap_vertices(writer *w, const sv_gltf_lod *l, const float *normals,
                                const float *uvs, const uint32_t *remap, size_t count,
                                remapped *o)
{
    const sv_mesh *m = l->mesh;
    size_t nv = m->vertex_count, n = count ? count : 1;
    memset(o, 0, sizeof *o);
    o->pos = malloc(n * 3 * sizeof(float));
    if (normals) o->nrm = malloc(n * 3 * sizeof(float));
    if (uvs) o->uv = malloc(n * 2 * sizeof(float));
    bool ok = o->pos && (!normals || o->nrm) && (!uvs || o->uv);
    for (uint32_t a = 0; ok && a < l->attribute_count; a++) {
        size_t sz = l->attributes[a].components * sizeof(float);
        if (!(o->ad[a] = malloc(n * sz))) ok = false;
        else meshopt_remapVertexBuffer(o->ad[a], l->attributes[a].data, nv, sz, remap);
        o->at[a] = l->attributes[a];
        o->at[a].data = o->ad[a];
    }
    if (!ok) {
        remapped_free(o);
        return nomem(w);
    }
    meshopt_remapVertexBuffer(o->pos, m->positions, nv, 3 * sizeof(float), remap);
    if (o->nrm) meshopt_remapVertexBuffer(o->nrm, normals, nv, 3 * sizeof(float), remap);
    if (o->uv) meshopt_remapVertexBuffer(o->uv, uvs, nv, 2 * sizeof(float), remap);
    o->m = *m;
    o->m.vertex_count = (uint32_t)count;
    o->m.positions = o->pos;
    o->m.normals = o->nrm;
    o->m.uvs = o->uv;
    o->l = *l;
    o->l.mesh = &o->m;
    o->l.attributes = l->attribute_count ? o->at : NULL;
    return SV_OK;
}

/* The most vertices a primitive of 16-bit indices can index (65535 is
 * primitive restart: never used). */
#define SV_GLTF_SHORT_VERTICES 65535u

/* Writes the welded primitive l (one material; its vertices in the order its
 * triangles first use them) into the mesh `into` as several primitives of
 * at most SV_GLTF_SHORT_VERTICES vertices each, so every one has 16-bit
 * indices: consecutive runs of its triangles, each with the vertices it
 * uses (a vertex two runs use is written in both; few are, the vertices
 * being numbered by first use). The acacia's full leaves, 122,892 vertices
 * and 298,053 indices, saved 596 KB of 32-bit indices. */
static sv_status write_chunks(writer *w, const sv_gltf_lod *l, const char *name, int *mesh_index,
                              double qoff[3], double *qscale, cJSON *into)
{
    const sv_mesh *m = l->mesh;
    size_t nv = m->vertex_count;
    sv_status st = SV_OK;
    /* remap: a vertex's number in the run being gathered, ~0u if none */
    uint32_t *remap = malloc((nv ? nv : 1) * sizeof *remap);
    uint32_t *glob = malloc(SV_GLTF_SHORT_VERTICES * sizeof *glob);
    uint32_t *ix = malloc(((size_t)m->triangle_count * 3 + 1) * sizeof *ix);
    if (!remap || !glob || !ix) {
        st = nomem(w);
        goto out;
    }
    memset(remap, 0xff, nv * sizeof *remap);
    uint32_t count = 0, t0 = 0;
    for (uint32_t t = 0; t <= m->triangle_count && !st; t++) {
        const uint32_t *tri = t < m->triangle_count ? &m->indices[3 * (size_t)t] : NULL;
        uint32_t fresh = 0;
        for (int c = 0; tri && c < 3; c++)
            fresh += remap[tri[c]] == ~0u && (c < 1 || tri[c] != tri[0]) &&
                     (c < 2 || tri[c] != tri[1]);
        if (!tri || count + fresh > SV_GLTF_SHORT_VERTICES) { /* the run [t0, t) */
            for (size_t k = 3 * (size_t)t0; k < 3 * (size_t)t; k++)
                ix[k - 3 * (size_t)t0] = remap[m->indices[k]];
            remapped r;
            st = remap_vertices(w, l, m->normals, m->uvs, remap, count, &r);
            if (st) break;
            r.m.triangle_count = t - t0;
            r.m.indices = ix;
            r.m.tri_material = m->tri_material + t0;
            st = write_welded(w, &r.l, name, mesh_index, qoff, qscale, into);
            remapped_free(&r);
            for (uint32_t v = 0; v < count; v++) remap[glob[v]] = ~0u;
            count = 0;
            t0 = t;
        }
        for (int c = 0; tri && c < 3; c++)
            if (remap[tri[c]] == ~0u) {
                remap[tri[c]] = count;
                glob[count++] = tri[c];
            }
    }
out:
    free(ix);
    free(glob);
    free(remap);
    return st;
}

/* Writes the mesh of LOD l with its identical vertices merged: vertices
 * equal in every attribute written (position, normal unless l->no_normals,
 * UV when a material samples a texture, the extra attributes; bit for bit)
 * become one, in the order the triangles first use
 * them (meshopt_generateVertexRemapMulti), and vertices no triangle uses are
 * left out. Lossless: the same triangles, drawn the same, in fewer bytes
 * (a tree's triangle soup held each vertex once per triangle). */
static sv_status weld_and_write(writer *w, const sv_gltf_lod *l, const char *name,
                                int *mesh_index, double qoff[3], double *qscale, cJSON *into)
{
    const sv_mesh *m = l->mesh;
    size_t nv = m->vertex_count, ni = (size_t)m->triangle_count * 3;
    struct meshopt_Stream streams[3 + 8];
    size_t ns = 0;
    /* normals the source never had are left to the reader (l->no_normals) */
    const float *normals = l->no_normals ? NULL : m->normals;
    streams[ns++] = (struct meshopt_Stream){m->positions, 3 * sizeof(float), 3 * sizeof(float)};
    if (normals)
        streams[ns++] = (struct meshopt_Stream){normals, 3 * sizeof(float), 3 * sizeof(float)};
    /* UVs only when a material samples a texture: without one they draw
     * nothing, and their seams keep vertices apart */
    bool uvs = false;
    for (uint32_t k = 0; m->uvs && k < m->material_count; k++) {
        const sv_material *mt = &m->materials[k];
        if (mt->base_texture >= 0 || mt->normal_texture >= 0 || mt->occlusion_texture >= 0)
            uvs = true;
    }
    if (uvs) streams[ns++] = (struct meshopt_Stream){m->uvs, 2 * sizeof(float), 2 * sizeof(float)};
    if (l->attribute_count > 8)
        return w->last = sv_fail(w->err, SV_ERR_INVALID,
                                 "glTF writer: more than 8 extra attributes");
    for (uint32_t a = 0; a < l->attribute_count; a++) {
        size_t sz = l->attributes[a].components * sizeof(float);
        streams[ns++] = (struct meshopt_Stream){l->attributes[a].data, sz, sz};
    }
    sv_status st = SV_OK;
    uint32_t *remap = malloc((nv ? nv : 1) * sizeof *remap);
    uint32_t *idx = malloc((ni ? ni : 1) * sizeof *idx);
    if (!remap || !idx) {
        st = nomem(w);
        goto out;
    }
    /* number the vertices in the order the primitives (ascending material)
     * first use them, so a primitive of few vertices ahead of a large one
     * (a trunk before its leaves) has 16-bit indices (write_welded); idx
     * holds the triangles grouped so for the moment */
    {
        size_t k = 0;
        for (uint32_t mi = 0; mi < m->material_count; mi++)
            for (uint32_t t = 0; t < m->triangle_count; t++)
                if (m->tri_material[t] == mi)
                    for (int c = 0; c < 3; c++) idx[k++] = m->indices[3 * (size_t)t + c];
    }
    size_t unique = meshopt_generateVertexRemapMulti(remap, idx, ni, nv, streams, ns);
    meshopt_remapIndexBuffer(idx, m->indices, ni, remap);
    remapped r;
    if ((st = remap_vertices(w, l, normals, uvs ? m->uvs : NULL, remap, unique, &r))) goto out;
    r.m.indices = idx;
    st = into && unique > SV_GLTF_SHORT_VERTICES
             ? write_chunks(w, &r.l, name, mesh_index, qoff, qscale, into)
             : write_welded(w, &r.l, name, mesh_index, qoff, qscale, into);
    remapped_free(&r);
out:
    free(idx);
    free(remap);
    return st;
}

/* Appends *jm to the document's meshes (which then own it; *jm = NULL) and
 * sets *mesh_index to its index. */
static void add_mesh(writer *w, cJSON **jm, int *mesh_index)
{
    cJSON_AddItemToArray(w->meshes, *jm);
    *jm = NULL;
    *mesh_index = cJSON_GetArraySize(w->meshes) - 1;
}

/* Writes the mesh of LOD l (weld_and_write). A level of several materials
 * is written a primitive at a time, each with vertices of its own, when it
 * has more than 65,535 vertices, so that each primitive whose own vertices
 * fit has 16-bit indices (one array for all gave every primitive but the
 * first 32-bit ones: the oak GLB's leaves, 63 KB more, its lod0_full.glb
 * over its input), and in a file of several levels, so that a primitive's
 * arrays do not depend on the others and a stochastic level's leaves can
 * share the level before it's (shared_view) whatever its trunk became. A
 * vertex two materials share is then written twice. Float geometry only
 * (quantized positions share one node transform, computed over the whole
 * level). */
static sv_status write_mesh(writer *w, const sv_gltf_lod *l, const char *name, int *mesh_index,
                            double qoff[3], double *qscale)
{
    const sv_mesh *m = l->mesh;
    uint32_t used = 0, *per = sv_calloc(m->material_count ? m->material_count : 1, sizeof *per);
    if (!per) return nomem(w);
    for (uint32_t t = 0; t < m->triangle_count; t++)
        if (per[m->tri_material[t]]++ == 0) used++;
    if (w->compress != SV_GLTF_FLOAT ||
        (m->vertex_count <= SV_GLTF_SHORT_VERTICES && (!w->several || used < 2))) {
        free(per);
        return weld_and_write(w, l, name, mesh_index, qoff, qscale, NULL);
    }
    sv_status st = SV_OK;
    cJSON *jm = cJSON_CreateObject();
    uint32_t *ix = malloc((size_t)m->triangle_count * 3 * sizeof *ix);
    uint32_t *tm = malloc((size_t)m->triangle_count * sizeof *tm);
    if (!jm || !ix || !tm || !cJSON_AddStringToObject(jm, "name", name) ||
        !cJSON_AddArrayToObject(jm, "primitives")) {
        st = nomem(w);
        goto out;
    }
    for (uint32_t mi = 0; mi < m->material_count && !st; mi++) {
        if (!per[mi]) continue;
        uint32_t n = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (m->tri_material[t] == mi) {
                memcpy(&ix[3 * (size_t)n], &m->indices[3 * (size_t)t], 3 * sizeof *ix);
                tm[n++] = mi;
            }
        sv_mesh sub = *m;
        sub.indices = ix;
        sub.tri_material = tm;
        sub.triangle_count = n;
        sv_gltf_lod sl = *l;
        sl.mesh = &sub;
        st = weld_and_write(w, &sl, name, mesh_index, qoff, qscale, jm);
    }
    if (!st) add_mesh(w, &jm, mesh_index);
out:
    cJSON_Delete(jm);
    free(ix);
    free(tm);
    free(per);
    return st;
}

/* Writes l's vertices (already welded) and one primitive per material used
 * into a new mesh (into NULL: *mesh_index is its index) or into the mesh
 * `into` (its primitives appended; *mesh_index untouched). */
static sv_status write_welded(writer *w, const sv_gltf_lod *l, const char *name, int *mesh_index,
                              double qoff[3], double *qscale, cJSON *into)
{
    const sv_mesh *m = l->mesh;
    sv_status st = SV_OK;
    uint32_t *per_mat = sv_calloc(m->material_count, sizeof *per_mat);
    void *idx = NULL;
    cJSON *jm = into ? NULL : cJSON_CreateObject(), *attrs = cJSON_CreateObject();
    cJSON *prims = into ? cJSON_GetObjectItemCaseSensitive(into, "primitives")
                 : jm   ? cJSON_AddArrayToObject(jm, "primitives")
                        : NULL;
    if (!per_mat || (!into && !jm) || !attrs || !prims ||
        (jm && !cJSON_AddStringToObject(jm, "name", name))) {
        st = nomem(w);
        goto out;
    }
    if ((st = write_vertices(w, l, attrs, qoff, qscale)) != SV_OK) goto out;
    for (uint32_t t = 0; t < m->triangle_count; t++) per_mat[m->tri_material[t]]++;
    for (uint32_t mi = 0; mi < m->material_count; mi++) {
        if (!per_mat[mi]) continue;
        /* 16-bit indices when this primitive's all fit (65535 is primitive
         * restart: never used) */
        uint32_t top = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (m->tri_material[t] == mi)
                for (int c = 0; c < 3; c++)
                    if (m->indices[3 * (size_t)t + c] > top) top = m->indices[3 * (size_t)t + c];
        bool small = top < 65535;
        size_t isz = small ? 2 : 4;
        size_t count = (size_t)per_mat[mi] * 3, bytes;
        if (!sv_mul_size(count, isz, &bytes) || !(idx = malloc(bytes))) {
            st = nomem(w);
            goto out;
        }
        size_t k = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            if (m->tri_material[t] != mi) continue;
            for (int c = 0; c < 3; c++, k++) {
                uint32_t v = m->indices[3 * (size_t)t + c];
                if (small) ((uint16_t *)idx)[k] = (uint16_t)v;
                else ((uint32_t *)idx)[k] = v;
            }
        }
        int acc = add_accessor(w, idx, isz, small ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT, false,
                               count, 1, GL_ELEMENT_ARRAY_BUFFER, m->vertex_count, NULL, NULL);
        free(idx);
        idx = NULL;
        if (acc < 0) {
            st = w->last;
            goto out;
        }
        int mat = material_for(w, m, mi);
        if (mat < 0) {
            st = w->last;
            goto out;
        }
        cJSON *p = cJSON_CreateObject();
        cJSON *pa = cJSON_Duplicate(attrs, true);
        if (!p || !pa) {
            cJSON_Delete(p);
            cJSON_Delete(pa);
            st = nomem(w);
            goto out;
        }
        cJSON_AddItemToObject(p, "attributes", pa);
        if (!add_int(p, "indices", acc) || !add_int(p, "material", mat)) {
            cJSON_Delete(p);
            st = nomem(w);
            goto out;
        }
        cJSON_AddItemToArray(prims, p);
    }
    if (jm) add_mesh(w, &jm, mesh_index);
out:
    free(idx);
    free(per_mat);
    cJSON_Delete(attrs);
    cJSON_Delete(jm);
    return st;
}

/* The LOD group's root node (node 0, before the levels): its name, the
 * levels as its children, the caller's extras. */
static sv_status group_root(writer *w, const sv_gltf_group *g, uint32_t lod_count)
{
    cJSON *node = cJSON_CreateObject();
    if (!node) return nomem(w);
    cJSON_AddItemToArray(w->nodes, node);
    cJSON *ch = cJSON_AddStringToObject(node, "name", g->root_name)
                    ? cJSON_AddArrayToObject(node, "children")
                    : NULL;
    if (!ch) return nomem(w);
    for (uint32_t i = 0; i < lod_count; i++) {
        cJSON *x = cJSON_CreateNumber(i + 1);
        if (!x) return nomem(w);
        cJSON_AddItemToArray(ch, x);
    }
    if (g->extras) {
        if (!cJSON_IsObject(g->extras))
            return sv_fail(w->err, SV_ERR_INVALID,
                           "glTF writer: the root's extras is not an object");
        cJSON *e = cJSON_Duplicate(g->extras, true);
        if (!e) return nomem(w);
        cJSON_AddItemToObject(node, "extras", e);
    }
    return SV_OK;
}

/* The document: levels as MSFT_lod alternates (group NULL) or as the
 * children of the group's root node. */
static sv_status build(writer *w, const sv_gltf_lod *lods, uint32_t lod_count,
                       const sv_gltf_group *group)
{
    cJSON *r = w->root;
    cJSON *asset = cJSON_AddObjectToObject(r, "asset");
    if (!asset || !cJSON_AddStringToObject(asset, "generator", "sylva " SV_VERSION) ||
        !cJSON_AddStringToObject(asset, "version", "2.0"))
        return nomem(w);
    if (lod_count > 1 && !group) {
        cJSON *used = cJSON_AddArrayToObject(r, "extensionsUsed");
        cJSON *s = cJSON_CreateString("MSFT_lod");
        if (!used || !s) {
            cJSON_Delete(s);
            return nomem(w);
        }
        cJSON_AddItemToArray(used, s);
    }
    cJSON *scenes = cJSON_CreateArray(), *scene = cJSON_CreateObject();
    cJSON *sn = scene ? cJSON_AddArrayToObject(scene, "nodes") : NULL;
    cJSON *zero = cJSON_CreateNumber(0);
    if (!scenes || !scene || !sn || !zero || !add_int(r, "scene", 0)) {
        cJSON_Delete(scenes);
        cJSON_Delete(scene);
        cJSON_Delete(zero);
        return nomem(w);
    }
    cJSON_AddItemToArray(sn, zero);
    cJSON_AddItemToArray(scenes, scene);
    cJSON_AddItemToObject(r, "scenes", scenes);
    /* Arrays in a fixed order; empty ones are removed at the end. */
    if (!(w->nodes = cJSON_AddArrayToObject(r, "nodes")) ||
        !(w->meshes = cJSON_AddArrayToObject(r, "meshes")) ||
        !(w->materials = cJSON_AddArrayToObject(r, "materials")) ||
        !(w->textures = cJSON_AddArrayToObject(r, "textures")) ||
        !(w->samplers = cJSON_AddArrayToObject(r, "samplers")) ||
        !(w->images = cJSON_AddArrayToObject(r, "images")) ||
        !(w->accessors = cJSON_AddArrayToObject(r, "accessors")) ||
        !(w->views = cJSON_AddArrayToObject(r, "bufferViews")))
        return nomem(w);
    if (group) {
        sv_status st = group_root(w, group, lod_count);
        if (st != SV_OK) return st;
    }

    for (uint32_t i = 0; i < lod_count; i++) {
        const sv_gltf_lod *l = &lods[i];
        char fallback[32];
        snprintf(fallback, sizeof fallback, "lod%u", i);
        const char *name = l->name && l->name[0] ? l->name : fallback;
        cJSON *node = cJSON_CreateObject();
        if (!node || !cJSON_AddStringToObject(node, "name", name)) {
            cJSON_Delete(node);
            return nomem(w);
        }
        cJSON_AddItemToArray(w->nodes, node);
        int mesh_index = -1;
        double qoff[3] = {0, 0, 0}, qscale = 0, tr3[3];
        if (l->mesh->triangle_count) {
            w->compress = l->compress;
            sv_status st = write_mesh(w, l, l->mesh_name && l->mesh_name[0] ? l->mesh_name : name,
                                      &mesh_index, qoff, &qscale);
            w->compress = SV_GLTF_FLOAT;
            if (st != SV_OK) return st;
        }
        /* the level's translation, plus the quantized positions' offset */
        for (int k = 0; k < 3; k++) tr3[k] = l->translation[k] + qoff[k];
        if (tr3[0] != 0 || tr3[1] != 0 || tr3[2] != 0) {
            /* %.17g: cJSON's own printing may drop the last bits of a double */
            cJSON *tr = cJSON_AddArrayToObject(node, "translation");
            for (int k = 0; tr && k < 3; k++) {
                char num[32];
                snprintf(num, sizeof num, "%.17g", tr3[k]);
                cJSON *x = cJSON_CreateRaw(num);
                if (!x) tr = NULL;
                else cJSON_AddItemToArray(tr, x);
            }
            if (!tr) return nomem(w);
        }
        if (qscale > 0) { /* undoes the quantization (KHR_mesh_quantization) */
            cJSON *sc = cJSON_AddArrayToObject(node, "scale");
            for (int k = 0; sc && k < 3; k++) {
                char num[32];
                snprintf(num, sizeof num, "%.17g", qscale);
                cJSON *x = cJSON_CreateRaw(num);
                if (!x) sc = NULL;
                else cJSON_AddItemToArray(sc, x);
            }
            if (!sc) return nomem(w);
        }
        if (mesh_index >= 0 && !add_int(node, "mesh", mesh_index)) return nomem(w);
        cJSON *extras = NULL;
        if (l->extras) {
            if (!cJSON_IsObject(l->extras))
                return sv_fail(w->err, SV_ERR_INVALID,
                               "glTF writer: LOD %u extras is not an object", i);
            if (!(extras = cJSON_Duplicate(l->extras, true))) return nomem(w);
        }
        if (i == 0 && lod_count > 1 && !group) {
            cJSON *ext = cJSON_AddObjectToObject(node, "extensions");
            cJSON *lod = ext ? cJSON_AddObjectToObject(ext, "MSFT_lod") : NULL;
            cJSON *ids = lod ? cJSON_AddArrayToObject(lod, "ids") : NULL;
            if (!extras) extras = cJSON_CreateObject();
            cJSON *cov = extras ? cJSON_CreateArray() : NULL;
            bool ok = ids && cov;
            for (uint32_t k = 1; ok && k < lod_count; k++) {
                cJSON *x = cJSON_CreateNumber(k);
                ok = x != NULL;
                if (x) cJSON_AddItemToArray(ids, x);
            }
            for (uint32_t k = 0; ok && k < lod_count; k++) {
                cJSON *x = cJSON_CreateNumber(lods[k].screen_coverage);
                ok = x != NULL;
                if (x) cJSON_AddItemToArray(cov, x);
            }
            if (ok) {
                cJSON_DeleteItemFromObjectCaseSensitive(extras, "MSFT_screencoverage");
                cJSON_AddItemToObject(extras, "MSFT_screencoverage", cov);
            } else {
                cJSON_Delete(cov);
                cJSON_Delete(extras);
                return nomem(w);
            }
        }
        if (extras) cJSON_AddItemToObject(node, "extras", extras);
    }
    if (w->bin_len) {
        cJSON *buffers = cJSON_AddArrayToObject(r, "buffers");
        cJSON *b = cJSON_CreateObject();
        if (!buffers || !b || !add_int(b, "byteLength", (double)w->bin_len)) {
            cJSON_Delete(b);
            return nomem(w);
        }
        cJSON_AddItemToArray(buffers, b);
        if (w->meshopt) {
            /* buffer 1: the decoded views' placeholder, without data
             * (EXT_meshopt_compression "Fallback buffers") */
            cJSON *f = cJSON_CreateObject(), *x = NULL, *m = NULL;
            bool ok = f &&
                      add_int(f, "byteLength", (double)(w->fallback_len ? w->fallback_len : 4)) &&
                      (x = cJSON_AddObjectToObject(f, "extensions")) &&
                      (m = cJSON_AddObjectToObject(x, "EXT_meshopt_compression")) &&
                      cJSON_AddTrueToObject(m, "fallback");
            if (!ok) {
                cJSON_Delete(f);
                return nomem(w);
            }
            cJSON_AddItemToArray(buffers, f);
        }
    }
    /* the geometry's extensions, required: a loader without them would
     * misread the data (or have none) */
    const char *geo_ext[2] = {w->quantized ? "KHR_mesh_quantization" : NULL,
                              w->meshopt ? "EXT_meshopt_compression" : NULL};
    for (int k = 0; k < 2; k++) {
        if (!geo_ext[k]) continue;
        const char *key[2] = {"extensionsUsed", "extensionsRequired"};
        for (int u = 0; u < 2; u++) {
            cJSON *list = cJSON_GetObjectItemCaseSensitive(r, key[u]);
            if (!list) list = cJSON_AddArrayToObject(r, key[u]);
            cJSON *x = cJSON_CreateString(geo_ext[k]);
            if (!list || !x) {
                cJSON_Delete(x);
                return nomem(w);
            }
            cJSON_AddItemToArray(list, x);
        }
    }
    /* KHR_materials_unlit is declared when a material uses it. */
    const cJSON *mat;
    bool unlit = false;
    cJSON_ArrayForEach(mat, w->materials)
    {
        const cJSON *ext = cJSON_GetObjectItemCaseSensitive(mat, "extensions");
        if (cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_unlit")) unlit = true;
    }
    if (unlit) {
        cJSON *used = cJSON_GetObjectItemCaseSensitive(r, "extensionsUsed");
        if (!used) used = cJSON_AddArrayToObject(r, "extensionsUsed");
        cJSON *s = cJSON_CreateString("KHR_materials_unlit");
        if (!used || !s) {
            cJSON_Delete(s);
            return nomem(w);
        }
        cJSON_AddItemToArray(used, s);
    }
    static const char *const optional[] = {"meshes", "materials", "textures",   "samplers",
                                           "images", "accessors", "bufferViews"};
    for (size_t k = 0; k < sizeof optional / sizeof *optional; k++) {
        cJSON *a = cJSON_GetObjectItemCaseSensitive(r, optional[k]);
        if (a && cJSON_GetArraySize(a) == 0)
            cJSON_DeleteItemFromObjectCaseSensitive(r, optional[k]);
    }
    return SV_OK;
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

/* sv_gltf_encode_glb and sv_gltf_encode_group_glb (group NULL: MSFT_lod). */
static sv_status encode(const sv_gltf_lod *lods, uint32_t lod_count, const sv_gltf_group *group,
                        uint8_t **out, size_t *out_size, sv_error *err)
{
    *out = NULL;
    *out_size = 0;
    if (!lods || lod_count == 0)
        return sv_fail(err, SV_ERR_INVALID, "glTF writer: no LODs to write");
    for (uint32_t i = 0; i < lod_count; i++) {
        sv_status st = check_lod(&lods[i], i, err);
        if (st != SV_OK) return st;
    }
    writer w = {.err = err};
    sv_status st = SV_OK;
    char *json = NULL;
    if (!(w.root = cJSON_CreateObject())) {
        st = nomem(&w);
        goto out;
    }
    w.several = lod_count > 1;
    if ((st = build(&w, lods, lod_count, group)) != SV_OK) goto out;
    if (!(json = cJSON_PrintUnformatted(w.root))) {
        st = nomem(&w);
        goto out;
    }
    size_t jlen = strlen(json), jpad = (jlen + 3) & ~(size_t)3;
    size_t total = 12 + 8 + jpad + (w.bin_len ? 8 + w.bin_len : 0);
    if (total > 0xFFFFFFFFu || jpad < jlen) {
        st = sv_fail(err, SV_ERR_LIMIT, "glTF writer: file would exceed 4 GiB");
        goto out;
    }
    uint8_t *buf = malloc(total);
    if (!buf) {
        st = nomem(&w);
        goto out;
    }
    put_u32(buf, GLB_MAGIC);
    put_u32(buf + 4, 2);
    put_u32(buf + 8, (uint32_t)total);
    put_u32(buf + 12, (uint32_t)jpad);
    put_u32(buf + 16, GLB_CHUNK_JSON);
    memcpy(buf + 20, json, jlen);
    memset(buf + 20 + jlen, ' ', jpad - jlen); /* JSON chunk pads with spaces */
    if (w.bin_len) {
        uint8_t *b = buf + 20 + jpad;
        put_u32(b, (uint32_t)w.bin_len);
        put_u32(b + 4, GLB_CHUNK_BIN);
        memcpy(b + 8, w.bin, w.bin_len);
    }
    *out = buf;
    *out_size = total;
out:
    cJSON_free(json);
    cJSON_Delete(w.root);
    free(w.bin);
    free(w.uniq);
    free(w.dv);
    return st;
}

sv_status sv_gltf_encode_glb(const sv_gltf_lod *lods, uint32_t lod_count, uint8_t **out,
                             size_t *out_size, sv_error *err)
{
    return encode(lods, lod_count, NULL, out, out_size, err);
}

sv_status sv_gltf_encode_group_glb(const sv_gltf_group *group, const sv_gltf_lod *lods,
                                   uint32_t lod_count, uint8_t **out, size_t *out_size,
                                   sv_error *err)
{
    *out = NULL;
    *out_size = 0;
    if (!group || !group->root_name || !group->root_name[0])
        return sv_fail(err, SV_ERR_INVALID, "glTF writer: a LOD group needs a root name");
    for (uint32_t i = 0; lods && i < lod_count; i++)
        if (!lods[i].name || !lods[i].name[0])
            return sv_fail(err, SV_ERR_INVALID, "glTF writer: LOD %u of a group has no name", i);
    return encode(lods, lod_count, group, out, out_size, err);
}

sv_status sv_gltf_write_group_glb(const char *path, const sv_gltf_group *group,
                                  const sv_gltf_lod *lods, uint32_t lod_count, sv_error *err)
{
    uint8_t *data;
    size_t size;
    sv_status st = sv_gltf_encode_group_glb(group, lods, lod_count, &data, &size, err);
    if (st != SV_OK) return st;
    st = sv_write_file(path, data, size, err);
    free(data);
    return st;
}

sv_status sv_gltf_write_glb(const char *path, const sv_gltf_lod *lods, uint32_t lod_count,
                            sv_error *err)
{
    uint8_t *data;
    size_t size;
    sv_status st = sv_gltf_encode_glb(lods, lod_count, &data, &size, err);
    if (st != SV_OK) return st;
    st = sv_write_file(path, data, size, err);
    free(data);
    return st;
}

sv_status sv_gltf_encode_level_glb(const sv_gltf_lod *lod, uint8_t **out, size_t *out_size,
                                   sv_error *err)
{
    *out = NULL;
    *out_size = 0;
    if (!lod || !lod->name || !lod->name[0])
        return sv_fail(err, SV_ERR_INVALID, "glTF writer: a standalone level needs a node name");
    sv_gltf_lod one = *lod;
    one.screen_coverage = 0; /* one level: nothing to switch to */
    return sv_gltf_encode_glb(&one, 1, out, out_size, err);
}

sv_status sv_gltf_write_level_glb(const char *path, const sv_gltf_lod *lod, sv_error *err)
{
    uint8_t *data;
    size_t size;
    sv_status st = sv_gltf_encode_level_glb(lod, &data, &size, err);
    if (st != SV_OK) return st;
    st = sv_write_file(path, data, size, err);
    free(data);
    return st;
}
