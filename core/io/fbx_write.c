/* fbx_write.c — the LOD group as FBX through assimp's exporter (see fbx.h).
 *
 * The second file that knows assimp (the importer is the first): an aiScene
 * is built here in plain C (assimp's structs are C-compatible), exported to
 * memory with aiExportSceneToBlob (assimp copies the scene before it works
 * on it, so ours stays ours and is freed here), then patched (the creation
 * time stamp) and written with sv_write_file. The FBX layout (nodes, Model
 * names, units) follows the binary FBX 7.5 that assimp writes.
 */
#include "fbx.h"

#include <assimp/cexport.h>
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* positions are metres; FBX units are centimetres (assimp writes
 * UnitScaleFactor 1) */
#define CM_PER_M 100.0

typedef struct fbx_tex {
    const sv_image *img;
    uint64_t hash;
    char file[64];
} fbx_tex;

typedef struct fbx_writer {
    struct aiScene *scene;
    uint32_t mesh_cap, mat_cap;
    fbx_tex *tex;
    uint32_t tex_count, tex_cap;
    const char *dir;
    const sv_fbx_file *known;
    uint32_t known_count;
    sv_error *err;
} fbx_writer;

static sv_status nomem(fbx_writer *w)
{
    return sv_fail(w->err, SV_ERR_NOMEM, "FBX writer: out of memory");
}

static void set_str(struct aiString *s, const char *text)
{
    size_t n = strlen(text);
    if (n >= sizeof s->data) n = sizeof s->data - 1;
    memcpy(s->data, text, n);
    s->data[n] = 0;
    s->length = (ai_uint32)n;
}

static void identity(struct aiMatrix4x4 *m)
{
    memset(m, 0, sizeof *m);
    m->a1 = m->b2 = m->c3 = m->d4 = 1;
}

/* The file name of img's texture beside the FBX, written on first use. */
static sv_status texture_file(fbx_writer *w, const sv_image *img, const char **name)
{
    if (!img->data || !img->width || !img->height)
        return sv_fail(w->err, SV_ERR_INVALID, "FBX writer: a material refers to an empty image");
    for (uint32_t k = 0; k < w->known_count; k++) {
        const sv_image *o = w->known[k].img;
        if (o && o->data == img->data && o->width == img->width && o->height == img->height &&
            o->channels == img->channels && o->bits == img->bits) {
            *name = w->known[k].file;
            return SV_OK;
        }
    }
    uint64_t h = sv_image_pixel_hash(img);
    for (uint32_t i = 0; i < w->tex_count; i++)
        if (w->tex[i].hash == h) {
            *name = w->tex[i].file;
            return SV_OK;
        }
    if (w->tex_count == w->tex_cap) {
        uint32_t cap = w->tex_cap ? 2 * w->tex_cap : 8;
        fbx_tex *t = realloc(w->tex, cap * sizeof *t);
        if (!t) return nomem(w);
        w->tex = t;
        w->tex_cap = cap;
    }
    fbx_tex *t = &w->tex[w->tex_count];
    t->img = img;
    t->hash = h;
    const uint8_t *src;
    size_t size;
    const char *mime;
    uint8_t *png = NULL;
    bool own = sv_image_source(img, &src, &size, &mime);
    if (!own) {
        sv_status st = sv_image_encode_png(img, &png, &size, w->err);
        if (st != SV_OK) return st;
        src = png;
        mime = "image/png";
    }
    snprintf(t->file, sizeof t->file, "tex_%016llx.%s", (unsigned long long)h,
             strcmp(mime, "image/jpeg") == 0 ? "jpg" : "png");
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", w->dir, t->file);
    sv_status st = sv_write_file(path, src, size, w->err);
    free(png);
    if (st != SV_OK) return st;
    w->tex_count++;
    *name = t->file;
    return SV_OK;
}

/* Appends one property to m (assimp's aiMaterial layout: key, semantic,
 * index, type, raw bytes). */
static bool add_prop(struct aiMaterial *m, const char *key, unsigned semantic,
                     enum aiPropertyTypeInfo type, const void *data, size_t len)
{
    if (m->mNumProperties == m->mNumAllocated) {
        unsigned cap = m->mNumAllocated ? 2 * m->mNumAllocated : 8;
        struct aiMaterialProperty **p = realloc(m->mProperties, cap * sizeof *p);
        if (!p) return false;
        m->mProperties = p;
        m->mNumAllocated = cap;
    }
    struct aiMaterialProperty *p = calloc(1, sizeof *p);
    if (!p || !(p->mData = malloc(len))) {
        free(p);
        return false;
    }
    set_str(&p->mKey, key);
    p->mSemantic = semantic;
    p->mIndex = 0;
    p->mType = type;
    p->mDataLength = (unsigned)len;
    memcpy(p->mData, data, len);
    m->mProperties[m->mNumProperties++] = p;
    return true;
}

