#!/bin/sh
# The viewer page in a real browser (issue 21 items 3-4; docs/runtime.md):
# a real sylvad and sylva-bake worker, a small tree (the aspen, 3.6k
# triangles) baked through the `sylva` client for a ground viewer with a
# slicing level and a hemi-octahedral impostor (8 x 8 frames) in its chain,
# then Debian's chromium, headless with WebGL2 on SwiftShader, driven by
# playwright-core (npm, tests/viewer/package.json) through
# GET /v1/bakes/{key}/view: the page loads with no error and no failed
# request, draws covered pixels for the original and every level (the
# slicing level through slicing.*.glsl), every shader builds, its distance
# slider walks the chain by report.json's switch distances, and the original
# it loads from the uploaded files covers what the full level covers
# (tests/viewer/viewer_check.mjs). Then the acceptance of issue 21: the
# page's render of the impostor through octahedral.*.glsl, from three
# directions (above the horizon, straight down, below it: the hemi clamp),
# against `sylva-bake view` of the same view (the evaluator's C reference
# runtime, sv_octa_render), coverage IoU >= 0.95 each (measured 0.99); and the
# full level, a plain glTF drawn by three.js, against the evaluator's OSMesa
# render (measured 0.98).
# Colour and alpha as glTF defines them (issue 41 item 4 and its three.js
# acceptance; docs/testing.md has the figures): the demo oak's GLB, whose
# leaves are alpha BLEND, drawn with transparent pixels inside the crown and
# covering what the evaluator covers; the Scopia bush baked with `{}`: the
# page's panels of it (original, levels, fade shader) as bright as its full
# level, and each of its level files drawn by three.js's own GLTFLoader as
# bright as the full mesh (mean linear luminance within 7 %).
# Screenshots stay in $T/shots when the test fails.
# sylva-test: no-sanitize (a browser and a real bake; the daemon's routes run under ASan in viewer_routes.sh) cost=40
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
CLIENT=$B/sylva
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
D=${SYLVA_DATA:-$SYLVA_ROOT/../shared/data}/eztree_aspen_small
[ -x "$BAKE" ] && [ -x "$CLIENT" ] || { echo "skipped: $BAKE or $CLIENT not built"; exit 77; }
[ -f "$D/aspen_small.obj" ] || { echo "skipped: $D/aspen_small.obj missing (shared data)"; exit 77; }
[ -x "$CHROMIUM" ] || { echo "skipped: no chromium at $CHROMIUM (deploy/apt-packages.txt installs it)"; exit 77; }
command -v node >/dev/null || { echo "skipped: node missing"; exit 77; }
. "$(dirname "$0")/npm.inc"
VT=$(npm_tool viewer) || { bad "npm ci of playwright-core failed"; finish; }
export CHROMIUM

start_daemon --workers 1 --worker "$BAKE"
# bake_key NAME SPEC FILES...: bakes through sylvad into $T/NAME, prints the key
bake_key() {
    o=$T/$1 sp=$2
    shift 2
    "$CLIENT" --server "$URL" --json bake "$@" --spec "$sp" --out "$o" --quiet > "$o.status" 2> "$o.err" \
        || { echo "sylva bake into $o failed: $(tail -3 "$o.err")" >&2; return 1; }
    sed -n 's/.*"key":"\([0-9a-f]\{64\}\)".*/\1/p' "$o.status" | head -n 1
}
printf '%s\n' '{"method":"octahedral","lod":{"coarsest":"slicing"},"scene":{"viewer":"ground"},
  "evaluate":{"views":4,"sizes":[64]}}' > "$T/spec.json"
# The demo oak's GLB, whose leaf cards are alpha BLEND: its full level alone
# (the source's materials). The Scopia bush (centimetres; its MTL tints the
# leaf texture with Kd 0.069 0.237 0.024) with the default method and chain,
# its glTF files compressed (output.compress "meshopt": quantized,
# EXT_meshopt_compression), which the page and GLTFLoader decode.
OAK=$SYLVA_ROOT/examples/oak_large/oak_large.glb
BUSH=${SYLVA_DATA:-$SYLVA_ROOT/../shared/data}/scopia_bush
printf '%s\n' '{"method":"stochastic","stochastic":{"levels":[1]},"lod":{"chain":false},
  "import":{"units":0.2},"evaluate":{"views":4,"sizes":[64]}}' > "$T/oak_spec.json"
printf '%s\n' '{"import":{"units":"cm"},"bake":{"max_atlas":512},"evaluate":{"views":4,"sizes":[128,64,32]},
  "output":{"compress":"meshopt"}}' > "$T/bush_spec.json"
t0=$(date +%s)
key=$(bake_key out "$T/spec.json" "$D/aspen_small.obj" "$D/aspen_small.mtl" "$D/bark_birch_color_1k.jpg" \
    "$D/leaves_aspen_color.png") && [ -n "$key" ] || { bad "no key for the aspen"; finish; }
okey=$(bake_key oak "$T/oak_spec.json" "$OAK") && [ -n "$okey" ] || { bad "no key for the oak"; finish; }
bkey=$(bake_key bush "$T/bush_spec.json" "$BUSH/bush.obj" "$BUSH/bush.mtl" "$BUSH/bark.jpg" "$BUSH/leaf.png") \
    && [ -n "$bkey" ] || { bad "no key for the bush"; finish; }
