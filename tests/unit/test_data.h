/* Reading the shared trees in the cmocka unit tests (include after
 * test_skip.h): one whole file into memory. */
#ifndef SV_TEST_DATA_H
#define SV_TEST_DATA_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The whole file at path (malloc'd, *size bytes), or NULL when it cannot be
 * opened or read. */
static inline uint8_t *sv_test_read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc(n > 0 ? (size_t)n : 1);
    if (b && n > 0 && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *size = n > 0 ? (size_t)n : 0;
    return b;
}

/* The file `rel` under the shared data folder `data`, read whole (NULL when
 * it cannot be read). */
static inline uint8_t *sv_test_read_data(const char *data, const char *rel, size_t *size)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", data, rel);
    return sv_test_read_all(path, size);
}

/* One row of tests/data/trees.tsv, the one table of the shared trees that
 * the shell tests, the benchmarks and these unit tests read. */
typedef struct sv_test_tree {
    char dir[96], file[96];
    double unit_scale;  /* import.unit_scale: 0.01 for "cm", else 0 (as given) */
    uint32_t triangles; /* the data README's counts */
    uint32_t foliage;
    uint32_t textures;           /* base-colour textures the import decodes */
    char material[64];           /* one material test_import checks: */
    uint32_t material_triangles; /* its README count */
    char alpha[16];              /* and its alpha mode after import: opaque, mask, blend */
} sv_test_tree;

/* Nonzero under SYLVA_TREES=small (the sanitizer pass): the tree tables keep
 * the trees tests/integration/lib.inc's trees() keeps, the OBJ trees of at most
 * 10,000 triangles and the GLB trees of at most 25,000 (OBJ and GLB, metres and
 * centimetres, every alpha mode: every import path, not every tree). */
static inline int sv_test_trees_small(void)
{
    const char *set = getenv("SYLVA_TREES");
    return set && !strcmp(set, "small");
}

/* The fewest rows sv_test_trees must return for the table to count as read:
 * 10 of the whole set, 3 of the small one. */
static inline size_t sv_test_trees_min(void) { return sv_test_trees_small() ? 3 : 10; }

/* Reads tests/data/trees.tsv (from the repository root, where tests run) into
 * out (at most cap rows; under SYLVA_TREES=small only the small trees);
 * returns the number of rows, 0 when it cannot be read. */
static inline size_t sv_test_trees(sv_test_tree *out, size_t cap)
{
    FILE *f = fopen("tests/data/trees.tsv", "r");
    if (!f) return 0;
    char line[512], units[16];
    size_t n = 0;
    while (n < cap && fgets(line, sizeof line, f)) {
        sv_test_tree *t = &out[n];
        unsigned tri = 0, fol = 0, tex = 0, mtri = 0;
        memset(t, 0, sizeof *t);
        if (line[0] == '#' ||
            sscanf(line, "%95[^\t]\t%95[^\t]\t%15[^\t]\t%u\t%u\t%u\t%63[^\t]\t%u\t%15[^\t\n]",
                   t->dir, t->file, units, &tri, &fol, &tex, t->material, &mtri, t->alpha) != 9)
            continue;
        const char *x = strrchr(t->file, '.');
        int glb = x && !strcmp(x, ".glb");
        if (sv_test_trees_small() && !(tri <= 10000 || (glb && tri <= 25000))) continue;
        t->unit_scale = units[0] == 'c' && units[1] == 'm' && !units[2] ? 0.01 : 0;
        t->triangles = tri;
        t->foliage = fol;
        t->textures = tex;
        t->material_triangles = mtri;
        n++;
    }
    fclose(f);
    return n;
}

#endif
