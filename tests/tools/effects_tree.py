#!/usr/bin/env python3
"""effects_tree.py OUT.obj — a synthetic tree whose baked maps are known
(tests/integration/scene_effects.sh): a thin trunk box (material "bark") on the
Y axis, four rows of leaf cards facing +Z (material "leaves") one above the
other, each at its own distance in front of the trunk, and a wide horizontal
leaf "roof" just above the lowest row. Baked as crossed quads, the quad facing
+Z sees the rows face on, so:
  - their normal-map texels are (0, 0, 1) in tangent space;
  - their depth (distance from the quad's plane) grows with the row's z, in
    proportion to its distance from the plane;
  - the lowest row, under the roof, sees little sky: its AO is darker than
    that of the open rows above.
Writes OUT.obj and OUT.mtl; prints the rows as JSON (y range, x range, z).
"""
import json
import os
import sys

out = sys.argv[1]
mtl = os.path.splitext(out)[0] + '.mtl'
ROWS = [  # y0, y1, z: the rows' heights and distances in front of the trunk axis
    (0.50, 0.80, 0.10),
    (1.20, 1.50, 0.35),
    (1.90, 2.20, 0.60),
    (2.60, 2.90, 0.85),
]
ROOF_Y = 0.90
X0, X1 = -0.40, 0.40
v, f = [], []


def quad(a, b, c, d, mat):
    base = len(v) + 1
    v.extend([a, b, c, d])
    f.append((mat, (base, base + 1, base + 2)))
    f.append((mat, (base, base + 2, base + 3)))


# trunk: a 0.1 m box from y = 0 to 3.2
t, h = 0.05, 3.2
corners = [(-t, -t), (t, -t), (t, t), (-t, t)]
for i in range(4):
    (xa, za), (xb, zb) = corners[i], corners[(i + 1) % 4]
    quad((xa, 0, za), (xb, 0, zb), (xb, h, zb), (xa, h, za), 'bark')
quad((-t, h, -t), (-t, h, t), (t, h, t), (t, h, -t), 'bark')
# leaf rows facing +Z (counter-clockwise seen from +Z)
for y0, y1, z in ROWS:
    quad((X0, y0, z), (X1, y0, z), (X1, y1, z), (X0, y1, z), 'leaves')
# the roof: 3 m x 3 m, facing up, over the lowest row
quad((-1.5, ROOF_Y, -1.5), (-1.5, ROOF_Y, 1.5), (1.5, ROOF_Y, 1.5), (1.5, ROOF_Y, -1.5), 'leaves')

with open(out, 'w') as o:
    o.write('# effects_tree.py: synthetic tree for scene_effects.sh\nmtllib %s\n' % os.path.basename(mtl))
    for p in v:
        o.write('v %.6f %.6f %.6f\n' % p)
    cur = None
    for mat, tri in f:
        if mat != cur:
            o.write('usemtl %s\n' % mat)
            cur = mat
        o.write('f %d %d %d\n' % tri)
with open(mtl, 'w') as o:
    o.write('newmtl bark\nKd 0.35 0.25 0.15\n\nnewmtl leaves\nKd 0.2 0.6 0.2\n')
print(json.dumps({'rows': [{'y': [y0, y1], 'x': [X0, X1], 'z': z} for y0, y1, z in ROWS],
                  'roof_y': ROOF_Y}))
