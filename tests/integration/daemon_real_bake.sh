#!/bin/sh
# The bundled oak baked through sylvad with the real sylva-bake worker is
# byte-identical to an offline `sylva-bake bake` run on the same input
# (report.json differs only in its "times" and is compared without them).
# sylva-test: no-sanitize (offline = daemon bytes, a property of the same code; docs/testing.md) cost=35
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
MESH=$SYLVA_ROOT/examples/oak_large/oak_large.glb
[ -x "$BAKE" ] || { echo "skipped: $BAKE not built"; exit 77; }
[ -f "$MESH" ] || { echo "skipped: $MESH missing"; exit 77; }
start_daemon --workers 1 --worker "$BAKE"
pick_spec # the first method the build registers, so offline and daemon agree
# its chain and atlases as {} makes them; 8 views at 128, 64 and 32 px (both
# evaluators, a third of the default evaluation's cost: identity needs no
# more); under sanitizers a default bake takes minutes: a cheap one proves
# the same path
SPEC="${SPEC%\}},\"evaluate\":{\"views\":8,\"sizes\":[128,64,32]}}"
case "$B" in *asan*) SPEC='{"method":"crossed_quads","bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}}' ;; esac
printf '%s' "$SPEC" > "$T/spec.json"
mkdir -p "$T/offline"
"$BAKE" bake "$MESH" --spec "$T/spec.json" --out "$T/offline" > "$T/offline.log" 2>&1 \
    || { bad "offline sylva-bake failed: $(tail -3 "$T/offline.log")"; finish; }
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=@$T/spec.json" -F "mesh=@$MESH" "$URL/v1/bakes")
check "upload of the oak is 202" 202 "$code"
key=$(json_str key < "$T/b")
wait_state "$key" done 300 && ok "daemon bake done" || bad "daemon bake not done: $(curl -s "$URL/v1/bakes/$key")"
mkdir -p "$T/daemon"
for f in $(ls "$T/offline"); do
    code=$(curl -s -o "$T/daemon/$f" -w '%{http_code}' "$URL/v1/bakes/$key/artifacts/$f")
    check "artifact $f served" 200 "$code"
    if [ "$f" = report.json ]; then
        strip='/"times":[[:space:]]*{[^}]*$/,/}/d; s/"times":[[:space:]]*{[^}]*}//'
        a=$(sed "$strip" "$T/offline/$f"); b=$(sed "$strip" "$T/daemon/$f")
        [ "$(wc -c < "$T/offline/$f")" -gt 0 ] && [ "$a" != "$(cat "$T/offline/$f")" ] \
            || bad "report.json has no times object to strip"
        [ "$a" = "$b" ] && ok "report.json equal but for times" || bad "report.json differs beyond times"
    else
        cmp -s "$T/offline/$f" "$T/daemon/$f" && ok "$f byte-identical" || bad "$f differs"
    fi
done
contains "status carries the summary" '"summary":{' "$(curl -s "$URL/v1/bakes/$key")"
finish
