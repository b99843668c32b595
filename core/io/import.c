/* import.c — mesh import through assimp's C API, from memory only.
 *
 * The upload is served to assimp through a custom aiFileIO that knows only the
 * files the caller handed in (sv_upload_find in sniff.c resolves names; anything
 * absolute, with `..`, a scheme or a drive letter is refused and fails the
 * import). The format is sniffed from the bytes first and assimp is given a file
 * name whose extension matches it, so assimp 5.2.5 runs exactly one parser
 * instead of trying ~40. glTF/GLB go through sv_gltf_precheck first, because
 * assimp recurses per node level and trusts declared lengths.
 *
 * Conventions on the way out (see sv.h): metres, +Y up, CCW, UV v down (glTF's).
 * Units and up axis: every format defaults to metres and +Y up (glTF by its
 * specification); a non-zero options.unit_scale or up_axis 'Z' is applied to any
 * format, glTF included, because files exported without conversion exist (the
 * Scopia ficus GLB is in centimetres like its OBJ). For COLLADA and FBX assimp
 * already applies the file's own unit/up metadata; the options apply on top.
 * info->unit_scale and info->up_axis report what was converted from.
 *
 * Materials:
 *  - base colour: glTF's baseColorFactor ($clr.base), else the diffuse colour.
 *    For non-glTF sources with a base-colour texture the diffuse colour is not
 *    multiplied in (as Blender's OBJ importer does: MTL exporters write Kd 0.8 or
 *    a flat average next to map_Kd); alpha is the material's opacity.
 *  - alpha mode: glTF's alphaMode/alphaCutoff. Other formats: an opacity map
 *    (OBJ map_d) or a base texture with any alpha < 255 means MASK (cutoff 0.5);
 *    opacity < 1 without such a texture means BLEND.
 *  - double-sided: $mat.twosided; formats without the flag (OBJ, PLY) are taken
 *    as double-sided when the material is alpha-masked or blended, since alpha
 *    cards (leaves, twigs) are always meant to be seen from both sides.
 *  - textures: embedded ("*N") or an uploaded file, decoded to RGBA8; one that
 *    does not decode is a warning, not an error.
 * Missing files ("honest outcomes"): a .mtl that assimp asks for and
 * a base-colour texture a material names, when neither is among the uploaded
 * files, are listed in info->missing_files and fail the import with
 * SV_ERR_MISSING naming them, unless options.missing_files_warn: then they are
 * warnings and the materials keep their plain colour (grey without the .mtl).
 * Only files sylva reads count: an OBJ's missing mtllib is forgiven when
 * assimp's own fallback, "<stem>.mtl", was uploaded and read instead (a
 * warning says so); other maps (map_d, bump) are never read.
 * Non-finite positions never leave the importer (assimp 5.2.5 lets them through
 * its validation): they fail with SV_ERR_INVALID naming the vertex. Repairs
 * (degenerate and duplicate triangles) are sv_validate's job.
 */
#include "import.h"
#include "image_io.h"

#include <assimp/GltfMaterial.h>
#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/commonMetaData.h>
#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <cjson/cJSON.h>

/* Copies src into dst (capacity cap), truncating. */
static void copy_str(char *dst, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap) n = cap - 1;
    memcpy(dst, src, n);
    dst[n] = 0;
}

/* ---- the in-memory file system served to assimp ---- */

#define IO_MISSING_MAX 8

typedef struct io_ctx {
    const sv_file *files;
    size_t count;
    const char *main_name; /* what assimp is told files[0] is called */
    sv_status refused;     /* SV_ERR_REFUSED once a reference was refused */
    char refused_msg[400];
    char fallback_mtl[160];            /* assimp's OBJ fallback: main_name with .mtl */
    char missing[IO_MISSING_MAX][160]; /* safe names asked for but not uploaded */
    unsigned missing_count;            /* all of them (the first IO_MISSING_MAX named) */
    bool fallback_used;                /* fallback_mtl was uploaded and opened after a miss */
    const uint8_t *main_data;          /* files[0] as served (an OBJ's shifted copy), or NULL */
    size_t main_size;
} io_ctx;

static bool ends_with_mtl(const char *name)
{
    size_t n = strlen(name);
    return n >= 4 && strcasecmp(name + n - 4, ".mtl") == 0;
}

typedef struct mem_file {
    const uint8_t *data;
    size_t size, pos;
} mem_file;

static size_t mf_read(struct aiFile *f, char *buf, size_t size, size_t count)
{
    mem_file *m = (mem_file *)f->UserData;
    if (size == 0 || count == 0) return 0;
    size_t avail = m->size - m->pos, n = count;
    if (avail / size < n) n = avail / size;
    memcpy(buf, m->data + m->pos, n * size);
    m->pos += n * size;
    return n;
}

static size_t mf_write(struct aiFile *f, const char *buf, size_t size, size_t count)
{
    (void)f, (void)buf, (void)size, (void)count;
    return 0;
}

static size_t mf_tell(struct aiFile *f)
{
    return ((mem_file *)f->UserData)->pos;
}
static size_t mf_size(struct aiFile *f)
{
    return ((mem_file *)f->UserData)->size;
}
static void mf_flush(struct aiFile *f)
{
    (void)f;
}

static enum aiReturn mf_seek(struct aiFile *f, size_t off, enum aiOrigin origin)
{
    mem_file *m = (mem_file *)f->UserData;
    size_t base = origin == aiOrigin_SET ? 0 : origin == aiOrigin_CUR ? m->pos : m->size;
    if (origin == aiOrigin_END) {
        /* assimp passes a "negative" size_t for offsets back from the end */
        size_t back = (size_t)0 - off;
        if (off == 0) back = 0;
        if (back > m->size) return aiReturn_FAILURE;
        m->pos = m->size - back;
        return aiReturn_SUCCESS;
    }
    if (off > m->size || base > m->size - off) return aiReturn_FAILURE;
    m->pos = base + off;
    return aiReturn_SUCCESS;
}

