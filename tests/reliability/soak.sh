#!/bin/sh
# soak.sh — issue 12, "Load": `make soak`, a long run of one real daemon (real
# sylva-bake worker) under a steady mix of work, SOAK_SECONDS long (1800):
# new bakes of small trees (a distinct seed each, so each is a new key), the
# same uploads again (answered from the store), status long-polls, artifact
# downloads, and wrk bursts on /v1/health. Every 10 s it samples the daemon's
# resident memory and open file descriptors.
# The store has a limit (SOAK_STORE, 4M) so that eviction bounds the number of
# keys the daemon holds: each stored key costs memory (its manifest, ~14 KB),
# so with an unbounded store memory grows with the keys, by design, not by a
# leak. Goals: memory growth < 5 % from the end of the warm-up (10 % of the
# run, or the first eviction if later: the store is full, the steady state) to
# the end, open files flat (end ≤ warm-up + 2), zero errors (every
# answer 2xx, every bake done). Prints ok/FAIL lines and a `figures:` line;
# samples go to bench/results/soak.csv. Not in CI (it is long by design).
set -u
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
SECS=${SOAK_SECONDS:-1800}
T=$(mktemp -d /tmp/sylva-soak.XXXXXX)
DPID="" SPID=""
cleanup() {
    [ -n "$SPID" ] && kill "$SPID" 2>/dev/null
    if [ -n "$DPID" ]; then
        for w in $(pgrep -P "$DPID" 2>/dev/null); do kill -9 "$w" 2>/dev/null; done
        kill -9 "$DPID" 2>/dev/null
    fi
    wait 2>/dev/null
    [ -n "${KEEP_T:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fails=0
ok() { echo "ok   - $1"; }
bad() { echo "FAIL - $1"; fails=$((fails + 1)); }
command -v wrk >/dev/null || { echo "skipped: wrk missing"; exit 77; }

python3 "$SYLVA_ROOT/tests/tools/synth_tree.py" "$T/tree.obj" 60 31337

"$B/sylvad" --listen 127.0.0.1:0 --store "$T/store" --port-file "$T/port" --worker "$B/sylva-bake" \
    --workers 1 --store-max-bytes "${SOAK_STORE:-4M}" 2>"$T/daemon.log" &
DPID=$!
k=0
while [ ! -s "$T/port" ] && [ $k -lt 100 ]; do sleep 0.1; k=$((k + 1)); done
[ -s "$T/port" ] || { echo "FAIL - sylvad did not start"; exit 1; }
URL=http://127.0.0.1:$(cat "$T/port")

# sampler: seconds, rss KiB, fds
( t0=$(date +%s)
  while kill -0 "$DPID" 2>/dev/null; do
      rss=$(sed -n 's/^VmRSS:[[:space:]]*\([0-9]*\).*/\1/p' /proc/"$DPID"/status 2>/dev/null)
      fds=$(ls /proc/"$DPID"/fd 2>/dev/null | wc -l)
      echo "$(( $(date +%s) - t0 )),$rss,$fds"
      sleep 10
  done ) > "$T/samples.csv" &
SPID=$!

errors=0 bakes=0 cached=0 gets=0 n=0
note() { errors=$((errors + 1)); echo "error: $*" >> "$T/errors.log"; }
code() { curl -s -o "$T/body" -w '%{http_code}' "$@"; }
end=$(( $(date +%s) + SECS ))
start=$(date +%s)
while [ "$(date +%s)" -lt "$end" ]; do
    n=$((n + 1))
    [ -s "$T/first_evict" ] || ! grep -q store_evicted "$T/daemon.log" ||
        echo $(( $(date +%s) - start )) > "$T/first_evict"
    spec="{\"method\":\"crossed_quads\",\"bake\":{\"max_atlas\":128},\"evaluate\":{\"views\":2,\"sizes\":[32]},\"lod\":{\"chain\":false,\"coarsest\":\"none\"},\"seed\":$n}"
    c=$(code -F "spec=$spec;type=application/json" -F "mesh=@$T/tree.obj" -F "file=@$T/tree.mtl" "$URL/v1/bakes")
    case "$c" in 2*) ;; *) note "POST $c $(cat "$T/body")"; continue ;; esac
    key=$(sed -n 's/.*"key":"\([0-9a-f]*\)".*/\1/p' "$T/body")
    state=""
    for _ in 1 2 3 4 5 6; do
        c=$(code "$URL/v1/bakes/$key?wait=10")
        case "$c" in 2*) ;; *) note "GET status $c"; break ;; esac
        state=$(sed -n 's/.*"state":"\([a-z]*\)".*/\1/p' "$T/body" | head -n 1)
        [ "$state" = done ] || [ "$state" = failed ] && break
    done
    [ "$state" = done ] && bakes=$((bakes + 1)) || { note "bake $key: $state"; continue; }
    for a in model.glb planes.json report.json; do
        c=$(code "$URL/v1/bakes/$key/artifacts/$a"); gets=$((gets + 1))
        case "$c" in 2*) ;; *) note "GET $a $c" ;; esac
    done
    c=$(code -F "spec=$spec;type=application/json" -F "mesh=@$T/tree.obj" -F "file=@$T/tree.mtl" "$URL/v1/bakes")
    case "$c" in 2*) cached=$((cached + 1)) ;; *) note "re-POST $c" ;; esac
    if [ $((n % 20)) = 0 ]; then
        wrk -t1 -c16 -d3s "$URL/v1/health" > "$T/wrk.txt" 2>&1
        grep -q -E 'Non-2xx|Socket errors' "$T/wrk.txt" && note "wrk: $(grep -E 'Non-2xx|Socket errors' "$T/wrk.txt")"
    fi
