#!/bin/sh
# client_retry.sh — the daemon is restarted (SIGTERM, down for a while, started
# again on the same port with the same store) while `sylva bake` is waiting for
# a bake; the command rides out the outage with its retries and still succeeds,
# with artifacts that match their SHA-256 on disk.
# Needs $BUILD/sylva, $BUILD/sylvad and $BUILD/sylva-bake (fails if missing).
# sylva-test: serial (restarts the daemon on the port it had: another test could take it meanwhile) no-sanitize (a restart's timing, run alone: 33 s of one core under ASan) cost=15
set -u
ROOT=${SYLVA_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
BUILD=${BUILD:-build}
cd "$ROOT" || exit 1
SYLVA=${SYLVA_CLI:-$BUILD/sylva}      # overridable: e.g. an ASan client against a plain daemon
SYLVAD=${SYLVAD:-$BUILD/sylvad}
BAKER=${SYLVA_BAKE:-$BUILD/sylva-bake}
for b in "$SYLVA" "$SYLVAD" "$BAKER"; do
    [ -x "$b" ] || { echo "FAIL: $b is missing (build it first)"; exit 1; }
done
T=$(mktemp -d /tmp/sylva_client_retry.XXXXXX)
DPID=""
CPID=""
cleanup() {
    [ -n "$CPID" ] && kill "$CPID" 2>/dev/null
    [ -n "$DPID" ] && kill "$DPID" 2>/dev/null && wait "$DPID" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT INT TERM
fails=0
check() {
    desc=$1; shift
    if "$@"; then echo "ok   $desc"; else echo "FAIL $desc"; fails=$((fails + 1)); fi
}
start_daemon() { # start_daemon PORT
    rm -f "$T/port"
    "$SYLVAD" --listen "127.0.0.1:$1" --store "$T/store" --port-file "$T/port" \
        --worker "$BAKER" --workers 1 --drain-timeout 5 >>"$T/sylvad.log" 2>&1 &
    DPID=$!
    i=0
    while [ ! -s "$T/port" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    [ -s "$T/port" ]
}

start_daemon 0 || { echo "FAIL: sylvad did not start"; cat "$T/sylvad.log"; exit 1; }
PORT=$(cat "$T/port")
unset SYLVA_TOKEN
export SYLVA_SERVER="http://127.0.0.1:$PORT"

# A bake that takes several seconds: leaf clusters (three LODs) on a small tree.
if [ -f "${SYLVA_DATA:-/nonexistent}/eztree_aspen_small/aspen_small.obj" ]; then
    M=$SYLVA_DATA/eztree_aspen_small
    MESH="$M/aspen_small.obj $M/aspen_small.mtl $M/bark_birch_color_1k.jpg $M/leaves_aspen_color.png"
else
    M=examples/oak_large
    MESH="$M/oak_large.obj $M/oak_large.mtl $M/bark_oak_color_1k.jpg $M/leaves_oak_color.png"
fi
"$SYLVA" bake $MESH --method leaf_clusters --set evaluate.views=2 --set evaluate.sizes=[64] \
    --progress plain --out "$T/out" >"$T/bake.out" 2>&1 &
CPID=$!

# Wait until the worker is at work, then restart the daemon under the client.
i=0
while ! grep -Eq ': (import|validate|classify|method|bake)' "$T/bake.out" && [ $i -lt 300 ] &&
    kill -0 "$CPID" 2>/dev/null; do
    sleep 0.1; i=$((i + 1))
done
check "the bake reached the worker" grep -Eq ': (import|validate|classify|method|bake)' "$T/bake.out"
check "the client is still waiting when the daemon goes down" kill -0 "$CPID"
kill -TERM "$DPID"
wait "$DPID"
DPID=""
sleep 1.5
check "the daemon comes back on the same port" start_daemon "$PORT"
wait "$CPID"
rc=$?
CPID=""
check "sylva bake still exits 0" test $rc -eq 0
[ $rc -eq 0 ] || cat "$T/bake.out"
check "  and prints the summary" grep -q "LODs:" "$T/bake.out"
check "  with a model.glb" test -s "$T/out/model.glb"
KEY=$(grep -o 'submitted as [0-9a-f]*' "$T/bake.out" | head -n 1 | cut -d' ' -f3)
"$SYLVA" status "$KEY" --json >"$T/status.json"
python3 -c 'import json,sys
d=json.load(open(sys.argv[1]))
print("\n".join(a["sha256"]+"  "+a["name"] for a in d["manifest"]["artifacts"]))' \
    "$T/status.json" >"$T/sums"
check "  whose artifacts all match the manifest" sh -c "cd '$T/out' && sha256sum -c --quiet '$T/sums'"

[ $fails -eq 0 ] || { echo "$fails check(s) failed"; tail -n 20 "$T/sylvad.log"; exit 1; }
echo "all retry checks passed"