static struct aiFile *io_open(struct aiFileIO *io, const char *name, const char *mode)
{
    io_ctx *ctx = (io_ctx *)io->UserData;
    if (!name || !mode || strpbrk(mode, "wa+")) return NULL;
    size_t idx = 0;
    if (strcmp(name, ctx->main_name) == 0) {
        idx = 0;
    } else {
        sv_error e = {0};
        sv_status st = sv_upload_find(ctx->files, ctx->count, name, &idx, &e);
        if (st == SV_ERR_REFUSED) {
            if (ctx->refused == SV_OK) {
                ctx->refused = SV_ERR_REFUSED;
                copy_str(ctx->refused_msg, sizeof ctx->refused_msg, e.message);
            }
            return NULL;
        }
        const char *plain = name;
        while (plain[0] == '.' && plain[1] == '/') plain += 2; /* assimp tries "x" and "./x" */
        /* after a missing mtllib assimp tries "<stem>.mtl": not a file the mesh names */
        bool guess = ctx->missing_count > 0 && strcmp(plain, ctx->fallback_mtl) == 0;
        if (st != SV_OK) {
            bool seen = false;
            for (unsigned i = 0; i < ctx->missing_count && i < IO_MISSING_MAX; i++)
                seen = seen || strcmp(ctx->missing[i], plain) == 0;
            if (!guess && !seen) {
                if (ctx->missing_count < IO_MISSING_MAX)
                    copy_str(ctx->missing[ctx->missing_count], sizeof ctx->missing[0], plain);
                ctx->missing_count++;
            }
            return NULL;
        }
        if (guess) ctx->fallback_used = true;
    }
    struct aiFile *f = calloc(1, sizeof *f);
    mem_file *m = calloc(1, sizeof *m);
    if (!f || !m) {
        free(f);
        free(m);
        return NULL;
    }
    m->data = idx == 0 && ctx->main_data ? ctx->main_data : ctx->files[idx].data;
    m->size = idx == 0 && ctx->main_data ? ctx->main_size : ctx->files[idx].size;
    f->ReadProc = mf_read;
    f->WriteProc = mf_write;
    f->TellProc = mf_tell;
    f->FileSizeProc = mf_size;
    f->SeekProc = mf_seek;
    f->FlushProc = mf_flush;
    f->UserData = (aiUserData)m;
    return f;
}

static void io_close(struct aiFileIO *io, struct aiFile *f)
{
    (void)io;
    if (!f) return;
    free(f->UserData);
    free(f);
}

/* ---- helpers ---- */

static void add_warning(sv_import_info *info, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
static void add_warning(sv_import_info *info, const char *fmt, ...)
{
    /* the last KiB is kept for the left-out count and later checks */
    size_t len = strlen(info->warnings), cap = sizeof info->warnings - 1024;
    va_list ap;
    va_start(ap, fmt);
    int need = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (need < 0 || len + 1 + (size_t)need + 1 > cap) {
        info->warnings_left_out++;
        return;
    }
    if (len) info->warnings[len++] = '\n';
    va_start(ap, fmt);
    vsnprintf(info->warnings + len, cap - len, fmt, ap);
    va_end(ap);
}

/* Records a file the mesh references that was not uploaded: once per name in
 * info->missing_files (", "-separated), and as a warning saying what it costs. */
static void add_missing(sv_import_info *info, const char *name, const char *consequence)
{
    char *list = info->missing_files;
    size_t nlen = strlen(name), cap = sizeof info->missing_files;
    if (nlen == 0) return;
    for (const char *p = list; (p = strstr(p, name)) != NULL; p += nlen)
        if ((p == list || p[-1] == ' ') && (p[nlen] == 0 || p[nlen] == ','))
            return; /* already listed */
    info->files_missing++;
    add_warning(info, "'%s' was not supplied: %s", name, consequence);
    size_t len = strlen(list);
    if (len + (len ? 2 : 0) + nlen + 1 > cap) {
        if (len + 5 < cap && !strstr(list, ", ...")) strcat(list, ", ...");
        return;
    }
    if (len) strcat(list, ", ");
    strcat(list, name);
}

/* The reader assimp used, from the scene's SourceAsset_Format (assimp records
 * the importer's name there); "" when absent. */
static const char *source_reader(const struct aiScene *scene)
{
    const struct aiMetadata *m = scene->mMetaData;
    if (!m) return "";
    for (unsigned i = 0; i < m->mNumProperties; i++)
        if (strcmp(m->mKeys[i].data, AI_METADATA_SOURCE_FORMAT) == 0 &&
            m->mValues[i].mType == AI_AISTRING && m->mValues[i].mData)
            return ((const struct aiString *)m->mValues[i].mData)->data;
    return "";
}

/* A word of the name of the assimp reader that must read each sniffed format.
 * With a name ending in .obj, .ply, .fbx or .dae exactly one reader claims the
 * file; .gltf/.glb are claimed by glTF (1.0) and glTF2, and when both decline,
 * assimp 5.2.5 asks every other reader: the check below catches that. */
static const char *expected_reader(sv_format f)
{
    switch (f) {
    case SV_FORMAT_GLB:
    case SV_FORMAT_GLTF:
        return "glTF2 ";
    case SV_FORMAT_OBJ:
        return "Wavefront Object";
    case SV_FORMAT_PLY:
        return "(PLY)";
    case SV_FORMAT_FBX:
        return "Autodesk FBX";
    case SV_FORMAT_COLLADA:
        return "Collada";
    case SV_FORMAT_UNKNOWN:
        break;
    }
    return "?";
}

static bool is_gltf(sv_format f)
{
    return f == SV_FORMAT_GLB || f == SV_FORMAT_GLTF;
}

typedef struct image_slot {
    char key[64]; /* "*N" or "file:<index>" */
} image_slot;

typedef struct importer {
    const sv_file *files;
    size_t count;
    sv_limits lim;
    uint64_t texture_bytes; /* decoded RGBA8 bytes of the textures so far */
    sv_format format;
    sv_import_info *info;
    sv_error *err;
    sv_image *images; /* up to material_count */
    image_slot *slots;
    uint32_t image_count;
} importer;

/* Loads (or reuses) the texture at `path` for material `mname`. Returns SV_OK
 * with *index = -1 when it is missing or does not decode (a warning); fails
 * with SV_ERR_REFUSED for an unsafe reference and SV_ERR_LIMIT for an image
 * over the size limit. */
static sv_status load_texture(importer *im, const struct aiScene *scene, const char *path,
                              const char *mname, int32_t *index)
{
    *index = -1;
    char key[64];
    const uint8_t *data = NULL;
    size_t size = 0;
    char shown[200];
    copy_str(shown, sizeof shown, path);
    if (path[0] == '*') {
        char *end = NULL;
        unsigned long n = strtoul(path + 1, &end, 10);
        if (!end || *end || n >= scene->mNumTextures) {
            add_warning(im->info, "material '%s': embedded texture '%s' does not exist", mname,
                        shown);
            im->info->textures_missing++;
            return SV_OK;
        }
        const struct aiTexture *t = scene->mTextures[n];
        snprintf(key, sizeof key, "*%lu", n);
        for (uint32_t i = 0; i < im->image_count; i++)
            if (strcmp(im->slots[i].key, key) == 0) {
                *index = (int32_t)i;
                return SV_OK;
            }
        sv_image *img = &im->images[im->image_count];
        if (t->mHeight == 0) {
            data = (const uint8_t *)t->pcData;
            size = t->mWidth;
        } else {
            /* uncompressed BGRA texels */
            if (t->mWidth > im->lim.max_texture_size || t->mHeight > im->lim.max_texture_size)
                return sv_fail(im->err, SV_ERR_LIMIT,
                               "material '%s': embedded texture %s is %ux%u, over the %u limit",
                               mname, shown, t->mWidth, t->mHeight, im->lim.max_texture_size);
            sv_status st = sv_image_alloc(img, t->mWidth, t->mHeight, 4, 8, im->err);
            if (st != SV_OK) return st;
            uint8_t *o = img->data;
            for (size_t k = 0; k < (size_t)t->mWidth * t->mHeight; k++) {
                o[4 * k + 0] = t->pcData[k].r;
                o[4 * k + 1] = t->pcData[k].g;
                o[4 * k + 2] = t->pcData[k].b;
                o[4 * k + 3] = t->pcData[k].a;
            }
        }
    } else {
        if (strncmp(path, "data:", 5) == 0) {
            add_warning(im->info, "material '%s': inline data: texture left undecoded", mname);
            im->info->textures_missing++;
            return SV_OK;
        }
        size_t fi = 0;
        sv_error e = {0};
        sv_status st = sv_upload_find(im->files, im->count, path, &fi, &e);
        if (st == SV_ERR_REFUSED)
            return sv_fail(im->err, SV_ERR_REFUSED, "material '%s': texture %s", mname, e.message);
        if (st != SV_OK) {
            char why[300];
            snprintf(why, sizeof why, "material '%.120s' is drawn without its texture", mname);
            add_missing(im->info, shown, why);
            im->info->textures_missing++;
            return SV_OK;
        }
        snprintf(key, sizeof key, "file:%zu", fi);
        for (uint32_t i = 0; i < im->image_count; i++)
            if (strcmp(im->slots[i].key, key) == 0) {
                *index = (int32_t)i;
                return SV_OK;
            }
        data = im->files[fi].data;
        size = im->files[fi].size;
    }
    sv_image *img = &im->images[im->image_count];
    if (data) {
        sv_error e = {0};
        sv_status st = sv_image_decode_rgba8_within(data, size, shown, im->lim.max_texture_size,
                                                    im->lim.max_texture_bytes, img, &e);
        if (st == SV_ERR_LIMIT || st == SV_ERR_NOMEM)
            return sv_fail(im->err, st, "material '%s': %s", mname, e.message);
        /* every texture stays decoded until the bake ends: their sum is bounded
         * as well as each decode */
        if (st == SV_OK) {
            im->texture_bytes += (uint64_t)img->width * img->height * 4;
            if (im->texture_bytes > im->lim.max_textures_bytes) {
                sv_image_free(img);
                return sv_fail(im->err, SV_ERR_LIMIT,
                               "material '%s': texture '%s' (%ux%u) takes the upload's decoded "
                               "textures to %llu bytes, over the %llu-byte budget of an upload",
                               mname, shown, img->width, img->height,
                               (unsigned long long)im->texture_bytes,
                               (unsigned long long)im->lim.max_textures_bytes);
            }
        }
        /* a broken texture is the input's (a warning, drawn without it); an
         * image decoder that cannot load is the installation's, and would
         * silently drop every texture */
        if (st != SV_OK && sv_image_plugin_load(&e) != SV_OK)
            return sv_fail(im->err, SV_ERR_INTERNAL, "material '%s': %s", mname, e.message);
        if (st != SV_OK) {
            add_warning(im->info, "material '%s': %s", mname, e.message);
            im->info->textures_missing++;
            return SV_OK;
        }
        /* the file itself, so outputs that keep this texture unchanged
         * store its bytes (a JPEG stays a JPEG) */
        if ((st = sv_image_set_source(img, data, size, im->err)) != SV_OK) {
            sv_image_free(img);
            return st;
        }
    }
    snprintf(im->slots[im->image_count].key, sizeof im->slots[0].key, "%s", key);
    *index = (int32_t)im->image_count++;
    im->info->textures_decoded++;
    return SV_OK;
}

static bool texture_has_alpha(const sv_image *img)
{
    const uint8_t *p = img->data;
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++)
        if (p[4 * i + 3] < 255) return true;
    return false;
}

