/* test_gltf.c — the GLB writer (gltf.h): container layout, the MSFT_lod chain,
 * accessors, materials, image sharing, extra attributes, determinism, errors;
 * merged vertices, input files kept as they are, the LOD group (lods.glb) and
 * its FBX (fbx.h, read back with assimp); quantized and meshopt-compressed
 * geometry (decoded again with meshoptimizer's decoders), opaque colour
 * textures as JPEG. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>

#include <meshoptimizer.h>

#include "fbx.h"
#include "gltf.h"

/* ---- fixtures ---------------------------------------------------------- */

/* A checker RGBA8 image whose alpha is 0 on odd cells (a leaf mask). */
static void checker(sv_image *img, uint32_t size, uint8_t tint)
{
    assert_int_equal(sv_image_alloc(img, size, size, 4, 8, NULL), SV_OK);
    uint8_t *p = img->data;
    for (uint32_t y = 0; y < size; y++)
        for (uint32_t x = 0; x < size; x++, p += 4) {
            bool on = ((x / 4) + (y / 4)) % 2 == 0;
            p[0] = tint;
            p[1] = (uint8_t)(100 + x);
            p[2] = (uint8_t)(50 + y);
            p[3] = on ? 255 : 0;
        }
}

/* `quads` unit quads side by side along x (material 0 = textured MASK leaf) plus
 * one triangle of material 1 (opaque, untextured "bark"). Normals deliberately
 * not unit length (the writer must renormalise). */
static sv_mesh *leaf_mesh(uint32_t quads, uint8_t tint)
{
    sv_mesh *m = sv_mesh_create(4 * quads + 3, 2 * quads + 1, 2, 1);
    assert_non_null(m);
    for (uint32_t q = 0; q < quads; q++) {
        static const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int i = 0; i < 4; i++) {
            float *p = &m->positions[3 * (4 * q + i)];
            p[0] = xy[i][0] + 1.5f * (float)q;
            p[1] = xy[i][1] + 0.25f;
            p[2] = -0.5f;
            m->normals[3 * (4 * q + i) + 2] = 2.0f;
            m->uvs[2 * (4 * q + i)] = xy[i][0];
            m->uvs[2 * (4 * q + i) + 1] = 1.0f - xy[i][1];
        }
        uint32_t b = 4 * q, *t = &m->indices[6 * q];
        t[0] = b, t[1] = b + 1, t[2] = b + 2, t[3] = b, t[4] = b + 2, t[5] = b + 3;
    }
    uint32_t v = 4 * quads;
    static const float tri[3][3] = {{-1, 0, 0}, {-0.5f, 0, 0}, {-0.75f, 3, 0.125f}};
    for (int i = 0; i < 3; i++) {
        memcpy(&m->positions[3 * (v + i)], tri[i], sizeof tri[i]);
        m->normals[3 * (v + i) + 2] = 1.0f;
        m->indices[6 * quads + i] = v + i;
    }
    m->tri_material[2 * quads] = 1;
    sv_material *leaf = &m->materials[0];
    snprintf(leaf->name, sizeof leaf->name, "leaf");
    leaf->base_texture = 0;
    leaf->alpha_mode = SV_ALPHA_MASK;
    leaf->alpha_cutoff = 0.3f;
    leaf->double_sided = true;
    leaf->base_color[1] = 0.8f;
    snprintf(m->materials[1].name, sizeof m->materials[1].name, "bark");
    checker(&m->images[0], 16, tint);
    return m;
}

/* A parsed GLB: the JSON chunk and the binary chunk. */
typedef struct glb {
    cJSON *json;
    const uint8_t *bin;
    uint32_t bin_len;
} glb;

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Checks the container (magic, version, lengths, chunk types, alignment) and
 * parses the JSON chunk. */
static glb parse_glb(const uint8_t *data, size_t size)
{
    glb g = {0};
    assert_true(size >= 20);
    assert_int_equal(rd32(data), 0x46546C67u);
    assert_int_equal(rd32(data + 4), 2);
    assert_int_equal(rd32(data + 8), size);
    uint32_t jlen = rd32(data + 12);
    assert_int_equal(jlen % 4, 0);
    assert_int_equal(rd32(data + 16), 0x4E4F534Au);
    assert_true(20 + (size_t)jlen <= size);
    g.json = cJSON_ParseWithLength((const char *)data + 20, jlen);
    assert_non_null(g.json);
    size_t off = 20 + (size_t)jlen;
    if (off < size) {
        assert_true(off + 8 <= size);
        g.bin_len = rd32(data + off);
        assert_int_equal(rd32(data + off + 4), 0x004E4942u);
        assert_int_equal(g.bin_len % 4, 0);
        assert_int_equal(off + 8 + g.bin_len, size);
        g.bin = data + off + 8;
    }
    return g;
}

static cJSON *get(const cJSON *o, const char *k)
{
    return cJSON_GetObjectItemCaseSensitive(o, k);
}
static cJSON *at(const cJSON *a, int i)
{
    return cJSON_GetArrayItem(a, i);
}
static double num(const cJSON *o, const char *k)
{
    cJSON *x = get(o, k);
    assert_true(cJSON_IsNumber(x));
    return x->valuedouble;
}

/* Pointer to accessor i's data, after checking its view lies inside the buffer. */
static const uint8_t *accessor_data(const glb *g, int i, size_t elem_size)
{
    cJSON *a = at(get(g->json, "accessors"), i);
    assert_non_null(a);
    cJSON *v = at(get(g->json, "bufferViews"), (int)num(a, "bufferView"));
    assert_non_null(v);
    double off = num(v, "byteOffset"), len = num(v, "byteLength");
    assert_int_equal((size_t)off % 4, 0);
    assert_true(off + len <= g->bin_len);
    assert_true(num(a, "count") * (double)elem_size <= len);
    return g->bin + (size_t)off;
}

static glb encode(const sv_gltf_lod *lods, uint32_t n, uint8_t **buf, size_t *size)
{
    sv_error err = {0};
    sv_status st = sv_gltf_encode_glb(lods, n, buf, size, &err);
    if (st != SV_OK) fail_msg("encode failed: %s", err.message);
    return parse_glb(*buf, *size);
}

/* ---- tests ------------------------------------------------------------- */

