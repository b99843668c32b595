#!/bin/sh
# honest_outcomes.sh — degraded results do not pass for good ones (issue 19,
# item 5), through sylva-bake, the daemon's status document and the sylva
# client:
#  1. a .mtl or texture the mesh references but the upload lacks, and that is
#     not beside the mesh either, refuses the bake (exit 1, code "missing",
#     the message names the file and the way on); with "import":
#     {"missing_files": "warn"} it bakes with a warning; one that lies beside
#     the mesh is found and used (said on stderr);
#  2. a "target" that is not met: every output is written, and sylva-bake
#     and sylva exit 3, each saying why on stderr; the status document
#     says "target": {"met": false, "reason": ...}.
# A small synthetic tree (tests/tools/synth_tree.py: a trunk and 40 leaf quads,
# tree.obj + tree.mtl) keeps it quick; the texture case gives the leaves a
# map_Kd that is not uploaded.
# sylva-test: no-sanitize (84 s under ASan; its C paths run there in test_import (missing files), test_server_store (target in the status document) and test_client_cli (exit 3)) cost=30
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
SYLVA=$B/sylva
[ -x "$BAKE" ] && [ -x "$SYLVA" ] || { echo "FAIL: sylva-bake or sylva not built"; exit 1; }
command -v python3 > /dev/null || { echo "FAIL: python3 missing"; exit 1; }
jget() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"; }

python3 "$SYLVA_ROOT/tests/tools/synth_tree.py" "$T/tree.obj" 40 4242
mkdir -p "$T/tex"
sed 's/^mtllib tree.mtl/mtllib tex.mtl/' "$T/tree.obj" > "$T/tex/tex.obj"
sed 's/^newmtl leaf$/newmtl leaf\nmap_Kd leaf.png/' "$T/tree.mtl" > "$T/tex/tex.mtl"
grep -q '^map_Kd leaf.png' "$T/tex/tex.mtl" || bad "could not write the textured .mtl"
# the mesh alone in a folder: nothing to find beside it
mkdir -p "$T/lone" && cp "$T/tree.obj" "$T/lone/tree.obj"
CHEAP='"method":"crossed_quads","lod":{"chain":false},"bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}'
echo "{$CHEAP}" > "$T/spec.json"
echo "{\"import\":{\"missing_files\":\"warn\"},$CHEAP}" > "$T/warn.json"
echo "{$CHEAP,\"target\":{\"iou\":0.999}}" > "$T/unmet.json"
echo "{$CHEAP,\"target\":{\"iou\":0.3}}" > "$T/met.json"

# ---- 1. missing files, offline
"$BAKE" bake "$T/lone/tree.obj" --spec "$T/spec.json" --out "$T/nomtl" --progress none 2> "$T/nomtl.err"
check "sylva-bake without the .mtl exits 1" 1 $?
check "  one line on stderr" 1 "$(wc -l < "$T/nomtl.err")"
contains "  naming the missing file" "references a file that was not supplied: tree.mtl" "$(cat "$T/nomtl.err")"
contains "  and how to proceed" '"import": {"missing_files": "warn"}' "$(cat "$T/nomtl.err")"
check "  error.json code" missing "$(jget "$T/nomtl/error.json" "d['error']['code']")"
check "  no outputs beside error.json" error.json "$(ls "$T/nomtl")"
"$BAKE" info "$T/lone/tree.obj" > /dev/null 2> "$T/info.err"
check "sylva-bake info without the .mtl exits 1" 1 $?
contains "  naming it" "not supplied: tree.mtl" "$(cat "$T/info.err")"
"$BAKE" bake "$T/tex/tex.obj" "$T/tex/tex.mtl" --spec "$T/spec.json" --out "$T/notex" --progress none 2> "$T/notex.err"
check "sylva-bake without a texture the .mtl names exits 1" 1 $?
contains "  naming the texture" "not supplied: leaf.png" "$(cat "$T/notex.err")"
"$BAKE" bake "$T/lone/tree.obj" --spec "$T/warn.json" --out "$T/warn" --progress none 2> "$T/warn.err"
check "missing_files warn: the bake goes on (exit 0)" 0 $?
contains "  warning on stderr" "sylva-bake: warning: 'tree.mtl' was not supplied: its materials are plain grey" \
    "$(cat "$T/warn.err")"