/* A string property as assimp stores one: uint32 length, bytes, NUL. */
static bool add_string(struct aiMaterial *m, const char *key, unsigned semantic, const char *s)
{
    size_t n = strlen(s);
    if (n > 1000) n = 1000;
    uint8_t buf[1024];
    uint32_t len = (uint32_t)n;
    memcpy(buf, &len, 4);
    memcpy(buf + 4, s, n);
    buf[4 + n] = 0;
    return add_prop(m, key, semantic, aiPTI_String, buf, 4 + n + 1);
}

static void free_material(struct aiMaterial *m)
{
    if (!m) return;
    for (unsigned i = 0; i < m->mNumProperties; i++) {
        free(m->mProperties[i]->mData);
        free(m->mProperties[i]);
    }
    free(m->mProperties);
    free(m);
}

/* The material's name when no earlier FBX material has it, else with the
 * level appended. */
static void material_name(const fbx_writer *w, const sv_material *sm, uint32_t level, char *out,
                          size_t cap)
{
    snprintf(out, cap, "%s", sm->name[0] ? sm->name : "material");
    for (unsigned i = 0; i < w->scene->mNumMaterials; i++) {
        struct aiString s;
        if (aiGetMaterialString(w->scene->mMaterials[i], AI_MATKEY_NAME, &s) == aiReturn_SUCCESS &&
            strcmp(s.data, out) == 0) {
            snprintf(out, cap, "%s_%u", sm->name[0] ? sm->name : "material", level);
            return;
        }
    }
}

/* True when materials a and b carry the same properties (names aside). */
static bool same_material(const struct aiMaterial *a, const struct aiMaterial *b)
{
    if (a->mNumProperties != b->mNumProperties) return false;
    for (unsigned i = 0; i < a->mNumProperties; i++) {
        const struct aiMaterialProperty *p = a->mProperties[i], *q = b->mProperties[i];
        if (strcmp(p->mKey.data, "?mat.name") == 0) continue;
        if (strcmp(p->mKey.data, q->mKey.data) != 0 || p->mSemantic != q->mSemantic ||
            p->mDataLength != q->mDataLength || memcmp(p->mData, q->mData, p->mDataLength) != 0)
            return false;
    }
    return true;
}

/* The FBX material index for material mi of level's mesh (equal ones shared). */
static sv_status material_for(fbx_writer *w, const sv_mesh *mesh, uint32_t mi, uint32_t level,
                              unsigned *index)
{
    const sv_material *sm = &mesh->materials[mi];
    const char *tex = NULL;
    if (sm->base_texture >= 0) {
        if ((uint32_t)sm->base_texture >= mesh->image_count)
            return sv_fail(w->err, SV_ERR_INVALID,
                           "FBX writer: material '%s' refers to image %d of %u", sm->name,
                           (int)sm->base_texture, mesh->image_count);
        sv_status st = texture_file(w, &mesh->images[sm->base_texture], &tex);
        if (st != SV_OK) return st;
    }
    struct aiMaterial *m = calloc(1, sizeof *m);
    char name[160];
    material_name(w, sm, level, name, sizeof name);
    float colour[4], opacity = sm->base_color[3];
    for (int k = 0; k < 4; k++) colour[k] = sm->base_color[k];
    int two = sm->double_sided ? 1 : 0;
    bool ok = m && add_string(m, "?mat.name", 0, name) &&
              add_prop(m, "$clr.diffuse", 0, aiPTI_Float, colour, sizeof colour) &&
              add_prop(m, "$mat.opacity", 0, aiPTI_Float, &opacity, sizeof opacity) &&
              add_prop(m, "$mat.twosided", 0, aiPTI_Integer, &two, sizeof two) &&
              (!tex || add_string(m, "$tex.file", aiTextureType_DIFFUSE, tex));
    if (!ok) {
        free_material(m);
        return nomem(w);
    }
    struct aiScene *s = w->scene;
    for (unsigned i = 0; i < s->mNumMaterials; i++)
        if (same_material(s->mMaterials[i], m)) {
            free_material(m);
            *index = i;
            return SV_OK;
        }
    if (s->mNumMaterials == w->mat_cap) {
        uint32_t cap = w->mat_cap ? 2 * w->mat_cap : 8;
        struct aiMaterial **p = realloc(s->mMaterials, cap * sizeof *p);
        if (!p) {
            free_material(m);
            return nomem(w);
        }
        s->mMaterials = p;
        w->mat_cap = cap;
    }
    *index = s->mNumMaterials;
    s->mMaterials[s->mNumMaterials++] = m;
    return SV_OK;
}