static void glb_container_has_aligned_chunks_and_exact_lengths(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(3, 10);
    sv_gltf_lod lod = {.name = "only", .mesh = m, .screen_coverage = 0.0};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    assert_non_null(g.bin);
    cJSON *b = at(get(g.json, "buffers"), 0);
    assert_int_equal((uint32_t)num(b, "byteLength"), g.bin_len);
    assert_null(get(b, "uri"));
    cJSON *asset = get(g.json, "asset");
    assert_string_equal(get(asset, "version")->valuestring, "2.0");
    assert_string_equal(get(asset, "generator")->valuestring, "sylva " SV_VERSION);
    cJSON *v;
    cJSON_ArrayForEach(v, get(g.json, "bufferViews"))
    {
        assert_int_equal((size_t)num(v, "byteOffset") % 4, 0);
        assert_true(num(v, "byteOffset") + num(v, "byteLength") <= g.bin_len);
    }
    /* One LOD: no MSFT_lod. */
    assert_null(get(g.json, "extensionsUsed"));
    assert_null(get(at(get(g.json, "nodes"), 0), "extensions"));
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

/* A translation is written on every node when it is not zero, every digit
 * of the double kept (JSON numbers); a zero one is left out. */
static void translation_is_written_with_every_digit_on_each_node(void **state)
{
    (void)state;
    sv_mesh *m0 = leaf_mesh(4, 10), *m1 = leaf_mesh(2, 10);
    sv_gltf_lod lods[2] = {{.name = "a", .mesh = m0, .screen_coverage = 0.3},
                           {.name = "b", .mesh = m1, .screen_coverage = 0.1}};
    const double t[3] = {2000000.0000000002, -12345678.901234567, 0.1};
    for (int i = 0; i < 2; i++) memcpy(lods[i].translation, t, sizeof t);
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    for (int i = 0; i < 2; i++) {
        cJSON *tr = get(at(get(g.json, "nodes"), i), "translation");
        assert_non_null(tr);
        for (int k = 0; k < 3; k++) assert_true(at(tr, k)->valuedouble == t[k]); /* exact */
    }
    cJSON_Delete(g.json);
    free(buf);
    memset(lods[0].translation, 0, sizeof t);
    g = encode(lods, 1, &buf, &size);
    assert_null(get(at(get(g.json, "nodes"), 0), "translation"));
    cJSON_Delete(g.json);
    free(buf);
    lods[0].translation[1] = NAN;
    sv_error err = {0};
    uint8_t *out = NULL;
    assert_int_equal(sv_gltf_encode_glb(lods, 1, &out, &size, &err), SV_ERR_INVALID);
    assert_null(out);
    sv_mesh_destroy(m0);
    sv_mesh_destroy(m1);
}

static void only_the_finest_lod_is_in_the_scene_and_coarser_ones_are_msft_lod_ids(void **state)
{
    (void)state;
    sv_mesh *m0 = leaf_mesh(4, 10), *m1 = leaf_mesh(2, 10), *m2 = leaf_mesh(1, 10);
    sv_gltf_lod lods[3] = {{"full", m0, 0.4, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"half", m1, 0.1, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"cards", m2, 0.01, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 3, &buf, &size);
    cJSON *used = get(g.json, "extensionsUsed");
    assert_int_equal(cJSON_GetArraySize(used), 1);
    assert_string_equal(at(used, 0)->valuestring, "MSFT_lod");
    assert_null(get(g.json, "extensionsRequired"));
    cJSON *nodes = get(g.json, "nodes");
    assert_int_equal(cJSON_GetArraySize(nodes), 3);
    cJSON *scene_nodes = get(at(get(g.json, "scenes"), (int)num(g.json, "scene")), "nodes");
    assert_int_equal(cJSON_GetArraySize(scene_nodes), 1);
    assert_int_equal(at(scene_nodes, 0)->valueint, 0);
    cJSON *n0 = at(nodes, 0);
    assert_string_equal(get(n0, "name")->valuestring, "full");
    cJSON *ids = get(get(get(n0, "extensions"), "MSFT_lod"), "ids");
    assert_int_equal(cJSON_GetArraySize(ids), 2);
    assert_int_equal(at(ids, 0)->valueint, 1);
    assert_int_equal(at(ids, 1)->valueint, 2);
    assert_string_equal(get(at(nodes, 2), "name")->valuestring, "cards");
    cJSON *cov = get(get(n0, "extras"), "MSFT_screencoverage");
    assert_int_equal(cJSON_GetArraySize(cov), 3);
    assert_float_equal(at(cov, 0)->valuedouble, 0.4, 1e-12);
    assert_float_equal(at(cov, 1)->valuedouble, 0.1, 1e-12);
    assert_float_equal(at(cov, 2)->valuedouble, 0.01, 1e-12);
    /* Each LOD node has its own mesh, with its own triangle count. */
    for (int i = 0; i < 3; i++) {
        cJSON *mesh = at(get(g.json, "meshes"), (int)num(at(nodes, i), "mesh"));
        cJSON *p = at(get(mesh, "primitives"), 0);
        cJSON *idx = at(get(g.json, "accessors"), (int)num(p, "indices"));
        assert_int_equal((int)num(idx, "count"), 6 * (4 >> (i == 0 ? 0 : i == 1 ? 1 : 2)));
    }
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m0);
    sv_mesh_destroy(m1);
    sv_mesh_destroy(m2);
}

static void position_accessor_has_exact_min_max_and_counts(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(3, 10);
    m->positions[3 * 5 + 2] = 0.1f; /* a value that is not exact in decimal */
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *prim = at(get(at(get(g.json, "meshes"), 0), "primitives"), 0);
    int pa = (int)num(get(prim, "attributes"), "POSITION");
    cJSON *acc = at(get(g.json, "accessors"), pa);
    assert_int_equal((int)num(acc, "count"), (int)m->vertex_count);
    assert_int_equal((int)num(acc, "componentType"), 5126);
    assert_string_equal(get(acc, "type")->valuestring, "VEC3");
    double mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < m->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            mn[k] = fmin(mn[k], m->positions[3 * v + k]);
            mx[k] = fmax(mx[k], m->positions[3 * v + k]);
        }
    for (int k = 0; k < 3; k++) {
        /* Exact: the JSON number must read back as the same float. */
        assert_true((float)at(get(acc, "min"), k)->valuedouble == (float)mn[k]);
        assert_true((float)at(get(acc, "max"), k)->valuedouble == (float)mx[k]);
    }
    const float *p = (const float *)accessor_data(&g, pa, 12);
    assert_memory_equal(p, m->positions, 12 * m->vertex_count);
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

static void each_used_material_gets_one_primitive_with_its_triangles(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(3, 10);
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *prims = get(at(get(g.json, "meshes"), 0), "primitives");
    assert_int_equal(cJSON_GetArraySize(prims), 2);
    int counts[2];
    for (int i = 0; i < 2; i++) {
        cJSON *p = at(prims, i);
        cJSON *idx = at(get(g.json, "accessors"), (int)num(p, "indices"));
        counts[i] = (int)num(idx, "count");
        assert_int_equal((int)num(idx, "componentType"), 5123); /* uint16 for few vertices */
        assert_string_equal(get(idx, "type")->valuestring, "SCALAR");
    }
    assert_int_equal(counts[0], 18);
    assert_int_equal(counts[1], 3);
    /* The bark primitive's indices are the triangle's vertices. */
    const uint16_t *ix = (const uint16_t *)accessor_data(&g, (int)num(at(prims, 1), "indices"), 2);
    assert_int_equal(ix[0], 12);
    assert_int_equal(ix[2], 14);
    /* A material no triangle uses is not written. */
    cJSON_Delete(g.json);
    free(buf);
    m->tri_material[6] = 0;
    glb g2 = encode(&lod, 1, &buf, &size);
    assert_int_equal(cJSON_GetArraySize(get(g2.json, "materials")), 1);
    assert_int_equal(cJSON_GetArraySize(get(at(get(g2.json, "meshes"), 0), "primitives")), 1);
    cJSON_Delete(g2.json);
    free(buf);
    sv_mesh_destroy(m);
}

static void mask_material_has_cutoff_texture_and_pbr_defaults(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(1, 10);
    m->materials[1].alpha_mode = SV_ALPHA_BLEND;
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *mats = get(g.json, "materials");
    cJSON *leaf = at(mats, 0), *bark = at(mats, 1);
    assert_string_equal(get(leaf, "name")->valuestring, "leaf");
    assert_string_equal(get(leaf, "alphaMode")->valuestring, "MASK");
    assert_float_equal(num(leaf, "alphaCutoff"), 0.3, 1e-7);
    assert_true(cJSON_IsTrue(get(leaf, "doubleSided")));
    cJSON *pbr = get(leaf, "pbrMetallicRoughness");
    assert_float_equal(num(pbr, "metallicFactor"), 0.0, 0);
    assert_float_equal(num(pbr, "roughnessFactor"), 1.0, 0);
    assert_float_equal(at(get(pbr, "baseColorFactor"), 1)->valuedouble, 0.8, 1e-7);
    int tex = (int)num(get(pbr, "baseColorTexture"), "index");
    cJSON *t = at(get(g.json, "textures"), tex);
    cJSON *img = at(get(g.json, "images"), (int)num(t, "source"));
    assert_string_equal(get(img, "mimeType")->valuestring, "image/png");
    assert_non_null(at(get(g.json, "samplers"), (int)num(t, "sampler")));
    /* The embedded bytes are a PNG. */
    cJSON *view = at(get(g.json, "bufferViews"), (int)num(img, "bufferView"));
    assert_memory_equal(g.bin + (size_t)num(view, "byteOffset"), "\x89PNG\r\n\x1a\n", 8);
    assert_string_equal(get(bark, "alphaMode")->valuestring, "BLEND");
    assert_null(get(bark, "alphaCutoff"));
    assert_null(get(bark, "doubleSided"));
    assert_null(get(get(bark, "pbrMetallicRoughness"), "baseColorTexture"));
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

static void identical_images_are_stored_once_across_lods(void **state)
{
    (void)state;
    sv_mesh *a = leaf_mesh(2, 10), *b = leaf_mesh(1, 10), *c = leaf_mesh(1, 99);
    sv_gltf_lod lods[3] = {{"a", a, 0.5, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"b", b, 0.2, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"c", c, 0.0, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "images")), 1);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "textures")), 1);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "materials")), 2); /* shared too */
    cJSON_Delete(g.json);
    free(buf);
    /* Different pixels are different images. */
    g = encode(lods, 3, &buf, &size);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "images")), 2);
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
    sv_mesh_destroy(c);
}

