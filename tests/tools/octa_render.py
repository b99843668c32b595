"""octa_render.py — an octahedral impostor renderer written from docs/runtime.md
("The format, rule by rule") alone, to check that those rules are enough
(tests/integration/octahedral.sh compares it with `sylva-bake view`, sylva's
own C runtime). Python standard library only (png.py beside it).

    python3 octa_render.py BAKE_DIR LOD SIZE X,Y,Z=REF.png... [--example]

Draws level LOD of BAKE_DIR/impostor.json (albedo level 0 and the depth map)
from each direction X,Y,Z (towards the viewer) into SIZE x SIZE pixels with the
evaluator's orthographic camera (docs/runtime.md, "The viewer page": the
sphere report.json evaluation.frame, its diameter tall, up as near +Y as
possible), one sample per pixel centre, and compares it with REF.png (an
8-bit RGBA render of the same view): coverage IoU (alpha >= 128) and, over
pixels both cover, the mean and largest difference of the sRGB bytes.
Prints them, a line per view; exits 1 when any IoU is below 0.995 or any
mean difference above 1 (byte). --example prints the frames, weights and the centre
pixel's texels, as the worked example of docs/runtime.md does.
"""
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import png  # noqa: E402


def sgn(x):
    return -1.0 if x < 0 else 1.0


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def encode(d, hemi, S):
    """rule 2: a unit direction to uv in [-1, 1]^2"""
    x, y, z = d[0], d[1] / S, d[2]
    if hemi and y < 0:
        y = 0.0
    n = abs(x) + abs(y) + abs(z)
    x, y, z = x / n, y / n, z / n
    if hemi:
        return (x + z, x - z)
    if y >= 0:
        return (x, z)
    return ((1 - abs(z)) * sgn(x), (1 - abs(x)) * sgn(z))


def decode(u, v, hemi, S):
    """rule 3: uv to a unit direction"""
    if hemi:
        x, z = (u + v) / 2, (u - v) / 2
        y = max(1 - abs(x) - abs(z), 0.0)
    else:
        x, z = u, v
        y = 1 - abs(u) - abs(v)
        if y < 0:
            x, z = (1 - abs(v)) * sgn(u), (1 - abs(u)) * sgn(v)
    return normalize((x, S * y, z))


def basis(d):
    """rule 5: right and up of the frame seen from d"""
    ref = (0.0, 1.0, 0.0)
    if abs(d[1]) > 0.9999:
        ref = (0.0, 0.0, -1.0 if d[1] > 0 else 1.0)
    right = normalize(cross(ref, d))
    return right, cross(d, right)


def select(d, N, hemi, S):
    """rules 4 and 9: three frames (i, j) and their weights"""
    u, v = encode(d, hemi, S)
    gx, gy = (u * 0.5 + 0.5) * (N - 1), (v * 0.5 + 0.5) * (N - 1)
    cx, cy = min(math.floor(gx), N - 2), min(math.floor(gy), N - 2)
    fx, fy = gx - cx, gy - cy
    if fx + fy <= 1:
        return [((cx, cy), 1 - fx - fy), ((cx + 1, cy), fx), ((cx, cy + 1), fy)]
    return [((cx + 1, cy + 1), fx + fy - 1), ((cx + 1, cy), 1 - fy), ((cx, cy + 1), 1 - fx)]


def srgb_to_linear(b):
    c = b / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def linear_to_srgb8(c):
    c = min(max(c, 0.0), 1.0)
    c = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(round(255 * c))


class Frames:
    """an atlas of N x N frames of F texels (rule 6), sampled bilinear (rule 8)"""

    def __init__(self, rows, channels, N, F, convert):
        self.rows, self.ch, self.N, self.F, self.convert = rows, channels, N, F, convert

    def sample(self, i, j, s, t):
        F = self.F
        x = min(max(s * F - 0.5, 0.0), F - 1.0)
        y = min(max(t * F - 0.5, 0.0), F - 1.0)
        x0, y0 = int(x), int(y)
        x1, y1 = min(x0 + 1, F - 1), min(y0 + 1, F - 1)
        fx, fy = x - x0, y - y0
        out = [0.0] * self.ch
        for (xx, yy, w) in ((x0, y0, (1 - fx) * (1 - fy)), (x1, y0, fx * (1 - fy)),
                            (x0, y1, (1 - fx) * fy), (x1, y1, fx * fy)):
            row = self.rows[j * F + yy]
            base = (i * F + xx) * self.ch
            for k in range(self.ch):
                out[k] += w * self.convert[k](row[base + k])
        return out


def load(imp, bake_dir):
    """the albedo (level 0) and depth atlases of one impostor.json entry"""
    N, F = imp['grid'], imp['frame_pixels']
    _, _, ch, bits, rows = png.read(os.path.join(bake_dir, imp['maps']['albedo']))
    assert ch == 4 and bits == 8, 'albedo must be RGBA8'
    lin = [srgb_to_linear(b) for b in range(256)]
    albedo = Frames(rows, 4, N, F, [lin.__getitem__] * 3 + [lambda a: a / 255.0])
    depth = None
    if imp['maps'].get('depth'):
        _, _, dch, dbits, drows = png.read(os.path.join(bake_dir, imp['maps']['depth']))
        assert dch == 1 and dbits == 16, 'depth must be 16-bit grey'
        depth = Frames(drows, 1, N, F, [lambda v: v / 65535.0])
    return albedo, depth


