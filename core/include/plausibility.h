/* plausibility.h — checks that an imported tree is the size and the way up a
 * tree is (issue 19, item 4): a Z-up source imported as Y-up bakes lying down,
 * a tree in the wrong units becomes 43 m or 4 mm tall, both without a word.
 * Pure geometry on the imported, classified mesh (sylva's frame: +Y up). */
#ifndef SV_PLAUSIBILITY_H
#define SV_PLAUSIBILITY_H

#include "mesh.h"

#define SV_TALLEST_TREE_M 150.0 /* taller than any living tree: wrong units */
#define SV_SMALLEST_TREE_M 0.05 /* shorter than 5 cm: wrong units */

typedef struct sv_up_guess {
    int z_up;         /* +1: looks Z-up (trunk base at the lowest Z), -1: base at the
                          highest Z, 0: looks Y-up or cannot tell */
    double height;    /* extent along the up axis the guess implies, metres */
    char reason[200]; /* why, for warnings and the report */
} sv_up_guess;

#define SV_UP_SLAB 0.05      /* base slab: 5 % of the box's longest side */
#define SV_UP_AREA_RATIO 2.0 /* a Z extreme holds this much more trunk than the lowest Y */
#define SV_UP_LONG 1.5       /* "much longer in Z than in Y" */

/* Decides whether mesh (in sylva's frame, +Y up) looks Z-up, from its trunk
 * triangles (tri_part[t] == SV_PART_TRUNK; tri_part may be NULL: every
 * triangle counts as trunk). The trunk base is where the lowest trunk
 * triangles are: the rule (docs/spec.md, import.up "auto") measures the trunk
 * area of the triangles that reach within SV_UP_SLAB x the box's longest side
 * of the lowest Y, the lowest Z and the highest Z of the bounding box:
 *   - a Z extreme holds more than SV_UP_AREA_RATIO x the trunk area at the
 *     lowest Y: the base is at that Z extreme (+1 lowest Z, -1 highest);
 *   - else, with no trunk at the lowest Y, a box at least SV_UP_LONG x longer
 *     in Z than in Y and trunk triangles spanning SV_UP_LONG x more Z than Y:
 *     the base is at the Z end the trunk comes closer to;
 *   - otherwise Y-up (0), also when there are no trunk triangles.
 * Fills *g (never fails). Pure and deterministic. */
void sv_detect_up(const sv_mesh *mesh, const uint8_t *tri_part, sv_up_guess *g);

/* Rotates the mesh in place so that the base found by sv_detect_up is at the
 * lowest Y: z_up = +1 maps (x, y, z) -> (x, z, -y) (the same as import.up "Z"),
 * -1 maps (x, y, z) -> (x, -z, y); normals alike. z_up = 0 does nothing. */
void sv_mesh_rotate_up(sv_mesh *mesh, int z_up);

/* Appends to buf (a '\n'-separated list, capacity cap, NUL-terminated) one
 * warning per implausibility of a tree of the given height (metres): taller
 * than SV_TALLEST_TREE_M or shorter than SV_SMALLEST_TREE_M, each naming
 * import.units as the fix; and, when g->z_up != 0 and !rotated, that the tree
 * looks lying down, naming import.up. Truncates rather than overflows. */
void sv_plausibility_warnings(const sv_up_guess *g, double height, bool rotated, char *buf,
                              size_t cap);

#endif