static sv_status convert_material(importer *im, const struct aiScene *scene,
                                  const struct aiMaterial *am, uint32_t mi, sv_material *m)
{
    sv_material_init(m);
    struct aiString s;
    if (aiGetMaterialString(am, AI_MATKEY_NAME, &s) == aiReturn_SUCCESS)
        copy_str(m->name, sizeof m->name, s.data);
    else snprintf(m->name, sizeof m->name, "material%u", mi);
    bool gltf = is_gltf(im->format);
    struct aiColor4D c;
    if ((gltf && aiGetMaterialColor(am, AI_MATKEY_BASE_COLOR, &c) == aiReturn_SUCCESS) ||
        aiGetMaterialColor(am, AI_MATKEY_COLOR_DIFFUSE, &c) == aiReturn_SUCCESS) {
        m->base_color[0] = c.r;
        m->base_color[1] = c.g;
        m->base_color[2] = c.b;
        m->base_color[3] = gltf ? c.a : 1.0f;
    }
    ai_real opacity = 1;
    unsigned int one = 1;
    if (!gltf &&
        aiGetMaterialFloatArray(am, AI_MATKEY_OPACITY, &opacity, &one) == aiReturn_SUCCESS &&
        isfinite(opacity) && opacity >= 0 && opacity <= 1)
        m->base_color[3] = opacity;
    for (int k = 0; k < 4; k++)
        if (!isfinite(m->base_color[k])) m->base_color[k] = 1.0f;

    enum aiTextureType tt = aiGetMaterialTextureCount(am, aiTextureType_BASE_COLOR) > 0
                                ? aiTextureType_BASE_COLOR
                                : aiTextureType_DIFFUSE;
    if (aiGetMaterialTextureCount(am, tt) > 0 &&
        aiGetMaterialTexture(am, tt, 0, &s, NULL, NULL, NULL, NULL, NULL, NULL) ==
            aiReturn_SUCCESS &&
        s.length > 0) {
        copy_str(m->texture_uri, sizeof m->texture_uri, s.data);
        sv_status st = load_texture(im, scene, s.data, m->name, &m->base_texture);
        if (st != SV_OK) return st;
        /* OBJ/MTL: the diffuse colour Kd multiplies map_Kd (as Blender, three.js's
         * MTLLoader and ../shared/tools/sveval draw it), like glTF's factor. */
    }

    int two = 0;
    unsigned int n1 = 1;
    bool has_two = aiGetMaterialIntegerArray(am, AI_MATKEY_TWOSIDED, &two, &n1) == aiReturn_SUCCESS;
    m->double_sided = has_two && two != 0;

    if (gltf) {
        if (aiGetMaterialString(am, AI_MATKEY_GLTF_ALPHAMODE, &s) == aiReturn_SUCCESS) {
            if (strcmp(s.data, "MASK") == 0) m->alpha_mode = SV_ALPHA_MASK;
            else if (strcmp(s.data, "BLEND") == 0) m->alpha_mode = SV_ALPHA_BLEND;
        }
        ai_real cut = 0.5f;
        one = 1;
        if (aiGetMaterialFloatArray(am, AI_MATKEY_GLTF_ALPHACUTOFF, &cut, &one) ==
                aiReturn_SUCCESS &&
            isfinite(cut) && cut >= 0 && cut <= 1)
            m->alpha_cutoff = cut;
    } else {
        bool opacity_map = aiGetMaterialTextureCount(am, aiTextureType_OPACITY) > 0;
        bool tex_alpha = m->base_texture >= 0 && texture_has_alpha(&im->images[m->base_texture]);
        if (opacity_map || tex_alpha) m->alpha_mode = SV_ALPHA_MASK;
        else if (m->base_color[3] < 1.0f) m->alpha_mode = SV_ALPHA_BLEND;
        if (m->alpha_mode != SV_ALPHA_OPAQUE) m->double_sided = true;
    }
    return SV_OK;
}

