#!/usr/bin/env python3
"""willow_tree.py OUT.obj [BRANCHES] [SEED] — a Y-up weeping tree for the
up-axis check: a trunk ("bark", 3 m, base at y = 0) whose BRANCHES (default
24) arch out from its top and hang down past its base (to y -0.1 .. -0.6), as a
weeping willow's do, with leaf quads ("leaf") along the hanging parts and
OUT.mtl beside it. The trunk base is not at the lowest Y; the hanging
branches reach every side of the box. Deterministic for a seed."""
import math
import os
import random
import sys

out = sys.argv[1]
branches = int(sys.argv[2]) if len(sys.argv) > 2 else 24
rnd = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 7)
v, faces = [], []


def tube(a, b, r0, r1, sides=8, step=0.2):
    """A tube from a (radius r0) to b (radius r1), as quads, in pieces at
    most `step` long (as a generator's rings are)."""
    ln = math.sqrt(sum((b[k] - a[k]) ** 2 for k in range(3)))
    n = max(1, int(math.ceil(ln / step)))
    for i in range(n):
        p = [a[k] + (b[k] - a[k]) * i / n for k in range(3)]
        q = [a[k] + (b[k] - a[k]) * (i + 1) / n for k in range(3)]
        ring(p, q, r0 + (r1 - r0) * i / n, r0 + (r1 - r0) * (i + 1) / n, sides)


def ring(a, b, r0, r1, sides):
    """One piece of a tube: `sides` quads from a to b."""
    d = [b[k] - a[k] for k in range(3)]
    ln = math.sqrt(sum(x * x for x in d))
    d = [x / ln for x in d]
    h = [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]
    u = [d[1] * h[2] - d[2] * h[1], d[2] * h[0] - d[0] * h[2], d[0] * h[1] - d[1] * h[0]]
    lu = math.sqrt(sum(x * x for x in u))
    u = [x / lu for x in u]
    w = [d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]]
    base = len(v)
    for p, r in ((a, r0), (b, r1)):
        for i in range(sides):
            t = 2 * math.pi * i / sides
            v.append(tuple(p[k] + r * (math.cos(t) * u[k] + math.sin(t) * w[k]) for k in range(3)))
    for i in range(sides):
        j = (i + 1) % sides
        faces.append(("bark", [base + i + 1, base + j + 1, base + sides + j + 1,
                               base + sides + i + 1]))


def leaf(c, s=0.12):
    a = rnd.uniform(0, 2 * math.pi)
    ux, uz = math.cos(a) * s, math.sin(a) * s
    base = len(v)
    v.extend([(c[0] - ux, c[1] - s, c[2] - uz), (c[0] + ux, c[1] - s, c[2] + uz),
              (c[0] + ux, c[1] + s, c[2] + uz), (c[0] - ux, c[1] + s, c[2] - uz)])
    faces.append(("leaf", [base + 1, base + 2, base + 3, base + 4]))


tube((0, 0, 0), (0, 3, 0), 0.22, 0.12)
for k in range(branches):
    ang = 2 * math.pi * (k + rnd.uniform(-0.3, 0.3)) / branches
    reach = rnd.uniform(1.6, 2.4)
    ca, sa = math.cos(ang), math.sin(ang)
    tip = rnd.uniform(-0.6, -0.1)
    pts = [(0, 3, 0), (0.5 * reach * ca, 3.5, 0.5 * reach * sa), (reach * ca, 3.3, reach * sa),
           (reach * ca * 1.05, 1.5, reach * sa * 1.05), (reach * ca * 1.08, tip, reach * sa * 1.08)]
    radii = [0.06, 0.05, 0.045, 0.04, 0.01]
    for i in range(len(pts) - 1):
        tube(pts[i], pts[i + 1], radii[i], radii[i + 1])
    for i in range(10):  # leaves along the hanging part
        t = i / 9
        leaf((reach * ca * (1 + 0.08 * t) + 0.1, 3.2 - 3.6 * t, reach * sa * (1 + 0.08 * t)))
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
        o.write("f %s\n" % " ".join(str(i) for i in idx))
