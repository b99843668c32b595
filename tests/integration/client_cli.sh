#!/bin/sh
# client_cli.sh — the `sylva` command end to end against a real sylvad on a free
# loopback port: exit codes, --json output, artifacts verified on disk, progress
# lines without \r when stdout is not a terminal, status/fetch/cancel/health,
# idempotent resubmission, a bake failure, a batch of two meshes.
# Needs $BUILD/sylva, $BUILD/sylvad and $BUILD/sylva-bake (fails if missing).
# sylva-test: cost=11
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
T=$(mktemp -d /tmp/sylva_client_cli.XXXXXX)
DPID=""
P503=""
cleanup() {
    [ -n "$DPID" ] && kill "$DPID" 2>/dev/null && wait "$DPID" 2>/dev/null
    [ -n "$P503" ] && kill "$P503"
P503="" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT INT TERM
fails=0
check() { # check DESCRIPTION COMMAND...
    desc=$1; shift
    if "$@"; then echo "ok   $desc"; else echo "FAIL $desc"; fails=$((fails + 1)); fi
}

"$SYLVAD" --listen 127.0.0.1:0 --store "$T/store" --port-file "$T/port" --worker "$BAKER" \
    --workers 2 >"$T/sylvad.log" 2>&1 &
DPID=$!
i=0
while [ ! -s "$T/port" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
[ -s "$T/port" ] || { echo "FAIL: sylvad did not start"; cat "$T/sylvad.log"; exit 1; }
export SYLVA_SERVER="http://127.0.0.1:$(cat "$T/port")"
unset SYLVA_TOKEN

# A small tree: the aspen from the shared data, else the bundled oak.
if [ -f "${SYLVA_DATA:-/nonexistent}/eztree_aspen_small/aspen_small.obj" ]; then
    M=$SYLVA_DATA/eztree_aspen_small
    MESH="$M/aspen_small.obj $M/aspen_small.mtl $M/bark_birch_color_1k.jpg $M/leaves_aspen_color.png"
    STEM=aspen_small
else
    echo "note: SYLVA_DATA not found, using examples/oak_large"
    M=examples/oak_large
    MESH="$M/oak_large.obj $M/oak_large.mtl $M/bark_oak_color_1k.jpg $M/leaves_oak_color.png"
    STEM=oak_large
fi
FAST="--method crossed_quads --set bake.max_atlas=256 --set evaluate.views=2 --set evaluate.sizes=[64]"
# under ASan without the LOD chain (its C paths run under ASan in bake_cli and
# lod_chain): the level table then starts with the crossed quads
FIRST=full
case "$BUILD" in *asan*) FAST="$FAST --set lod.chain=false" FIRST=crossed ;; esac

json_get() { # json_get FILE PYTHON-EXPR (d = the document)
    python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"
}

# one daemon per store (issue 23): a second sylvad on the same --store exits
# at once naming the first one's pid
"$SYLVAD" --listen 127.0.0.1:0 --store "$T/store" --worker "$BAKER" >"$T/second.log" 2>&1
rc2=$?
check "a second sylvad on the same store exits non-zero" test "$rc2" -ne 0
check "  saying the store is in use by the first (pid $DPID)" \
    grep -q "in use by another sylvad (pid $DPID" "$T/second.log"

# one daemon per port (issue 23): no SO_REUSEPORT unless reuse_port = on
"$SYLVAD" --listen "127.0.0.1:$(cat "$T/port")" --store "$T/store2" --worker "$BAKER" \
    >"$T/third.log" 2>&1
rc3=$?
check "a second sylvad on the same port exits non-zero" test "$rc3" -ne 0
check "  saying it cannot listen" grep -q "cannot listen on 127.0.0.1:$(cat "$T/port")" "$T/third.log"

# --version on all three programs (issue 23): one line, the program and its version
ver=$(sed -n 's/^#define SV_VERSION "\(.*\)"/\1/p' "$(dirname "$0")/../../core/include/sv.h")
check "sylva --version prints 'sylva $ver'" test "$("$SYLVA" --version)" = "sylva $ver"
check "sylvad --version prints 'sylvad $ver'" test "$("$SYLVAD" --version)" = "sylvad $ver"
check "sylva-bake --version prints 'sylva-bake $ver'" test "$("$BAKER" --version)" = "sylva-bake $ver"

# health
check "health exits 0" "$SYLVA" health
"$SYLVA" health --json >"$T/health.json"
check "health --json is JSON naming the server" \
    test "$(json_get "$T/health.json" 'd["server"]')" = "$SYLVA_SERVER"
"$SYLVA" health --server http://127.0.0.1:1 --retries 0 >"$T/down.out" 2>"$T/down.err"
check "health against a closed port exits 6 (service)" test $? -eq 6
check "  with one line on stderr" test "$(wc -l <"$T/down.err")" -eq 1
# without --retries too: a probe tries each server once and does not wait
# (it sat 24 s in silence before issue 23); 10 s is a hang guard, not a speed bound
timeout 10 "$SYLVA" health --server http://127.0.0.1:1,http://127.0.0.1:2 >/dev/null 2>"$T/down2.err"
check "health with no server up exits 6 at once (no retry rounds)" test $? -eq 6
check "  having tried both servers" grep -q "127.0.0.1:2" "$T/down2.err"
# no daemon at all (nothing listens: connection refused before any answer):
# one line naming the address and the way to change it, exit 6, at once
# rather than after the retry rounds (24 s before)
for cmd in "status 0123456789ab" "bake $MESH --out $T/nodaemon"; do
    t0=$(date +%s%N)
    "$SYLVA" $cmd --server http://127.0.0.1:1 >/dev/null 2>"$T/nod.err"
    rc=$?
    ms=$(( ($(date +%s%N) - t0) / 1000000 ))
    check "sylva ${cmd%% *} with no daemon exits 6 (service) within 2 s (${ms} ms)" \
        test "$rc" -eq 6 -a "$ms" -lt 2000
    check "  with one error line: no daemon at the address, is sylvad running, --server" \
        sh -c "test \"\$(grep -c '' '$T/nod.err')\" -eq 1 && grep -q '^sylva: error: no sylva daemon answers at http://127.0.0.1:1 (connection refused): is sylvad running? (--server / SYLVA_SERVER)\$' '$T/nod.err'"
done
# a daemon that answers 503 is worth waiting for: other commands say why
# they wait, unless --quiet
python3 -c '
import http.server, sys
class H(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        self.send_response(503); self.send_header("Content-Length", "0"); self.end_headers()
    def log_message(self, *a): pass
s = http.server.HTTPServer(("127.0.0.1", 0), H)
open(sys.argv[1], "w").write(str(s.server_port)); s.serve_forever()' "$T/p503" &
P503=$!
i=0
while [ ! -s "$T/p503" ] && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
"$SYLVA" status 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef \
    --server "http://127.0.0.1:$(cat "$T/p503")" --retries 2 >/dev/null 2>"$T/retry.err"
check "a retried request (503) says so on stderr before each wait (2 notices)" \
    test "$(grep -c 'retrying in .* (attempt [23] of 3)' "$T/retry.err")" -eq 2
"$SYLVA" status 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef \
    --server "http://127.0.0.1:$(cat "$T/p503")" --retries 2 --quiet >/dev/null 2>"$T/retryq.err"
check "  and --quiet keeps them back" test "$(grep -c 'retrying in' "$T/retryq.err")" -eq 0
kill "$P503"
P503=""

# usage errors
"$SYLVA" bake $MESH >/dev/null 2>"$T/usage.err"
check "bake without --out exits 2" test $? -eq 2
check "  naming --out" grep -q -- "--out" "$T/usage.err"
"$SYLVA" status nothex --json >"$T/badkey.json" 2>/dev/null
check "status of a malformed key exits 2" test $? -eq 2
check "  and prints an error object with --json" \
    test "$(json_get "$T/badkey.json" 'd["error"]["code"]')" != ""

# bake with --json
"$SYLVA" bake $MESH $FAST --out "$T/out" --json >"$T/bake.json" 2>"$T/bake.err"
rc=$?
check "bake --json exits 0" test $rc -eq 0
[ $rc -eq 0 ] || cat "$T/bake.err"
KEY=$(json_get "$T/bake.json" 'd["key"]')
check "  reports a 64-hex key" sh -c "echo '$KEY' | grep -Eq '^[0-9a-f]{64}$'"
check "  state done" test "$(json_get "$T/bake.json" 'd["state"]')" = done
check "  lists model.glb" \
    test "$(json_get "$T/bake.json" '"model.glb" in [a["name"] for a in d["artifacts"]]')" = True
check "  summary has LODs and times" \
    test "$(json_get "$T/bake.json" 'len(d["summary"]["lods"]) > 0 and "total" in d["summary"]["times"]')" = True
json_get "$T/bake.json" '"\n".join(a["sha256"] + "  " + a["name"] for a in d["artifacts"])' \
    >"$T/sums"
check "  every artifact on disk matches its SHA-256" sh -c "cd '$T/out' && sha256sum -c --quiet '$T/sums'"
check "  no temporary files left" sh -c "! ls -A '$T/out' | grep -q part"

# the same bake again: same key, answered from the store; plain progress lines
"$SYLVA" bake $MESH $FAST --out "$T/out2" >"$T/plain.out" 2>&1
check "second identical bake exits 0" test $? -eq 0
check "  has the same key" grep -q "$KEY" "$T/plain.out"
check "  progress output has no carriage return when not a terminal" \
    sh -c "! grep -q \"\$(printf '\\r')\" '$T/plain.out'"
check "  and prints the summary" grep -q "LODs:" "$T/plain.out"
check "  same artifacts" cmp -s "$T/out/model.glb" "$T/out2/model.glb"
# on a terminal (script(1) gives the command a pty): a \r-updated bar
if command -v script >/dev/null; then
    script -qec "'$SYLVA' bake $MESH $FAST --out '$T/tty'" /dev/null >"$T/tty.out" 2>&1
    check "on a terminal the progress is a bar updated with \\r" \
        sh -c "grep -q \"\$(printf '\\r')\" '$T/tty.out' && grep -q '\\[#' '$T/tty.out'"
else
    echo "FAIL script(1) is missing: cannot test the terminal progress bar"; fails=$((fails + 1))
fi
"$SYLVA" bake $MESH $FAST --out "$T/out3" --quiet >"$T/quiet.out" 2>&1
check "--quiet prints no progress lines" sh -c "! grep -q submitted '$T/quiet.out'"

# evaluate.flattening_bound through the server (docs/accuracy.md "The flattening
# bound"): a quad level carries it beside its accuracy, at the same sizes;
# exact flattening moves leaves, so it is below 1
BOUND="--method billboard_cloud --set billboard_cloud.lods=[8] --set lod.chain=false --set bake.max_atlas=512 --set evaluate.views=4 --set evaluate.sizes=[64] --set evaluate.flattening_bound=true"
"$SYLVA" bake $MESH $BOUND --out "$T/bound" --quiet >"$T/bound.out" 2>&1
check "bake with evaluate.flattening_bound exits 0" test $? -eq 0
check "  report.json gives the level its flattening bound at 64 px, in (0.2, 0.99)" \
    test "$(json_get "$T/bound/report.json" '[0.2 < b["iou_mean"] < 0.99 for b in d["lods"][0]["flattening_bound"] if b["pixels"] == 64] == [True]')" = True
check "  at the sizes of its accuracy" \
    test "$(json_get "$T/bound/report.json" '[a["pixels"] for a in d["lods"][0]["accuracy"]] == [b["pixels"] for b in d["lods"][0]["flattening_bound"]]')" = True
check "  a bake without it (the first above) has none" \
    test "$(json_get "$T/out/report.json" 'any("flattening_bound" in l for l in d["lods"])')" = False
"$SYLVA" bake $MESH $FAST --set evaluate.flattening_bound=1 --out "$T/badb" >/dev/null 2>"$T/badb.err"
check "a flattening_bound that is not true or false exits 1" test $? -eq 1
check "  naming evaluate.flattening_bound" grep -q "evaluate.flattening_bound" "$T/badb.err"

# status / fetch
"$SYLVA" status "$KEY" --json >"$T/status.json"
check "status --json exits 0" test $? -eq 0
check "  state done with a manifest" \
    test "$(json_get "$T/status.json" 'd["state"] + str(len(d["manifest"]["artifacts"]) > 0)')" = doneTrue
"$SYLVA" status "$KEY" >"$T/status.txt"
check "status prints the state" grep -q "done" "$T/status.txt"
check "  and the table of levels with their triangles" \
    sh -c "grep -q '^level  *triangles  *texels' '$T/status.txt' && grep -Eq '^$FIRST +[1-9][0-9]* ' '$T/status.txt'"
SHORT=$(echo "$KEY" | cut -c1-12)
"$SYLVA" status "$SHORT" >"$T/status12.txt" 2>&1
check "status by the 12-digit key the bake printed exits 0" test $? -eq 0
check "  and names the whole key" grep -q "^$KEY done" "$T/status12.txt"
mkdir -p "$T/fetched"
touch "$T/fetched/lod9_stale.glb" "$T/fetched/atlas_stale_albedo.png" "$T/fetched/mine.txt"
"$SYLVA" fetch "$SHORT" --out "$T/fetched" --json >"$T/fetch.json"
check "fetch by the short key exits 0" test $? -eq 0
check "  an earlier bake's files left in --out are removed" \
    test ! -e "$T/fetched/lod9_stale.glb" -a ! -e "$T/fetched/atlas_stale_albedo.png"
check "  a file sylva does not write is kept" test -e "$T/fetched/mine.txt"
check "  fetched files equal the baked ones" cmp -s "$T/out/model.glb" "$T/fetched/model.glb"
ZERO=0000000000000000000000000000000000000000000000000000000000000000
"$SYLVA" status $ZERO >/dev/null 2>"$T/nf.err"
check "status of an unknown key exits 1" test $? -eq 1
check "  with one line on stderr" test "$(wc -l <"$T/nf.err")" -eq 1

# a bad spec is refused by the server (400) -> exit 1
"$SYLVA" bake $MESH --method no_such_method --out "$T/bad" --json >"$T/bad.json" 2>"$T/bad.err"
check "bake with an unknown method exits 1" test $? -eq 1
check "  the error names the method" grep -q "no_such_method" "$T/bad.err"
check "  --json carries the server's error code" \
    test "$(json_get "$T/bad.json" 'd["error"]["code"]')" = spec

# a mesh that is not a mesh: the bake fails in the worker (or is refused) -> exit 1
printf 'this is not an OBJ file\x00\x01\x02' >"$T/broken.obj"
"$SYLVA" bake "$T/broken.obj" $FAST --out "$T/broken" --json >"$T/broken.json" 2>"$T/broken.err"
check "bake of a broken mesh exits 1" test $? -eq 1
check "  with a clear one-line reason" test "$(wc -l <"$T/broken.err")" -eq 1
check "  and no artifacts" sh -c "! test -f '$T/broken/model.glb'"

# batch: two meshes, submitted together, each into out/<stem>/
mkdir -p "$T/b2"
cp $MESH "$T/b2/"
for f in "$T"/b2/*.obj; do mv "$f" "$T/b2/copy.obj"; done
"$SYLVA" bake $MESH "$T/b2/copy.obj" $(ls "$T"/b2/* | grep -v '\.obj$') $FAST \
    --out "$T/batch" --json >"$T/batch.json" 2>"$T/batch.err"
rc=$?
check "batch bake exits 0" test $rc -eq 0
[ $rc -eq 0 ] || cat "$T/batch.err"
check "  reports two bakes, ok" test "$(json_get "$T/batch.json" 'str(d["ok"]) + str(len(d["bakes"]))')" = True2
check "  writes out/$STEM/ and out/copy/" \
    sh -c "test -f '$T/batch/$STEM/model.glb' && test -f '$T/batch/copy/model.glb'"

# cancel of a finished bake is refused (its results stay); --delete deletes it
"$SYLVA" cancel "$KEY" >"$T/cancel.out" 2>"$T/cancel.err"
check "cancel of a finished bake is refused (exit 1, issue 23)" test $? -eq 1
check "  saying it finished and naming --delete" grep -q "has finished (done).*--delete" "$T/cancel.err"
"$SYLVA" status "$KEY" >/dev/null 2>&1
check "  and the bake is still there" test $? -eq 0
"$SYLVA" cancel --delete "$KEY" >"$T/cancel.out"
check "cancel --delete of a finished bake exits 0" test $? -eq 0
check "  and says it deleted it, not 'cancelled' (issue 23)" grep -q "^$KEY deleted" "$T/cancel.out"
"$SYLVA" status "$KEY" >/dev/null 2>&1
check "  and its status is then unknown (exit 1)" test $? -eq 1

# a restart on the same port while the old connections sit in TIME_WAIT (the
# server closes them first with "Connection: close"): SO_REUSEADDR must stay
# on when SO_REUSEPORT is off (MHD drops both for "reuse = 0")
PORT=$(cat "$T/port")
for i in 1 2 3; do curl -s -H "Connection: close" "$SYLVA_SERVER/v1/health" >/dev/null; done
kill "$DPID" && wait "$DPID" 2>/dev/null
DPID=""
"$SYLVAD" --listen "127.0.0.1:$PORT" --store "$T/store" --worker "$BAKER" >"$T/restart.log" 2>&1 &
DPID=$!
i=0
until "$SYLVA" health >/dev/null 2>&1 || [ $i -ge 50 ]; do sleep 0.1; i=$((i + 1)); done
check "the daemon restarts on its port at once (TIME_WAIT connections do not block it)" \
    "$SYLVA" health
if [ $fails -ne 0 ]; then
    echo "$fails check(s) failed; daemon log tail:"
    tail -n 20 "$T/sylvad.log"
    exit 1
fi
echo "all client CLI checks passed"