done
kill -0 "$DPID" 2>/dev/null && ok "the daemon ran for $SECS s" || bad "the daemon died"
kill "$SPID" 2>/dev/null; wait "$SPID" 2>/dev/null; SPID=""
mkdir -p "$SYLVA_ROOT/bench/results"
{ echo "seconds,rss_kib,fds"; cat "$T/samples.csv"; } > "$SYLVA_ROOT/bench/results/soak.csv"
fe=$(cat "$T/first_evict" 2>/dev/null || echo -1)
echo "first eviction after: $fe s"
[ "$fe" -ge 0 ] || bad "the store never reached its limit: no steady state to measure"
set -- $(python3 - "$T/samples.csv" "$SECS" "$fe" <<'EOF'
import sys
rows = [tuple(map(int, l.split(","))) for l in open(sys.argv[1]) if l.count(",") == 2 and l.split(",")[1]]
secs = int(sys.argv[2])
warm = [r for r in rows if r[0] >= max(secs * 0.1, int(sys.argv[3]))] or rows
w, e = warm[0], rows[-1]
print("%.2f %d %d %d %d %d" % (100.0 * (e[1] - w[1]) / w[1], w[1], e[1], w[2], e[2], max(r[1] for r in rows)))
EOF
)
growth=$1 rss_w=$2 rss_e=$3 fd_w=$4 fd_e=$5 rss_max=$6
echo "memory: $rss_w KiB after warm-up, $rss_e KiB at the end ($growth %), max $rss_max KiB; fds $fd_w -> $fd_e"
python3 -c "import sys; sys.exit(0 if $growth < 5 else 1)" && ok "memory growth < 5 % ($growth %)" || bad "memory grew $growth %"
[ "$fd_e" -le $((fd_w + 2)) ] && ok "open files flat ($fd_w -> $fd_e)" || bad "open files grew $fd_w -> $fd_e"
[ "$errors" = 0 ] && ok "zero errors ($bakes bakes, $cached cached uploads, $gets downloads)" ||
    { bad "$errors errors"; head -n 5 "$T/errors.log"; }
echo "figures: soak_seconds=$SECS first_eviction_s=$fe bakes=$bakes cached_uploads=$cached downloads=$gets errors=$errors rss_warm_kib=$rss_w rss_end_kib=$rss_e rss_growth_pct=$growth fds_warm=$fd_w fds_end=$fd_e"
[ "$fails" -eq 0 ]