/* Area-weighted vertex normals for triangles [t0,t1) over vertices [v0,v1). */
static sv_status normals_for_range(sv_mesh *mesh, uint32_t t0, uint32_t t1, uint32_t v0,
                                   uint32_t v1, sv_error *err)
{
    double *acc = sv_calloc((size_t)(v1 - v0), 3 * sizeof(double));
    if (!acc) return sv_fail(err, SV_ERR_NOMEM, "cannot allocate normals for %u vertices", v1 - v0);
    for (uint32_t t = t0; t < t1; t++) {
        const uint32_t *ix = &mesh->indices[3 * (size_t)t];
        double n[3];
        sv_tri_cross(mesh, t, n); /* length = 2 × area: area weighting for free */
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) acc[3 * (size_t)(ix[j] - v0) + k] += n[k];
    }
    for (uint32_t v = v0; v < v1; v++) {
        double *a = &acc[3 * (size_t)(v - v0)];
        double l = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        for (int k = 0; k < 3; k++)
            mesh->normals[3 * (size_t)v + k] = (l > 0 && isfinite(l)) ? (float)(a[k] / l)
                                                                      : (k == 1);
    }
    free(acc);
    return SV_OK;
}

/* ---- far from the origin: positions in double before they are floats ----
 *
 * assimp 5.2.5 keeps positions as float (ai_real): an OBJ vertex written at
 * 10^7 units is read to the nearest unit. So an OBJ's "v" lines are read here
 * in double first; when the box of its vertices is away from the origin (by
 * at least half a grid step, origin_grid), assimp is served a copy whose "v" lines
 * have `shift` (the grid point nearest the box's centre) taken off, written
 * with the decimals the file gave (or %.17g), and the shift is added back in
 * double in merge_scene. Other formats reach sylva as assimp's floats. */

/* The power of ten at least twice the longest side `extent` and at least 1
 * (file units): the spacing of the grid an offset is snapped to, so a tree
 * modelled near the origin keeps an offset of exactly zero and its
 * coordinates as they are. Decimal, so a tree moved by a round number (a
 * scene tile's corner) lands on the grid and bakes as it did unmoved; an
 * integer, so offsets and their differences are exact in double. */
static double origin_grid(double extent)
{
    double q = 1;
    while (q < 2 * extent && q < 1e300) q *= 10;
    return q;
}

/* The start of the next line after p (or end). */
static const char *line_end(const char *p, const char *end)
{
    const char *nl = memchr(p, '\n', (size_t)(end - p));
    return nl ? nl + 1 : end;
}

/* Parses the number token at *p (after blanks) within [*p, end) into *v,
 * and its decimals (digits after '.', -1 when the token has an exponent or
 * is not plain decimal). Advances *p past it. False when there is none. */
static bool obj_number(const char **p, const char *end, double *v, int *decimals)
{
    const char *c = *p;
    while (c < end && (*c == ' ' || *c == '\t')) c++;
    const char *t = c;
    while (c < end && !isspace((unsigned char)*c)) c++;
    size_t n = (size_t)(c - t);
    char buf[72];
    if (n == 0 || n >= sizeof buf) return false;
    memcpy(buf, t, n);
    buf[n] = 0;
    char *stop;
    *v = strtod(buf, &stop);
    if (*stop || !isfinite(*v)) return false;
    int dec = -1;
    bool plain = true;
    for (size_t i = 0; i < n && plain; i++) {
        char ch = buf[i];
        if (ch == '.') dec = 0;
        else if (isdigit((unsigned char)ch)) dec += dec >= 0;
        else if (!((ch == '-' || ch == '+') && i == 0)) plain = false;
    }
    *decimals = plain ? (dec < 0 ? 0 : dec) : -1;
    *p = c;
    return true;
}

/* Whether the line at p is an OBJ vertex position ("v" then a blank). */
static bool obj_v_line(const char *p, const char *end)
{
    return end - p >= 2 && p[0] == 'v' && (p[1] == ' ' || p[1] == '\t');
}

/* Computes an OBJ's shift (see above) and, when it is not zero, the copy of
 * the file assimp reads (*out, malloc'ed, *out_size); else *out = NULL and
 * shift is zero. Any "v" line that does not hold three finite numbers leaves
 * the file as it is. */
