#!/bin/sh
# tests/reliability/load.sh — load figures of sylvad against a bare
# libmicrohttpd server (issue 12, docs/reliability.md).
#
# Starts a real sylvad (--workers 2, the real worker $BUILD/sylva-bake) on a
# temporary store, bakes the bundled oak once so artifacts are cached, starts
# $BUILD/tools/mhd_hello (libmicrohttpd configured as sylvad configures it,
# serving copies of the artifacts with --serve-dir), then runs
#     wrk -t$LOAD_THREADS -c$LOAD_CONNECTIONS -d${LOAD_SECONDS}s --latency \
#         --timeout ${LOAD_TIMEOUT}s URL
# for each pair (baseline, sylvad): mhd_hello's 15-byte body and GET
# /v1/health; mhd_hello sending model.glb and GET .../artifacts/model.glb;
# the same for planes.json — first with nothing else running ("idle"), then
# while two bakes keep both worker slots busy ("2 bakes": two pumps each
# submit a bake, wait for it, and submit the next with another seed, so two
# bakes run for the whole measurement; the running count is read from
# /v1/metrics before and after each run and recorded).
#
# Writes $LOAD_OUT/load.json (one run per line in "runs") and
# $LOAD_OUT/load.md (the table; ratio = req/s over the req/s of mhd_hello
# sending the same body in the same condition; health/hello is the headline
# figure, goal >= 90 %), and prints the table. It asserts nothing about speed.
#
# Environment (defaults):
#   BUILD=build              binaries: $BUILD/sylvad, sylva-bake, tools/mhd_hello
#   LOAD_SECONDS=10          seconds per wrk run
#   LOAD_CONNECTIONS=64      wrk connections
#   LOAD_THREADS=2           wrk threads
#   LOAD_TIMEOUT=10          wrk --timeout (a request slower than this is a
#                            socket error and leaves the latency figures)
#   LOAD_TARGETS="health model.glb planes.json"   sylvad targets measured
#   LOAD_OUT=bench/results   where load.json and load.md go
#   LOAD_CACHE_SPEC='{"method":"billboard_cloud","scene":{"viewer":"ground"},
#       "bake":{"max_atlas":1024},"evaluate":{"enabled":false}}'
#                            spec of the bake whose artifacts are served
#   The bakes that load the CPU use the demo spec (billboard_cloud, ground,
#   evaluation on) with seed N*1000+i: each upload is a new key.
#   LOAD_BAKE_TIMEOUT=600    seconds allowed for that bake
#   LOAD_DAEMON_FLAGS=""     extra sylvad flags (word-split), e.g. "--http-threads 2";
#                            mhd_hello gets the HTTP ones too (same parser)
#   SYLVA_DATA=../shared/data  if it holds scopia_ficusTree/ficusTree.glb, the
#                            second pump bakes it; else both bake the oak
# Exit: 0 when every run completed and was parsed and the daemon survived
# without a sanitizer report; 1 otherwise; 77 when a prerequisite (a binary,
# wrk, curl, the oak) is missing. Everything started is stopped and the
# temporary directory removed on exit (KEEP_T=1 keeps it).
set -u
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$ROOT/$BUILD ;; esac
SECS=${LOAD_SECONDS:-10}
CONNS=${LOAD_CONNECTIONS:-64}
WTHREADS=${LOAD_THREADS:-2}
WTIMEOUT=${LOAD_TIMEOUT:-10}
TARGETS=${LOAD_TARGETS:-health model.glb planes.json}
OUT=${LOAD_OUT:-$ROOT/bench/results}
CACHE_SPEC=${LOAD_CACHE_SPEC:-'{"method":"billboard_cloud","scene":{"viewer":"ground"},"bake":{"max_atlas":1024},"evaluate":{"enabled":false}}'}
BAKE_TIMEOUT=${LOAD_BAKE_TIMEOUT:-600}
DFLAGS=${LOAD_DAEMON_FLAGS:-}
DATA=${SYLVA_DATA:-$ROOT/../shared/data}
SYLVAD=$B/sylvad
BAKE=$B/sylva-bake
HELLO=$B/tools/mhd_hello
OAK=$ROOT/examples/oak_large/oak_large.glb
FICUS=$DATA/scopia_ficusTree/ficusTree.glb

