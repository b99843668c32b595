#!/bin/sh
# scene_effects.sh — the scene decides the effects, and the maps hold what
# they should.
#  1. On a real tree (the aspen of ../shared/data): static lighting bakes no
#     normal or depth map, lit albedo, an unlit material, and says so in
#     report.json; dynamic lighting + ambient occlusion + shadows bakes normal,
#     AO and 16-bit depth maps, reports each done, and model.glb has a
#     normalTexture. Its normal map: the median covered texel is unit length
#     and 99 % point out of the quad's plane (tangent-space z > 0).
#  2. On a synthetic tree whose answer is known (tests/tools/effects_tree.py:
#     four leaf rows facing +Z at known distances, one under a roof), read
#     back texel by texel (tests/tools/png.py, standard-library Python):
#     normal texels of the rows are unit length and point out of the plane;
#     AO is in range, dark under the roof and light on the open rows; depth
#     is constant over each flat row, grows with the row's distance from the
#     quad's plane in proportion to it, and stays within 16 bits.
# Small atlases (max_atlas 256) keep the Python reading quick.
# sylva-test: cost=15
set -eu
. "$(dirname "$0")/lib.inc"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
d="$data/eztree_aspen_small"
[ -d "$data" ] || skip "no tree data at $data"
[ -f "$d/aspen_small.obj" ] || fail "missing $d/aspen_small.obj"
# shellcheck disable=SC2046
set -- "$d/aspen_small.obj" $(companions "$d" aspen_small.obj)
lod=crossed
effect() { json_get "$1/report.json" "[e['status'] for e in j['effects'] if e['effect']=='$2'][0]"; }
common='"method": "crossed_quads", "bake": {"max_atlas": 256}, "lod": {"chain": false}, "evaluate": {"views": 4, "sizes": [64]}'
export PYTHONPATH="$root/tests/tools"

# --- 1. the real tree
echo "{$common, \"scene\": {\"lighting\": \"static\"}}" > "$tmp/static.json"
"$bake" bake "$@" --spec "$tmp/static.json" --out "$tmp/static" || fail "static bake"
[ ! -e "$tmp/static/atlas_${lod}_normal.png" ] || fail "static lighting baked a normal map"
[ "$(effect "$tmp/static" normal_map)" = skipped ] || fail "static: normal_map not reported skipped"
[ "$(effect "$tmp/static" lit_albedo)" = done ] || fail "static: lit_albedo not done"
[ ! -e "$tmp/static/atlas_${lod}_depth.png" ] || fail "no shadows, yet a depth map"
[ "$(effect "$tmp/static" depth_map)" = skipped ] || fail "static: depth_map not reported skipped"
grep -q KHR_materials_unlit "$tmp/static/model.glb" || fail "static: atlas not marked unlit"

scene='"scene": {"lighting": "dynamic", "ambient_occlusion": true, "shadows": true}'
echo "{$common, $scene}" > "$tmp/dyn.json"
"$bake" bake "$@" --spec "$tmp/dyn.json" --out "$tmp/dyn" || fail "dynamic bake"
for m in normal ao depth; do
    [ -s "$tmp/dyn/atlas_${lod}_$m.png" ] || fail "dynamic + AO + shadows baked no $m map"
done
for e in normal_map ambient_occlusion depth_map; do
    [ "$(effect "$tmp/dyn" $e)" = done ] || fail "dynamic: $e not reported done"
