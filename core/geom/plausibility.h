/* plausibility.h — checks that an imported tree is the size and the way up a
 * tree is: a Z-up source imported as Y-up bakes lying down,
 * a tree in the wrong units becomes 43 m or 4 mm tall, both without a word.
 * Pure geometry on the imported, classified mesh (sylva's frame: +Y up). */
#ifndef SV_PLAUSIBILITY_H
#define SV_PLAUSIBILITY_H

#include "classify.h"
#include "mesh.h"

#define SV_TALLEST_TREE_M 150.0 /* taller than any living tree: wrong units */
#define SV_SMALLEST_TREE_M 0.05 /* shorter than 5 cm: wrong units */

typedef struct sv_up_guess {
    int z_up;         /* +1: looks Z-up (trunk root at the lowest Z), -1: root at the
                          highest Z, 0: looks Y-up, unsure or cannot tell */
    bool unsure;      /* the trunk did not say: the file's axis is kept, with a warning */
    double height;    /* extent along the up axis the guess implies, metres */
    double normal_y;  /* the Y column's share of trunk normals along Y (NAN: none) */
    double normal_z;  /* the Z column's along Z (the two the rule compares) */
    char reason[320]; /* why, for warnings and the report */
} sv_up_guess;

#define SV_UP_RATIO 1.5      /* one axis's normal share this many times the other's */
#define SV_UP_SLAB 0.05      /* a box extreme's slab: this x the box's longest side */
#define SV_UP_SLAB_RATIO 2.0 /* a Z extreme holds this much more trunk than the lowest Y */
#define SV_UP_ROOT 1.5       /* the root quarter holds this many times the other end's trunk area */
#define SV_UP_CAP 0.94       /* |normal . axis| above this: a flat cap, not a tube wall */
#define SV_UP_COLUMN 0.1     /* a column's radius: this x the box's longest side */
#define SV_UP_TUBE_SHARE 0.2 /* a column alone says tubes along it: share below this */

/* Decides whether mesh (in sylva's frame, +Y up) looks Z-up, from its trunk
 * triangles alone (tri_part[t] == SV_PART_TRUNK; tri_part may be NULL: every
 * triangle counts as trunk); foliage and the crown's extent play no part.
 * The rule (docs/spec.md, "Plausibility checks"):
 *   - the trunk's axis: bark is tubes, whose walls face away from their axis.
 *     Columns along Y and along Z through the trunk's area-weighted median
 *     point (radius SV_UP_COLUMN x the box's longest side), each split at that
 *     point; per half, the area-weighted share of the squared normal
 *     component along the column, caps (|n . axis| > SV_UP_CAP) left out; the
 *     smaller half counts. Z's >= SV_UP_RATIO x Y's: along Y; the reverse:
 *     along Z; else unclear. A column with nothing but caps leaves the other
 *     to decide (a share below SV_UP_TUBE_SHARE: along it);
 *   - the root: the thicker end of the Z column (its lowest and highest
 *     quarter's trunk area, one SV_UP_ROOT x the other) and the box extreme
 *     the base sits at (trunk area within SV_UP_SLAB x the longest side of
 *     the lowest Y, lowest Z, highest Z; a Z extreme with SV_UP_SLAB_RATIO x
 *     the lowest Y's). Along Z, the thicker end decides unless the extreme
 *     says the other end; unclear axis, the extreme decides unless the
 *     thicker end says the other end; along Y, kept unless both say one Z end.
 * z_up +1: root at the lowest Z, -1: at the highest; signals that disagree
 * set g->unsure (z_up 0: the file's axis is kept). No trunk triangles: z_up
 * 0, not unsure ("not checked"). g->height is the box's extent along the up
 * axis the guess implies (Y unless z_up != 0). Fills *g (never fails). Pure
 * and deterministic. */
void sv_detect_up(const sv_mesh *mesh, const uint8_t *tri_part, sv_up_guess *g);

/* Rotates the mesh in place so that the base found by sv_detect_up is at the
 * lowest Y: z_up = +1 maps (x, y, z) -> (x, z, -y) (the same as import.up "Z"),
 * -1 maps (x, y, z) -> (x, -z, y); normals alike. z_up = 0 does nothing. */
void sv_mesh_rotate_up(sv_mesh *mesh, int z_up);

/* The same rotation on one point p (e.g. the mesh's local origin,
 * import.h), in double. z_up = 0 does nothing. */
void sv_point_rotate_up(double p[3], int z_up);

