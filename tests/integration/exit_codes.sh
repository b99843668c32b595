#!/bin/sh
# exit_codes.sh — docs/client.md's one exit-code table, path by path, from
# sylva-bake and from sylva: the same outcome gives the same code in both.
#   0 done; 1 input refused or missing (the mesh, a companion neither listed
#   nor beside it, the spec file), or the bake failed, or an unknown key;
#   2 usage (one line and a --help hint); 3 done but the target not met;
#   5 cancelled; 6 no service. (4, a download that fails its SHA-256, is
#   client_tamper.sh's.) Also sylvad's own usage errors: an unknown option is
#   named as unknown, and no store refuses to start.
# A small synthetic tree (tests/tools/synth_tree.py) keeps the real bakes quick;
# the fake worker gives a failed and a cancelled bake.
# sylva-test: no-sanitize (exit statuses only: the same C paths run under ASan in client_cli and bake_cli) cost=40
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
SYLVA=$B/sylva
[ -x "$BAKE" ] && [ -x "$SYLVA" ] || { echo "FAIL: sylva-bake or sylva not built"; exit 1; }
command -v python3 > /dev/null || { echo "FAIL: python3 missing"; exit 1; }

python3 "$SYLVA_ROOT/tests/tools/synth_tree.py" "$T/tree.obj" 40 4242
mkdir -p "$T/lone" && cp "$T/tree.obj" "$T/lone/tree.obj"
CHEAP='"method":"crossed_quads","lod":{"chain":false},"bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}'
echo "{$CHEAP}" > "$T/spec.json"
echo "{$CHEAP,\"target\":{\"iou\":0.999}}" > "$T/unmet.json"

# run NAME CMD...: runs CMD, its stdout and stderr in $T/NAME.out and .err;
# the exit status in $rc
run() { n=$1; shift; "$@" > "$T/$n.out" 2> "$T/$n.err"; rc=$?; }

# ---- sylva-bake
run b_ok "$BAKE" bake "$T/tree.obj" --spec "$T/spec.json" -o "$T/b_ok" -q
check "sylva-bake: done: 0" 0 $rc
run b_nomesh "$BAKE" bake "$T/nothere.obj" -o "$T/b_nomesh"
check "sylva-bake: a mesh that is not there: 1" 1 $rc
contains "  naming it" "nothere.obj" "$(cat "$T/b_nomesh.err")"
run b_nomtl "$BAKE" bake "$T/lone/tree.obj" --spec "$T/spec.json" -o "$T/b_nomtl"
check "sylva-bake: a companion neither listed nor beside the mesh: 1" 1 $rc
contains "  naming it" "not supplied: tree.mtl" "$(cat "$T/b_nomtl.err")"
run b_nospec "$BAKE" bake "$T/tree.obj" --spec "$T/nothere.json" -o "$T/b_nospec"
check "sylva-bake: a spec file that is not there: 1" 1 $rc
run b_usage "$BAKE" bake "$T/tree.obj" -o "$T/b_usage" --bogus
check "sylva-bake: an unknown option: 2" 2 $rc
check "  one line and the hint" "sylva-bake: unknown option --bogus|try 'sylva-bake --help'" \
    "$(paste -sd'|' "$T/b_usage.err")"
run b_noval "$BAKE" bake "$T/tree.obj" -o
check "sylva-bake: an option without its value: 2" 2 $rc
run b_set "$BAKE" bake "$T/tree.obj" -o "$T/b_set" --set novalue
check "sylva-bake: --set without '=': 2" 2 $rc
run b_up "$BAKE" info "$T/tree.obj" --up X
check "sylva-bake info: --up X: 2" 2 $rc
run b_unmet "$BAKE" bake "$T/tree.obj" --spec "$T/unmet.json" -o "$T/b_unmet" --progress none
check "sylva-bake: the target not met: 3" 3 $rc
run b_method "$BAKE" bake "$T/tree.obj" --method crossed_quads --set lod.chain=false \
    --set bake.max_atlas=256 --set evaluate.views=4 --set 'evaluate.sizes=[64]' -o "$T/b_method" -v
