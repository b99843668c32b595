/* sylva-test: cost=10 (tests/run.sh starts the longest first) */
/* test_classify.c — foliage vs trunk and leaf elements (core/geom/classify.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_data.h"
#include "test_skip.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"
#include "import.h"

/* ---------- a tiny mesh builder ---------- */

typedef struct builder {
    float pos[3 * 20000];
    uint32_t idx[3 * 20000];
    uint32_t mat[20000];
    uint32_t nv, nt;
    double scale, offset[3];
} builder;

static builder *builder_new(void)
{
    builder *b = calloc(1, sizeof *b);
    assert_non_null(b);
    b->scale = 1;
    return b;
}

static uint32_t vtx(builder *b, double x, double y, double z)
{
    assert_true(b->nv < 20000);
    b->pos[3 * b->nv] = (float)(x * b->scale + b->offset[0]);
    b->pos[3 * b->nv + 1] = (float)(y * b->scale + b->offset[1]);
    b->pos[3 * b->nv + 2] = (float)(z * b->scale + b->offset[2]);
    return b->nv++;
}

static void tri(builder *b, uint32_t a, uint32_t c, uint32_t d, uint32_t m)
{
    assert_true(b->nt < 20000);
    b->idx[3 * b->nt] = a;
    b->idx[3 * b->nt + 1] = c;
    b->idx[3 * b->nt + 2] = d;
    b->mat[b->nt++] = m;
}

/* Quad centre c, half-edge vectors u and v (two triangles, own vertices). */
static void quad(builder *b, const double c[3], const double u[3], const double v[3], uint32_t m)
{
    uint32_t i[4];
    const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; k++)
        i[k] = vtx(b, c[0] + su[k] * u[0] + sv[k] * v[0], c[1] + su[k] * u[1] + sv[k] * v[1],
                   c[2] + su[k] * u[2] + sv[k] * v[2]);
    tri(b, i[0], i[1], i[2], m);
    tri(b, i[0], i[2], i[3], m);
}

/* Closed axis-aligned box (12 triangles, shared vertices). */
static void box(builder *b, const double lo[3], const double hi[3], uint32_t m)
{
    uint32_t v[8];
    for (int k = 0; k < 8; k++)
        v[k] = vtx(b, (k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]);
    static const int f[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (int i = 0; i < 6; i++) {
        tri(b, v[f[i][0]], v[f[i][1]], v[f[i][2]], m);
        tri(b, v[f[i][0]], v[f[i][2]], v[f[i][3]], m);
    }
}

static sv_mesh *build(const builder *b, uint32_t nmat, const char *const *names)
{
    sv_mesh *m = sv_mesh_create(b->nv, b->nt, nmat, 0);
    assert_non_null(m);
    memcpy(m->positions, b->pos, (size_t)b->nv * 3 * sizeof(float));
    memcpy(m->indices, b->idx, (size_t)b->nt * 3 * sizeof(uint32_t));
    memcpy(m->tri_material, b->mat, (size_t)b->nt * sizeof(uint32_t));
    for (uint32_t i = 0; i < nmat; i++)
        snprintf(m->materials[i].name, sizeof m->materials[i].name, "%s", names[i]);
    return m;
}

/* A "tree": a tall trunk box (material 0) and a crown of n leaf quads
 * (material 1) at seeded pseudo-random positions and orientations. */
static void add_tree(builder *b, int n, uint64_t seed)
{
    box(b, (double[]){-0.2, 0, -0.2}, (double[]){0.2, 4, 0.2}, 0);
    for (int i = 0; i < n; i++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        double r1 = (double)(seed >> 40) / (double)(1u << 24);
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        double r2 = (double)(seed >> 40) / (double)(1u << 24);
        double a = 6.283185307179586 * r1, h = 3 + 2 * r2;
        double c[3] = {1.5 * cos(a) * (0.3 + r2), h, 1.5 * sin(a) * (0.3 + r2)};
        double u[3] = {0.1 * cos(a + r2), 0.02, 0.1 * sin(a + r2)};
        double v[3] = {-0.08 * sin(a), 0.05, 0.08 * cos(a)};
        quad(b, c, u, v, 1);
    }
}

static const sv_material_class *mc_of(const sv_classification *c, uint32_t i)
{
    assert_true(i < c->material_count);
    return &c->materials[i];
}

/* ---------- classification ---------- */

static void caller_lists_win_over_names_and_alpha(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 10, 1);
    const char *names[] = {"Leaves", "Bark"}; /* deliberately swapped */
    sv_mesh *m = build(b, 2, names);
    m->materials[1].alpha_mode = SV_ALPHA_MASK;
    const char *fol[] = {"LEAVES"}, *trk[] = {"ba*"};
    sv_classify_options opt = {.foliage = fol, .foliage_count = 1, .trunk = trk, .trunk_count = 1};
    sv_classification c;
    assert_int_equal(sv_classify(m, &opt, &c, NULL), SV_OK);
    assert_int_equal(mc_of(&c, 0)->part, SV_PART_FOLIAGE);
    assert_int_equal(mc_of(&c, 1)->part, SV_PART_TRUNK);
    assert_non_null(strstr(mc_of(&c, 0)->reason, "listed by caller"));
    assert_non_null(strstr(mc_of(&c, 1)->reason, "ba*"));
    assert_int_equal(c.foliage_triangles, 12);
    assert_int_equal(c.trunk_triangles, 20);
    for (uint32_t t = 0; t < m->triangle_count; t++)
        assert_int_equal(c.tri_part[t], m->tri_material[t] == 0 ? SV_PART_FOLIAGE : SV_PART_TRUNK);
    sv_classification_free(&c);
    sv_classification_free(&c); /* freeing twice after the first free is harmless */
    sv_classification_free(NULL);
    sv_mesh_destroy(m);
    free(b);
}

