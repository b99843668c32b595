#!/usr/bin/env python3
"""synth_tree.py OUT.obj [LEAVES] [SEED] — a small synthetic tree for tests:
a square trunk ("bark", 2 m, 0.2 m wide) and LEAVES (default 40) tilted leaf
quads ("leaf", 0.3 m) scattered over a crown above it, with OUT.mtl beside it.
Deterministic for a seed. Used by tests that need a quick real bake."""
import math
import os
import random
import sys

out = sys.argv[1]
leaves = int(sys.argv[2]) if len(sys.argv) > 2 else 40
rnd = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 4242)
v, faces = [], []


def quad(pts, mat):
    faces.append((mat, [len(v) + i + 1 for i in range(4)]))
    v.extend(pts)


r, h = 0.1, 2.0
c = [(-r, -r), (r, -r), (r, r), (-r, r)]
for i in range(4):
    (x0, z0), (x1, z1) = c[i], c[(i + 1) % 4]
    quad([(x0, 0, z0), (x1, 0, z1), (x1, h, z1), (x0, h, z0)], "bark")
for k in range(leaves):
    cx, cy, cz = rnd.uniform(-1, 1), h + rnd.uniform(-0.5, 0.7), rnd.uniform(-1, 1)
    a, s = rnd.uniform(0, 2 * math.pi), 0.15
    ux, uz, tilt = math.cos(a) * s, math.sin(a) * s, rnd.uniform(-1, 1) * s
    quad([(cx - ux, cy - tilt, cz - uz), (cx + ux, cy - tilt, cz + uz),
          (cx + ux, cy + s, cz + uz), (cx - ux, cy + s, cz - uz)], "leaf")
mtl = os.path.splitext(out)[0] + ".mtl"
with open(mtl, "w") as m:
    m.write("newmtl bark\nKd 0.35 0.22 0.10\nnewmtl leaf\nKd 0.20 0.50 0.15\n")
with open(out, "w") as o:
    o.write("mtllib %s\n" % os.path.basename(mtl))
    o.writelines("v %.5f %.5f %.5f\n" % p for p in v)
    cur = None
    for mat, idx in faces:
        if mat != cur:
            o.write("usemtl %s\n" % mat)
            cur = mat
        o.write("f %d %d %d %d\n" % tuple(idx))