static sv_status obj_shift(const uint8_t *data, size_t size, double shift[3], uint8_t **out,
                           size_t *out_size, sv_error *err)
{
    shift[0] = shift[1] = shift[2] = 0;
    *out = NULL;
    *out_size = 0;
    const char *b = (const char *)data, *end = b + size;
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t lines = 0;
    for (const char *p = b; p < end; p = line_end(p, end)) {
        if (!obj_v_line(p, end)) continue;
        const char *c = p + 1, *le = line_end(p, end);
        for (int k = 0; k < 3; k++) {
            double v;
            int dec;
            if (!obj_number(&c, le, &v, &dec)) return SV_OK;
            mn[k] = fmin(mn[k], v);
            mx[k] = fmax(mx[k], v);
        }
        lines++;
    }
    if (!lines) return SV_OK;
    double q = origin_grid(fmax(mx[0] - mn[0], fmax(mx[1] - mn[1], mx[2] - mn[2])));
    bool any = false;
    for (int k = 0; k < 3; k++) {
        shift[k] = round(0.5 * (mn[k] + mx[k]) / q) * q;
        any = any || shift[k] != 0;
    }
    if (!any) return SV_OK;
    size_t cap = size + 3 * 40 * lines + 1;
    char *o = malloc(cap), *w = o;
    if (!o) {
        shift[0] = shift[1] = shift[2] = 0;
        return sv_fail(err, SV_ERR_NOMEM, "out of memory for a copy of the OBJ");
    }
    for (const char *p = b; p < end;) {
        const char *le = line_end(p, end);
        if (obj_v_line(p, end)) {
            const char *c = p + 1;
            *w++ = 'v';
            for (int k = 0; k < 3; k++) {
                double v;
                int dec;
                obj_number(&c, le, &v, &dec);
                double l = v - shift[k];
                int n = dec >= 0 && dec <= 17 ? snprintf(w, 40, " %.*f", dec, l) : 40;
                if (n >= 40) n = snprintf(w, 40, " %.17g", l); /* at most 25 bytes */
                w += n;
            }
            memcpy(w, c, (size_t)(le - c)); /* the rest: colours, the line's end */
            w += le - c;
        } else {
            memcpy(w, p, (size_t)(le - p));
            w += le - p;
        }
        p = le;
    }
    *out = (uint8_t *)o;
    *out_size = (size_t)(w - o);
    return SV_OK;
}

/* glTF far from the origin: a tree placed by a large root-node translation
 * is flattened by assimp in float (aiProcess_PreTransformVertices). When a
 * root node of a scene (translation, or a matrix's last column) is at least
 * SV_GLTF_SHIFT_MIN file units from the origin, assimp is served a copy whose
 * root nodes have `shift` (that translation rounded to whole units, the same
 * for every root) taken off, and the shift is added back in double in
 * merge_scene, as for an OBJ. *out is NULL (shift zero) otherwise, and when
 * the JSON has no scenes or cannot be read (assimp reports that). */
#define SV_GLTF_SHIFT_MIN 1e4

/* The translation of glTF node n (its "translation", or a 16-number
 * "matrix"'s 13th..15th), into t; false when it has neither. */
static bool gltf_node_translation(const cJSON *n, double t[3], cJSON **items)
{
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(n, "translation");
    const cJSON *mt = cJSON_GetObjectItemCaseSensitive(n, "matrix");
    int base = 0;
    const cJSON *arr = NULL;
    if (cJSON_IsArray(tr) && cJSON_GetArraySize(tr) == 3) arr = tr;
    else if (cJSON_IsArray(mt) && cJSON_GetArraySize(mt) == 16) arr = mt, base = 12;
    if (!arr) return false;
    for (int k = 0; k < 3; k++) {
        cJSON *x = cJSON_GetArrayItem(arr, base + k);
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble)) return false;
        t[k] = x->valuedouble;
        if (items) items[k] = x;
    }
    return true;
}

static sv_status gltf_shift(const sv_file *f, bool is_glb, double shift[3], uint8_t **out,
                            size_t *out_size, sv_error *err)
{
    shift[0] = shift[1] = shift[2] = 0;
    *out = NULL;
    *out_size = 0;
    const uint8_t *js = f->data;
    size_t jlen = f->size;
    if (is_glb) { /* sv_gltf_precheck has checked the header and the chunk */
        if (f->size < 20) return SV_OK;
        jlen = (size_t)f->data[12] | (size_t)f->data[13] << 8 | (size_t)f->data[14] << 16 |
               (size_t)f->data[15] << 24;
        if (jlen > f->size - 20) return SV_OK;
        js = f->data + 20;
    }
    cJSON *root = cJSON_ParseWithLength((const char *)js, jlen);
    const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(root, "scenes");
    cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes");
    int count = cJSON_GetArraySize(nodes);
    uint8_t *is_root = count > 0 ? calloc((size_t)count, 1) : NULL;
    bool far = false;
    const cJSON *sc;
    cJSON_ArrayForEach(sc, scenes)
    {
        const cJSON *r;
        cJSON_ArrayForEach(r, cJSON_GetObjectItemCaseSensitive(sc, "nodes"))
        {
            int i = cJSON_IsNumber(r) ? r->valueint : -1;
            double t[3];
            if (!is_root || i < 0 || i >= count || is_root[i]) continue;
            is_root[i] = 1;
            if (!gltf_node_translation(cJSON_GetArrayItem(nodes, i), t, NULL)) continue;
            if (!far && fmax(fabs(t[0]), fmax(fabs(t[1]), fabs(t[2]))) >= SV_GLTF_SHIFT_MIN) {
                far = true;
                for (int k = 0; k < 3; k++) shift[k] = round(t[k]);
            }
        }
    }
    sv_status st = SV_OK;
    for (int i = 0; far && i < count; i++) {
        if (!is_root[i]) continue;
        cJSON *n = cJSON_GetArrayItem(nodes, i), *items[3];
        double t[3];
        if (gltf_node_translation(n, t, items)) {
            for (int k = 0; k < 3; k++) cJSON_SetNumberValue(items[k], t[k] - shift[k]);
        } else {
            double minus[3] = {-shift[0], -shift[1], -shift[2]};
            cJSON *tr = cJSON_CreateDoubleArray(minus, 3);
            if (!tr || !cJSON_AddItemToObject(n, "translation", tr)) {
                cJSON_Delete(tr);
                far = false;
                st = sv_fail(err, SV_ERR_NOMEM, "out of memory for a copy of the glTF");
            }
        }
    }
    char *text = far ? cJSON_PrintUnformatted(root) : NULL;
    if (far && !text) st = sv_fail(err, SV_ERR_NOMEM, "out of memory for a copy of the glTF");
    if (text) {
        size_t tl = strlen(text), pad = is_glb ? (4 - tl % 4) % 4 : 0;
        size_t rest = is_glb ? f->size - 20 - jlen : 0, total = (is_glb ? 20 : 0) + tl + pad + rest;
        uint8_t *o = total <= UINT32_MAX ? malloc(total) : NULL;
        if (!o) {
            st = sv_fail(err, SV_ERR_NOMEM, "out of memory for a copy of the glTF");
        } else if (is_glb) {
            memcpy(o, f->data, 12);
            for (int b = 0; b < 4; b++) {
                o[8 + b] = (uint8_t)(total >> (8 * b));
                o[12 + b] = (uint8_t)((tl + pad) >> (8 * b));
            }
            memcpy(o + 16, f->data + 16, 4); /* the chunk type: JSON */
            memcpy(o + 20, text, tl);
            memset(o + 20 + tl, ' ', pad);
            memcpy(o + 20 + tl + pad, f->data + 20 + jlen, rest);
        } else {
            memcpy(o, text, tl);
        }
        *out = o;
        *out_size = o ? total : 0;
    }
    if (st != SV_OK || !*out) shift[0] = shift[1] = shift[2] = 0;
    cJSON_free(text);
    free(is_root);
    cJSON_Delete(root);
    return st;
}