skip() { echo "load.sh: cannot run: $1" >&2; exit 77; }
for f in "$SYLVAD" "$BAKE" "$HELLO"; do [ -x "$f" ] || skip "$f not built"; done
command -v wrk >/dev/null || skip "wrk missing (Debian package wrk)"
command -v curl >/dev/null || skip "curl missing"
[ -f "$OAK" ] || skip "$OAK missing"

T=$(mktemp -d /tmp/sylva-load.XXXXXX)
DPID="" HPID="" PUMPS="" WPID=""
say() { echo "load: $(date +%T) $*" >&2; }
stop_pid() { # stop_pid PID: TERM, then KILL after 10 s; reaps it
    kill -TERM "$1" 2>/dev/null || return 0
    i=0
    while kill -0 "$1" 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    kill -9 "$1" 2>/dev/null
    wait "$1" 2>/dev/null
}
stop_pumps() {
    touch "$T/stop"
    for p in $PUMPS; do
        kill $(pgrep -P "$p" 2>/dev/null) "$p" 2>/dev/null
        wait "$p" 2>/dev/null
    done
    PUMPS=""
}
cleanup() {
    [ -n "$WPID" ] && kill "$WPID" 2>/dev/null
    stop_pumps
    # Both servers stop at once. drain_timeout is 1 s and a second TERM means
    # "stop now": running bakes are aborted (their process groups killed).
    [ -n "$HPID" ] && kill -TERM "$HPID" 2>/dev/null
    [ -n "$DPID" ] && kill -TERM "$DPID" 2>/dev/null && sleep 0.3
    [ -n "$HPID" ] && stop_pid "$HPID"
    [ -n "$DPID" ] && stop_pid "$DPID"
    # workers left behind if the daemon had to be SIGKILLed: their command
    # line holds this run's temporary directory, nothing else's does
    for p in $(pgrep -f "$T/" 2>/dev/null); do kill -9 "$p" 2>/dev/null; done
    [ -n "${KEEP_T:-}" ] && say "kept $T" || rm -rf "$T"
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

# wait_port FILE: the port a server wrote, or "" after 20 s
wait_port() {
    i=0
    while [ ! -s "$1" ] && [ $i -lt 200 ]; do sleep 0.1; i=$((i + 1)); done
    cat "$1" 2>/dev/null
}
json_str() { sed -n "s/.*\"$1\":\"\\([^\"]*\\)\".*/\\1/p" | head -n 1; }
running_bakes() { curl -s --max-time 5 "$URL/v1/metrics" | sed -n 's/^sylva_running_jobs \([0-9]*\).*/\1/p'; }

# ---- the daemon, a cached bake, the baseline ----
mkdir -p "$T/store" "$T/files" "$OUT"
cd "$T" || exit 1
# The baseline, with the same HTTP settings as the daemon (sylvad's parser,
# its defaults, the same extra flags); it serves the artifacts' bytes from
# $T/files once they are downloaded below.
"$HELLO" --listen 127.0.0.1:0 --port-file "$T/hello.port" --serve-dir "$T/files" $DFLAGS \
    2>>"$T/hello.log" &
HPID=$!
"$SYLVAD" --listen 127.0.0.1:0 --store "$T/store" --port-file "$T/port" --worker "$BAKE" \
    --workers 2 --drain-timeout 1 --log-level info --max-conns-per-ip 0 $DFLAGS 2>>"$T/daemon.log" &
DPID=$!
PORT=$(wait_port "$T/port")
[ -n "$PORT" ] || { say "sylvad did not start"; cat "$T/daemon.log" >&2; exit 1; }
URL=http://127.0.0.1:$PORT
HPORT=$(wait_port "$T/hello.port")
[ -n "$HPORT" ] || { say "mhd_hello did not start"; cat "$T/hello.log" >&2; exit 1; }

say "baking the oak once (spec $CACHE_SPEC)"
printf '%s' "$CACHE_SPEC" > "$T/cache-spec.json"
code=$(curl -s -o "$T/sub" -w '%{http_code}' -F "spec=@$T/cache-spec.json;type=application/json" \
    -F "mesh=@$OAK" "$URL/v1/bakes")
KEY=$(json_str key < "$T/sub")
case "$code" in 200 | 202) ;; *) say "upload of the oak: $code $(cat "$T/sub")"; exit 1 ;; esac
t0=$(date +%s)
state=""
while [ $(($(date +%s) - t0)) -lt "$BAKE_TIMEOUT" ]; do
    state=$(curl -s --max-time 40 "$URL/v1/bakes/$KEY?wait=30" | json_str state)
    case "$state" in done | failed | cancelled) break ;; esac