contains "  and in report.json input.warnings" "'tree.mtl' was not supplied" \
    "$(jget "$T/warn/report.json" "d['input']['warnings']")"
[ -s "$T/warn/model.glb" ] && ok "  model.glb written" || bad "  no model.glb"
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/spec.json" --out "$T/full" --progress none 2> "$T/full.err"
check "with its .mtl the same tree bakes (exit 0)" 0 $?
check "  without a warning" "" "$(cat "$T/full.err")"
"$BAKE" bake "$T/tree.obj" --spec "$T/spec.json" --out "$T/found" --progress none > "$T/found.out" 2> "$T/found.err"
check "its .mtl beside it, not listed: found, the tree bakes (exit 0)" 0 $?
check "  saying which file it used" "sylva-bake: using $T/tree.mtl (named by tree.obj)" "$(cat "$T/found.err")"
cmp -s "$T/found/model.glb" "$T/full/model.glb" && ok "  the bake is the listed one's" || bad "  model.glb differs"
contains "  a summary table on stdout" "level" "$(head -1 "$T/found.out")"
"$BAKE" bake "$T/tex/tex.obj" --spec "$T/spec.json" --out "$T/notex2" --progress none 2> "$T/notex2.err"
check "a texture neither listed nor beside the mesh: exit 1" 1 $?
contains "  naming the texture" "not supplied: leaf.png" "$(cat "$T/notex2.err")"
contains "  after using the .mtl it found" "using $T/tex/tex.mtl" "$(cat "$T/notex2.err")"

# ---- 2. targets, offline
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/unmet.json" --out "$T/unmet" --progress none 2> "$T/unmet.err"
check "an unmet target: sylva-bake exits 3" 3 $?
contains "  says so on stderr" "sylva-bake: target not met: goal IoU 0.999 at 64 px" "$(cat "$T/unmet.err")"
contains "  with the best IoU reached and the try baked" "reached IoU" "$(cat "$T/unmet.err")"
contains "  naming the try" "try " "$(cat "$T/unmet.err")"
for f in model.glb report.json planes.json; do
    [ -s "$T/unmet/$f" ] && ok "  $f written" || bad "  $f missing"
done
check "  report.json target.met" False "$(jget "$T/unmet/report.json" "d['target']['met']")"
check "  report.json target.reason is what stderr said" True "$(python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))["target"]["reason"]
print("sylva-bake: target not met: " + r in open(sys.argv[2]).read())' "$T/unmet/report.json" "$T/unmet.err")"
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/met.json" --out "$T/met" --progress none 2> "$T/met.err"
check "a target that is met: exit 0" 0 $?
check "  no reason in the report" False "$(jget "$T/met/report.json" "'reason' in d['target']")"

# ---- 3. the daemon (real worker) and the client
start_daemon --workers 1 --worker "$BAKE"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=@$T/spec.json" -F "mesh=@$T/tree.obj" "$URL/v1/bakes")
check "upload without the .mtl is accepted (202)" 202 "$code"
key=$(json_str key < "$T/b")
wait_state "$key" failed 120 && ok "  the job fails" || bad "  the job did not fail: $(curl -s "$URL/v1/bakes/$key")"
curl -s "$URL/v1/bakes/$key" > "$T/st_nomtl.json"
check "  status error.code is missing" missing "$(jget "$T/st_nomtl.json" "d['error']['code']")"
contains "  status error.message names the file" "not supplied: tree.mtl" "$(jget "$T/st_nomtl.json" "d['error']['message']")"
contains "  and the way on" "missing_files" "$(jget "$T/st_nomtl.json" "d['error']['message']")"
check "  an input error: not retried" 1 "$(jget "$T/st_nomtl.json" "d['attempts']")"