static void free_mesh(struct aiMesh *m)
{
    if (!m) return;
    free(m->mVertices);
    free(m->mNormals);
    free(m->mTextureCoords[0]);
    for (unsigned f = 0; m->mFaces && f < m->mNumFaces; f++) free(m->mFaces[f].mIndices);
    free(m->mFaces);
    free(m);
}

/* One aiMesh of the triangles of material mi in level l (vertices
 * compacted), appended to the scene; its index into *index. */
static sv_status mesh_for(fbx_writer *w, const sv_gltf_lod *l, uint32_t mi, uint32_t count,
                          uint32_t level, unsigned *index)
{
    const sv_mesh *sm = l->mesh;
    struct aiMesh *m = calloc(1, sizeof *m);
    uint32_t *remap = malloc((size_t)sm->vertex_count * sizeof *remap);
    sv_status st = SV_OK;
    if (!m || !remap || !(m->mFaces = calloc(count, sizeof *m->mFaces))) {
        st = nomem(w);
        goto out;
    }
    memset(remap, 0xff, (size_t)sm->vertex_count * sizeof *remap);
    uint32_t nv = 0;
    for (uint32_t t = 0; t < sm->triangle_count; t++)
        if (sm->tri_material[t] == mi)
            for (int c = 0; c < 3; c++) {
                uint32_t v = sm->indices[3 * (size_t)t + c];
                if (remap[v] == UINT32_MAX) remap[v] = nv++;
            }
    m->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
    m->mNumVertices = nv;
    m->mVertices = calloc(nv, sizeof *m->mVertices);
    m->mNormals = sm->normals ? calloc(nv, sizeof *m->mNormals) : NULL;
    m->mTextureCoords[0] = sm->uvs ? calloc(nv, sizeof *m->mTextureCoords[0]) : NULL;
    if (!m->mVertices || (sm->normals && !m->mNormals) || (sm->uvs && !m->mTextureCoords[0])) {
        st = nomem(w);
        goto out;
    }
    m->mNumUVComponents[0] = sm->uvs ? 2 : 0;
    for (uint32_t v = 0; v < sm->vertex_count; v++) {
        uint32_t o = remap[v];
        if (o == UINT32_MAX) continue;
        m->mVertices[o].x = (ai_real)(sm->positions[3 * (size_t)v] * CM_PER_M);
        m->mVertices[o].y = (ai_real)(sm->positions[3 * (size_t)v + 1] * CM_PER_M);
        m->mVertices[o].z = (ai_real)(sm->positions[3 * (size_t)v + 2] * CM_PER_M);
        if (m->mNormals) {
            m->mNormals[o].x = sm->normals[3 * (size_t)v];
            m->mNormals[o].y = sm->normals[3 * (size_t)v + 1];
            m->mNormals[o].z = sm->normals[3 * (size_t)v + 2];
        }
        if (m->mTextureCoords[0]) { /* glTF's v runs down, FBX's up */
            m->mTextureCoords[0][o].x = sm->uvs[2 * (size_t)v];
            m->mTextureCoords[0][o].y = 1.0f - sm->uvs[2 * (size_t)v + 1];
        }
    }
    uint32_t f = 0;
    for (uint32_t t = 0; t < sm->triangle_count; t++) {
        if (sm->tri_material[t] != mi) continue;
        struct aiFace *face = &m->mFaces[f++];
        m->mNumFaces = f;
        if (!(face->mIndices = malloc(3 * sizeof *face->mIndices))) {
            st = nomem(w);
            goto out;
        }
        face->mNumIndices = 3;
        for (int c = 0; c < 3; c++) face->mIndices[c] = remap[sm->indices[3 * (size_t)t + c]];
    }
    char name[200];
    snprintf(name, sizeof name, "%s_%u", l->mesh_name && l->mesh_name[0] ? l->mesh_name : l->name,
             mi);
    set_str(&m->mName, name);
    if ((st = material_for(w, sm, mi, level, &m->mMaterialIndex)) != SV_OK) goto out;
    struct aiScene *s = w->scene;
    if (s->mNumMeshes == w->mesh_cap) {
        uint32_t cap = w->mesh_cap ? 2 * w->mesh_cap : 8;
        struct aiMesh **p = realloc(s->mMeshes, cap * sizeof *p);
        if (!p) {
            st = nomem(w);
            goto out;
        }
        s->mMeshes = p;
        w->mesh_cap = cap;
    }
    *index = s->mNumMeshes;
    s->mMeshes[s->mNumMeshes++] = m;
    m = NULL;
out:
    free(remap);
    free_mesh(m);
    return st;
}