static void names_decide_foliage_and_trunk(void **state)
{
    (void)state;
    const char *names[] = {"OldLeaves",    "Branches", "PotMat", "GroundMat", "branch-card_01",
                           "Pine_Needles", "bark",     "Wood",   "Fern frond"};
    const sv_part want[] = {SV_PART_FOLIAGE, SV_PART_TRUNK,   SV_PART_TRUNK,
                            SV_PART_TRUNK,   SV_PART_FOLIAGE, SV_PART_FOLIAGE,
                            SV_PART_TRUNK,   SV_PART_TRUNK,   SV_PART_FOLIAGE};
    builder *b = builder_new();
    for (uint32_t i = 0; i < 9; i++)
        quad(b, (double[]){(double)i, 0, 0}, (double[]){0.3, 0, 0}, (double[]){0, 0.3, 0}, i);
    sv_mesh *m = build(b, 9, names);
    sv_classification c;
    assert_int_equal(sv_classify(m, NULL, &c, NULL), SV_OK);
    for (uint32_t i = 0; i < 9; i++) {
        assert_int_equal(mc_of(&c, i)->part, want[i]);
        assert_non_null(strstr(mc_of(&c, i)->reason, "name contains"));
        assert_int_equal(mc_of(&c, i)->triangles, 2);
    }
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void alpha_blend_material_is_foliage_whatever_its_name(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 5, 2);
    const char *names[] = {"mat0", "trunk_like_name"};
    sv_mesh *m = build(b, 2, names);
    m->materials[1].alpha_mode = SV_ALPHA_BLEND;
    sv_classification c;
    assert_int_equal(sv_classify(m, NULL, &c, NULL), SV_OK);
    assert_int_equal(mc_of(&c, 1)->part, SV_PART_FOLIAGE);
    assert_string_equal(mc_of(&c, 1)->reason, "alpha mode BLEND");
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void cut_out_texture_makes_a_branch_material_foliage(void **state)
{
    (void)state;
    /* Bonsai case: "branch1" is an alpha card whose file never said so. */
    builder *b = builder_new();
    add_tree(b, 5, 3);
    const char *names[] = {"bark", "branch1"};
    sv_mesh *m = build(b, 2, names);
    sv_mesh *grown = sv_mesh_create(m->vertex_count, m->triangle_count, 2, 1);
    assert_non_null(grown);
    memcpy(grown->positions, m->positions, (size_t)m->vertex_count * 3 * sizeof(float));
    memcpy(grown->indices, m->indices, (size_t)m->triangle_count * 3 * sizeof(uint32_t));
    memcpy(grown->tri_material, m->tri_material, (size_t)m->triangle_count * sizeof(uint32_t));
    memcpy(grown->materials, m->materials, 2 * sizeof(sv_material));
    sv_mesh_destroy(m);
    m = grown;
    assert_int_equal(sv_image_alloc(&m->images[0], 8, 8, 4, 8, NULL), SV_OK);
    uint8_t *px = m->images[0].data;
    for (int i = 0; i < 64; i++) px[4 * i + 3] = (i % 8) < 4 ? 255 : 0; /* half transparent */
    m->materials[1].base_texture = 0;
    sv_classification c;
    assert_int_equal(sv_classify(m, NULL, &c, NULL), SV_OK);
    assert_int_equal(mc_of(&c, 1)->part, SV_PART_FOLIAGE);
    assert_non_null(strstr(mc_of(&c, 1)->reason, "cut-out alpha (50%"));
    sv_classification_free(&c);
    /* The same texture made opaque: the name rule says trunk. */
    for (int i = 0; i < 64; i++) px[4 * i + 3] = 255;
    assert_int_equal(sv_classify(m, NULL, &c, NULL), SV_OK);
    assert_int_equal(mc_of(&c, 1)->part, SV_PART_TRUNK);
    assert_non_null(strstr(mc_of(&c, 1)->reason, "'branch'"));
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void unnamed_small_flat_pieces_are_foliage_and_solids_are_trunk(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 60, 4);
    /* a third unnamed material: one big flat ground sheet (large → trunk) */
    quad(b, (double[]){0, 0, 0}, (double[]){3, 0, 0}, (double[]){0, 0, 3}, 2);
    const char *names[] = {"Material.001", "Material.002", "Material.003"};
    sv_mesh *m = build(b, 3, names);
    sv_classification c;
    assert_int_equal(sv_classify(m, NULL, &c, NULL), SV_OK);
    assert_int_equal(mc_of(&c, 0)->part, SV_PART_TRUNK);
    assert_int_equal(mc_of(&c, 1)->part, SV_PART_FOLIAGE);
    assert_int_equal(mc_of(&c, 2)->part, SV_PART_TRUNK);
    assert_non_null(strstr(mc_of(&c, 1)->reason, "components: 100% of its triangles in 60"));
    assert_non_null(strstr(mc_of(&c, 0)->reason, "components: only 0%"));
    assert_int_equal(c.foliage_triangles, 120);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void bad_material_index_is_rejected_with_its_triangle(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 2, 5);
    const char *names[] = {"bark", "leaf"};
    sv_mesh *m = build(b, 2, names);
    m->tri_material[13] = 7;
    sv_classification c;
    sv_error e = {0};
    assert_int_equal(sv_classify(m, NULL, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "triangle 13"));
    assert_null(c.tri_part);
    sv_mesh_destroy(m);
    free(b);
}

/* ---------- leaf elements ---------- */

static sv_mesh *leaf_mesh(const builder *b)
{
    const char *names[] = {"bark", "leaves"};
    return build(b, 2, names);
}

static void build_leaves(const sv_mesh *m, sv_classification *c, sv_leaves *l)
{
    assert_int_equal(sv_classify(m, NULL, c, NULL), SV_OK);
    assert_int_equal(sv_leaves_build(m, c, l, NULL), SV_OK);
}

static void back_to_back_quads_keep_a_unit_normal(void **state)
{
    (void)state;
    builder *b = builder_new();
    /* One two-sided leaf as two coincident quads of opposite winding, welded. */
    uint32_t v[4] = {vtx(b, 0, 0, 0), vtx(b, 1, 0, 0), vtx(b, 1, 0, 1), vtx(b, 0, 0, 1)};
    tri(b, v[0], v[1], v[2], 1);
    tri(b, v[0], v[2], v[3], 1);
    tri(b, v[0], v[2], v[1], 1);
    tri(b, v[0], v[3], v[2], 1);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 1);
    const sv_leaf *f = &l.leaves[0];
    assert_int_equal(f->count, 4);
    assert_true(fabs(fabs(f->normal[1]) - 1) < 1e-12);
    assert_true(fabs(f->area - 2) < 1e-12);
    assert_true(fabs(f->centre[0] - 0.5) < 1e-12 && fabs(f->centre[2] - 0.5) < 1e-12);
    assert_true(fabs(f->radius - sqrt(0.5)) < 1e-9);
    sv_leaves_free(&l);
    sv_leaves_free(NULL);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void back_to_back_leaf_tilted_apart_averages_after_flipping(void **state)
{
    (void)state;
    /* Front face up (+Y); back face hinged on the x = 0 edge, tilted 10° and
     * wound the other way. Summed as they are, the normals would almost
     * cancel into a horizontal vector; flipped first they average to ~5° off +Y. */
    builder *b = builder_new();
    double c10 = cos(10 * M_PI / 180), s10 = sin(10 * M_PI / 180);
    uint32_t v0 = vtx(b, 0, 0, 0), v1 = vtx(b, 1, 0, 0), v2 = vtx(b, 1, 0, 1), v3 = vtx(b, 0, 0, 1);
    uint32_t w1 = vtx(b, c10, s10, 0), w2 = vtx(b, c10, s10, 1);
    tri(b, v0, v2, v1, 1); /* (0,0,0),(1,0,1),(1,0,0): normal +Y */
    tri(b, v0, v3, v2, 1);
    tri(b, v0, w1, w2, 1); /* reversed: normal ≈ -Y tilted */
    tri(b, v0, w2, v3, 1);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 1);
    const double *n = l.leaves[0].normal;
    assert_true(fabs(n[1]) > cos(6 * M_PI / 180));
    assert_true(fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) < 1e-12);
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void single_triangle_is_one_leaf(void **state)
{
    (void)state;
    builder *b = builder_new();
    tri(b, vtx(b, 0, 0, 0), vtx(b, 2, 0, 0), vtx(b, 0, 2, 0), 1);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 1);
    assert_int_equal(l.tri_count, 1);
    assert_int_equal(l.tris[0], 0);
    assert_true(fabs(l.leaves[0].normal[2] - 1) < 1e-12);
    assert_true(fabs(l.leaves[0].area - 2) < 1e-12);
    assert_true(fabs(l.leaves[0].centre[0] - 2.0 / 3) < 1e-12);
    assert_int_equal(l.split, 0);
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void no_foliage_gives_no_leaves_and_no_error(void **state)
{
    (void)state;
    builder *b = builder_new();
    box(b, (double[]){0, 0, 0}, (double[]){1, 1, 1}, 0);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 0);
    assert_null(l.leaves);
    assert_int_equal(l.tri_count, 0);
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void leaves_are_connected_pieces_welded_by_position_in_order(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 30, 6); /* each quad has its own 4 vertices: 30 leaves */
    /* A leaf whose two triangles do not share vertex indices, only positions. */
    uint32_t a = vtx(b, 9, 9, 9), c0 = vtx(b, 9.1, 9, 9), d = vtx(b, 9.1, 9.1, 9);
    uint32_t a2 = vtx(b, 9, 9, 9), d2 = vtx(b, 9.1, 9.1, 9), e = vtx(b, 9, 9.1, 9);
    tri(b, a, c0, d, 1);
    box(b, (double[]){5, 0, 5}, (double[]){5.2, 1, 5.2}, 0); /* trunk in between */
    tri(b, a2, d2, e, 1);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 31);
    assert_int_equal(l.tri_count, 62);
    for (uint32_t i = 0; i < l.count; i++) {
        const sv_leaf *f = &l.leaves[i];
        assert_int_equal(f->count, 2);
        double n2 = f->normal[0] * f->normal[0] + f->normal[1] * f->normal[1] +
                    f->normal[2] * f->normal[2];
        assert_true(fabs(n2 - 1) < 1e-12);
        if (i) assert_true(l.tris[f->first] > l.tris[l.leaves[i - 1].first]);
        assert_true(l.tris[f->first] < l.tris[f->first + 1]);
    }
    const sv_leaf *last = &l.leaves[30];
    assert_int_equal(l.tris[last->first], 72); /* after 12 trunk + 60 leaf triangles */
    assert_int_equal(l.tris[last->first + 1], 85);
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void huge_connected_sheet_is_split_into_leaf_sized_pieces(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 40, 7); /* typical leaves: 0.2 × 0.16-ish quads, area ≈ 0.064 */
    /* A 24 × 24 grid sheet of 0.2-sized cells, fully welded: ~36 m², one piece. */
    const int n = 24;
    uint32_t base = b->nv;
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++) vtx(b, 10 + 0.2 * i, 2, 0.2 * j);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            uint32_t a = base + (uint32_t)(i * (n + 1) + j), c0 = a + (uint32_t)(n + 1);
            tri(b, a, a + 1, c0 + 1, 1);
            tri(b, a, c0 + 1, c0, 1);
        }
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.split, 1);
    assert_true(l.count > 40 + 16);
    uint32_t total = 0;
    for (uint32_t i = 0; i < l.count; i++) {
        assert_true(l.leaves[i].area <= 16 * l.median_area + 1e-9);
        total += l.leaves[i].count;
    }
    assert_int_equal(total, l.tri_count);
    assert_int_equal(l.tri_count, 80 + 2 * n * n);
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void welded_crossed_cards_split_into_flat_pieces(void **state)
{
    (void)state;
    builder *b = builder_new();
    add_tree(b, 20, 8);
    /* Two cards crossing at right angles, sharing their two axis vertices. */
    uint32_t top = vtx(b, 20, 0.4, 0), bot = vtx(b, 20, 0, 0);
    uint32_t xa = vtx(b, 19.9, 0.2, 0), xb = vtx(b, 20.1, 0.2, 0);
    uint32_t za = vtx(b, 20, 0.2, -0.1), zb = vtx(b, 20, 0.2, 0.1);
    tri(b, bot, xb, top, 1);
    tri(b, bot, top, xa, 1);
    tri(b, bot, zb, top, 1);
    tri(b, bot, top, za, 1);
    sv_mesh *m = leaf_mesh(b);
    sv_classification c;
    sv_leaves l;
    build_leaves(m, &c, &l);
    assert_int_equal(l.count, 22);
    assert_int_equal(l.split, 1);
    for (uint32_t i = 20; i < 22; i++) {
        const sv_leaf *f = &l.leaves[i];
        assert_int_equal(f->count, 2);
        /* each piece is one flat card: normal along x or along z */
        assert_true(fabs(fabs(f->normal[0]) - 1) < 1e-9 || fabs(fabs(f->normal[2]) - 1) < 1e-9);
    }
    sv_leaves_free(&l);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    free(b);
}