static void normals_are_written_unit_length(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(2, 10);
    m->normals[0] = m->normals[1] = m->normals[2] = 0.0f; /* degenerate */
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *attrs = get(at(get(at(get(g.json, "meshes"), 0), "primitives"), 0), "attributes");
    const float *n = (const float *)accessor_data(&g, (int)num(attrs, "NORMAL"), 12);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        double len = sqrt((double)n[3 * v] * n[3 * v] + (double)n[3 * v + 1] * n[3 * v + 1] +
                          (double)n[3 * v + 2] * n[3 * v + 2]);
        assert_float_equal(len, 1.0, 1e-6);
    }
    assert_float_equal(n[5], 1.0, 1e-7); /* 2·z renormalised */
    assert_float_equal(n[1], 1.0, 1e-7); /* zero → +Y */
    assert_non_null(get(attrs, "TEXCOORD_0"));
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

static void extra_vertex_attributes_are_written_under_their_names(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(2, 10);
    float *order = calloc(m->vertex_count, sizeof *order);
    float *centre = calloc(m->vertex_count * 3, sizeof *centre);
    assert_non_null(order);
    assert_non_null(centre);
    for (uint32_t v = 0; v < m->vertex_count; v++) order[v] = (float)(v / 4);
    sv_gltf_attribute attrs[2] = {{"_ORDER", order, 1}, {"_LEAF_CENTRE", centre, 3}};
    cJSON *extras = cJSON_CreateObject();
    cJSON_AddNumberToObject(extras, "fade_start", 12.5);
    sv_gltf_lod lod = {.mesh = m, .attributes = attrs, .attribute_count = 2, .extras = extras};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *ja = get(at(get(at(get(g.json, "meshes"), 0), "primitives"), 0), "attributes");
    int ia = (int)num(ja, "_ORDER");
    cJSON *acc = at(get(g.json, "accessors"), ia);
    assert_string_equal(get(acc, "type")->valuestring, "SCALAR");
    assert_int_equal((int)num(acc, "count"), (int)m->vertex_count);
    assert_memory_equal(accessor_data(&g, ia, 4), order, 4 * m->vertex_count);
    acc = at(get(g.json, "accessors"), (int)num(ja, "_LEAF_CENTRE"));
    assert_string_equal(get(acc, "type")->valuestring, "VEC3");
    assert_float_equal(num(get(at(get(g.json, "nodes"), 0), "extras"), "fade_start"), 12.5, 0);
    cJSON_Delete(g.json);
    free(buf);
    /* A name without the application prefix is refused. */
    attrs[0].name = "ORDER";
    sv_error err = {0};
    assert_int_equal(sv_gltf_encode_glb(&lod, 1, &buf, &size, &err), SV_ERR_INVALID);
    assert_null(buf);
    assert_non_null(strstr(err.message, "attribute"));
    cJSON_Delete(extras);
    free(order);
    free(centre);
    sv_mesh_destroy(m);
}

/* A primitive of more than 65,535 vertices is written as consecutive runs
 * of its triangles of at most 65,535 vertices each, every one with 16-bit
 * indices, drawing the same triangles; quantized, it keeps one primitive of
 * 32-bit indices. */
static void large_primitives_are_split_into_runs_with_16_bit_indices(void **state)
{
    (void)state;
    /* 70002 distinct vertices, each used once: nothing to merge */
    sv_mesh *m = sv_mesh_create(70002, 23334, 1, 0);
    assert_non_null(m);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        m->positions[3 * v] = (float)v * 1e-3f;
        m->positions[3 * v + 1] = (float)(v % 7);
        m->indices[v] = v;
    }
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *prims = get(at(get(g.json, "meshes"), 0), "primitives"), *acc = get(g.json, "accessors");
    assert_int_equal(cJSON_GetArraySize(prims), 2);
    uint32_t t = 0; /* the source triangle the next index belongs to */
    for (int p = 0; p < 2; p++) {
        cJSON *pr = at(prims, p);
        int ii = (int)num(pr, "indices"), pa = (int)num(get(pr, "attributes"), "POSITION");
        assert_int_equal((int)num(at(acc, ii), "componentType"), 5123);
        assert_int_equal((int)num(at(acc, pa), "count"), p == 0 ? 65535 : 70002 - 65535);
        int count = (int)num(at(acc, ii), "count");
        const uint16_t *ix = (const uint16_t *)accessor_data(&g, ii, 2);
        const float *pos = (const float *)accessor_data(&g, pa, 12);
        for (int k = 0; k < count; k++, t += k % 3 == 0) {
            uint32_t v = m->indices[3 * t + (uint32_t)k % 3];
            assert_float_equal(pos[3 * ix[k]], m->positions[3 * v], 0);
            assert_float_equal(pos[3 * ix[k] + 1], m->positions[3 * v + 1], 0);
        }
    }
    assert_int_equal(t, m->triangle_count);
    cJSON_Delete(g.json);
    free(buf);
    lod.compress = SV_GLTF_QUANTIZE;
    g = encode(&lod, 1, &buf, &size);
    prims = get(at(get(g.json, "meshes"), 0), "primitives");
    assert_int_equal(cJSON_GetArraySize(prims), 1);
    int ii = (int)num(at(prims, 0), "indices");
    assert_int_equal((int)num(at(get(g.json, "accessors"), ii), "componentType"), 5125);
    const uint32_t *ix = (const uint32_t *)accessor_data(&g, ii, 4);
    assert_int_equal(ix[65535], 65535);
    assert_int_equal(ix[70001], 70001);
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

/* A level of more than 65,535 vertices over two materials whose own
 * vertices fit (a trunk and its leaves): each primitive has vertices of its
 * own and 16-bit indices, and draws the same triangles. */
static void primitives_whose_vertices_fit_get_16_bit_indices(void **state)
{
    (void)state;
    sv_mesh *m = sv_mesh_create(70002, 23334, 2, 0);
    assert_non_null(m);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        m->positions[3 * v] = (float)v * 1e-3f;
        m->positions[3 * v + 1] = (float)(v % 7);
        m->indices[v] = v;
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) m->tri_material[t] = t % 2;
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *prims = get(at(get(g.json, "meshes"), 0), "primitives"), *acc = get(g.json, "accessors");
    assert_int_equal(cJSON_GetArraySize(prims), 2);
    for (int p = 0; p < 2; p++) {
        cJSON *pr = at(prims, p);
        int ii = (int)num(pr, "indices"), pa = (int)num(get(pr, "attributes"), "POSITION");
        assert_int_equal((int)num(at(acc, ii), "componentType"), 5123);
        assert_int_equal((int)num(at(acc, pa), "count"), 35001);
        const uint16_t *ix = (const uint16_t *)accessor_data(&g, ii, 2);
        const float *pos = (const float *)accessor_data(&g, pa, 12);
        for (uint32_t k = 0; k < 35001; k++) { /* triangle k of this material, corner by corner */
            uint32_t t = 2 * (k / 3) + (uint32_t)p, v = m->indices[3 * t + k % 3];
            assert_float_equal(pos[3 * ix[k]], m->positions[3 * v], 0);
            assert_float_equal(pos[3 * ix[k] + 1], m->positions[3 * v + 1], 0);
        }
    }
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

