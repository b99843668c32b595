#!/usr/bin/env python3
"""twig_tree.py OUT.obj [CARDS] [SEED] [WIDTH] [twigs] — a synthetic tree
whose foliage is twig cards: a trunk ("bark", 6 m) with CARDS (default 1500)
cards ("leaf"), each a bent strip 0.5 m long and WIDTH m wide (default 0.06)
tessellated into 2 x 8 quads (32 triangles), textured with an alpha image of
several leaves along a midrib (OUT_twig.png). With `twigs` each card is
instead one connected mesh: a thin stem strip with five modelled leaves
(12-triangle fans, WIDTH across) joined to it, as twig elements of several
leaves are modelled; simplified as one element to a few triangles such a
twig becomes a sliver along its stem. Deterministic for a seed."""
import math
import os
import random
import struct
import sys
import zlib

out = sys.argv[1]
cards = int(sys.argv[2]) if len(sys.argv) > 2 else 1500
rnd = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 7)
width = float(sys.argv[4]) if len(sys.argv) > 4 else 0.06
twigs = len(sys.argv) > 5 and sys.argv[5] == "twigs"
v, vt, faces = [], [], []


def png(path, w, h, px):
    raw = b"".join(b"\0" + bytes(px[y * w * 4:(y + 1) * w * 4]) for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# the texture: 64 x 256, a midrib along v and five leaf ellipses on alternate sides
W, H = 64, 256
px = [0] * (W * H * 4)
for y in range(H):
    for x in range(W):
        u, t = (x + 0.5) / W, (y + 0.5) / H
        a = abs(u - 0.5) < 0.04
        for k in range(5):
            cu, ct = (0.3 if k % 2 else 0.7), 0.12 + 0.19 * k
            if ((u - cu) / 0.28) ** 2 + ((t - ct) / 0.11) ** 2 < 1:
                a = True
        i = 4 * (y * W + x)
        px[i:i + 4] = [50, 110 + (x * 3) % 40, 40, 255 if a else 0]
base = os.path.splitext(out)[0]
tex = base + "_twig.png"
png(tex, W, H, px)


def box(x0, y0, z0, x1, y1, z1, r):
    c = [(-r, -r), (r, -r), (r, r), (-r, r)]
    for i in range(4):
        (a0, b0), (a1, b1) = c[i], c[(i + 1) % 4]
        n = len(v)
        v.extend([(x0 + a0, y0, z0 + b0), (x0 + a1, y0, z0 + b1), (x1 + a1, y1, z1 + b1), (x1 + a0, y1, z1 + b0)])
        vt.extend([(0, 0), (1, 0), (1, 1), (0, 1)])
        faces.append(("bark", [n + 1, n + 2, n + 3, n + 4]))


box(0, 0, 0, 0, 6, 0, 0.15)
for k in range(12):
    a = 2 * math.pi * k / 12 + rnd.uniform(-0.2, 0.2)
    y = 2.5 + 3.0 * k / 12
    box(0, y, 0, 1.8 * math.cos(a), y + 0.9, 1.8 * math.sin(a), 0.04)
NL, NW = 8, 2
for c in range(cards):
    # a point in an ellipsoidal crown, the card along a random direction
    while True:
        p = [rnd.uniform(-1, 1) for _ in range(3)]
        if sum(q * q for q in p) < 1:
            break
    cx, cy, cz = 2.2 * p[0], 4.6 + 1.7 * p[1], 2.2 * p[2]
    th, ph = rnd.uniform(0, 2 * math.pi), rnd.uniform(-0.6, 0.9)
    d = (math.cos(ph) * math.cos(th), math.sin(ph), math.cos(ph) * math.sin(th))
    s = (-math.sin(th), 0, math.cos(th))  # across the card
    n = (d[1] * s[2] - d[2] * s[1], d[2] * s[0] - d[0] * s[2], d[0] * s[1] - d[1] * s[0])
    bend = rnd.uniform(0.05, 0.15)
    first = len(v)
    if twigs:
        def at(t, w, lift=0.0):
            return tuple((cx, cy, cz)[a] + 0.5 * (t - 0.5) * d[a] + w * s[a] - (bend * t * t + lift) * n[a]
                         for a in range(3))
        # the stem: 6 quads, 0.008 m wide
        for i in range(7):
            v.extend([at(i / 6, -0.004), at(i / 6, 0.004)])
            vt.extend([(0.5, i / 6), (0.5, i / 6)])
        for i in range(6):
            a = first + 2 * i + 1
            faces.append(("leaf", [a, a + 1, a + 3, a + 2]))
        for k in range(5):
            t0 = 0.15 + 0.18 * k
            side = 1 if k % 2 else -1
            root_v = first + 2 * int(round(t0 * 6)) + (1 if side > 0 else 0) + 1
            ctr = at(t0 + 0.05, side * 0.6 * width)
            c_id = len(v) + 1
            v.append(ctr)
            vt.append((0.5, 0.5))
            ring = []
            for j in range(12):
                ang = 2 * math.pi * j / 12
                lob = 0.5 * width * (0.75 + 0.25 * math.cos(5 * ang))
                ring.append(len(v) + 1)
                v.append(at(t0 + 0.05 + lob * math.sin(ang), side * (0.6 * width + lob * math.cos(ang)), 0.01 * math.sin(ang)))
                vt.append((0.5, 0.5))
            for j in range(12):
                faces.append(("leaf", [c_id, ring[j], ring[(j + 1) % 12]]))
            faces.append(("leaf", [root_v, ring[6 if side > 0 else 0], c_id]))
        continue
    for i in range(NL + 1):
        t = i / NL
        droop = bend * t * t
        for j in range(NW + 1):
            w = (j / NW - 0.5) * width
            curl = 0.15 * width * (2 * j / NW - 1) ** 2
            v.append(tuple(
                (cx, cy, cz)[a] + 0.5 * (t - 0.5) * d[a] + w * s[a] - (droop + curl) * n[a] for a in range(3)))
            vt.append((j / NW, t))
    for i in range(NL):
        for j in range(NW):
            a = first + i * (NW + 1) + j + 1
            faces.append(("leaf", [a, a + 1, a + NW + 2, a + NW + 1]))
with open(base + ".mtl", "w") as m:
    m.write("newmtl bark\nKd 0.35 0.22 0.10\n"
            + ("newmtl leaf\nKd 0.2 0.5 0.15\n" if twigs else
               "newmtl leaf\nKd 1 1 1\nmap_Kd %s\nmap_d %s\n" % (os.path.basename(tex), os.path.basename(tex))))
with open(out, "w") as o:
    o.write("mtllib %s\n" % os.path.basename(base + ".mtl"))
    o.writelines("v %.5f %.5f %.5f\n" % q for q in v)
    o.writelines("vt %.5f %.5f\n" % q for q in vt)
    cur = None
    for mat, idx in faces:
        if mat != cur:
            o.write("usemtl %s\n" % mat)
            cur = mat
        o.write("f %s\n" % " ".join("%d/%d" % (i, i) for i in idx))