static void offset_and_scale_give_the_same_elements(void **state)
{
    (void)state;
    sv_leaves ref, got;
    sv_classification c;
    builder *b = builder_new();
    add_tree(b, 50, 9);
    sv_mesh *m = leaf_mesh(b);
    build_leaves(m, &c, &ref);
    sv_classification_free(&c);
    sv_mesh_destroy(m);
    /* (offset, scale) pairs; floats at 1e6 resolve 0.0625, so that case uses a
     * 100× larger tree to keep its shape representable. */
    const double cases[2][2] = {{1e6, 100}, {0, 1e-4}};
    for (int k = 0; k < 2; k++) {
        builder *t = builder_new();
        t->scale = cases[k][1];
        t->offset[0] = cases[k][0];
        t->offset[1] = -cases[k][0];
        t->offset[2] = cases[k][0];
        add_tree(t, 50, 9);
        sv_mesh *mt = leaf_mesh(t);
        build_leaves(mt, &c, &got);
        assert_int_equal(got.count, ref.count);
        assert_int_equal(got.split, ref.split);
        double s = cases[k][1];
        /* float input at 1e6 quantises vertices by 1/16: compare relative to the leaf size */
        double tol = k == 0 ? 0.05 : 1e-4;
        for (uint32_t i = 0; i < ref.count; i++) {
            const sv_leaf *a = &ref.leaves[i], *g = &got.leaves[i];
            assert_int_equal(a->count, g->count);
            assert_memory_equal(ref.tris + a->first, got.tris + g->first,
                                a->count * sizeof(uint32_t));
            double dot = 0;
            for (int q = 0; q < 3; q++) {
                dot += a->normal[q] * g->normal[q];
                double off = q == 1 ? -cases[k][0] : cases[k][0];
                assert_true(fabs((g->centre[q] - off) / s - a->centre[q]) < tol * 0.1);
            }
            assert_true(dot > 1 - tol);
            assert_true(fabs(g->area / (s * s) - a->area) < tol * a->area);
        }
        sv_leaves_free(&got);
        sv_classification_free(&c);
        sv_mesh_destroy(mt);
        free(t);
    }
    sv_leaves_free(&ref);
    free(b);
}

