#!/bin/sh
# client_tamper.sh — download verification: an artifact whose bytes were changed
# on the way (a proxy flips one byte of model.glb, keeping length and headers) is
# refused: `sylva fetch` and `sylva bake` exit 4, name the artifact, and leave no
# model.glb (nor a temporary file) behind. Through an honest proxy the same
# fetch succeeds, so the failure is the tampering and not the proxy.
# Needs $BUILD/sylva, $BUILD/sylvad, $BUILD/sylva-bake and python3.
# sylva-test: no-sanitize (the client's checksum refusal; under ASan its download and verify paths run in client_refetch and client_cli, the real worker through the daemon in client_cli) cost=15
set -u
ROOT=${SYLVA_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
BUILD=${BUILD:-build}
cd "$ROOT" || exit 1
SYLVA=${SYLVA_CLI:-$BUILD/sylva}      # overridable: e.g. an ASan client against a plain daemon
SYLVAD=${SYLVAD:-$BUILD/sylvad}
BAKER=${SYLVA_BAKE:-$BUILD/sylva-bake}
PROXY=tests/integration/client_tamper_proxy.py
for b in "$SYLVA" "$SYLVAD" "$BAKER"; do
    [ -x "$b" ] || { echo "FAIL: $b is missing (build it first)"; exit 1; }
done
command -v python3 >/dev/null || { echo "FAIL: python3 is missing"; exit 1; }
T=$(mktemp -d /tmp/sylva_client_tamper.XXXXXX)
PIDS=""
cleanup() {
    for p in $PIDS; do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null; done
    rm -rf "$T"
}
trap cleanup EXIT INT TERM
fails=0
check() {
    desc=$1; shift
    if "$@"; then echo "ok   $desc"; else echo "FAIL $desc"; fails=$((fails + 1)); fi
}
wait_file() {
    i=0
    while [ ! -s "$1" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    [ -s "$1" ]
}

"$SYLVAD" --listen 127.0.0.1:0 --store "$T/store" --port-file "$T/port" --worker "$BAKER" \
    --workers 1 >"$T/sylvad.log" 2>&1 &
PIDS="$PIDS $!"
wait_file "$T/port" || { echo "FAIL: sylvad did not start"; cat "$T/sylvad.log"; exit 1; }
DIRECT="http://127.0.0.1:$(cat "$T/port")"
python3 "$PROXY" "$DIRECT" "$T/evil.port" model.glb 2>"$T/evil.log" &
PIDS="$PIDS $!"
python3 "$PROXY" "$DIRECT" "$T/honest.port" no-such-artifact 2>"$T/honest.log" &
PIDS="$PIDS $!"
wait_file "$T/evil.port" && wait_file "$T/honest.port" || { echo "FAIL: proxy did not start"; exit 1; }
EVIL="http://127.0.0.1:$(cat "$T/evil.port")"
HONEST="http://127.0.0.1:$(cat "$T/honest.port")"
unset SYLVA_TOKEN SYLVA_SERVER

M=examples/oak_large
MESH="$M/oak_large.obj $M/oak_large.mtl $M/bark_oak_color_1k.jpg $M/leaves_oak_color.png"
FAST="--method crossed_quads --set bake.max_atlas=256 --set evaluate.views=2 --set evaluate.sizes=[64]"

"$SYLVA" --server "$DIRECT" bake $MESH $FAST --out "$T/direct" --json >"$T/bake.json" 2>"$T/bake.err"
rc=$?
check "direct bake exits 0" test $rc -eq 0
[ $rc -eq 0 ] || { cat "$T/bake.err"; exit 1; }
KEY=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["key"])' "$T/bake.json")

"$SYLVA" --server "$HONEST" fetch "$KEY" --out "$T/honest" >/dev/null 2>"$T/honest.err"
check "fetch through the honest proxy exits 0" test $? -eq 0
check "  and gets the same model.glb" cmp -s "$T/direct/model.glb" "$T/honest/model.glb"

"$SYLVA" --server "$EVIL" fetch "$KEY" --out "$T/evil" >/dev/null 2>"$T/evil.err"
check "fetch through the tampering proxy exits 4" test $? -eq 4
check "  naming the artifact" grep -q "model.glb" "$T/evil.err"
check "  leaving no model.glb behind" sh -c "! test -e '$T/evil/model.glb'"
check "  nor a temporary file" sh -c "! ls -A '$T/evil' 2>/dev/null | grep -q part"

"$SYLVA" --server "$EVIL" bake $MESH $FAST --out "$T/evilbake" --json >"$T/evilbake.json" 2>/dev/null
check "bake through the tampering proxy exits 4" test $? -eq 4
check "  with error code integrity" python3 -c \
    'import json,sys; sys.exit(json.load(open(sys.argv[1]))["error"]["code"] != "integrity")' \
    "$T/evilbake.json"
check "  and no model.glb" sh -c "! test -e '$T/evilbake/model.glb'"

[ $fails -eq 0 ] || { echo "$fails check(s) failed"; exit 1; }
echo "all tamper checks passed"