SYLVA_SERVER=$URL "$SYLVA" bake "$T/lone/tree.obj" --spec "$T/spec.json" --out "$T/c_nomtl" > "$T/c_nomtl.out" 2> "$T/c_nomtl.err"
check "sylva bake without the .mtl exits 1" 1 $?
contains "  naming it" "not supplied: tree.mtl" "$(cat "$T/c_nomtl.err")"
SYLVA_SERVER=$URL "$SYLVA" bake "$T/lone/tree.obj" --spec "$T/warn.json" --out "$T/c_warn" > "$T/c_warn.out" 2>&1
check "sylva bake with missing_files warn exits 0" 0 $?
contains "  prints the warning" "warning: 'tree.mtl' was not supplied" "$(cat "$T/c_warn.out")"
cmp -s "$T/c_warn/model.glb" "$T/warn/model.glb" && ok "  its model.glb is the offline one" \
    || bad "  model.glb differs from the offline bake"

SYLVA_SERVER=$URL "$SYLVA" --json bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/unmet.json" \
    --out "$T/c_unmet" > "$T/c_unmet.json" 2> "$T/c_unmet.err"
check "sylva bake with an unmet target exits 3, as sylva-bake" 3 $?
contains "  says so on stderr" "target not met: goal IoU 0.999" "$(cat "$T/c_unmet.err")"
check "  --json summary.target.met" False "$(jget "$T/c_unmet.json" "d['summary']['target']['met']")"
cmp -s "$T/c_unmet/model.glb" "$T/unmet/model.glb" && ok "  outputs downloaded, model.glb is the offline one" \
    || bad "  model.glb missing or differs from the offline bake"
ukey=$(jget "$T/c_unmet.json" "d['key']")
curl -s "$URL/v1/bakes/$ukey" > "$T/st_unmet.json"
check "  status document: state done" done "$(jget "$T/st_unmet.json" "d['state']")"
check "  status document: target.met false" False "$(jget "$T/st_unmet.json" "d['target']['met']")"
contains "  status document: target.reason" "no setting reached it" "$(jget "$T/st_unmet.json" "d['target']['reason']")"
check "  manifest summary has the search" True "$(jget "$T/st_unmet.json" "len(d['manifest']['summary']['target']['tries']) > 0")"
SYLVA_SERVER=$URL "$SYLVA" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/unmet.json" \
    --out "$T/c_unmet2" > "$T/c_unmet2.out" 2> "$T/c_unmet2.err"
check "  the plain client run exits 3 too" 3 $?
contains "  its summary says target not met" "target not met: goal IoU 0.999" "$(cat "$T/c_unmet2.out")"
contains "  stderr says where the outputs are" "the outputs in $T/c_unmet2 are that bake" "$(cat "$T/c_unmet2.err")"
SYLVA_SERVER=$URL "$SYLVA" fetch "$ukey" --out "$T/c_fetch" > /dev/null 2> "$T/c_fetch.err"
check "  sylva fetch of that bake exits 3" 3 $?
SYLVA_SERVER=$URL "$SYLVA" bake "$T/tree.obj" --spec "$T/spec.json" --out "$T/c_found" \
    > "$T/c_found.out" 2> "$T/c_found.err"
check "sylva bake finds the .mtl beside the mesh (exit 0)" 0 $?
contains "  saying so" "sylva: using $T/tree.mtl (named by tree.obj)" "$(cat "$T/c_found.err")"
cmp -s "$T/c_found/model.glb" "$T/full/model.glb" && ok "  its model.glb is the offline one" \
    || bad "  model.glb differs from the offline bake"
contains "  the summary table has the triangles" "triangles" "$(cat "$T/c_found.out")"
SYLVA_SERVER=$URL "$SYLVA" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/met.json" --out "$T/c_met" \
    > "$T/c_met.out" 2>&1
check "sylva bake with a met target exits 0" 0 $?
contains "  and says target met" "target met" "$(cat "$T/c_met.out")"
finish
