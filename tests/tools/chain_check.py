#!/usr/bin/env python3
"""chain_check.py REPORT.json [...] — checks a bake's LOD chain against the
promises of docs/lod.md "Which level is drawn", from report.json alone:

1. cost: at no measured screen size is the level drawn there more than
   COST_RATIO (10) times the triangles of another level (kept or skipped) whose
   1 - IoU at that size is within SLACK (0.02) of max(tolerance, the drawn
   level's error);
2. density: no level of more than 5,000 triangles is drawn below 48 px;
3. LOD0 is the original (source "stochastic" λ 1 or the name "full") when the
   chain is on; switch sizes do not increase along the chain.

Prints one line per report; exit 1 if any check fails. Used by
tests/integration/lod_chain.sh on every shared tree and by the benches."""
import json
import math
import sys

COST_RATIO = 10.0
SLACK = 0.02
FAR_PIXELS = 48.0
FAR_TRIANGLES = 5000


def err_at(acc, px):
    """1 - mean IoU at px: linear in log2 size between measured sizes, held
    outside (as evaluate.c sv_eval_error_at)."""
    pts = sorted((a['pixels'], 1.0 - a['iou_mean']) for a in acc)
    if px <= pts[0][0]:
        return pts[0][1]
    if px >= pts[-1][0]:
        return pts[-1][1]
    for (p0, e0), (p1, e1) in zip(pts, pts[1:]):
        if p0 <= px <= p1:
            t = (math.log2(px) - math.log2(p0)) / (math.log2(p1) - math.log2(p0))
            return e0 + t * (e1 - e0)
    return pts[-1][1]


def drawn_at(lods, px):
    """The kept level drawn at px: the last whose switch size is >= px (a
    switch found by bisection may sit a hair below a measured size: px is
    taken 1e-6 smaller)."""
    px *= 1 - 1e-6
    d = 0
    for i, l in enumerate(lods):
        if l['switch_pixels'] >= px:
            d = i
    return d


def check(path):
    r = json.load(open(path))
    lods = r['lods']
    c = r['lod_chain']
    tol, tolpx = c['tolerance'], c['tolerance_pixels']
    ratio, slack = c.get('cost_ratio', COST_RATIO), c.get('slack', SLACK)
    bad = []
    sw = [l['switch_pixels'] for l in lods]
    if any(sw[i] < sw[i + 1] for i in range(len(sw) - 1)):
        bad.append('switch sizes increase: %s' % sw)
    if c['chain'] and lods and len(lods) > 1 and lods[0]['name'] != 'full':
        bad.append('LOD0 is %s, not the original' % lods[0]['name'])
    others = [(l['name'], l['triangles'], l.get('accuracy') or []) for l in lods]
    others += [(s['name'], s['triangles'], s.get('accuracy') or [])
               for s in c['skipped'] if 'triangles' in s]
    sizes = sorted({a['pixels'] for _, _, acc in others for a in acc}, reverse=True)
    for px in sizes:
        if len(lods) < 2:
            break
        a = lods[drawn_at(lods, px)]
        ea = 0.0 if a['name'] == 'full' or not a.get('accuracy') else err_at(a['accuracy'], px)
        T = tol * tolpx / px if tolpx > 0 else tol
        for name, tris, acc in others:
            if not acc or name == a['name']:
                continue
            if a['triangles'] > ratio * tris and err_at(acc, px) <= max(T, ea) + slack + 1e-9:
                bad.append('at %g px %s (%d triangles, 1-IoU %.3f) is drawn where %s (%d, %.3f) '
                           'is within %g' % (px, a['name'], a['triangles'], ea, name, tris,
                                             err_at(acc, px), slack))
    for px in [FAR_PIXELS * 0.999] + [p for p in sizes if p < FAR_PIXELS]:
        if len(lods) > 1 and lods[drawn_at(lods, px)]["triangles"] > FAR_TRIANGLES:
            l = lods[drawn_at(lods, px)]
            bad.append('%s (%d triangles) is drawn at %.4g px' % (l['name'], l['triangles'], px))
    return bad


def main():
    ok = True
    for p in sys.argv[1:]:
        bad = check(p)
        ok = ok and not bad
        print('%s: %s' % (p, 'ok' if not bad else '; '.join(bad)))
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