def render(imp, maps, bake_dir, view, size, example=False):
    N, F, H = imp['grid'], imp['frame_pixels'], imp['half']
    S = imp.get('elevation_scale', 1.0)
    hemi, cut = imp['hemi'], imp.get('alpha_cutoff', 0.5)
    c = imp['centre']
    albedo, depth = maps
    report = json.load(open(os.path.join(bake_dir, 'report.json')))
    fc, r = report['evaluation']['frame']['centre'], report['evaluation']['frame']['radius']
    D = normalize(view)
    # the evaluator's camera: right = ref x D, up = D x right, ref Y (or -Z / +Z
    # within 0.999 of straight above / below)
    ref = (0.0, 1.0, 0.0) if abs(D[1]) <= 0.999 else (0.0, 0.0, -1.0 if D[1] > 0 else 1.0)
    cr = normalize(cross(ref, D))
    cu = cross(D, cr)
    frames = []
    for (i, j), w in select(D, N, hemi, S):
        d = decode(2 * i / (N - 1) - 1, 2 * j / (N - 1) - 1, hemi, S)
        rt, up = basis(d)
        frames.append((i, j, w, d, rt, up))
    if example:
        for (i, j, w, d, rt, up) in frames:
            print('frame (%d, %d) weight %.6f d (%.6f, %.6f, %.6f) right (%.6f, %.6f, %.6f) '
                  'up (%.6f, %.6f, %.6f)' % ((i, j, w) + d + rt + up))
    img = []
    for y in range(size):
        for x in range(size):
            sx = (2 * (x + 0.5) / size - 1) * r
            sy = (1 - 2 * (y + 0.5) / size) * r
            q = [fc[k] + sx * cr[k] + sy * cu[k] - c[k] for k in range(3)]
            a, prem = 0.0, [0.0, 0.0, 0.0]
            for (i, j, w, d, rt, up) in frames:
                dd = dot(D, d)
                if w <= 0 or dd <= 1e-4:
                    continue
                h, inside = 0.0, True
                steps = 3 if depth else 0
                for it in range(steps + 1):
                    t = (dot(q, d) - h) / dd
                    P = [q[k] - t * D[k] - h * d[k] for k in range(3)]
                    s = dot(P, rt) / H * 0.5 + 0.5
                    tt = 0.5 - dot(P, up) / H * 0.5
                    inside = 0 <= s <= 1 and 0 <= tt <= 1
                    if not inside or it == steps:
                        break
                    h = (depth.sample(i, j, s, tt)[0] - 0.5) * 2 * H
                if not inside:
                    continue
                rr, gg, bb, ak = albedo.sample(i, j, s, tt)
                if example and x == size // 2 and y == size // 2:
                    print('centre pixel, frame (%d, %d): (s, t) (%.6f, %.6f), texel (%.4f, %.4f), '
                          'alpha %.3f' % (i, j, s, tt, i * F + s * F - 0.5, j * F + tt * F - 0.5, ak))
                a += w * ak
                prem = [prem[0] + w * ak * rr, prem[1] + w * ak * gg, prem[2] + w * ak * bb]
            if a >= cut:
                img.append(tuple(linear_to_srgb8(p / a) for p in prem) + (255,))
            else:
                img.append((0, 0, 0, 0))
    return img


def main(argv):
    example = '--example' in argv
    argv = [a for a in argv if a != '--example']
    if len(argv) < 4 or not all('=' in a for a in argv[3:]):
        print(__doc__.split('\n\n')[1], file=sys.stderr)
        return 2
    bake_dir, lod, size = argv[0], argv[1], int(argv[2])
    doc = json.load(open(os.path.join(bake_dir, 'impostor.json')))
    imp = [e for e in doc['lods'] if e['lod'] == lod]
    if not imp:
        print('octa_render.py: no level %s in impostor.json' % lod, file=sys.stderr)
        return 2
    maps = load(imp[0], bake_dir)
    status = 0
    for arg in argv[3:]:
        view, ref_png = arg.split('=', 1)
        img = render(imp[0], maps, bake_dir, [float(v) for v in view.split(',')], size, example)
        status |= compare(img, lod, view, size, ref_png)
    return status


def compare(img, lod, view, size, ref_png):
    w, h, ch, bits, rows = png.read(ref_png)
    assert (w, h, ch, bits) == (size, size, 4, 8), (w, h, ch, bits)
    inter = union = 0
    diff, worst = 0, 0
    for y in range(size):
        for x in range(size):
            p = img[y * size + x]
            q = rows[y][4 * x:4 * x + 4]
            a, b = p[3] >= 128, q[3] >= 128
            union += a or b
            if a and b:
                inter += 1
                dv = max(abs(p[k] - q[k]) for k in range(3))
                diff += sum(abs(p[k] - q[k]) for k in range(3)) / 3
                worst = max(worst, dv)
    iou = inter / union if union else 1.0
    mean = diff / inter if inter else 0.0
    print('%s from %s at %d px: coverage IoU %.4f against %s, colour over %d px: mean |diff| %.3f, '
          'largest %d (sRGB bytes)' % (lod, view, size, iou, os.path.basename(ref_png), inter, mean, worst))
    return 0 if iou >= 0.995 and mean <= 1.0 and inter > 0 else 1


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