ok "aspen, oak (GLB) and bush ({}) baked through sylvad in $(( $(date +%s) - t0 )) s"
grep -q '"azimuth_step_deg"' "$T/out/planes.json" && ok "the chain has a slicing level" || bad "no slicing level in planes.json"
octa=$(sed -n 's/.*"lod":[[:space:]]*"\([A-Za-z0-9_]*\)".*/\1/p' "$T/out/impostor.json" 2>/dev/null | head -n 1)
[ -n "$octa" ] && grep -q '"hemi":[[:space:]]*true' "$T/out/impostor.json" && ok "the chain has a hemi-octahedral level, $octa" \
    || { bad "no hemi-octahedral level in impostor.json"; finish; }
# the evaluator's renders of the views the page is compared on
compare=""
for v in "out $octa 0.5,0.2,0.84" "out $octa 0,1,0" "out $octa -0.3,-0.5,0.81" "out full 0.5,0.2,0.84" \
    "oak full 0.5,0.2,0.84"; do
    set -- $v
    ref=$T/ref_$1_$2_$3.png
    "$BAKE" view "$T/$1" --lod "$2" --dir "$3" --size 256 --out "$ref" > "$T/view.log" 2>&1 \
        || bad "sylva-bake view of $1's $2 from $3 failed: $(tail -2 "$T/view.log")"
    [ "$1" = out ] && compare="$compare --compare $2 $3 256 $ref"
done

mkdir -p "$T/shots"
t0=$(date +%s)
# the original as the page loads it (OBJ + MTL + textures from /inputs, the
# import's units and up) covers what the full level covers: the full level
# is the same mesh with its leaves reordered; and the fade shader drawing the
# full level at the aspen's stochastic50 (mu = 1: every leaf fits the budget
# once simplified) draws the full level, and the impostor and slicing
# shaders draw it as bright as three.js draws the full level. The oak's full level and original
# drawn as three.js draws BLEND, with transparent pixels inside the crown,
# covering what the evaluator's render of the full level covers. The bush:
# the page's own panels of it (the OBJ original with its MTL, three.js's
# materials, the stochastic fade shader) as bright as its full level, and
# every level file drawn by three.js's own GLTFLoader, unlit, as bright as
# the full mesh within 7 %, with the mipmaps its samplers ask for and without
# them (the quad levels bake factor x texture in linear light, as glTF
# defines colour; the bush's leaf texture, black where it is transparent, is
# dilated by the bake so its mip levels do not darken the mesh levels:
# docs/outputs.md "Textures").
# the bush's kept levels, as its report names them (the chain decides how many)
blevels=$(python3 -B -c "import json, sys; print(' '.join(l['name'] for l in json.load(open(sys.argv[1]))['lods'] if l['name'] != 'full'))" "$T/bush/report.json")
nb=$(echo $blevels | wc -w)
node "$VT/viewer_check.mjs" "$URL" "$key" "$T/shots" \
    --compare original 0.5,0.2,0.84 256 page:full \
    --compare 'stochastic50?fade=1' 0.5,0.2,0.84 256 page:full $compare \
    --panels "$key" 0.5,0.2,0.84 256 full original stochastic50 "$octa" slicing \
    --on "$okey" --compare full 0.5,0.2,0.84 256 "$T/ref_oak_full_0.5,0.2,0.84.png" \
    --compare original 0.5,0.2,0.84 256 page:full \
    --blend full 0.5,0.2,0.84 256 --blend original 0.5,0.2,0.84 256 \
    --panels "$bkey" 0.5,0.2,0.84 256 full original $blevels 'stochastic50?fade=1' \
    --luminance "$bkey" 256 > "$T/check.log" 2>&1
rc=$?
cat "$T/check.log"
grep -q '^levels: .*slicing=slicing' "$T/check.log" && ok "the slicing level is drawn by slicing.*.glsl" \
    || bad "the page did not draw the slicing level with its shader"
grep -q "^levels: .*$octa=octahedral" "$T/check.log" && ok "$octa is drawn by octahedral.*.glsl" \
    || bad "the page did not draw $octa with its shader"
n=$(grep -c "^ok   - .* coverage IoU .* against the evaluator's render (ref_out_" "$T/check.log")
check "four views agree with the evaluator's renders (IoU >= 0.95)" 4 "$n"
n=$(grep -c "^ok   - .* inside the crown transparent" "$T/check.log")
check "the oak's BLEND leaves drawn with transparent pixels inside the crown (full level, original)" 2 "$n"
grep -q "^ok   - full from .* against the evaluator's render (ref_oak_" "$T/check.log" \
    && ok "the oak's full level covers what the evaluator's render covers" || bad "the oak's full level against the evaluator"
n=$(grep -c "^ok   - viewer panel " "$T/check.log")
check "the page draws the aspen's and the bush's originals, levels and shaders as bright as their full level (7 %)" $((8 + nb)) "$n"
n=$(grep -c "^ok   - three.js GLTFLoader, unlit: " "$T/check.log")
m=$(sed -n 's/.*"file":[[:space:]]*"lod\([0-9]*\)_.*/\1/p' "$T/bush/report.json" | wc -l)
[ "$m" -ge 4 ] && check "every one of the bush's $m level files as bright as its full mesh in three.js, with mipmaps and without (7 %)" "$m" "$n" \
    || bad "the bush's report.json lists $m level files"
[ "$rc" = 0 ] && ok "viewer checks passed in $(( $(date +%s) - t0 )) s" || { bad "viewer checks failed (exit $rc)"; KEEP_T=1; }
[ -s "$T/shots/view.png" ] && ok "screenshot of the page" || bad "no screenshot"
[ "$fails" = 0 ] || echo "screenshots kept in $T/shots"
finish