/* The node of level l: its translation, one mesh per material used. */
static sv_status level_node(fbx_writer *w, const sv_gltf_lod *l, uint32_t level, struct aiNode *n)
{
    const sv_mesh *sm = l->mesh;
    set_str(&n->mName, l->name);
    identity(&n->mTransformation);
    n->mTransformation.a4 = (ai_real)(l->translation[0] * CM_PER_M);
    n->mTransformation.b4 = (ai_real)(l->translation[1] * CM_PER_M);
    n->mTransformation.c4 = (ai_real)(l->translation[2] * CM_PER_M);
    uint32_t *per = sv_calloc(sm->material_count ? sm->material_count : 1, sizeof *per);
    if (!per) return nomem(w);
    uint32_t used = 0;
    for (uint32_t t = 0; t < sm->triangle_count; t++)
        if (per[sm->tri_material[t]]++ == 0) used++;
    sv_status st = SV_OK;
    if (used && !(n->mMeshes = calloc(used, sizeof *n->mMeshes))) st = nomem(w);
    for (uint32_t mi = 0; st == SV_OK && mi < sm->material_count; mi++) {
        if (!per[mi]) continue;
        unsigned idx = 0;
        if ((st = mesh_for(w, l, mi, per[mi], level, &idx)) == SV_OK)
            n->mMeshes[n->mNumMeshes++] = idx;
    }
    free(per);
    return st;
}