/* Position v of am in sylva's axes and the file's units, in double:
 * assimp's value plus shift (see obj_shift), Z-up turned Y-up (exact). */
static void source_position(const struct aiMesh *am, unsigned v, const double shift[3], char up,
                            double o[3])
{
    const struct aiVector3D *p = &am->mVertices[v];
    double x = p->x, y = p->y, z = p->z;
    if (shift[0] != 0 || shift[1] != 0 || shift[2] != 0) /* else keep a -0 as it was */
        x += shift[0], y += shift[1], z += shift[2];
    o[0] = x;
    o[1] = up == 'Z' ? z : y;
    o[2] = up == 'Z' ? -y : z;
}

/* The local frame's origin (docs/outputs.md, "origin"), in sylva's axes and
 * the file's units: the point of a grid (spacing origin_grid of the longest
 * side) nearest the centre of the bounding box at its lowest Y, computed in
 * double over every triangle mesh's vertices. Zero for an empty scene and
 * for a tree modelled near the origin. Kept in the file's units so that a
 * position's local value, (position - origin) x scale, is what the same tree
 * at the origin would give, bit for bit. */
static void local_origin(const struct aiScene *scene, const double shift[3], char up,
                         double origin[3])
{
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *am = scene->mMeshes[i];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        for (unsigned v = 0; v < am->mNumVertices; v++) {
            double p[3];
            source_position(am, v, shift, up, p);
            for (int k = 0; k < 3; k++)
                if (isfinite(p[k])) {
                    mn[k] = fmin(mn[k], p[k]);
                    mx[k] = fmax(mx[k], p[k]);
                }
        }
    }
    origin[0] = origin[1] = origin[2] = 0;
    if (!(mn[0] <= mx[0] && mn[1] <= mx[1] && mn[2] <= mx[2])) return;
    double q = origin_grid(fmax(mx[0] - mn[0], fmax(mx[1] - mn[1], mx[2] - mn[2])));
    double at[3] = {0.5 * (mn[0] + mx[0]), mn[1], 0.5 * (mn[2] + mx[2])};
    for (int k = 0; k < 3; k++) origin[k] = round(at[k] / q) * q + 0.0; /* no -0 */
}

/* Whether am is a glTF primitive without normals, which glTF draws with flat
 * normals ("client implementations MUST calculate flat normals"): merge_scene
 * then gives each of its triangles corners of its own, so the normals
 * computed for them are the face's. (Other formats without normals: assimp's
 * OBJ reader already gives each face its own corners; elsewhere the shared
 * corners get area-weighted normals.) */
static bool drawn_flat(const importer *im, const struct aiMesh *am)
{
    return is_gltf(im->format) && !am->mNormals;
}

/* Merges every triangle mesh of the scene into one sv_mesh, its positions
 * relative to the local origin (local_origin, into im->info->origin). */