done
[ "$state" = done ] || { say "the oak bake is '$state': $(curl -s "$URL/v1/bakes/$KEY")"; exit 1; }
CACHE_SECONDS=$(($(date +%s) - t0))
# the same bytes, for mhd_hello --serve-dir
for a in model.glb planes.json; do
    code=$(curl -s -o "$T/files/$a" -w '%{http_code}' "$URL/v1/bakes/$KEY/artifacts/$a")
    [ "$code" = 200 ] || { say "artifact $a: $code"; exit 1; }
done
GLB_BYTES=$(wc -c < "$T/files/model.glb" | tr -d ' ')
PLANES_BYTES=$(wc -c < "$T/files/planes.json" | tr -d ' ')
say "cached bake $KEY done in ${CACHE_SECONDS} s (model.glb $GLB_BYTES B, planes.json $PLANES_BYTES B)"


# ---- measurement ----
# parse_wrk FILE -> "req_s mb_s p50_ms p90_ms p99_ms requests non2xx connect read write timeout"
parse_wrk() {
    awk '
    function ms(v) {
        if (v ~ /us$/) return substr(v, 1, length(v) - 2) / 1000
        if (v ~ /ms$/) return substr(v, 1, length(v) - 2) + 0
        if (v ~ /m$/) return substr(v, 1, length(v) - 1) * 60000
        if (v ~ /s$/) return substr(v, 1, length(v) - 1) * 1000
        return -1
    }
    function mb(v) {  # wrk prints 1024-based units
        if (v ~ /GB$/) return substr(v, 1, length(v) - 2) * 1024
        if (v ~ /MB$/) return substr(v, 1, length(v) - 2) + 0
        if (v ~ /KB$/) return substr(v, 1, length(v) - 2) / 1024
        if (v ~ /B$/) return substr(v, 1, length(v) - 1) / 1048576
        return -1
    }
    BEGIN { rps = -1; tps = -1; p50 = p90 = p99 = -1; n = -1; bad = 0; c = r = w = t = 0 }
    $1 == "50%" { p50 = ms($2) }
    $1 == "90%" { p90 = ms($2) }
    $1 == "99%" { p99 = ms($2) }
    $2 == "requests" && $3 == "in" { n = $1 }
    $1 == "Socket" && $2 == "errors:" { c = $4 + 0; r = $6 + 0; w = $8 + 0; t = $10 + 0 }
    /^ *Non-2xx or 3xx responses:/ { bad = $NF + 0 }
    $1 == "Requests/sec:" { rps = $2 + 0 }
    $1 == "Transfer/sec:" { tps = mb($2) }
    END { printf "%.2f %.3f %.3f %.3f %.3f %d %d %d %d %d %d\n", rps, tps, p50, p90, p99, n, bad, c, r, w, t }
    ' "$1"
}

