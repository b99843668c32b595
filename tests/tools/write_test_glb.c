/* write_test_glb.c — writes GLB files that exercise every feature of the glTF
 * writer (gltf.h), for tests/integration/gltf_validator.sh to check with the
 * Khronos validator.
 *
 * usage: write_test_glb OUT_DIR
 * writes OUT_DIR/chain3.glb   3 LODs (MSFT_lod): textured MASK leaves, a bark
 *                             material with normal + occlusion textures, a BLEND
 *                             material, extra attributes _ORDER/_LEAF_CENTRE,
 *                             a texture shared between LODs
 *        OUT_DIR/large.glb    one opaque LOD with > 65535 vertices (uint32 indices)
 *        OUT_DIR/culled.glb   2 LODs, the coarsest empty (node without a mesh)
 *        OUT_DIR/lod<i>_<name>.glb  each level of chain3 standalone
 *                             (sv_gltf_write_level_glb), as a bake writes them
 *        OUT_DIR/chain3_quantize.glb, chain3_meshopt.glb, large_meshopt.glb
 *                             the same with output.compress's encodings
 *                             (KHR_mesh_quantization; then EXT_meshopt_compression)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gltf.h"

/* xorshift64*: deterministic leaf placement. */
static double rnd(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

static int fill_image(sv_image *img, uint32_t size, uint32_t channels, int kind)
{
    if (sv_image_alloc(img, size, size, channels, 8, NULL) != SV_OK) return -1;
    uint8_t *p = img->data;
    for (uint32_t y = 0; y < size; y++)
        for (uint32_t x = 0; x < size; x++, p += channels) {
            double u = (x + 0.5) / size - 0.5, v = (y + 0.5) / size - 0.5;
            if (kind == 0) { /* leaf: ellipse mask, green */
                bool in = u * u * 4.0 + v * v * 1.2 < 0.28;
                p[0] = (uint8_t)(40 + 60 * (u + 0.5));
                p[1] = (uint8_t)(120 + 80 * (v + 0.5));
                p[2] = 30;
                p[3] = in ? 255 : 0;
            } else if (kind == 1) { /* bark colour stripes */
                p[0] = (uint8_t)(90 + 30 * ((x / 4) % 2));
                p[1] = 60;
                p[2] = 40;
            } else if (kind == 2) { /* flat normal map with a ripple */
                p[0] = (uint8_t)(128 + 40 * sin(6.28 * u * 4));
                p[1] = 128;
                p[2] = 250;
            } else { /* occlusion: darker towards the bottom */
                p[0] = (uint8_t)(255 - 100 * (v + 0.5));
            }
        }
    return 0;
}

/* Leaves: `leaves` quads scattered in a crown; plus a bark cylinder (material 1,
 * normal + occlusion maps) and a BLEND "haze" triangle (material 2). */
static sv_mesh *tree(uint32_t leaves, uint32_t bark_segments, uint64_t seed)
{
    uint32_t bark_v = 2 * (bark_segments + 1);
    sv_mesh *m = sv_mesh_create(4 * leaves + bark_v + 3, 2 * leaves + 2 * bark_segments + 1, 3, 4);
    if (!m) return NULL;
    uint64_t s = seed;
    for (uint32_t l = 0; l < leaves; l++) {
        double c[3] = {rnd(&s) * 2 - 1, 2 + rnd(&s) * 2, rnd(&s) * 2 - 1};
        double a = rnd(&s) * 6.283, h = 0.15;
        double ux = cos(a) * h, uz = sin(a) * h;
        static const double q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int i = 0; i < 4; i++) {
            uint32_t v = 4 * l + i;
            m->positions[3 * v] = (float)(c[0] + q[i][0] * ux);
            m->positions[3 * v + 1] = (float)(c[1] + q[i][1] * h);
            m->positions[3 * v + 2] = (float)(c[2] + q[i][0] * uz);
            m->normals[3 * v] = (float)-sin(a);
            m->normals[3 * v + 2] = (float)cos(a);
            m->uvs[2 * v] = (float)(0.5 + 0.5 * q[i][0]);
            m->uvs[2 * v + 1] = (float)(0.5 - 0.5 * q[i][1]);
        }
        uint32_t b = 4 * l, *t = &m->indices[6 * l];
        t[0] = b, t[1] = b + 1, t[2] = b + 2, t[3] = b, t[4] = b + 2, t[5] = b + 3;
    }
    uint32_t v0 = 4 * leaves, t0 = 2 * leaves;
    for (uint32_t k = 0; k <= bark_segments; k++) {
        double a = 6.283185307179586 * k / bark_segments;
        for (int j = 0; j < 2; j++) {
            uint32_t v = v0 + 2 * k + j;
            m->positions[3 * v] = (float)(0.12 * cos(a));
            m->positions[3 * v + 1] = (float)(j * 2.5);
            m->positions[3 * v + 2] = (float)(0.12 * sin(a));
            m->normals[3 * v] = (float)cos(a);
            m->normals[3 * v + 2] = (float)sin(a);
            m->uvs[2 * v] = (float)k / bark_segments;
            m->uvs[2 * v + 1] = (float)(1 - j);
        }
    }
    for (uint32_t k = 0; k < bark_segments; k++) {
        uint32_t a = v0 + 2 * k, *t = &m->indices[3 * (t0 + 2 * k)];
        t[0] = a, t[1] = a + 3, t[2] = a + 2, t[3] = a, t[4] = a + 1, t[5] = a + 3;
        m->tri_material[t0 + 2 * k] = m->tri_material[t0 + 2 * k + 1] = 1;
    }
    uint32_t hv = v0 + bark_v, ht = t0 + 2 * bark_segments;
    static const float haze[3][3] = {{-1, 0.1f, -1}, {1, 0.1f, -1}, {0, 0.1f, 1}};
    for (int i = 0; i < 3; i++) {
        memcpy(&m->positions[3 * (hv + i)], haze[i], sizeof haze[i]);
        m->normals[3 * (hv + i) + 1] = 1;
        m->indices[3 * ht + i] = hv + (uint32_t)i;
    }
    m->tri_material[ht] = 2;
    sv_material *leaf = &m->materials[0], *bark = &m->materials[1], *hz = &m->materials[2];
    snprintf(leaf->name, sizeof leaf->name, "leaves");
    leaf->base_texture = 0;
    leaf->alpha_mode = SV_ALPHA_MASK;
    leaf->alpha_cutoff = 0.5f;
    leaf->double_sided = true;
    snprintf(bark->name, sizeof bark->name, "bark");
    bark->base_texture = 1;
    bark->normal_texture = 2;
    bark->occlusion_texture = 3;
    snprintf(hz->name, sizeof hz->name, "haze");
    hz->alpha_mode = SV_ALPHA_BLEND;
    hz->base_color[3] = 0.4f;
    if (fill_image(&m->images[0], 64, 4, 0) || fill_image(&m->images[1], 32, 3, 1) ||
        fill_image(&m->images[2], 32, 3, 2) || fill_image(&m->images[3], 16, 1, 3)) {
        sv_mesh_destroy(m);
        return NULL;
    }
    return m;
}

