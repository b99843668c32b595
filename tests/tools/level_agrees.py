#!/usr/bin/env python3
"""level_agrees.py OUTDIR FILE SVEVAL64 SVEVAL32 — one written level of a bake
against what report.json says of it: every MASK material's alphaCutoff in
[0.1, 0.9] (docs/accuracy.md, "Alpha calibration"), and the independent
evaluator's soft IoU at 64 and 32 px (given) within 0.02 of the report's mean
IoU at those sizes. Exit 1 with the figures when not."""
import json
import os
import struct
import sys


def main():
    out, f = sys.argv[1], sys.argv[2]
    s64, s32 = float(sys.argv[3]), float(sys.argv[4])
    r = json.load(open(os.path.join(out, 'report.json')))
    lod = [l for l in r['lods'] if l['file'] == f][0]
    acc = {a['pixels']: a['iou_mean'] for a in lod['accuracy']}
    b = open(os.path.join(out, f), 'rb').read()
    g = json.loads(b[20:20 + struct.unpack_from('<I', b, 12)[0]])
    cuts = [m['alphaCutoff'] for m in g.get('materials', [])
            if m.get('alphaMode') == 'MASK' and 'alphaCutoff' in m]
    print('  %s: ours %.4f / %.4f, sveval %.4f / %.4f, cutoffs %s' %
          (f, acc[64], acc[32], s64, s32, [round(c, 3) for c in cuts]))
    ok = all(0.1 <= c <= 0.9 for c in cuts)
    ok = ok and abs(acc[64] - s64) <= 0.02 and abs(acc[32] - s32) <= 0.02
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