RUNS=$T/runs.txt # target condition url req_s mb_s p50 p90 p99 n non2xx c r w t before after load
: > "$RUNS"
failed=0
measure() { # measure TARGET CONDITION URL
    before=$(running_bakes)
    f=$T/wrk-$1-$2.txt
    say "wrk $2 $1: $3"
    wrk -t"$WTHREADS" -c"$CONNS" -d"${SECS}s" --latency --timeout "${WTIMEOUT}s" "$3" > "$f" 2>&1 &
    WPID=$!
    wait "$WPID"
    rc=$?
    WPID=""
    after=$(running_bakes)
    load=$(cut -d' ' -f1 /proc/loadavg)
    p=$(parse_wrk "$f")
    case "$p" in -* | *" -1"* | "")
        say "wrk failed (exit $rc) on $3:"; cat "$f" >&2; failed=1; return ;;
    esac
    [ "$rc" -eq 0 ] || { say "wrk exit $rc on $3"; failed=1; }
    echo "$1 $2 $3 $p ${before:-?} ${after:-?} $load" >> "$RUNS"
}
ART=$URL/v1/bakes/$KEY/artifacts
HELLO_URL=http://127.0.0.1:$HPORT
measure_all() { # measure_all CONDITION: each sylvad target right after its baseline
    for t in $TARGETS; do
        case "$t" in
        health) measure hello "$1" "$HELLO_URL/v1/health"; measure health "$1" "$URL/v1/health" ;;
        model.glb | planes.json)
            measure "hello:$t" "$1" "$HELLO_URL/files/$t"; measure "$t" "$1" "$ART/$t" ;;
        *) say "unknown target '$t' in LOAD_TARGETS"; failed=1 ;;
        esac
    done
}

measure_all idle

# Two pumps keep two bakes running: pump N submits (seed N*1000+i), waits
# until the bake ends, and submits the next, until $T/stop exists.
pump() { # pump N MESH
    i=0
    while [ ! -e "$T/stop" ]; do
        printf '{"method":"billboard_cloud","scene":{"viewer":"ground"},"seed":%d}' \
            $(($1 * 1000 + i)) > "$T/pump$1.json"
        k=$(curl -s --max-time 60 -F "spec=@$T/pump$1.json;type=application/json" -F "mesh=@$2" \
            "$URL/v1/bakes" | json_str key)
        echo "$1 $k $2" >> "$T/pumped.txt"
        [ -n "$k" ] || { sleep 1; i=$((i + 1)); continue; }
        while [ ! -e "$T/stop" ]; do
            s=$(curl -s --max-time 10 "$URL/v1/bakes/$k?wait=5" | json_str state)
            case "$s" in queued | running) ;; *) break ;; esac
        done
        i=$((i + 1))
    done
}
: > "$T/pumped.txt"
MESH2=$OAK
[ -f "$FICUS" ] && MESH2=$FICUS
pump 1 "$OAK" &
PUMPS=$!
pump 2 "$MESH2" &
PUMPS="$PUMPS $!"
i=0
while [ "$(running_bakes)" != 2 ] && [ $i -lt 600 ]; do sleep 0.1; i=$((i + 1)); done
[ "$(running_bakes)" = 2 ] || say "warning: 2 bakes not running after 60 s ($(running_bakes) running)"
sleep 1 # past the upload, into the bakes' CPU-bound stages
measure_all "2 bakes"
stop_pumps
PUMPED=$(awk '$2 != ""' "$T/pumped.txt" | wc -l | tr -d ' ')
FINISHED=$(curl -s "$URL/v1/metrics" | awk '/^sylva_jobs_finished_total/ { s += $2 } END { print s + 0 }')

kill -0 "$DPID" 2>/dev/null || { say "sylvad died during the measurement"; failed=1; }
if grep -q -E "AddressSanitizer|LeakSanitizer|runtime error:" "$T/daemon.log" "$T/hello.log" 2>/dev/null; then
    say "sanitizer report:"; grep -E -A20 "AddressSanitizer|LeakSanitizer|runtime error:" "$T/daemon.log" "$T/hello.log" >&2
    failed=1
fi