/* The units check: the tree's size read three ways, each against the sizes
 * trees have, and the unit that makes all three plausible when the one
 * given does not (docs/spec.md "Plausibility checks"). In metres as read: */
#define SV_UNITS_H_MIN 0.05  /* height: a seedling, a bonsai */
#define SV_UNITS_H_MAX 100.0 /* the tallest living trees reach 100-116 m */
#define SV_UNITS_L_MIN 0.003 /* leaf element (sqrt of its area): a needle, a heather leaf */
#define SV_UNITS_L_MAX 2.0   /* a card holding a whole branch; 4 m^2 */
#define SV_UNITS_D_MIN 0.002 /* trunk diameter near the base: a seedling's stem */
#define SV_UNITS_D_MAX 6.0   /* the widest trunks (a pot or a root flare counts too) */
/* Typical sizes, to choose between units that all fit (a tree, a single
 * modelled leaf, a leaf card of at most 4 triangles, a trunk): */
#define SV_UNITS_H_TYPICAL 5.0
#define SV_UNITS_LEAF_TYPICAL 0.05
#define SV_UNITS_CARD_TYPICAL 0.3
#define SV_UNITS_D_TYPICAL 0.3
/* Leaf elements of more triangles than this on average are foliage masses
 * (a conifer modelled as a few blobs), not leaves or cards: not judged. */
#define SV_UNITS_MASS_TRIS 64

typedef struct sv_units_guess {
    double height;          /* m as read: the tree's extent along up */
    double leaf_size;       /* m as read: sqrt of the median leaf element's area (0: none) */
    double trunk_diameter;  /* m as read: near the base (0: not measured) */
    bool implausible;       /* a size outside its range above */
    double factor;          /* the likely true size / the size read (1 when plausible; 0 when
                              no unit makes all three plausible) */
    double metres_per_unit; /* the unit the file likely has: unit_scale x factor (0: none) */
    char unit[24];          /* its spelling for --units / import.units ("cm", "0.1", ...) */
    char reason[400];       /* what is implausible, and why that unit */
} sv_units_guess;

/* Judges the units of a tree read with unit_scale metres per unit (mesh in
 * metres, +Y up, height its extent along up): its height, the size of its
 * median leaf element (leaves; NULL, none, or more than SV_UNITS_MASS_TRIS
 * triangles an element on average: not judged) and its trunk's
 * diameter near the base (the trunk triangles whose walls face sideways,
 * tri_part[t] == SV_PART_TRUNK, reaching into the slab 2..15 % of the height
 * above the lowest point: twice their centroids' area-weighted median
 * distance from their area-weighted centre, across the up axis; none: not
 * judged), each against [SV_UNITS_*_MIN,
 * SV_UNITS_*_MAX]. One outside: implausible. The likely unit is then, of
 * m, cm, mm and 0.1 m, the one whose factor brings every measure in range
 * and whose sizes are the most typical (the sum over the measures of the
 * squared log distance to SV_UNITS_*_TYPICAL over a spread: 1.5 for the
 * height, 1 for the leaf, 2 for the trunk; a leaf element of at most 4
 * triangles is a card); when none of them does, in, ft or another power of
 * ten of a metre from 1e-6 to 1e6, chosen the same way. None at all: factor 0.
 * Fills *u (never fails); pure and deterministic. */
void sv_check_units(const sv_mesh *mesh, const uint8_t *tri_part, const sv_leaves *leaves,
                    double unit_scale, double height, sv_units_guess *u);

/* Appends u's warning to buf (as sv_plausibility_warnings), when implausible:
 * what is implausible, the likely unit and how to say it (--units U, spec
 * "import": {"units": U}). */
void sv_units_warning(const sv_units_guess *u, char *buf, size_t cap);

/* Appends to buf (a '\n'-separated list, capacity cap, NUL-terminated) one
 * warning per implausibility of a tree of the given height (metres; NAN: no
 * size warning, sv_check_units judges the size): taller
 * than SV_TALLEST_TREE_M or shorter than SV_SMALLEST_TREE_M, each naming
 * import.units as the fix; when g->z_up != 0, either that the tree looks
 * lying down, naming import.up (!rotated), or that it was rotated upright
 * (rotated: a rotation is never silent); when g->unsure, that the up axis
 * could not be told and the file's was kept. Truncates rather than overflows. */
void sv_plausibility_warnings(const sv_up_guess *g, double height, bool rotated, char *buf,
                              size_t cap);

#endif
