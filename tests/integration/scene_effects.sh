#!/bin/sh
# scene_effects.sh — the scene decides the effects: static lighting bakes no
# normal map and says so; dynamic lighting bakes one; shadows bake depth maps;
# ambient occlusion bakes an AO map; and report.json lists each as done/skipped.
set -eu
. "$(dirname "$0")/lib.inc"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
d="$data/eztree_aspen_small"
if [ -d "$d" ]; then
    set -- "$d/aspen_small.obj" $(companions "$d" aspen_small.obj)
    lod=crossed
else
    oak="$root/examples/oak_large"
    set -- "$oak/oak_large.obj" $(companions "$oak" oak_large.obj)
    lod=crossed
fi
effect() { json_get "$1/report.json" "[e['status'] for e in j['effects'] if e['effect']=='$2'][0]"; }
common='"method": "crossed_quads", "evaluate": {"views": 4, "sizes": [64]}'

echo "{$common, \"scene\": {\"lighting\": \"static\"}}" > "$tmp/static.json"
"$bake" bake "$@" --spec "$tmp/static.json" --out "$tmp/static" || fail "static bake"
[ ! -e "$tmp/static/atlas_${lod}_normal.png" ] || fail "static lighting baked a normal map"
[ "$(effect "$tmp/static" normal_map)" = skipped ] || fail "static: normal_map not reported skipped"
[ "$(effect "$tmp/static" lit_albedo)" = done ] || fail "static: lit_albedo not done"
[ ! -e "$tmp/static/atlas_${lod}_depth.png" ] || fail "no shadows, yet a depth map"
grep -q KHR_materials_unlit "$tmp/static/model.glb" || fail "static: atlas not marked unlit"

echo "{$common, \"scene\": {\"lighting\": \"dynamic\", \"ambient_occlusion\": true}}" > "$tmp/dyn.json"
"$bake" bake "$@" --spec "$tmp/dyn.json" --out "$tmp/dyn" || fail "dynamic bake"
[ -s "$tmp/dyn/atlas_${lod}_normal.png" ] || fail "dynamic lighting baked no normal map"
[ -s "$tmp/dyn/atlas_${lod}_ao.png" ] || fail "ambient_occlusion baked no AO map"
[ "$(effect "$tmp/dyn" normal_map)" = done ] || fail "dynamic: normal_map not reported done"
[ "$(effect "$tmp/dyn" lit_albedo)" = skipped ] || fail "dynamic: lit albedo not skipped"
if grep -q KHR_materials_unlit "$tmp/dyn/model.glb"; then fail "dynamic: atlas marked unlit"; fi
grep -q normalTexture "$tmp/dyn/model.glb" || fail "dynamic: model.glb has no normalTexture"

echo "{$common, \"scene\": {\"shadows\": true}}" > "$tmp/sh.json"
"$bake" bake "$@" --spec "$tmp/sh.json" --out "$tmp/sh" || fail "shadows bake"
[ -s "$tmp/sh/atlas_${lod}_depth.png" ] || fail "shadows baked no depth map"
[ "$(effect "$tmp/sh" depth_map)" = done ] || fail "shadows: depth_map not reported done"
python3 - "$tmp/sh/atlas_${lod}_depth.png" <<'PY' || fail "depth map is not 16-bit"
import struct, sys
d = open(sys.argv[1], 'rb').read()
assert d[:8] == b'\x89PNG\r\n\x1a\n'
bit_depth = d[24]
assert bit_depth == 16, bit_depth
PY
echo ok
