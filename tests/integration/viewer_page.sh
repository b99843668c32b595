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
# Screenshots stay in $T/shots when the test fails.
# sylva-test: no-sanitize (a browser and a real bake; the daemon's routes run under ASan in viewer_routes.sh) cost=25
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
SPEC_FILE=$T/spec.json
printf '%s\n' '{"method":"octahedral","lod":{"coarsest":"slicing"},"scene":{"viewer":"ground"},
  "evaluate":{"views":4,"sizes":[64]}}' > "$SPEC_FILE"
t0=$(date +%s)
"$CLIENT" --server "$URL" --json bake "$D/aspen_small.obj" "$D/aspen_small.mtl" "$D/bark_birch_color_1k.jpg" \
    "$D/leaves_aspen_color.png" --spec "$SPEC_FILE" --out "$T/out" --quiet > "$T/bake.json" 2> "$T/bake.err" \
    || { bad "sylva bake failed: $(tail -3 "$T/bake.err")"; finish; }
key=$(sed -n 's/.*"key":"\([0-9a-f]\{64\}\)".*/\1/p' "$T/bake.json" | head -n 1)
[ -n "$key" ] && ok "aspen baked through sylvad in $(( $(date +%s) - t0 )) s" || { bad "no key in $(head -c 300 "$T/bake.json")"; finish; }
grep -q '"azimuth_step_deg"' "$T/out/planes.json" && ok "the chain has a slicing level" || bad "no slicing level in planes.json"
octa=$(sed -n 's/.*"lod":[[:space:]]*"\([A-Za-z0-9_]*\)".*/\1/p' "$T/out/impostor.json" 2>/dev/null | head -n 1)
[ -n "$octa" ] && grep -q '"hemi":[[:space:]]*true' "$T/out/impostor.json" && ok "the chain has a hemi-octahedral level, $octa" \
    || { bad "no hemi-octahedral level in impostor.json"; finish; }
# the evaluator's renders of the views the page is compared on
compare=""
for v in "$octa 0.5,0.2,0.84" "$octa 0,1,0" "$octa -0.3,-0.5,0.81" "full 0.5,0.2,0.84"; do
    set -- $v
    ref=$T/ref_$1_$2.png
    "$BAKE" view "$T/out" --lod "$1" --dir "$2" --size 256 --out "$ref" > "$T/view.log" 2>&1 \
        || bad "sylva-bake view of $1 from $2 failed: $(tail -2 "$T/view.log")"
    compare="$compare --compare $1 $2 256 $ref"
done

mkdir -p "$T/shots"
t0=$(date +%s)
# the original as the page loads it (OBJ + MTL + textures from /inputs, the
# import's units and up) covers what the full level covers: the full level
# is the same mesh with its leaves reordered; and the fade shader drawing the
# full level at the aspen's stochastic50 (mu = 1: every leaf fits the budget
# once simplified) draws the full level
node "$VT/viewer_check.mjs" "$URL" "$key" "$T/shots" \
    --compare original 0.5,0.2,0.84 256 page:full \
    --compare 'stochastic50?fade=1' 0.5,0.2,0.84 256 page:full $compare > "$T/check.log" 2>&1
rc=$?
cat "$T/check.log"
grep -q '^levels: .*slicing=slicing' "$T/check.log" && ok "the slicing level is drawn by slicing.*.glsl" \
    || bad "the page did not draw the slicing level with its shader"
grep -q "^levels: .*$octa=octahedral" "$T/check.log" && ok "$octa is drawn by octahedral.*.glsl" \
    || bad "the page did not draw $octa with its shader"
n=$(grep -c "^ok   - .* coverage IoU .* against the evaluator's render" "$T/check.log")
check "four views agree with the evaluator's renders (IoU >= 0.95)" 4 "$n"
[ "$rc" = 0 ] && ok "viewer checks passed in $(( $(date +%s) - t0 )) s" || { bad "viewer checks failed (exit $rc)"; KEEP_T=1; }
[ -s "$T/shots/view.png" ] && ok "screenshot of the page" || bad "no screenshot"
[ "$fails" = 0 ] || echo "screenshots kept in $T/shots"
finish