# ---- report ----
NPROC=$(nproc)
KERNEL=$(uname -r)
CPU=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)
DATE=$(date -u +%Y-%m-%dT%H:%M:%SZ)
WRKV=$(wrk -v 2>&1 | head -n 1 | sed 's/ *Copyright.*//')
MHDV=$(pkg-config --modversion libmicrohttpd 2>/dev/null || echo unknown)
case "$B" in *asan*) SAN=true ;; *) SAN=false ;; esac
MESH2_NAME=$(basename "$MESH2")

awk -v date="$DATE" -v nproc="$NPROC" -v kernel="$KERNEL" -v cpu="$CPU" -v wrkv="$WRKV" \
    -v mhdv="$MHDV" -v build="$BUILD" -v san="$SAN" -v secs="$SECS" -v conns="$CONNS" \
    -v wthreads="$WTHREADS" -v key="$KEY" -v glb="$GLB_BYTES" -v planes="$PLANES_BYTES" \
    -v cachesec="$CACHE_SECONDS" -v pumped="$PUMPED" -v finished="$FINISHED" -v mesh2="$MESH2_NAME" \
    -v wtimeout="$WTIMEOUT" -v cachespec="$CACHE_SPEC" -v dflags="$DFLAGS" \
    -v json="$T/load.json" -v md="$T/load.md" '