/* ---------- the real trees ---------- */

/* the shared trees: tests/data/trees.tsv (test_data.h) */
typedef sv_test_tree tree_case;

/* Imports dir/file with every non-mesh file of dir as a companion. */
static sv_mesh *import_tree(const char *data, const tree_case *tc)
{
    char path[1024];
    sv_file files[16];
    char names[16][256];
    size_t n = 0;
    assert_true(snprintf(path, sizeof path, "%s/%s/%s", data, tc->dir, tc->file) <
                (int)sizeof path);
    files[0].name = tc->file;
    files[0].data = sv_test_read_all(path, &files[0].size);
    assert_non_null(files[0].data);
    n = 1;
    assert_true(snprintf(path, sizeof path, "%s/%s", data, tc->dir) < (int)sizeof path);
    DIR *d = opendir(path);
    assert_non_null(d);
    struct dirent *e;
    while ((e = readdir(d)) && n < 16) {
        const char *x = strrchr(e->d_name, '.');
        if (e->d_name[0] == '.' || !x) continue;
        if (strcmp(x, ".mtl") && strcmp(x, ".png") && strcmp(x, ".jpg")) continue;
        snprintf(names[n], sizeof names[n], "%s", e->d_name);
        if (snprintf(path, sizeof path, "%s/%s/%s", data, tc->dir, e->d_name) >= (int)sizeof path)
            continue;
        files[n].name = names[n];
        files[n].data = sv_test_read_all(path, &files[n].size);
        if (files[n].data) n++;
    }
    closedir(d);
    sv_import_options opt = {.unit_scale = tc->unit_scale};
    sv_mesh *m = NULL;
    sv_error err = {0};
    sv_status st = sv_import(files, n, &opt, &m, NULL, &err);
    if (st) print_error("import %s: %s\n", tc->file, err.message);
    for (size_t i = 0; i < n; i++) free((void *)files[i].data);
    assert_int_equal(st, SV_OK);
    return m;
}