static void free_scene(struct aiScene *s)
{
    if (!s) return;
    struct aiNode *top = s->mRootNode, *root = top ? top->mChildren[0] : NULL;
    for (unsigned i = 0; root && i < root->mNumChildren; i++) {
        free(root->mChildren[i]->mMeshes);
        free(root->mChildren[i]);
    }
    if (root) free(root->mChildren);
    free(root);
    if (top) free(top->mChildren);
    free(top);
    for (unsigned i = 0; i < s->mNumMeshes; i++) free_mesh(s->mMeshes[i]);
    free(s->mMeshes);
    for (unsigned i = 0; i < s->mNumMaterials; i++) free_material(s->mMaterials[i]);
    free(s->mMaterials);
    free(s);
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A node record's field before its name: 32 bits before FBX 7.5, 64 from
 * it (the high half must be 0 here). */
static uint64_t get_field(const uint8_t *p, bool wide)
{
    return wide ? (get_u32(p + 4) ? UINT64_MAX : get_u32(p)) : get_u32(p);
}

/* Sets the fields of the binary FBX's CreationTimeStamp node (children
 * "Year", "Month", ... each one int32 property 'I') to 1970-01-01
 * 00:00:00.000. A node record is: end offset, property count, property
 * bytes (each 4 bytes, 8 from version 7500), name length (1 byte), name,
 * properties. Returns false when the node is not there. */
static bool fix_timestamp(uint8_t *d, size_t n)
{
    if (n < 27 || memcmp(d, "Kaydara FBX Binary  ", 20) != 0) return false;
    bool wide = get_u32(d + 23) >= 7500;
    size_t fw = wide ? 8 : 4;
    static const char tag[] = "\x11"
                              "CreationTimeStamp";
    uint8_t *at = NULL;
    for (size_t i = 27 + 3 * fw; i + sizeof tag - 1 <= n; i++)
        if (memcmp(d + i, tag, sizeof tag - 1) == 0) {
            at = d + i;
            break;
        }
    if (!at) return false;
    uint64_t end = get_field(at - 3 * fw, wide);
    if (end > n || end <= (uint64_t)(at - d)) return false;
    static const struct {
        const char *name;
        int32_t value;
    } fields[] = {{"Year", 1970}, {"Month", 1},  {"Day", 1},        {"Hour", 0},
                  {"Minute", 0},  {"Second", 0}, {"Millisecond", 0}};
    for (size_t f = 0; f < sizeof fields / sizeof *fields; f++) {
        size_t len = strlen(fields[f].name);
        bool found = false;
        for (uint8_t *p = at; p + 1 + len + 5 <= d + end; p++)
            if (p[0] == len && memcmp(p + 1, fields[f].name, len) == 0 && p[1 + len] == 'I' &&
                get_field(p - 2 * fw, wide) == 1 && get_field(p - fw, wide) == 5) {
                uint32_t v = (uint32_t)fields[f].value;
                uint8_t *q = p + 2 + len;
                q[0] = (uint8_t)v;
                q[1] = (uint8_t)(v >> 8);
                q[2] = (uint8_t)(v >> 16);
                q[3] = (uint8_t)(v >> 24);
                found = true;
                break;
            }
        if (!found) return false;
    }
    return true;
}

static void put_field(uint8_t *p, uint64_t v, bool wide)
{
    for (int k = 0; k < (wide ? 8 : 4); k++) p[k] = (uint8_t)(v >> (8 * k));
}

/* Bytes being rebuilt (add_sentinels). */
typedef struct fbx_buf {
    uint8_t *d;
    size_t len, cap;
} fbx_buf;

static bool buf_put(fbx_buf *b, const void *data, size_t n)
{
    if (b->len + n > b->cap) {
        size_t cap = b->cap ? b->cap : 65536;
        while (cap < b->len + n) cap *= 2;
        uint8_t *p = realloc(b->d, cap);
        if (!p) return false;
        b->d = p;
        b->cap = cap;
    }
    if (data) memcpy(b->d + b->len, data, n);
    else memset(b->d + b->len, 0, n);
    b->len += n;
    return true;
}

/* Copies the node record at d + off (ending at or before n) into b, whose
 * first byte is at file offset 27, with a null record after its nested list
 * when it has one; *next: where the record ends in d. False when the record
 * is malformed or memory runs out. */
static bool copy_node(const uint8_t *d, size_t n, size_t off, bool wide, fbx_buf *b, int depth,
                      size_t *next)
{
    size_t fw = wide ? 8 : 4, head = 3 * fw + 1;
    if (depth > 64 || off + head > n) return false;
    uint64_t end = get_field(d + off, wide), plen = get_field(d + off + 2 * fw, wide);
    size_t nl = d[off + 3 * fw];
    if (end > n || end < off + head + nl || plen > end - off - head - nl) return false;
    size_t at = b->len;
    if (!buf_put(b, d + off, head + nl + plen)) return false;
    size_t p = off + head + nl + plen;
    bool kids = false;
    static const uint8_t zero[25];
    while (p < end) {
        if (end - p >= head && memcmp(d + p, zero, head) == 0) { /* assimp's own, if any */
            p += head;
            continue;
        }
        if (!copy_node(d, n, p, wide, b, depth + 1, &p)) return false;
        kids = true;
    }
    if (kids && !buf_put(b, NULL, head)) return false;
    put_field(b->d + at, 27 + b->len, wide);
    *next = end;
    return true;
}

/* assimp 5.2's binary FBX leaves out the null record that ends every nested
 * list (the FBX SDK writes it, and readers need it: assimp's own importer
 * and Blender's refuse the file without it). Rebuilds data (n bytes) with
 * them: every node record copied with its end offset moved, then the
 * footer, its zero padding recomputed (to a multiple of 16 after the footer
 * id, as assimp computes it). *out is malloc'ed; false when the file is not
 * the binary FBX assimp writes or memory runs out. */
static bool add_sentinels(const uint8_t *d, size_t n, uint8_t **out, size_t *out_len)
{
    if (n < 27 || memcmp(d, "Kaydara FBX Binary  ", 20) != 0) return false;
    bool wide = get_u32(d + 23) >= 7500;
    size_t fw = wide ? 8 : 4, head = 3 * fw + 1, off = 27;
    fbx_buf b = {0};
    bool ok = true;
    while (ok && off + head <= n && get_field(d + off, wide) != 0)
        ok = copy_node(d, n, off, wide, &b, 0, &off);
    /* footer: null record, 16-byte id, zeros, version, 120 zeros, 16-byte magic */
    size_t tail_fixed = 4 + 120 + 16;
    if (!ok || n - off < head + 16 + tail_fixed) {
        free(b.d);
        return false;
    }
    ok = buf_put(&b, d + off, head + 16);
    size_t pos = 27 + b.len, pad = 16 - pos % 16 + 4;
    ok = ok && buf_put(&b, NULL, pad) && buf_put(&b, d + n - tail_fixed, tail_fixed);
    uint8_t *all = ok ? malloc(27 + b.len) : NULL;
    if (!all) {
        free(b.d);
        return false;
    }
    memcpy(all, d, 27);
    memcpy(all + 27, b.d, b.len);
    *out = all;
    *out_len = 27 + b.len;
    free(b.d);
    return true;
}

sv_status sv_fbx_write(const char *dir, const char *file, const char *root_name,
                       const sv_gltf_lod *lods, uint32_t lod_count, const sv_fbx_file *known,
                       uint32_t known_count, sv_error *err)
{
    if (!dir || !file || !root_name || !root_name[0] || !lods || lod_count == 0)
        return sv_fail(err, SV_ERR_INVALID, "FBX writer: no levels, folder or root name");
    for (uint32_t i = 0; i < lod_count; i++) {
        const sv_mesh *m = lods[i].mesh;
        if (!m || !lods[i].name || !lods[i].name[0])
            return sv_fail(err, SV_ERR_INVALID, "FBX writer: level %u has no mesh or name", i);
        if (m->triangle_count && (!m->indices || !m->tri_material || !m->positions))
            return sv_fail(err, SV_ERR_INVALID, "FBX writer: level %u mesh lacks arrays", i);
        for (size_t t = 0; t < m->triangle_count; t++) {
            if (m->tri_material[t] >= m->material_count)
                return sv_fail(err, SV_ERR_INVALID,
                               "FBX writer: level %u triangle %zu uses material %u of %u", i, t,
                               m->tri_material[t], m->material_count);
            for (int c = 0; c < 3; c++)
                if (m->indices[3 * t + c] >= m->vertex_count)
                    return sv_fail(err, SV_ERR_INVALID,
                                   "FBX writer: level %u triangle %zu uses vertex %u of %u", i, t,
                                   m->indices[3 * t + c], m->vertex_count);
        }
    }
    fbx_writer w = {.dir = dir, .known = known, .known_count = known ? known_count : 0, .err = err};
    sv_status st = SV_OK;
    const struct aiExportDataBlob *blob = NULL;
    /* assimp's scene root is the FBX document's root, which holds no name:
     * the named root is its only child */
    struct aiScene *s = w.scene = calloc(1, sizeof *s);
    struct aiNode *top = s ? calloc(1, sizeof *top) : NULL;
    struct aiNode *root = top ? calloc(1, sizeof *root) : NULL;
    if (top && !(top->mChildren = calloc(1, sizeof *top->mChildren))) root = (free(root), NULL);
    if (!root || !(root->mChildren = calloc(lod_count, sizeof *root->mChildren))) {
        free(root);
        if (top) free(top->mChildren);
        free(top);
        st = nomem(&w);
        goto out;
    }
    s->mRootNode = top;
    set_str(&top->mName, "RootNode");
    identity(&top->mTransformation);
    top->mChildren[0] = root;
    top->mNumChildren = 1;
    root->mParent = top;
    s->mFlags = AI_SCENE_FLAGS_NON_VERBOSE_FORMAT; /* vertices shared by faces */
    set_str(&root->mName, root_name);
    identity(&root->mTransformation);
    for (uint32_t i = 0; i < lod_count && st == SV_OK; i++) {
        struct aiNode *n = calloc(1, sizeof *n);
        if (!n) {
            st = nomem(&w);
            break;
        }
        n->mParent = root;
        root->mChildren[root->mNumChildren++] = n;
        st = level_node(&w, &lods[i], i, n);
    }
    if (st != SV_OK) goto out;
    if (!(blob = aiExportSceneToBlob(s, "fbx", 0))) {
        st = sv_fail(err, SV_ERR_INTERNAL, "FBX writer: assimp's export failed: %s",
                     aiGetErrorString());
        goto out;
    }
    uint8_t *bytes = NULL;
    size_t size = 0;
    if (!add_sentinels(blob->data, blob->size, &bytes, &size)) {
        st = sv_fail(err, SV_ERR_INTERNAL,
                     "FBX writer: assimp's file is not the binary FBX expected (or out of memory)");
        goto out;
    }
    if (!fix_timestamp(bytes, size)) {
        free(bytes);
        st = sv_fail(err, SV_ERR_INTERNAL,
                     "FBX writer: assimp's file has no CreationTimeStamp where binary FBX has it");
        goto out;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    st = sv_write_file(path, bytes, size, err);
    free(bytes);
out:
    if (blob) aiReleaseExportBlob(blob);
    free_scene(s);
    free(w.tex);
    return st;
}