/* Levels of one file share geometry: B's leaves are A's first three in the
 * same order, grown about their centres (a stochastic level), with a trunk
 * of its own. B's UVs, normals and leaf indices are a prefix of A's and use
 * A's buffer views (which then carry byteStride, as glTF requires of a
 * vertex view two accessors use); its positions are its own. */
static void levels_share_the_buffer_views_their_data_begins(void **state)
{
    (void)state;
    sv_mesh *a = leaf_mesh(5, 10), *b = leaf_mesh(3, 10);
    for (uint32_t q = 0; q < 3; q++)
        for (int i = 0; i < 4; i++) {
            float *p = &b->positions[3 * (4 * q + i)];
            float cx = 0.5f + 1.5f * (float)q, cy = 0.75f;
            p[0] = cx + 1.25f * (p[0] - cx);
            p[1] = cy + 1.25f * (p[1] - cy);
        }
    b->positions[3 * 12 + 1] = 2.0f; /* the trunk changed too */
    sv_gltf_lod lods[2] = {{.name = "a", .mesh = a, .screen_coverage = 0.3},
                           {.name = "b", .mesh = b, .screen_coverage = 0.1}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    cJSON *acc = get(g.json, "accessors"), *views = get(g.json, "bufferViews");
    cJSON *pa = at(get(at(get(g.json, "meshes"), 0), "primitives"), 0);
    cJSON *pb = at(get(at(get(g.json, "meshes"), 1), "primitives"), 0);
    assert_int_equal((int)num(pa, "material"), (int)num(pb, "material"));
#define VIEW(p, k) (int)num(at(acc, (int)num(get(p, "attributes"), k)), "bufferView")
    assert_int_equal(VIEW(pb, "TEXCOORD_0"), VIEW(pa, "TEXCOORD_0"));
    assert_int_equal(VIEW(pb, "NORMAL"), VIEW(pa, "NORMAL"));
    assert_int_not_equal(VIEW(pb, "POSITION"), VIEW(pa, "POSITION"));
    assert_int_equal(num(at(views, VIEW(pa, "TEXCOORD_0")), "byteStride"), 8);
    assert_int_equal(num(at(views, VIEW(pa, "NORMAL")), "byteStride"), 12);
    assert_null(get(at(views, VIEW(pa, "POSITION")), "byteStride"));
#undef VIEW
    int ia = (int)num(pa, "indices"), ib = (int)num(pb, "indices");
    assert_int_equal(num(at(acc, ib), "bufferView"), num(at(acc, ia), "bufferView"));
    assert_int_equal((int)num(at(acc, ib), "count"), 18);
    assert_int_equal((int)num(at(acc, (int)num(get(pb, "attributes"), "TEXCOORD_0")), "count"), 12);
    /* what b's accessors read is b's leaves */
    const uint16_t *ix = (const uint16_t *)accessor_data(&g, ib, 2);
    const float *pos =
        (const float *)accessor_data(&g, (int)num(get(pb, "attributes"), "POSITION"), 12);
    const float *uv =
        (const float *)accessor_data(&g, (int)num(get(pb, "attributes"), "TEXCOORD_0"), 8);
    for (int k = 0; k < 18; k++) {
        uint32_t v = b->indices[k];
        assert_float_equal(pos[3 * ix[k]], b->positions[3 * v], 0);
        assert_float_equal(pos[3 * ix[k] + 1], b->positions[3 * v + 1], 0);
        assert_float_equal(uv[2 * ix[k] + 1], b->uvs[2 * v + 1], 0);
    }
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
}

/* A texture a coarser level reduced (its trunk's bark) is, in a file that
 * holds the texture it was reduced from, that one: one image. Alone, the
 * level keeps its reduced copy. */
static void a_reduced_texture_is_its_original_in_a_file_that_holds_it(void **state)
{
    (void)state;
    sv_mesh *a = leaf_mesh(2, 10), *b = leaf_mesh(1, 10);
    assert_int_equal(sv_image_reduce(&b->images[0], 4, NULL), SV_OK);
    assert_int_equal(b->images[0].width, 4);
    uint64_t origin = 0;
    assert_true(sv_image_reduced_from(&b->images[0], &origin));
    assert_true(origin == sv_image_pixel_hash(&a->images[0]));
    sv_gltf_lod lods[2] = {{.name = "a", .mesh = a, .screen_coverage = 0.3},
                           {.name = "b", .mesh = b, .screen_coverage = 0.1}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "images")), 1);
    cJSON_Delete(g.json);
    free(buf);
    g = encode(&lods[1], 1, &buf, &size);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "images")), 1);
    cJSON *v = at(get(g.json, "bufferViews"), (int)num(at(get(g.json, "images"), 0), "bufferView"));
    const uint8_t *png = g.bin + (size_t)num(v, "byteOffset");
    assert_int_equal((uint32_t)png[16] << 24 | (uint32_t)png[17] << 16 | (uint32_t)png[18] << 8 | png[19],
                     4); /* the IHDR's width */
    cJSON_Delete(g.json);
    free(buf);
    /* changed after the reduction: no longer the original's */
    ((uint8_t *)b->images[0].data)[0] ^= 0xff;
    assert_false(sv_image_reduced_from(&b->images[0], &origin));
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
}