static void every_tree_in_the_data_set_classifies_as_its_readme_says(void **state)
{
    (void)state;
    const char *data = sv_test_data("real-tree classification");
    tree_case trees[32];
    size_t count = sv_test_trees(trees, 32);
    assert_true(count >= sv_test_trees_min()); /* the table is there and read */
    for (size_t i = 0; i < count; i++) {
        const tree_case *tc = &trees[i];
        sv_mesh *m = import_tree(data, tc);
        sv_classification c;
        sv_error err = {0};
        assert_int_equal(sv_classify(m, NULL, &c, &err), SV_OK);
        sv_leaves l;
        assert_int_equal(sv_leaves_build(m, &c, &l, &err), SV_OK);
        print_message("%-30s %6u tris, foliage %6u, %5u leaves (median area %.3g m², %u split)\n",
                      tc->file, m->triangle_count, c.foliage_triangles, l.count, l.median_area,
                      l.split);
        for (uint32_t k = 0; k < c.material_count; k++)
            print_message("    %-16s %-7s %6u  %s\n", m->materials[k].name,
                          c.materials[k].part == SV_PART_FOLIAGE ? "foliage" : "trunk",
                          c.materials[k].triangles, c.materials[k].reason);
        assert_int_equal(m->triangle_count, tc->triangles);
        assert_int_equal(c.foliage_triangles, tc->foliage);
        assert_int_equal(c.trunk_triangles, tc->triangles - tc->foliage);
        assert_int_equal(l.tri_count, tc->foliage);
        assert_true(l.count > 0);
        for (uint32_t k = 0; k < l.count; k++) {
            const double *nv = l.leaves[k].normal;
            assert_true(fabs(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2] - 1) < 1e-9);
        }
        sv_leaves_free(&l);
        sv_classification_free(&c);
        sv_mesh_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(caller_lists_win_over_names_and_alpha),
        cmocka_unit_test(names_decide_foliage_and_trunk),
        cmocka_unit_test(alpha_blend_material_is_foliage_whatever_its_name),
        cmocka_unit_test(cut_out_texture_makes_a_branch_material_foliage),
        cmocka_unit_test(unnamed_small_flat_pieces_are_foliage_and_solids_are_trunk),
        cmocka_unit_test(bad_material_index_is_rejected_with_its_triangle),
        cmocka_unit_test(back_to_back_quads_keep_a_unit_normal),
        cmocka_unit_test(back_to_back_leaf_tilted_apart_averages_after_flipping),
        cmocka_unit_test(single_triangle_is_one_leaf),
        cmocka_unit_test(no_foliage_gives_no_leaves_and_no_error),
        cmocka_unit_test(leaves_are_connected_pieces_welded_by_position_in_order),
        cmocka_unit_test(huge_connected_sheet_is_split_into_leaf_sized_pieces),
        cmocka_unit_test(welded_crossed_cards_split_into_flat_pieces),
        cmocka_unit_test(offset_and_scale_give_the_same_elements),
        cmocka_unit_test(every_tree_in_the_data_set_classifies_as_its_readme_says),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