check "sylva-bake: the spec as flags: 0" 0 $rc
cmp -s "$T/b_method/model.glb" "$T/b_ok/model.glb" && ok "  the same bake as the spec file's" ||
    bad "  model.glb differs from the spec file's bake"
contains "  -v says the spec" '"method":"crossed_quads"' "$(cat "$T/b_method.err")"
contains "  the table on stdout" "IoU@64" "$(head -n 1 "$T/b_method.out")"

# ---- sylvad's usage
run d_bogus "$SYLVAD" --bogus
check "sylvad --bogus: 2" 2 $rc
contains "  says unknown option --bogus" "unknown option --bogus" "$(cat "$T/d_bogus.err")"
run d_nostore "$SYLVAD" --listen 127.0.0.1:0
check "sylvad without a store: 2" 2 $rc
contains "  saying why" "no store: pass --store DIR" "$(cat "$T/d_nostore.err")"

# ---- sylva, no service
run c_down "$SYLVA" --server http://127.0.0.1:1 --retries 0 bake "$T/tree.obj" --spec "$T/spec.json" -o "$T/c_down"
check "sylva: no server: 6" 6 $rc
run c_usage "$SYLVA" bake "$T/tree.obj" -o "$T/c_usage" --bogus
check "sylva: an unknown option: 2" 2 $rc
check "  one line and the hint" 2 "$(wc -l < "$T/c_usage.err")"
run c_nomesh "$SYLVA" --server http://127.0.0.1:1 bake "$T/nothere.obj" -o "$T/c_nomesh"
check "sylva: a mesh that is not there: 1, as sylva-bake (before any connection)" 1 $rc
run c_nospec "$SYLVA" --server http://127.0.0.1:1 bake "$T/tree.obj" --spec "$T/nothere.json" -o "$T/c_nospec"
check "sylva: a spec file that is not there: 1, as sylva-bake" 1 $rc

# ---- sylva against a daemon with the fake worker: failed, cancelled, unknown key
start_daemon --workers 1
export SYLVA_SERVER=$URL
run c_health "$SYLVA" health
check "sylva health: 0" 0 $rc
printf '# mode=fail\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/fail.obj"
run c_fail "$SYLVA" bake "$T/fail.obj" -o "$T/c_fail"
check "sylva: the bake failed: 1" 1 $rc
run c_nokey "$SYLVA" status 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef
check "sylva status of an unknown key: 1" 1 $rc
printf '# mode=sleep\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/sleep.obj"
"$SYLVA" bake "$T/sleep.obj" -o "$T/c_cancel" --progress plain > "$T/c_cancel.out" 2> "$T/c_cancel.err" &
cpid=$!
i=0
while ! grep -q "submitted as" "$T/c_cancel.out" 2> /dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
key=$(sed -n 's/.*submitted as \([0-9a-f]*\).*/\1/p' "$T/c_cancel.out" | head -n 1)
"$SYLVA" cancel "$key" > /dev/null 2>&1
wait "$cpid"
check "sylva: a bake cancelled on the server: 5" 5 $?
stop_daemon

# ---- sylva against a daemon with the real worker: done, missing, target
start_daemon --workers 1 --worker "$BAKE"
export SYLVA_SERVER=$URL
run c_ok "$SYLVA" bake "$T/tree.obj" --spec "$T/spec.json" -o "$T/c_ok"
check "sylva: done: 0" 0 $rc
contains "  found tree.mtl beside the mesh" "sylva: using $T/tree.mtl (named by tree.obj)" "$(cat "$T/c_ok.err")"
contains "  the table with the triangles" "triangles" "$(cat "$T/c_ok.out")"
run c_nomtl "$SYLVA" bake "$T/lone/tree.obj" --spec "$T/spec.json" -o "$T/c_nomtl"
check "sylva: a companion neither listed nor beside the mesh: 1, as sylva-bake" 1 $rc
contains "  naming it" "not supplied: tree.mtl" "$(cat "$T/c_nomtl.err")"
run c_unmet "$SYLVA" bake "$T/tree.obj" --spec "$T/unmet.json" -o "$T/c_unmet"
check "sylva: the target not met: 3, as sylva-bake" 3 $rc
finish
