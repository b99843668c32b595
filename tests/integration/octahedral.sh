#!/bin/sh
# octahedral.sh — method "octahedral" (issue 21) on the bundled oak: offline
# and through sylvad with the `sylva` client (byte-identical but for
# report.json's times: a second bake in another process, so also the
# determinism check a second offline bake made); impostor.json, the grid
# atlas, its mips (each half the last), the 16-bit depth map and the proxy
# quad; model.glb passes the Khronos validator; the reported IoU; `sylva-bake
# view` draws the level and refuses bad arguments; bad settings are refused
# by the daemon (400) and offline (exit 1) naming the key; report.json's
# effects name the depth map the impostor ships; tests/tools/octa_render.py,
# a renderer written from docs/runtime.md alone, draws five views as
# `sylva-bake view` does (a full 5 x 5 impostor for the fold and the poles).
# sylva-test: cost=16
. "$(dirname "$0")/daemon_lib.inc"
. "$(dirname "$0")/lib.inc"
BAKE=$B/sylva-bake
CLIENT=$B/sylva
oak="$SYLVA_ROOT/examples/oak_large"
set -- "$oak/oak_large.obj" "$oak/oak_large.mtl" "$oak/leaves_oak_color.png" "$oak/bark_oak_color_1k.jpg"
spec='{"method": "octahedral", "octahedral": {"grid": 6, "frame_pixels": 64},
  "scene": {"viewer": "ground"}, "lod": {"chain": false}, "evaluate": {"views": 8, "sizes": [64]}}'
printf '%s\n' "$spec" > "$T/spec.json"
# one offline bake (under sanitizers it runs the new code: the method, the
# reference runtime, view, the writers); determinism and the daemon's bytes
# are properties of the same code, checked in the plain build by the bake
# through sylvad below
"$BAKE" bake "$@" --spec "$T/spec.json" --out "$T/a" --progress none || { bad "offline bake failed"; finish; }
python3 - "$T/a" << 'PY' && ok "impostor.json, atlas, mips and depth map" || bad "octahedral outputs"
import json, struct, sys, zlib
d = sys.argv[1]
def png(name):
    b = open(d + "/" + name, "rb").read()
    assert b[:8] == b"\x89PNG\r\n\x1a\n", name
    w, h, bits, ctype = struct.unpack(">IIBB", b[16:26])
    return w, h, bits, ctype
imp = json.load(open(d + "/impostor.json"))
assert imp["schema"] == "sylva.impostor/1"
(l,) = imp["lods"]
assert l["lod"] == "hocta6" and l["hemi"] is True and l["grid"] == 6, l
assert l["frame_pixels"] == 64 and l["layout"] == "hemi-octahedral"
assert l["half"] > 0 and abs(l["billboard_half"] - l["half"] * 2 ** 0.5) < 1e-9
assert png(l["maps"]["albedo"]) == (384, 384, 8, 6), png(l["maps"]["albedo"])
assert png(l["maps"]["depth"])[:3] == (384, 384, 16), png(l["maps"]["depth"])
mips = l["mips"]
assert mips[0] == l["maps"]["albedo"] and len(mips) == 5, mips   # 64 -> 32 -> 16 -> 8 -> 4
for k, m in enumerate(mips):
    assert png(m)[:2] == (384 >> k, 384 >> k), (m, png(m))
rep = json.load(open(d + "/report.json"))
(lod,) = rep["lods"]
assert lod["name"] == "hocta6" and lod["triangles"] == 6 and lod["quads"] == 3, lod
iou = [a["iou_mean"] for a in lod["accuracy"] if a["pixels"] == 64][0]
print("IoU@64 %.3f" % iou); assert iou > 0.8, "IoU@64 %.3f" % iou
fr = rep["evaluation"]["frame"]
assert len(fr["centre"]) == 3 and fr["radius"] > 0
pl = json.load(open(d + "/planes.json"))
assert pl["method"] == "octahedral" and pl["lods"][0]["impostor"] is True
# the proxy: three quads, each in the plane of a near-horizontal frame 60°
# apart, with that frame's rectangle of the atlas (a plain viewer's fallback)
qs = pl["lods"][0]["quads"]
assert len(qs) == 3, len(qs)
for q in qs:
    u0, v0, u1, v1 = q["uv"]
    assert abs((u1 - u0) - 1 / 6) < 1e-6 and abs((v1 - v0) - 1 / 6) < 1e-6, q["uv"]
    assert abs(q["normal"][1]) < 0.5, q["normal"]      # near the horizon
for a in range(3):
    for b in range(a + 1, 3):
        c = abs(sum(x * y for x, y in zip(qs[a]["normal"], qs[b]["normal"])))
        assert c < 0.75, (a, b, c)                        # about 60° apart, not one plane
print("IoU@64 %.3f" % iou)
PY
strip='/"times":[[:space:]]*{[^}]*$/,/}/d; s/"times":[[:space:]]*{[^}]*}//'
same_as_a() { # same_as_a DIR WHAT: every file of $T/a in DIR, equal but for report times
    for f in $(ls "$T/a"); do
        if [ "$f" = report.json ]; then
            [ "$(sed "$strip" "$T/a/$f")" = "$(sed "$strip" "$1/$f")" ] || { bad "$2: report.json differs"; return; }
        else
            cmp -s "$T/a/$f" "$1/$f" || { bad "$2: $f differs"; return; }
        fi
    done
    ok "$2: every output identical"
}
v=""
command -v npm > /dev/null 2>&1 && v=$(ensure_validator)
if [ -n "$v" ]; then
    node "$v" "$T/a/model.glb" > /dev/null && ok "model.glb validates" || bad "model.glb does not validate"