static sv_status merge_scene(importer *im, const struct aiScene *scene, double scale, char up,
                             const double shift[3], sv_mesh **out)
{
    uint64_t nv = 0, nt = 0;
    uint32_t used = 0;
    bool any_normals = false;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *am = scene->mMeshes[i];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        uint64_t tris = 0;
        for (unsigned f = 0; f < am->mNumFaces; f++) tris += am->mFaces[f].mNumIndices == 3;
        nt += tris;
        nv += drawn_flat(im, am) ? 3 * tris : am->mNumVertices;
        used++;
        if (am->mNormals) any_normals = true;
    }
    im->info->source_meshes = used;
    im->info->no_normals = used && !any_normals;
    if (nt > im->lim.max_triangles)
        return sv_fail(im->err, SV_ERR_LIMIT, "mesh has %llu triangles (limit %llu)",
                       (unsigned long long)nt, (unsigned long long)im->lim.max_triangles);
    if (nv > im->lim.max_vertices || nv >= UINT32_MAX)
        return sv_fail(im->err, SV_ERR_LIMIT, "mesh has %llu vertices (limit %llu)",
                       (unsigned long long)nv, (unsigned long long)im->lim.max_vertices);
    if (nt == 0) return sv_fail(im->err, SV_ERR_INVALID, "the file contains no triangles");
    uint32_t nmat = scene->mNumMaterials ? scene->mNumMaterials : 1;
    if (nmat > im->lim.max_materials)
        return sv_fail(im->err, SV_ERR_LIMIT, "the file has %u materials (limit %u)", nmat,
                       im->lim.max_materials);

    im->images = sv_calloc(nmat, sizeof *im->images);
    im->slots = sv_calloc(nmat, sizeof *im->slots);
    sv_material *mats = sv_calloc(nmat, sizeof *mats);
    sv_status st = SV_OK;
    sv_mesh *mesh = NULL;
    unsigned *corner = NULL; /* see below */
    if (!im->images || !im->slots || !mats) {
        st = sv_fail(im->err, SV_ERR_NOMEM, "out of memory for %u materials", nmat);
        goto out;
    }
    for (uint32_t i = 0; i < nmat; i++) {
        if (i < scene->mNumMaterials)
            st = convert_material(im, scene, scene->mMaterials[i], i, &mats[i]);
        else sv_material_init(&mats[i]);
        if (st != SV_OK) goto out;
    }
    mesh = sv_mesh_create((uint32_t)nv, (uint32_t)nt, nmat, im->image_count);
    if (!mesh) {
        st = sv_fail(im->err, SV_ERR_NOMEM,
                     "cannot allocate a mesh of %llu vertices, %llu triangles",
                     (unsigned long long)nv, (unsigned long long)nt);
        goto out;
    }
    memcpy(mesh->materials, mats, nmat * sizeof *mats);
    for (uint32_t i = 0; i < im->image_count; i++) {
        mesh->images[i] = im->images[i];
        memset(&im->images[i], 0, sizeof im->images[i]);
    }
    double origin[3], to_local[3];
    local_origin(scene, shift, up, origin);
    for (int k = 0; k < 3; k++) im->info->origin[k] = origin[k] * scale;
    /* assimp's value plus (shift - origin), that difference taken first and in
     * the file's axes: both are grid points, so it is exact, and a vertex of a
     * tree moved by a grid step reads as the unmoved one's, bit for bit */
    to_local[0] = shift[0] - origin[0];
    to_local[1] = up == 'Z' ? shift[1] + origin[2] : shift[1] - origin[1];
    to_local[2] = up == 'Z' ? shift[2] - origin[1] : shift[2] - origin[2];
    uint32_t v0 = 0, t0 = 0;
    bool bad_uv = false;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *am = scene->mMeshes[i];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        uint32_t mat = am->mMaterialIndex < nmat ? am->mMaterialIndex : 0;
        /* corner[j]: the source vertex of output vertex j (drawn_flat: one
         * per triangle corner) */
        unsigned count = am->mNumVertices;
        free(corner);
        corner = NULL;
        if (drawn_flat(im, am)) {
            count = 0;
            corner = malloc(3 * (size_t)am->mNumFaces * sizeof *corner + 1);
            if (!corner) {
                st = sv_fail(im->err, SV_ERR_NOMEM, "out of memory");
                goto out;
            }
            for (unsigned f = 0; f < am->mNumFaces; f++) {
                const struct aiFace *face = &am->mFaces[f];
                if (face->mNumIndices != 3) continue;
                for (int k = 0; k < 3; k++) {
                    if (face->mIndices[k] >= am->mNumVertices) {
                        st = sv_fail(im->err, SV_ERR_INVALID,
                                     "triangle %u refers to vertex %u of %u", t0 + count / 3,
                                     v0 + face->mIndices[k], v0 + am->mNumVertices);
                        goto out;
                    }
                    corner[count++] = face->mIndices[k];
                }
            }
        }
        for (unsigned j = 0; j < count; j++) {
            unsigned v = corner ? corner[j] : j;
            double w[3];
            source_position(am, v, to_local, up, w);
            float *o = &mesh->positions[3 * ((size_t)v0 + j)];
            for (int k = 0; k < 3; k++) o[k] = (float)(w[k] * scale);
            for (int k = 0; k < 3; k++)
                if (!isfinite(o[k])) {
                    st = sv_fail(im->err, SV_ERR_INVALID, "vertex %u has %s coordinate", v0 + v,
                                 isnan(o[k]) ? "a NaN" : "an infinite");
                    goto out;
                }
            if (am->mNormals) {
                const struct aiVector3D *n = &am->mNormals[v];
                float *q = &mesh->normals[3 * ((size_t)v0 + j)];
                q[0] = n->x;
                q[1] = up == 'Z' ? n->z : n->y;
                q[2] = up == 'Z' ? -n->y : n->z;
            }
            if (am->mTextureCoords[0]) {
                float u = am->mTextureCoords[0][v].x, w = am->mTextureCoords[0][v].y;
                if (!isfinite(u) || !isfinite(w)) {
                    u = w = 0;
                    bad_uv = true;
                }
                mesh->uvs[2 * ((size_t)v0 + j)] = u;
                mesh->uvs[2 * ((size_t)v0 + j) + 1] = w;
            }
        }
        uint32_t tstart = t0;
        for (unsigned f = 0; f < am->mNumFaces; f++) {
            const struct aiFace *face = &am->mFaces[f];
            if (face->mNumIndices != 3) continue;
            for (int k = 0; k < 3; k++) {
                if (face->mIndices[k] >= am->mNumVertices) {
                    st = sv_fail(im->err, SV_ERR_INVALID, "triangle %u refers to vertex %u of %u",
                                 t0, v0 + face->mIndices[k], v0 + am->mNumVertices);
                    goto out;
                }
                mesh->indices[3 * (size_t)t0 + k] =
                    v0 + (corner ? 3 * (t0 - tstart) + (uint32_t)k : face->mIndices[k]);
            }
            mesh->tri_material[t0] = mat;
            t0++;
        }
        if (!am->mNormals) {
            st = normals_for_range(mesh, tstart, t0, v0, v0 + count, im->err);
            if (st != SV_OK) goto out;
        }
        v0 += count;
    }
    if (bad_uv) add_warning(im->info, "non-finite texture coordinates were set to (0,0)");
out:
    if (im->images)
        for (uint32_t i = 0; i < im->image_count; i++) sv_image_free(&im->images[i]);
    free(corner);
    free(im->images);
    free(im->slots);
    free(mats);
    im->images = NULL;
    im->slots = NULL;
    if (st != SV_OK) {
        sv_mesh_destroy(mesh);
        mesh = NULL;
    }
    *out = mesh;
    return st;
}

/* The name assimp is told files[0] has: its stem (when that is a plain, safe
 * name, so assimp's "<stem>.mtl" fallback finds the MTL) with the extension of
 * the sniffed format. */
static void main_file_name(const sv_file *f, sv_format fmt, char *out, size_t cap)
{
    const char *ext = sv_format_name(fmt);
    char stem[128] = "upload";
    const char *n = f->name;
    if (n && n[0] && n[0] != '.') {
        size_t len = 0;
        bool ok = true;
        for (; n[len] && n[len] != '.'; len++)
            if (!(isalnum((unsigned char)n[len]) || n[len] == '_' || n[len] == '-')) ok = false;
        if (ok && len > 0 && len < sizeof stem) {
            memcpy(stem, n, len);
            stem[len] = 0;
        }
    }
    snprintf(out, cap, "%s.%s", stem, ext);
}

