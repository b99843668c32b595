#!/bin/sh
# gltf_validator.sh — the GLB writer's output passes the Khronos glTF validator
# (npm gltf-validator) with zero errors: a 3-LOD MSFT_lod chain with textured
# MASK leaves, normal/occlusion maps, BLEND, extra attributes; a >65535-vertex
# mesh (uint32 indices); a chain whose coarsest LOD is empty; each level of the
# chain as a standalone file (lod<i>_<name>.glb: one node, images embedded).
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
node "$vdir/validate.js" "$out"/chain3.glb "$out"/large.glb "$out"/culled.glb "$out"/lod*_*.glb