else
    bad "npm missing: model.glb not validated"
fi
# one evaluation view, and its refusals
"$BAKE" view "$T/a" --lod hocta6 --dir 0,0.2,1 --size 64 --out "$T/view.png" &&
python3 - "$T/view.png" << 'PY' && ok "sylva-bake view draws the impostor" || bad "sylva-bake view"
import struct, sys
b = open(sys.argv[1], "rb").read()
assert struct.unpack(">IIBB", b[16:26]) == (64, 64, 8, 6)
PY
"$BAKE" view "$T/a" --lod nope --dir 0,0,1 --out "$T/x.png" 2> "$T/err"; rc=$?
check "view of an unknown level exits 1" 1 "$rc"
contains "and names it" "no level named 'nope'" "$(cat "$T/err")"
"$BAKE" view "$T/a" --lod hocta6 --dir 0,1 --out "$T/x.png" 2> /dev/null; rc=$?
check "view with a two-number direction exits 2" 2 "$rc"
printf '{"method": "octahedral", "octahedral": {"frame_pixels": 100}}\n' > "$T/bad.json"
"$BAKE" bake "$@" --spec "$T/bad.json" --out "$T/bad" --progress none 2> "$T/err"; rc=$?
check "frame_pixels 100 refused offline" 1 "$rc"
contains "naming the key" "octahedral.frame_pixels" "$(cat "$T/err")"
printf '{"method": "octahedral", "octahedral": {"proxy_quads": 9}}\n' > "$T/bad.json"
"$BAKE" bake "$@" --spec "$T/bad.json" --out "$T/bad" --progress none 2> "$T/err"; rc=$?
check "proxy_quads 9 refused offline" 1 "$rc"
contains "naming the key" "octahedral.proxy_quads" "$(cat "$T/err")"
# report.json's effects say what the outputs hold: no shadows were asked
# for, yet the impostor ships its depth map (its runtime's parallax)
python3 - "$T/a/report.json" << 'PY' && ok "report.json: depth_map done, in atlas_hocta6_depth.png" || bad "report.json effects"
import json, sys
e = {x["effect"]: x for x in json.load(open(sys.argv[1]))["effects"]}
assert e["depth_map"]["status"] == "done" and e["depth_map"]["outputs"] == ["atlas_hocta6_depth.png"], e["depth_map"]
assert e["normal_map"]["status"] == "skipped" and e["normal_map"]["outputs"] == [], e["normal_map"]
assert e["albedo"]["outputs"] == ["atlas_hocta6_albedo.png"], e["albedo"]
PY
case "$B" in *asan*) finish ;; esac
# docs/runtime.md is enough to write a renderer: tests/tools/octa_render.py,
# written from it alone, draws what sylva's C runtime (`sylva-bake view`)
# draws: this hemi impostor between frames (parallax) and below the horizon
# (the clamp), and a full 5 x 5 one, whose odd grid has frames at the poles
# (their basis), from above, below the horizon (the fold) and from below
printf '%s\n' '{"method": "octahedral", "octahedral": {"grid": 5, "hemi": false, "frame_pixels": 32},
  "lod": {"chain": false}, "evaluate": {"views": 4, "sizes": [64]}}' > "$T/full.json"
"$BAKE" bake "$@" --spec "$T/full.json" --out "$T/full" --progress none > /dev/null || bad "full 5 x 5 bake failed"
docs_render() { # docs_render BAKE LOD DIR...: octa_render.py against sylva-bake view, 48 px
    bd=$1 lv=$2
    shift 2
    views=""
    for dv in "$@"; do
        "$BAKE" view "$T/$bd" --lod "$lv" --dir "$dv" --size 48 --out "$T/ref_${lv}_$dv.png" > /dev/null 2>&1 ||
            bad "sylva-bake view of $lv from $dv failed"
        views="$views $dv=$T/ref_${lv}_$dv.png"
    done
    # shellcheck disable=SC2086
    python3 "$SYLVA_ROOT/tests/tools/octa_render.py" "$T/$bd" "$lv" 48 $views > "$T/docs_$lv.log" 2>&1
    rc=$?
    while read -r line; do ok "renderer from the docs: $line"; done < "$T/docs_$lv.log"
    [ "$rc" = 0 ] || bad "renderer from the docs disagrees with sylva-bake view on $lv (exit $rc)"
}
docs_render a hocta6 0.5,0.2,0.84 -0.3,-0.5,0.81
docs_render full octa5 0,1,0 -0.3,-0.5,0.81 0.05,-1,0.02
# through the daemon and the client
start_daemon --workers 1 --worker "$BAKE"
code=$(curl -s -o "$T/body" -w '%{http_code}' -F 'spec={"method":"octahedral","octahedral":{"grid":1}};type=application/json' \
    -F "mesh=@$oak/oak_large.glb" "$URL/v1/bakes")
check "grid 1 refused with 400" 400 "$code"
contains "naming the key" "octahedral.grid" "$(cat "$T/body")"
SYLVA_SERVER=$URL "$CLIENT" bake "$@" --spec "$T/spec.json" --out "$T/d" > "$T/client.log" 2>&1 ||
    bad "sylva bake through the daemon failed: $(tail -3 "$T/client.log")"
same_as_a "$T/d" "through sylvad"
finish