function esc(s) { gsub(/\\/, "\\\\", s); gsub(/"/, "\\\"", s); return s }
function label(t) {
    if (t == "hello") return "mhd_hello, 15-byte body"
    if (t ~ /^hello:/) return "mhd_hello, " substr(t, 7)
    if (t == "health") return "sylvad GET /v1/health"
    return "sylvad GET artifacts/" t
}
function base(t) { return t == "health" ? "hello" : (t ~ /^hello/ ? t : "hello:" t) }
{
    # fields: target, condition (may be two words), url, 11 figures, before, after, load
    tg[NR] = $1
    if ($2 == "2") { cond[NR] = "2 bakes"; o = 1 } else { cond[NR] = $2; o = 0 }
    url[NR] = $(3 + o); rps[NR] = $(4 + o); mbs[NR] = $(5 + o)
    p50[NR] = $(6 + o); p90[NR] = $(7 + o); p99[NR] = $(8 + o); req[NR] = $(9 + o)
    bad[NR] = $(10 + o); ec[NR] = $(11 + o); er[NR] = $(12 + o); ew[NR] = $(13 + o); et[NR] = $(14 + o)
    bef[NR] = $(15 + o); aft[NR] = $(16 + o); la[NR] = $(17 + o)
    got[cond[NR], $1] = rps[NR]
    if (bad[NR] + ec[NR] + er[NR] + ew[NR] + et[NR] > 0) errs = errs " " $1 " (" cond[NR] ")"
    n = NR
}
END {
    for (i = 1; i <= n; i++) {
        b = got[cond[i], base(tg[i])]
        ratio[i] = (b > 0) ? rps[i] / b : -1
    }
    for (i = 1; i <= n; i++) if (tg[i] == "health") head[cond[i]] = ratio[i]
    printf "{\n" > json
    printf "  \"what\": \"wrk against sylvad and a bare libmicrohttpd server configured the same way (tests/reliability/load.sh)\",\n" > json
    printf "  \"date\": \"%s\",\n", date > json
    printf "  \"machine\": {\"nproc\": %d, \"kernel\": \"%s\", \"cpu\": \"%s\"},\n", nproc, esc(kernel), esc(cpu) > json
    printf "  \"wrk\": \"%s\", \"libmicrohttpd\": \"%s\",\n", esc(wrkv), esc(mhdv) > json
    printf "  \"build\": \"%s\", \"sanitizers\": %s,\n", esc(build), san > json
    printf "  \"wrk_args\": {\"threads\": %d, \"connections\": %d, \"seconds\": %d, \"latency\": true},\n", wthreads, conns, secs > json
    printf "  \"daemon\": {\"workers\": 2, \"http_threads\": 4, \"note\": \"sylvad defaults but --workers 2; mhd_hello gets the same HTTP settings\"},\n" > json
    printf "  \"wrk_timeout_s\": %d, \"daemon_flags\": \"%s\",\n", wtimeout, esc(dflags) > json
    printf "  \"cached_bake\": {\"key\": \"%s\", \"spec\": \"%s\", \"seconds\": %d, \"model.glb_bytes\": %d, \"planes.json_bytes\": %d},\n", key, esc(cachespec), cachesec, glb, planes > json
    printf "  \"bakes_during\": {\"meshes\": [\"oak_large.glb\", \"%s\"], \"submitted\": %d, \"finished_total\": %d},\n", esc(mesh2), pumped, finished > json
    printf "  \"headline\": {\"health_over_hello_idle\": %.3f, \"health_over_hello_2bakes\": %.3f, \"goal\": 0.9},\n", head["idle"], head["2 bakes"] > json
    printf "  \"runs\": [\n" > json
    for (i = 1; i <= n; i++)
        printf "    {\"target\": \"%s\", \"condition\": \"%s\", \"url\": \"%s\", \"requests\": %d, \"req_s\": %.2f, \"mb_s\": %.3f, \"p50_ms\": %.3f, \"p90_ms\": %.3f, \"p99_ms\": %.3f, \"baseline\": \"%s\", \"ratio_to_baseline\": %.3f, \"non2xx\": %d, \"socket_errors\": {\"connect\": %d, \"read\": %d, \"write\": %d, \"timeout\": %d}, \"running_bakes\": [\"%s\", \"%s\"], \"loadavg_1m\": %s}%s\n", \
            tg[i], cond[i], url[i], req[i], rps[i], mbs[i], p50[i], p90[i], p99[i], base(tg[i]), ratio[i], bad[i], ec[i], er[i], ew[i], et[i], bef[i], aft[i], la[i], (i < n ? "," : "") > json
    printf "  ]\n}\n" > json

    printf "# Load: sylvad against bare libmicrohttpd\n\n" > md
    printf "%s; %d CPUs (%s), kernel %s; %s; libmicrohttpd %s; build `%s`%s.\n", date, nproc, cpu, kernel, wrkv, mhdv, build, (san == "true" ? " (ASan+UBSan: ratios mean nothing)" : "") > md
    printf "`wrk -t%d -c%d -d%ds --latency --timeout %ds` per row, rows run one after another. sylvad: defaults (4 HTTP threads), `--workers 2`, real worker; mhd_hello (tests/tools/mhd_hello.c): the same libmicrohttpd flags and options, the same 15-byte body as /v1/health, and the same artifact bytes sent the same way (an fd response). Cached artifacts: model.glb %d B, planes.json %d B (oak, baked in %d s). \"2 bakes\": two bakes (oak_large.glb, %s) running throughout, %d submitted in all. Ratio: req/s over mhd_hello sending the same body in the same condition.\n\n", wthreads, conns, secs, wtimeout, glb, planes, cachesec, mesh2, pumped > md
    printf "| target | condition | req/s | MB/s | p50 | p90 | p99 | ratio to hello |\n" > md
    printf "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n" > md
    for (i = 1; i <= n; i++)
        printf "| %s | %s | %.0f | %.2f | %.2f ms | %.2f ms | %.2f ms | %.1f %% |\n", label(tg[i]), cond[i], rps[i], mbs[i], p50[i], p90[i], p99[i], 100 * ratio[i] > md
    printf "\nHeadline, health/hello: **%.1f %% idle, %.1f %% during 2 bakes** (goal >= 90 %%).\n", 100 * head["idle"], 100 * head["2 bakes"] > md
    printf "MB/s is wrk'"'"'s (2^20 bytes, headers included); latencies are wrk'"'"'s percentiles over all requests.\n" > md
    if (errs == "") printf "Every run: 0 non-2xx answers, 0 socket errors.\n" > md
    else printf "Non-2xx answers or socket errors in:%s (see load.json).\n", errs > md
}' "$RUNS"
cp "$T/load.json" "$T/load.md" "$OUT/"
cat "$T/load.md"
say "wrote $OUT/load.json and $OUT/load.md"
exit $failed