static void two_writes_of_the_same_lods_are_byte_identical(void **state)
{
    (void)state;
    sv_mesh *m0 = leaf_mesh(5, 10), *m1 = leaf_mesh(1, 20);
    sv_gltf_lod lods[2] = {{"a", m0, 0.3, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"b", m1, 0.05, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    char dir[] = "/tmp/sv_gltf_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char p1[64], p2[64];
    snprintf(p1, sizeof p1, "%s/1.glb", dir);
    snprintf(p2, sizeof p2, "%s/2.glb", dir);
    sv_error err = {0};
    assert_int_equal(sv_gltf_write_glb(p1, lods, 2, &err), SV_OK);
    assert_int_equal(sv_gltf_write_glb(p2, lods, 2, &err), SV_OK);
    uint8_t *mem;
    size_t size;
    assert_int_equal(sv_gltf_encode_glb(lods, 2, &mem, &size, &err), SV_OK);
    uint8_t *f[2] = {NULL, NULL};
    const char *paths[2] = {p1, p2};
    for (int i = 0; i < 2; i++) {
        FILE *fp = fopen(paths[i], "rb");
        assert_non_null(fp);
        f[i] = malloc(size + 1);
        assert_int_equal(fread(f[i], 1, size + 1, fp), size);
        fclose(fp);
        assert_memory_equal(f[i], mem, size);
        unlink(paths[i]);
        free(f[i]);
    }
    rmdir(dir);
    free(mem);
    sv_mesh_destroy(m0);
    sv_mesh_destroy(m1);
}

static void out_of_range_index_is_refused_with_a_message(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(1, 10);
    m->indices[4] = 99;
    sv_gltf_lod lod = {.mesh = m};
    uint8_t *buf = (uint8_t *)&lod;
    size_t size = 1;
    sv_error err = {0};
    assert_int_equal(sv_gltf_encode_glb(&lod, 1, &buf, &size, &err), SV_ERR_INVALID);
    assert_null(buf);
    assert_int_equal(size, 0);
    assert_non_null(strstr(err.message, "vertex 99"));
    m->indices[4] = 2;
    m->positions[1] = NAN;
    assert_int_equal(sv_gltf_encode_glb(&lod, 1, &buf, &size, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "non-finite"));
    m->positions[1] = 0;
    m->materials[0].base_texture = 3;
    assert_int_equal(sv_gltf_encode_glb(&lod, 1, &buf, &size, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "image 3"));
    assert_int_equal(sv_gltf_encode_glb(&lod, 0, &buf, &size, &err), SV_ERR_INVALID);
    assert_int_equal(sv_gltf_write_glb("/nonexistent-dir/x.glb", &lod, 1, &err), SV_ERR_INVALID);
    m->materials[0].base_texture = 0;
    assert_int_equal(sv_gltf_write_glb("/nonexistent-dir/x.glb", &lod, 1, &err), SV_ERR_IO);
    assert_non_null(strstr(err.message, "/nonexistent-dir/x.glb"));
    sv_mesh_destroy(m);
}

static void empty_lod_becomes_a_node_without_a_mesh(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(1, 10), *e = sv_mesh_create(0, 0, 0, 0);
    assert_non_null(e);
    sv_gltf_lod lods[2] = {{"leaves", m, 0.2, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                           {"culled", e, 0.0, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    cJSON *n1 = at(get(g.json, "nodes"), 1);
    assert_string_equal(get(n1, "name")->valuestring, "culled");
    assert_null(get(n1, "mesh"));
    assert_int_equal(cJSON_GetArraySize(get(g.json, "meshes")), 1);
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
    sv_mesh_destroy(e);
}

/* A standalone level (lod<i>_<name>.glb): one scene holding only that level's
 * node under its <asset>_LOD<i> name, the mesh under the level's name, no
 * MSFT_lod, and every image it samples embedded in the binary chunk. */
static void standalone_level_is_one_named_node_with_embedded_images(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(2, 30);
    cJSON *extras = cJSON_CreateObject();
    cJSON_AddNumberToObject(extras, "lambda", 0.5);
    sv_gltf_lod lod = {.name = "oak_LOD2",
                       .mesh = m,
                       .screen_coverage = 0.25,
                       .extras = extras,
                       .mesh_name = "clusters16"};
    uint8_t *buf = NULL;
    size_t size = 0;
    sv_error err = {0};
    assert_int_equal(sv_gltf_encode_level_glb(&lod, &buf, &size, &err), SV_OK);
    glb g = parse_glb(buf, size);
    assert_int_equal(cJSON_GetArraySize(get(g.json, "scenes")), 1);
    cJSON *scene_nodes = get(at(get(g.json, "scenes"), (int)num(g.json, "scene")), "nodes");
    assert_int_equal(cJSON_GetArraySize(scene_nodes), 1);
    cJSON *nodes = get(g.json, "nodes");
    assert_int_equal(cJSON_GetArraySize(nodes), 1);
    cJSON *n0 = at(nodes, at(scene_nodes, 0)->valueint);
    assert_string_equal(get(n0, "name")->valuestring, "oak_LOD2");
    assert_null(get(n0, "extensions"));
    assert_null(get(get(n0, "extras"), "MSFT_screencoverage"));
    assert_float_equal(num(get(n0, "extras"), "lambda"), 0.5, 0);
    assert_null(get(g.json, "extensionsUsed"));
    cJSON *mesh = at(get(g.json, "meshes"), (int)num(n0, "mesh"));
    assert_string_equal(get(mesh, "name")->valuestring, "clusters16");
    /* images: every one in the binary chunk (bufferView + PNG mime), no uri */
    cJSON *images = get(g.json, "images");
    assert_true(cJSON_GetArraySize(images) >= 1);
    cJSON *im;
    cJSON_ArrayForEach(im, images)
    {
        assert_null(get(im, "uri"));
        assert_string_equal(get(im, "mimeType")->valuestring, "image/png");
        cJSON *v = at(get(g.json, "bufferViews"), (int)num(im, "bufferView"));
        assert_non_null(v);
        const uint8_t *png = g.bin + (size_t)num(v, "byteOffset");
        assert_memory_equal(png, "\x89PNG", 4);
    }
    assert_null(get(at(get(g.json, "buffers"), 0), "uri"));
    /* deterministic, and a nameless level is refused */
    uint8_t *buf2 = NULL;
    size_t size2 = 0;
    assert_int_equal(sv_gltf_encode_level_glb(&lod, &buf2, &size2, &err), SV_OK);
    assert_int_equal(size, size2);
    assert_memory_equal(buf, buf2, size);
    free(buf2);
    lod.name = NULL;
    assert_int_equal(sv_gltf_encode_level_glb(&lod, &buf2, &size2, &err), SV_ERR_INVALID);
    assert_null(buf2);
    cJSON_Delete(g.json);
    cJSON_Delete(extras);
    free(buf);
    sv_mesh_destroy(m);
}

/* A mesh none of whose materials samples a texture is written without
 * TEXCOORD_0 (its UVs draw nothing), and the vertices its UV seams kept
 * apart merge; with a texture the UVs are kept. */
static void uvs_without_a_texture_are_left_out(void **state)
{
    (void)state;
    /* a quad whose two triangles meet at a UV seam: 6 corners, 4 positions */
    static const float p[6][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    sv_mesh *m = sv_mesh_create(6, 2, 1, 1);
    assert_non_null(m);
    memcpy(m->positions, p, sizeof p);
    for (int v = 0; v < 6; v++) {
        m->indices[v] = (uint32_t)v;
        m->normals[3 * v + 2] = 1.0f;
        m->uvs[2 * v] = v < 3 ? 0.0f : 0.5f; /* the seam */
    }
    checker(&m->images[0], 8, 10);
    sv_gltf_lod lod = {.mesh = m};
    for (int textured = 0; textured < 2; textured++) {
        m->materials[0].base_texture = textured ? 0 : -1;
        uint8_t *buf;
        size_t size;
        glb g = encode(&lod, 1, &buf, &size);
        cJSON *attrs = get(at(get(at(get(g.json, "meshes"), 0), "primitives"), 0), "attributes");
        int n = (int)num(at(get(g.json, "accessors"), (int)num(attrs, "POSITION")), "count");
        if (textured) {
            assert_non_null(get(attrs, "TEXCOORD_0"));
            assert_int_equal(n, 6);
        } else {
            assert_null(get(attrs, "TEXCOORD_0"));
            assert_int_equal(n, 4);
        }
        cJSON_Delete(g.json);
        free(buf);
    }
    sv_mesh_destroy(m);
}

static bool has_string(const cJSON *a, const char *s)
{
    const cJSON *x;
    cJSON_ArrayForEach(x, a) if (cJSON_IsString(x) && strcmp(x->valuestring, s) == 0) return true;
    return false;
}

/* output.compress: quantized attributes (KHR_mesh_quantization) read back
 * through the node's transform within half a step of the floats, and every
 * EXT_meshopt_compression view decoded by meshoptimizer's decoders gives the
 * quantized file's bytes for that view exactly. */
static void quantized_and_meshopt_geometry_decode_to_the_mesh(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(300, 10); /* 1203 vertices: 16-bit indices */
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        m->positions[3 * v + 2] += 0.01f * (float)(v % 13); /* not flat */
        m->normals[3 * v] = 0.3f * (float)(v % 5);
    }
    sv_gltf_lod lod = {.name = "q", .mesh = m, .translation = {100, 0, -3}};
    uint8_t *bf, *bq, *bm, *bm2;
    size_t sf, sq, sm, sm2;
    glb gf = encode(&lod, 1, &bf, &sf);
    lod.compress = SV_GLTF_QUANTIZE;
    glb gq = encode(&lod, 1, &bq, &sq);
    lod.compress = SV_GLTF_MESHOPT;
    glb gm = encode(&lod, 1, &bm, &sm);
    glb gm2 = encode(&lod, 1, &bm2, &sm2);
    assert_int_equal(sm, sm2); /* deterministic */
    assert_memory_equal(bm, bm2, sm);
    assert_true(sm < sq && sq < sf);
    assert_true(has_string(get(gq.json, "extensionsRequired"), "KHR_mesh_quantization"));
    assert_null(get(gf.json, "extensionsRequired"));
    assert_true(has_string(get(gm.json, "extensionsRequired"), "EXT_meshopt_compression"));
    assert_true(has_string(get(gm.json, "extensionsUsed"), "KHR_mesh_quantization"));

    /* quantized values, through the node's translation and scale */
    cJSON *nq = at(get(gq.json, "nodes"), 0);
    double t[3], sc = at(get(nq, "scale"), 0)->valuedouble;
    for (int k = 0; k < 3; k++) t[k] = at(get(nq, "translation"), k)->valuedouble;
    cJSON *af = get(at(get(at(get(gf.json, "meshes"), 0), "primitives"), 0), "attributes");
    cJSON *aq = get(at(get(at(get(gq.json, "meshes"), 0), "primitives"), 0), "attributes");
    int n = (int)num(at(get(gf.json, "accessors"), (int)num(af, "POSITION")), "count");
    cJSON *pa = at(get(gq.json, "accessors"), (int)num(aq, "POSITION"));
    assert_int_equal((int)num(pa, "componentType"), 5122);
    assert_int_equal(
        (int)num(at(get(gq.json, "bufferViews"), (int)num(pa, "bufferView")), "byteStride"), 8);
    const float *pf = (const float *)accessor_data(&gf, (int)num(af, "POSITION"), 12);
    const int16_t *pq = (const int16_t *)accessor_data(&gq, (int)num(aq, "POSITION"), 8);
    const float *nf = (const float *)accessor_data(&gf, (int)num(af, "NORMAL"), 12);
    const int8_t *nq8 = (const int8_t *)accessor_data(&gq, (int)num(aq, "NORMAL"), 4);
    const float *uf = (const float *)accessor_data(&gf, (int)num(af, "TEXCOORD_0"), 8);
    const uint16_t *uq = (const uint16_t *)accessor_data(&gq, (int)num(aq, "TEXCOORD_0"), 4);
    /* (in double: cmocka's assert_float_equal compares floats) */
    for (int v = 0; v < n; v++)
        for (int k = 0; k < 3; k++) {
            double p = t[k] + sc * pq[4 * v + k], want = 100.0 * (k == 0) - 3.0 * (k == 2);
            assert_true(fabs(p - (want + pf[3 * v + k])) <= 0.5 * sc * (1 + 1e-9));
            assert_true(fabs(nq8[4 * v + k] / 127.0 - nf[3 * v + k]) <= 0.5 / 127 + 1e-7);
            if (k < 2) assert_true(fabs(uq[2 * v + k] / 65535.0 - uf[2 * v + k]) <= 0.5 / 65535);
        }

    /* every compressed view decodes to the quantized file's bytes */
    cJSON *vm = get(gm.json, "bufferViews"), *vq = get(gq.json, "bufferViews");
    assert_int_equal(cJSON_GetArraySize(vm), cJSON_GetArraySize(vq));
    cJSON *fb = at(get(gm.json, "buffers"), 1);
    assert_null(get(fb, "uri"));
    assert_true(
        cJSON_IsTrue(get(get(get(fb, "extensions"), "EXT_meshopt_compression"), "fallback")));
    int compressed = 0;
    for (int i = 0; i < cJSON_GetArraySize(vm); i++) {
        cJSON *v = at(vm, i), *x = get(get(v, "extensions"), "EXT_meshopt_compression");
        if (!x) continue;
        compressed++;
        size_t count = (size_t)num(x, "count"), stride = (size_t)num(x, "byteStride");
        size_t len = (size_t)num(v, "byteLength");
        assert_int_equal((int)num(v, "buffer"), 1);
        assert_true(num(v, "byteOffset") + len <= num(fb, "byteLength"));
        assert_int_equal(len, count * stride);
        assert_int_equal((size_t)num(at(vq, i), "byteLength"), len);
        const uint8_t *enc = gm.bin + (size_t)num(x, "byteOffset");
        size_t enc_len = (size_t)num(x, "byteLength");
        assert_true(num(x, "byteOffset") + enc_len <= gm.bin_len);
        uint8_t *dec = malloc(len);
        assert_non_null(dec);
        int rc = strcmp(get(x, "mode")->valuestring, "ATTRIBUTES") == 0
                     ? meshopt_decodeVertexBuffer(dec, count, stride, enc, enc_len)
                     : meshopt_decodeIndexBuffer(dec, count, stride, enc, enc_len);
        assert_int_equal(rc, 0);
        assert_memory_equal(dec, gq.bin + (size_t)num(at(vq, i), "byteOffset"), len);
        free(dec);
    }
    assert_int_equal(compressed, 5); /* position, normal, UV, two index lists */
    cJSON_Delete(gf.json);
    cJSON_Delete(gq.json);
    cJSON_Delete(gm.json);
    cJSON_Delete(gm2.json);
    free(bf);
    free(bq);
    free(bm);
    free(bm2);
    sv_mesh_destroy(m);
}

/* A base-colour texture the bake made that uses no alpha is JPEG; one that
 * uses alpha, and a normal map, stay PNG. */
static void opaque_colour_textures_are_jpeg(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(2, 10);
    sv_mesh *o = sv_mesh_create(m->vertex_count, m->triangle_count, 2, 2);
    assert_non_null(o);
    memcpy(o->positions, m->positions, 12 * (size_t)m->vertex_count);
    memcpy(o->normals, m->normals, 12 * (size_t)m->vertex_count);
    memcpy(o->uvs, m->uvs, 8 * (size_t)m->vertex_count);
    memcpy(o->indices, m->indices, 12 * (size_t)m->triangle_count);
    memcpy(o->tri_material, m->tri_material, 4 * (size_t)m->triangle_count);
    memcpy(o->materials, m->materials, 2 * sizeof *o->materials);
    checker(&o->images[0], 16, 10);
    checker(&o->images[1], 16, 90);
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < 16 * 16; i++) ((uint8_t *)o->images[k].data)[4 * i + 3] = 255;
    o->materials[0].normal_texture = 1;
    sv_gltf_lod lods[2] = {{.name = "a", .mesh = o}, {.name = "b", .mesh = m}};
    uint8_t *buf;
    size_t size;
    glb g = encode(lods, 2, &buf, &size);
    cJSON *mats = get(g.json, "materials"), *tex = get(g.json, "textures");
    cJSON *images = get(g.json, "images");
    const char *want[3] = {"image/jpeg", "image/png", "image/png"}; /* o's base, normal; m's */
    int idx[3] = {
        (int)num(get(get(at(mats, 0), "pbrMetallicRoughness"), "baseColorTexture"), "index"),
        (int)num(get(at(mats, 0), "normalTexture"), "index"), -1};
    for (int i = 0; i < cJSON_GetArraySize(mats); i++) {
        cJSON *bt = get(get(at(mats, i), "pbrMetallicRoughness"), "baseColorTexture");
        if (i > 0 && bt) idx[2] = (int)num(bt, "index");
    }
    assert_true(idx[2] >= 0);
    for (int k = 0; k < 3; k++) {
        cJSON *im = at(images, (int)num(at(tex, idx[k]), "source"));
        assert_string_equal(get(im, "mimeType")->valuestring, want[k]);
        const uint8_t *p = g.bin +
                           (size_t)num(at(get(g.json, "bufferViews"), (int)num(im, "bufferView")),
                                       "byteOffset");
        assert_memory_equal(p, k == 0 ? "\xFF\xD8\xFF" : "\x89PN", 3);
    }
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(o);
    sv_mesh_destroy(m);
}

static void identical_vertices_are_written_once(void **state)
{
    (void)state;
    /* two triangles of a quad as a triangle soup (6 vertices, 2 repeated),
     * and one vertex no triangle uses */
    sv_mesh *m = sv_mesh_create(7, 2, 1, 0);
    assert_non_null(m);
    static const float xy[6][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}};
    for (uint32_t v = 0; v < 6; v++) {
        m->positions[3 * v] = xy[v][0];
        m->positions[3 * v + 1] = xy[v][1];
        m->normals[3 * v + 2] = 1;
        m->indices[v] = v;
    }
    m->positions[3 * 6] = 50; /* unused: must not widen the bounds */
    sv_gltf_lod lod = {.name = "soup", .mesh = m};
    uint8_t *buf;
    size_t size;
    glb g = encode(&lod, 1, &buf, &size);
    cJSON *prim = at(get(at(get(g.json, "meshes"), 0), "primitives"), 0);
    int pa = (int)num(get(prim, "attributes"), "POSITION"), ia = (int)num(prim, "indices");
    cJSON *acc = get(g.json, "accessors");
    assert_int_equal((int)num(at(acc, pa), "count"), 4);
    assert_float_equal(at(get(at(acc, pa), "max"), 0)->valuedouble, 1.0, 0);
    assert_int_equal((int)num(at(acc, ia), "count"), 6);
    assert_int_equal((int)num(at(acc, ia), "componentType"), 5123);
    const uint16_t *ix = (const uint16_t *)accessor_data(&g, ia, 2);
    const float *pos = (const float *)accessor_data(&g, pa, 12);
    for (int k = 0; k < 6; k++) { /* the same corners, in the same order */
        assert_float_equal(pos[3 * ix[k]], xy[k][0], 0);
        assert_float_equal(pos[3 * ix[k] + 1], xy[k][1], 0);
    }
    cJSON_Delete(g.json);
    free(buf);
    sv_mesh_destroy(m);
}

/* A source without normals (an OBJ with no "vn"): each face has its own
 * corners with the face's normal, so corners of two faces meeting at an
 * edge differ only there. With no_normals the file has no NORMAL (readers
 * compute flat normals, as for the source) and those corners become one;
 * without it the normals are written and keep them apart. */
static void a_level_without_source_normals_merges_on_position(void **state)
{
    (void)state;
    /* two triangles folded along the edge (0,0,0)-(1,0,0), face normals
     * +Z and +Y, as a soup */
    static const float p[6][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                                  {1, 0, 0}, {0, 0, 0}, {0, 0, -1}};
    sv_mesh *m = sv_mesh_create(6, 2, 1, 0);
    assert_non_null(m);
    for (uint32_t v = 0; v < 6; v++) {
        memcpy(&m->positions[3 * v], p[v], sizeof p[v]);
        m->normals[3 * v + (v < 3 ? 2 : 1)] = 1;
        m->indices[v] = v;
    }
    for (int drop = 0; drop < 2; drop++) {
        sv_gltf_lod lod = {.name = "folded", .mesh = m, .no_normals = drop};
        uint8_t *buf;
        size_t size;
        glb g = encode(&lod, 1, &buf, &size);
        cJSON *attrs = get(at(get(at(get(g.json, "meshes"), 0), "primitives"), 0), "attributes");
        int pa = (int)num(attrs, "POSITION");
        assert_int_equal(cJSON_HasObjectItem(attrs, "NORMAL"), !drop);
        assert_int_equal((int)num(at(get(g.json, "accessors"), pa), "count"), drop ? 4 : 6);
        cJSON_Delete(g.json);
        free(buf);
    }
    sv_mesh_destroy(m);
}

/* The image the glTF of lod embeds (the first), with its mimeType. */
static const uint8_t *first_image(const glb *g, const char **mime, size_t *len)
{
    cJSON *im = at(get(g->json, "images"), 0);
    assert_non_null(im);
    *mime = get(im, "mimeType")->valuestring;
    cJSON *v = at(get(g->json, "bufferViews"), (int)num(im, "bufferView"));
    *len = (size_t)num(v, "byteLength");
    return g->bin + (size_t)num(v, "byteOffset");
}

static void an_unchanged_texture_is_embedded_as_its_own_file(void **state)
{
    (void)state;
    sv_mesh *m = leaf_mesh(1, 40);
    /* the writer never decodes it: a JPEG's signature and some bytes do */
    static const uint8_t jpeg[] = {0xFF, 0xD8, 0xFF, 0xE0, 1, 2, 3, 4, 5, 6, 7, 0xFF, 0xD9};
    assert_int_equal(sv_image_set_source(&m->images[0], jpeg, sizeof jpeg, NULL), SV_OK);
    sv_gltf_lod lod = {.name = "a", .mesh = m};
    uint8_t *buf;
    size_t size, len;
    const char *mime;
    glb g = encode(&lod, 1, &buf, &size);
    const uint8_t *img = first_image(&g, &mime, &len);
    assert_string_equal(mime, "image/jpeg");
    assert_int_equal(len, sizeof jpeg);
    assert_memory_equal(img, jpeg, sizeof jpeg);
    cJSON_Delete(g.json);
    free(buf);
    /* a copy of the image (another level's mesh) keeps it */
    sv_image copy;
    assert_int_equal(sv_image_copy(&m->images[0], &copy, NULL), SV_OK);
    const uint8_t *src;
    size_t n;
    assert_true(sv_image_source(&copy, &src, &n, &mime));
    assert_int_equal(n, sizeof jpeg);
    sv_image_free(&copy);
    /* pixels changed in place: the file no longer says them, PNG it is */
    ((uint8_t *)m->images[0].data)[5] ^= 1;
    g = encode(&lod, 1, &buf, &size);
    img = first_image(&g, &mime, &len);
    assert_string_equal(mime, "image/png");
    assert_memory_equal(img, "\x89PNG", 4);
    cJSON_Delete(g.json);
    free(buf);
    /* new pixels (a reduced texture) have no source; nor has a TGA */
    ((uint8_t *)m->images[0].data)[5] ^= 1;
    assert_true(sv_image_source(&m->images[0], &src, &n, &mime));
    assert_int_equal(sv_image_reduce(&m->images[0], 8, NULL), SV_OK);
    assert_false(sv_image_source(&m->images[0], &src, &n, &mime));
    static const uint8_t tga[] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(sv_image_set_source(&m->images[0], tga, sizeof tga, NULL), SV_OK);
    assert_false(sv_image_source(&m->images[0], &src, &n, &mime));
    sv_mesh_destroy(m);
}

static void lod_group_is_one_root_with_every_level_as_a_named_child(void **state)
{
    (void)state;
    sv_mesh *a = leaf_mesh(3, 10), *b = leaf_mesh(1, 20);
    cJSON *ea = cJSON_CreateObject(), *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(ea, "switch_distance", 12.5);
    cJSON_AddNumberToObject(root, "fov_deg", 60);
    sv_gltf_lod lods[2] = {{.name = "oak_LOD0", .mesh = a, .screen_coverage = 0.5, .extras = ea},
                           {.name = "oak_LOD1", .mesh = b, .translation = {1, 2, 3}}};
    sv_gltf_group grp = {"oak", root};
    uint8_t *buf = NULL;
    size_t size = 0;
    sv_error err = {0};
    assert_int_equal(sv_gltf_encode_group_glb(&grp, lods, 2, &buf, &size, &err), SV_OK);
    glb g = parse_glb(buf, size);
    cJSON *scene_nodes = get(at(get(g.json, "scenes"), 0), "nodes");
    assert_int_equal(cJSON_GetArraySize(scene_nodes), 1);
    cJSON *nodes = get(g.json, "nodes");
    assert_int_equal(cJSON_GetArraySize(nodes), 3);
    cJSON *r = at(nodes, at(scene_nodes, 0)->valueint);
    assert_string_equal(get(r, "name")->valuestring, "oak");
    assert_float_equal(num(get(r, "extras"), "fov_deg"), 60, 0);
    assert_null(get(r, "mesh"));
    cJSON *ch = get(r, "children");
    assert_int_equal(cJSON_GetArraySize(ch), 2);
    cJSON *n0 = at(nodes, at(ch, 0)->valueint), *n1 = at(nodes, at(ch, 1)->valueint);
    assert_string_equal(get(n0, "name")->valuestring, "oak_LOD0");
    assert_string_equal(get(n1, "name")->valuestring, "oak_LOD1");
    assert_float_equal(num(get(n0, "extras"), "switch_distance"), 12.5, 0);
    assert_non_null(get(n0, "mesh"));
    assert_non_null(get(n1, "mesh"));
    assert_float_equal(at(get(n1, "translation"), 2)->valuedouble, 3, 0);
    /* no MSFT_lod: every level an ordinary node */
    assert_null(get(n0, "extensions"));
    assert_null(get(get(n0, "extras"), "MSFT_screencoverage"));
    assert_null(get(g.json, "extensionsUsed"));
    cJSON_Delete(g.json);
    free(buf);
    /* a level without a name cannot be grouped */
    lods[1].name = NULL;
    assert_int_equal(sv_gltf_encode_group_glb(&grp, lods, 2, &buf, &size, &err), SV_ERR_INVALID);
    assert_null(buf);
    cJSON_Delete(ea);
    cJSON_Delete(root);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
}

static uint8_t *read_all(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *d = malloc(len > 0 ? (size_t)len : 1);
    *n = d ? fread(d, 1, (size_t)len, f) : 0;
    fclose(f);
    return d;
}

/* Meshes, triangles and base-colour textures (that exist in dir) of node n
 * and its children (assimp's FBX exporter writes a level's meshes after the
 * first as child models). */
static void count_node(const struct aiScene *s, const struct aiNode *n, const char *dir,
                       unsigned *meshes, unsigned *tris, unsigned *textured)
{
    for (unsigned k = 0; k < n->mNumMeshes; k++) {
        const struct aiMesh *mm = s->mMeshes[n->mMeshes[k]];
        (*meshes)++;
        *tris += mm->mNumFaces;
        struct aiString tex;
        if (aiGetMaterialTexture(s->mMaterials[mm->mMaterialIndex], aiTextureType_DIFFUSE, 0, &tex,
                                 NULL, NULL, NULL, NULL, NULL, NULL) == aiReturn_SUCCESS) {
            char tp[1200];
            snprintf(tp, sizeof tp, "%s/%s", dir, tex.data);
            assert_int_equal(access(tp, R_OK), 0);
            (*textured)++;
        }
    }
    for (unsigned k = 0; k < n->mNumChildren; k++)
        count_node(s, n->mChildren[k], dir, meshes, tris, textured);
}

static void lod_group_fbx_reimports_with_its_levels_and_textures(void **state)
{
    (void)state;
    char dir[] = "/tmp/sv_fbx_XXXXXX";
    assert_non_null(mkdtemp(dir));
    sv_mesh *a = leaf_mesh(3, 10), *b = leaf_mesh(1, 20);
    sv_gltf_lod lods[2] = {{.name = "oak_LOD0", .mesh = a, .mesh_name = "full"},
                           {.name = "oak_LOD1", .mesh = b, .mesh_name = "clusters"}};
    sv_error err = {0};
    assert_int_equal(sv_fbx_write(dir, "lods.fbx", "oak", lods, 2, NULL, 0, &err), SV_OK);
    char path[256], path2[256];
    snprintf(path, sizeof path, "%s/lods.fbx", dir);
    const struct aiScene *s = aiImportFile(path, 0);
    if (!s) fail_msg("assimp cannot read the FBX back: %s", aiGetErrorString());
    const struct aiNode *root = s->mRootNode; /* assimp's own root node above ours */
    for (unsigned k = 0; k < s->mRootNode->mNumChildren; k++)
        if (strcmp(s->mRootNode->mChildren[k]->mName.data, "oak") == 0)
            root = s->mRootNode->mChildren[k];
    assert_string_equal(root->mName.data, "oak");
    assert_int_equal(root->mNumChildren, 2);
    const char *names[2] = {"oak_LOD0", "oak_LOD1"};
    unsigned tris[2] = {7, 3};
    for (int i = 0; i < 2; i++) {
        const struct aiNode *n = root->mChildren[i];
        assert_string_equal(n->mName.data, names[i]);
        unsigned meshes = 0, t = 0, textured = 0;
        count_node(s, n, dir, &meshes, &t, &textured);
        assert_int_equal(meshes, 2); /* leaf and bark */
        assert_int_equal(t, tris[i]);
        assert_int_equal(textured, 1);
    }
    aiReleaseImport(s);
    /* the same levels, the same bytes: assimp stamps the local time, which
     * another time zone moves by hours (no waiting for the clock) */
    const char *tz = getenv("TZ");
    char saved[64] = "";
    if (tz) snprintf(saved, sizeof saved, "%s", tz);
    setenv("TZ", "XXX-5:30", 1);
    tzset();
    assert_int_equal(sv_fbx_write(dir, "again.fbx", "oak", lods, 2, NULL, 0, &err), SV_OK);
    if (tz) setenv("TZ", saved, 1);
    else unsetenv("TZ");
    tzset();
    snprintf(path2, sizeof path2, "%s/again.fbx", dir);
    size_t n1, n2;
    uint8_t *f1 = read_all(path, &n1), *f2 = read_all(path2, &n2);
    assert_non_null(f1);
    assert_non_null(f2);
    assert_int_equal(n1, n2);
    assert_memory_equal(f1, f2, n1);
    free(f1);
    free(f2);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(translation_is_written_with_every_digit_on_each_node),
        cmocka_unit_test(glb_container_has_aligned_chunks_and_exact_lengths),
        cmocka_unit_test(only_the_finest_lod_is_in_the_scene_and_coarser_ones_are_msft_lod_ids),
        cmocka_unit_test(position_accessor_has_exact_min_max_and_counts),
        cmocka_unit_test(each_used_material_gets_one_primitive_with_its_triangles),
        cmocka_unit_test(mask_material_has_cutoff_texture_and_pbr_defaults),
        cmocka_unit_test(identical_images_are_stored_once_across_lods),
        cmocka_unit_test(normals_are_written_unit_length),
        cmocka_unit_test(extra_vertex_attributes_are_written_under_their_names),
        cmocka_unit_test(large_primitives_are_split_into_runs_with_16_bit_indices),
        cmocka_unit_test(primitives_whose_vertices_fit_get_16_bit_indices),
        cmocka_unit_test(levels_share_the_buffer_views_their_data_begins),
        cmocka_unit_test(a_reduced_texture_is_its_original_in_a_file_that_holds_it),
        cmocka_unit_test(two_writes_of_the_same_lods_are_byte_identical),
        cmocka_unit_test(out_of_range_index_is_refused_with_a_message),
        cmocka_unit_test(empty_lod_becomes_a_node_without_a_mesh),
        cmocka_unit_test(standalone_level_is_one_named_node_with_embedded_images),
        cmocka_unit_test(identical_vertices_are_written_once),
        cmocka_unit_test(a_level_without_source_normals_merges_on_position),
        cmocka_unit_test(uvs_without_a_texture_are_left_out),
        cmocka_unit_test(quantized_and_meshopt_geometry_decode_to_the_mesh),
        cmocka_unit_test(opaque_colour_textures_are_jpeg),
        cmocka_unit_test(an_unchanged_texture_is_embedded_as_its_own_file),
        cmocka_unit_test(lod_group_is_one_root_with_every_level_as_a_named_child),
        cmocka_unit_test(lod_group_fbx_reimports_with_its_levels_and_textures),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