/* Crossed quads: two vertical quads through the trunk axis with a leaf atlas. */
static sv_mesh *crossed(void)
{
    sv_mesh *m = sv_mesh_create(8, 4, 1, 1);
    if (!m) return NULL;
    for (int q = 0; q < 2; q++)
        for (int i = 0; i < 4; i++) {
            uint32_t v = 4 * q + i;
            double s = (i == 0 || i == 3) ? -1.2 : 1.2, y = i < 2 ? 0.0 : 4.0;
            m->positions[3 * v] = (float)(q ? 0 : s);
            m->positions[3 * v + 1] = (float)y;
            m->positions[3 * v + 2] = (float)(q ? s : 0);
            m->normals[3 * v + (q ? 0 : 2)] = 1;
            m->uvs[2 * v] = (float)(0.5 * q + (s > 0 ? 0.5 : 0.0));
            m->uvs[2 * v + 1] = (float)(y > 0 ? 0.0 : 1.0);
        }
    for (uint32_t q = 0; q < 2; q++) {
        uint32_t b = 4 * q, *t = &m->indices[6 * q];
        t[0] = b, t[1] = b + 1, t[2] = b + 2, t[3] = b, t[4] = b + 2, t[5] = b + 3;
    }
    sv_material *a = &m->materials[0];
    snprintf(a->name, sizeof a->name, "atlas");
    a->base_texture = 0;
    a->alpha_mode = SV_ALPHA_MASK;
    a->double_sided = true;
    if (fill_image(&m->images[0], 128, 4, 0)) {
        sv_mesh_destroy(m);
        return NULL;
    }
    return m;
}