done
[ "$(effect "$tmp/dyn" lit_albedo)" = skipped ] || fail "dynamic: lit albedo not skipped"
if grep -q KHR_materials_unlit "$tmp/dyn/model.glb"; then fail "dynamic: atlas marked unlit"; fi
grep -q normalTexture "$tmp/dyn/model.glb" || fail "dynamic: model.glb has no normalTexture"
python3 - "$tmp/dyn" "$lod" <<'EOF' || fail "aspen: normal map content"
import math, sys, png
d, lod = sys.argv[1], sys.argv[2]
W, H, _, _, alb = png.read('%s/atlas_%s_albedo.png' % (d, lod))
w, h, ch, bits, nm = png.read('%s/atlas_%s_normal.png' % (d, lod))
assert (w, h, ch, bits) == (W, H, 3, 8), (w, h, ch, bits)
cov = [(x, y) for y in range(H) for x in range(W) if alb[y][4 * x + 3]]
assert len(cov) > 1000, 'only %d covered texels' % len(cov)
ns = [[2 * nm[y][3 * x + k] / 255 - 1 for k in range(3)] for x, y in cov]
lens = sorted(math.sqrt(sum(a * a for a in n)) for n in ns)
med = lens[len(lens) // 2]
out = sum(1 for n in ns if n[2] > 0) / len(ns)
# (per-channel median filtering leaves some texels where leaves meet short of
# unit length: only the median is held to it; see docs/testing.md)
assert abs(med - 1) < 0.02, 'median normal length %.3f' % med
assert out >= 0.99, 'only %.3f of the normals point out of the plane' % out
print('ok aspen normal map: %d texels, median length %.3f, %.4f with z > 0' % (len(cov), med, out))
EOF

# --- 2. the synthetic tree: the maps' content, texel by texel
python3 "$root/tests/tools/effects_tree.py" "$tmp/syn.obj" > "$tmp/rows.json"
"$bake" bake "$tmp/syn.obj" "$tmp/syn.mtl" --spec "$tmp/dyn.json" --out "$tmp/syn" > "$tmp/syn.log" 2>&1 ||
    fail "synthetic bake: $(tail -n 3 "$tmp/syn.log")"
python3 - "$tmp/syn" "$lod" "$tmp/rows.json" <<'EOF' || fail "synthetic tree: map content"
import json, math, sys, png
d, lod = sys.argv[1], sys.argv[2]
rows = json.load(open(sys.argv[3]))['rows']
W, H, _, _, alb = png.read('%s/atlas_%s_albedo.png' % (d, lod))
_, _, _, _, nm = png.read('%s/atlas_%s_normal.png' % (d, lod))
_, _, ach, abits, ao = png.read('%s/atlas_%s_ao.png' % (d, lod))
_, _, dch, dbits, dp = png.read('%s/atlas_%s_depth.png' % (d, lod))
assert (ach, abits, dch, dbits) == (1, 8, 1, 16), (ach, abits, dch, dbits)
lods = json.load(open('%s/planes.json' % d))['lods']
quads = [q for l in lods if l['name'] == lod for q in l['quads']]
q = [q for q in quads if q['normal'] == [0, 0, 1]]
assert len(q) == 1, 'no quad facing +Z: %s' % [q['normal'] for q in quads]
q = q[0]
u0, v0, u1, v1 = q['uv']
c = q['corners']
xa, xb, ya, yb = c[0][0], c[1][0], c[0][1], c[3][1]
plane_z = -q['d']  # normal (0,0,1): z + d = 0
px = lambda x: (u0 + (x - xa) / (xb - xa) * (u1 - u0)) * W
py = lambda y: (v0 + (yb - y) / (yb - ya) * (v1 - v0)) * H  # atlas rows run down
errs, ao_mean, depth = [], [], []
for k, r in enumerate(rows):
    # the row's texels, 2 texels in from its edges
    x0, x1 = int(px(r['x'][0])) + 2, int(px(r['x'][1])) - 2
    y0, y1 = int(py(r['y'][1])) + 2, int(py(r['y'][0])) - 2
    tex = [(x, y) for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)]
    assert len(tex) > 50, 'row %d: %d texels' % (k, len(tex))
    if not all(alb[y][4 * x + 3] for x, y in tex):
        errs.append('row %d not covered where the leaves are (atlas mapping?)' % k)
        continue
    for x, y in tex:
        n = [2 * nm[y][3 * x + i] / 255 - 1 for i in range(3)]
        ln = math.sqrt(sum(a * a for a in n))
        if abs(ln - 1) > 0.02 or n[2] < 0.98:  # the rows face the quad: (0, 0, 1)
            errs.append('row %d texel (%d,%d): normal %s, length %.3f' % (k, x, y, n, ln))
            break
    ao_mean.append(sum(ao[y][x] for x, y in tex) / len(tex) / 255)
    ds = [dp[y][x] for x, y in tex]
    if max(ds) - min(ds) > 0.01 * max(ds) + 1:
        errs.append('row %d: depth not constant over a flat row (%d..%d)' % (k, min(ds), max(ds)))
    depth.append((abs(r['z'] - plane_z), sum(ds) / len(ds)))
if not errs:
    # AO: in range, dark under the roof, light in the open
    if not all(0 <= a <= 1 for a in ao_mean):
        errs.append('AO out of range: %s' % ao_mean)
    if not min(ao_mean[1:]) > 0.6:
        errs.append('open rows not light: AO %s' % ['%.2f' % a for a in ao_mean])
    if not ao_mean[0] < 0.5 * min(ao_mean[1:]):
        errs.append('the row under the roof (AO %.2f) is not darker than the open rows %s'
                    % (ao_mean[0], ['%.2f' % a for a in ao_mean[1:]]))
    # depth: grows with the distance from the plane, in proportion, within 16 bits
    depth.sort()
    if not all(0 < m <= 65535 for _, m in depth):
        errs.append('depth out of range: %s' % depth)
    if not all(depth[i][1] < depth[i + 1][1] for i in range(len(depth) - 1)):
        errs.append('depth not monotonic in the distance from the plane: %s' % depth)
    scale = [m / dist for dist, m in depth]
    if max(scale) > 1.03 * min(scale):
        errs.append('depth not proportional to distance: units per metre %s' % scale)
if errs:
    sys.exit('\n'.join(errs[:10]))
print('ok synthetic: normals (0,0,1), AO %s, depth/metre %.0f' %
      (' '.join('%.2f' % a for a in ao_mean), scale[0]))
EOF
echo ok
