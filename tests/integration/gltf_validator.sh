#!/bin/sh
# gltf_validator.sh — the GLB writer's output passes the Khronos glTF validator
# (npm gltf-validator) with zero errors: a 3-LOD MSFT_lod chain with textured
# MASK leaves, normal/occlusion maps, BLEND, extra attributes; a >65535-vertex
# mesh (uint32 indices); a chain whose coarsest LOD is empty; each level of the
# chain as a standalone file (lod<i>_<name>.glb: one node, images embedded);
# the chain with output.compress's encodings, KHR_mesh_quantization and then
# EXT_meshopt_compression (whose encoded bytes the validator cannot read:
# test_gltf decodes them), which three.js's GLTFLoader also loads with the
# triangles and bounds of the plain file (three_load.mjs, meshopt decoder).
# Installs the validator under build/test-npm/ when missing (npm.inc).
# Skips (exit 77, "skipped: ...") only when node/npm are not installed.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=${SYLVA_ROOT:-$(cd "$here/../.." && pwd)}
build=${BUILD:-build}
case "$build" in /*) ;; *) build="$root/$build" ;; esac

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "skipped: node/npm not available (Debian packages nodejs, npm)"
    exit 77
fi
. "$here/npm.inc"
vdir=$(npm_tool gltf-validator) || { echo "FAIL: npm ci of gltf-validator failed"; exit 1; }
tool="$build/tools/write_test_glb"
if [ ! -x "$tool" ]; then
    echo "FAIL: $tool not built (make BUILD=... $tool)"
    exit 1
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT INT TERM
"$tool" "$out"
ls "$out"/lod0_*.glb "$out"/lod1_*.glb "$out"/lod2_*.glb > /dev/null
node "$vdir/validate.js" "$out"/chain3.glb "$out"/large.glb "$out"/culled.glb "$out"/lod*_*.glb \
    "$out"/chain3_quantize.glb "$out"/chain3_meshopt.glb "$out"/large_meshopt.glb
# the compressed files draw what the plain one draws in three.js: the same
# triangles and, within the quantization step, the same bounding box
node "$vdir/three_load.mjs" "$out"/chain3.glb "$out"/chain3_quantize.glb "$out"/chain3_meshopt.glb \
    > "$out/three.jsonl"
python3 - "$out/three.jsonl" <<'EOF'
import json, sys
r = [json.loads(l) for l in open(sys.argv[1])]
for x in r[1:]:
    assert x['triangles'] == r[0]['triangles'] and x['textured'] == r[0]['textured'], (x, r[0])
    for a, b in zip(sum(x['box'], []), sum(r[0]['box'], [])):
        assert abs(a - b) <= 1e-3 * max(1, abs(b)), (x['file'], x['box'], r[0]['box'])
print('three.js loads the quantized and meshopt chains as the plain one:', r[0]['triangles'], 'triangles')
EOF