static int write(const char *dir, const char *name, const sv_gltf_lod *lods, uint32_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    sv_error err = {0};
    if (sv_gltf_write_glb(path, lods, n, &err) != SV_OK) {
        fprintf(stderr, "write_test_glb: %s: %s\n", path, err.message);
        return 1;
    }
    printf("%s\n", path);
    return 0;
}

/* Writes lods[i] alone as dir/lod<i>_<mesh name or name>.glb. */
static int write_levels(const char *dir, const sv_gltf_lod *lods, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/lod%u_%s.glb", dir, i,
                 lods[i].mesh_name ? lods[i].mesh_name : lods[i].name);
        sv_error err = {0};
        if (sv_gltf_write_level_glb(path, &lods[i], &err) != SV_OK) {
            fprintf(stderr, "write_test_glb: %s: %s\n", path, err.message);
            return 1;
        }
        printf("%s\n", path);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: write_test_glb OUT_DIR\n");
        return 2;
    }
    int rc = 1;
    sv_mesh *full = tree(400, 16, 1), *half = tree(200, 8, 1), *cards = crossed();
    sv_mesh *big = tree(17000, 64, 7), *empty = sv_mesh_create(0, 0, 0, 0);
    float *order = NULL, *centre = NULL;
    if (!full || !half || !cards || !big || !empty) goto out;
    order = calloc(full->vertex_count, sizeof *order);
    centre = calloc((size_t)full->vertex_count * 3, sizeof *centre);
    if (!order || !centre) goto out;
    for (uint32_t v = 0; v < full->vertex_count; v++) {
        uint32_t leaf = v / 4;
        order[v] = (float)leaf;
        if (v < 4 * 400) {
            for (int k = 0; k < 3; k++) {
                double c = 0;
                for (int i = 0; i < 4; i++) c += full->positions[3 * (4 * leaf + i) + k];
                centre[3 * v + k] = (float)(c / 4);
            }
        }
    }
    sv_gltf_attribute attrs[2] = {{"_ORDER", order, 1}, {"_LEAF_CENTRE", centre, 3}};
    sv_gltf_lod chain[3] = {
        {"tree_LOD0", full, 0.5, attrs, 2, NULL, "full", {0, 0, 0}, SV_GLTF_FLOAT, false},
        {"half", half, 0.2, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
        {"crossed_quads", cards, 0.02, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    sv_gltf_lod large[1] = {{"large", big, 0.0, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    sv_gltf_lod culled[2] = {{"cards", cards, 0.05, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false},
                             {"culled", empty, 0.0, NULL, 0, NULL, NULL, {0, 0, 0}, SV_GLTF_FLOAT, false}};
    rc = write(argv[1], "chain3.glb", chain, 3) || write(argv[1], "large.glb", large, 1) ||
         write(argv[1], "culled.glb", culled, 2) || write_levels(argv[1], chain, 3);
    for (int c = SV_GLTF_QUANTIZE; !rc && c <= SV_GLTF_MESHOPT; c++) {
        for (int i = 0; i < 3; i++) chain[i].compress = (sv_gltf_compress)c;
        large[0].compress = (sv_gltf_compress)c;
        rc = write(argv[1], c == SV_GLTF_QUANTIZE ? "chain3_quantize.glb" : "chain3_meshopt.glb",
                   chain, 3) ||
             (c == SV_GLTF_MESHOPT && write(argv[1], "large_meshopt.glb", large, 1));
    }
out:
    if (rc && (!full || !half || !cards || !big || !empty || !order || !centre))
        fprintf(stderr, "write_test_glb: out of memory\n");
    free(order);
    free(centre);
    sv_mesh_destroy(full);
    sv_mesh_destroy(half);
    sv_mesh_destroy(cards);
    sv_mesh_destroy(big);
    sv_mesh_destroy(empty);
    return rc;
}