sv_status sv_import(const sv_file *files, size_t count, const sv_import_options *opt, sv_mesh **out,
                    sv_import_info *info, sv_error *err)
{
    sv_import_info local_info;
    if (!info) info = &local_info;
    memset(info, 0, sizeof *info);
    if (!out) return sv_fail(err, SV_ERR_INTERNAL, "sv_import: out is NULL");
    *out = NULL;
    if (!files || count == 0) return sv_fail(err, SV_ERR_INTERNAL, "sv_import: no files");
    sv_import_options o = {0};
    if (opt) o = *opt;
    sv_limits lim = sv_limits_resolve(o.limits);
    const char *main = files[0].name ? files[0].name : "(unnamed)";
    char shown[160];
    copy_str(shown, sizeof shown, main);

    for (size_t i = 0; i < count; i++) {
        if (files[i].size && !files[i].data)
            return sv_fail(err, SV_ERR_INTERNAL, "sv_import: file %zu has no data", i);
        if (files[i].size > lim.max_file_bytes)
            return sv_fail(err, SV_ERR_LIMIT, "file '%.150s' is %zu bytes (limit %llu)",
                           files[i].name ? files[i].name : "?", files[i].size,
                           (unsigned long long)lim.max_file_bytes);
    }
    if (files[0].size == 0) return sv_fail(err, SV_ERR_PARSE, "'%s' is empty", shown);
    sv_format fmt = sv_sniff_format(files[0].data, files[0].size);
    info->format = fmt;
    if (fmt == SV_FORMAT_UNKNOWN)
        return sv_fail(err, SV_ERR_FORMAT,
                       "'%s' is not a mesh format sylva accepts (glTF/GLB, OBJ, PLY, FBX, COLLADA)",
                       shown);

    double scale = 1.0;
    char up = 'Y';
    if (o.unit_scale < 0 || !isfinite(o.unit_scale))
        return sv_fail(err, SV_ERR_SPEC, "unit scale %g is not a positive number", o.unit_scale);
    if (o.unit_scale > 0) scale = o.unit_scale;
    char u = (char)toupper((unsigned char)o.up_axis);
    if (u == 'Z') up = 'Z';
    else if (u != 0 && u != 'Y')
        return sv_fail(err, SV_ERR_SPEC, "up axis '%c' is not supported (Y or Z)", o.up_axis);
    info->unit_scale = scale;
    info->up_axis = up;

    /* Refuse what is over the limits before assimp allocates for it. */
    if (is_gltf(fmt)) {
        sv_status st = sv_gltf_precheck(files[0].data, files[0].size, fmt == SV_FORMAT_GLB, files,
                                        count, &lim, err);
        if (st != SV_OK) { /* name the file, as sv_mesh_precheck does */
            char msg[sizeof err->message];
            copy_str(msg, sizeof msg, err ? err->message : "");
            return sv_fail(err, st, "'%s': %s", shown, msg);
        }
    } else {
        sv_status st = sv_mesh_precheck(fmt, files[0].data, files[0].size, shown, &lim, err);
        if (st != SV_OK) return st;
    }

    double shift[3] = {0, 0, 0};
    uint8_t *shifted = NULL;
    size_t shifted_size = 0;
    if (fmt == SV_FORMAT_OBJ || is_gltf(fmt)) {
        sv_status st = fmt == SV_FORMAT_OBJ ? obj_shift(files[0].data, files[0].size, shift,
                                                        &shifted, &shifted_size, err)
                                            : gltf_shift(&files[0], fmt == SV_FORMAT_GLB, shift,
                                                         &shifted, &shifted_size, err);
        if (st != SV_OK) return st;
    }
    char name[160];
    main_file_name(&files[0], fmt, name, sizeof name);
    io_ctx ctx = {.files = files,
                  .count = count,
                  .main_name = name,
                  .main_data = shifted,
                  .main_size = shifted_size};
    copy_str(ctx.fallback_mtl, sizeof ctx.fallback_mtl, name);
    char *dot = strrchr(ctx.fallback_mtl, '.');
    if (dot && (size_t)(dot - ctx.fallback_mtl) + 5 <= sizeof ctx.fallback_mtl) strcpy(dot, ".mtl");
    struct aiFileIO io = {.OpenProc = io_open, .CloseProc = io_close, .UserData = (aiUserData)&ctx};
    struct aiPropertyStore *props = aiCreatePropertyStore();
    if (!props) {
        free(shifted);
        return sv_fail(err, SV_ERR_NOMEM, "assimp: cannot create a property store");
    }
    aiSetImportPropertyInteger(props, AI_CONFIG_PP_SBP_REMOVE,
                               aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    /* Normals are computed by sylva when missing (cheaper than assimp's spatial
     * sort); degenerate/duplicate faces are sv_validate's job. */
    unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices |
                     aiProcess_SortByPType | aiProcess_ValidateDataStructure | aiProcess_FlipUVs;
    const struct aiScene *scene = aiImportFileExWithProperties(name, flags, &io, props);
    aiReleasePropertyStore(props);
    free(shifted); /* assimp has read it */

    sv_status st = SV_OK;
    if (ctx.refused != SV_OK) {
        st = sv_fail(err, SV_ERR_REFUSED, "'%s' references a file outside the upload: %s", shown,
                     ctx.refused_msg);
    } else if (!scene) {
        char msg[300];
        copy_str(msg, sizeof msg, aiGetErrorString());
        for (char *c = msg; *c; c++)
            if (*c == '\n' || *c == '\r') *c = ' ';
        st = sv_fail(err, SV_ERR_PARSE, "cannot read '%s' as %s: %s", shown, sv_format_name(fmt),
                     msg[0] ? msg : "assimp gave no reason");
    } else if (!strstr(source_reader(scene), expected_reader(fmt))) {
        char reader[120];
        copy_str(reader, sizeof reader, source_reader(scene));
        st = sv_fail(err, SV_ERR_FORMAT, "'%s' sniffs as %s but assimp read it with '%s'", shown,
                     sv_format_name(fmt), reader[0] ? reader : "an unnamed reader");
    } else {
        for (unsigned i = 0; i < ctx.missing_count && i < IO_MISSING_MAX; i++) {
            if (ends_with_mtl(ctx.missing[i]) && ctx.fallback_used)
                add_warning(info, "'%s' was not supplied: the materials were read from '%s'",
                            ctx.missing[i], ctx.fallback_mtl);
            else
                add_missing(info, ctx.missing[i],
                            ends_with_mtl(ctx.missing[i]) ? "its materials are plain grey"
                                                          : "it was not read");
        }
        if (ctx.missing_count > IO_MISSING_MAX) /* counted, not named */
            add_missing(info, "...", "more files were asked for than are named here");
        importer im = {
            .files = files, .count = count, .lim = lim, .format = fmt, .info = info, .err = err};
        st = merge_scene(&im, scene, scale, up, shift, out);
        if (info->warnings_left_out) { /* into the reserved KiB: never lost silently */
            size_t len = strlen(info->warnings);
            snprintf(info->warnings + len, sizeof info->warnings - len,
                     "%s%u more import warnings were left out (the list is full)", len ? "\n" : "",
                     info->warnings_left_out);
        }
        if (st == SV_OK && info->files_missing && !o.missing_files_warn) {
            sv_mesh_destroy(*out);
            *out = NULL;
            char what[32] = "a file";
            if (info->files_missing > 1)
                snprintf(what, sizeof what, "%u files", info->files_missing);
            st = sv_fail(err, SV_ERR_MISSING,
                         "'%s' references %s that %s not supplied: %s. Supply %s with the mesh, "
                         "or set \"import\": {\"missing_files\": \"warn\"} to bake with "
                         "plain-coloured materials",
                         shown, what, info->files_missing > 1 ? "were" : "was", info->missing_files,
                         info->files_missing > 1 ? "them" : "it");
        }
    }
    if (scene) aiReleaseImport(scene);
    return st;
}
