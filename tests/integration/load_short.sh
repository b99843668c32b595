#!/bin/sh
# The short form of tests/reliability/load.sh for CI: the same script (real
# sylvad, real worker, mhd_hello baseline, idle then 2 bakes) with 1 s per wrk
# run, 16 connections, and only the /v1/health and planes.json pairs; the
# cached bake is a cheap one (crossed quads, 256-texel atlas, no evaluation,
# no LOD chain) so the ASan build fits too. Checks sanity only: the script
# succeeded (daemon alive, no sanitizer report), every run has figures, 0
# non-2xx answers and 0 socket errors, and /v1/health served > 0 req/s in both
# conditions. No speed or ratio is asserted (CI machines are shared and
# noisy; the long form reports them). Results go to a temporary directory,
# never to bench/results/. Budget: under 60 s.
# sylva-test: serial (wrk measures throughput and latency) no-sanitize (figures only; docs/testing.md) cost=30
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
command -v wrk >/dev/null || { echo "skipped: wrk missing (Debian package wrk)"; exit 77; }
OUTD=$(mktemp -d /tmp/sylva-load-short.XXXXXX)
trap 'rm -rf "$OUTD"' EXIT
fails=0
ok() { echo "ok   - $1"; }
bad() { echo "FAIL - $1"; fails=$((fails + 1)); }

start=$(date +%s)
BUILD=$BUILD LOAD_SECONDS=1 LOAD_CONNECTIONS=16 LOAD_THREADS=2 LOAD_OUT=$OUTD \
    LOAD_TARGETS="health planes.json" LOAD_BAKE_TIMEOUT=40 \
    LOAD_CACHE_SPEC='{"method":"crossed_quads","bake":{"max_atlas":256},"evaluate":{"enabled":false},"lod":{"chain":false,"coarsest":"none"}}' \
    sh "$SYLVA_ROOT/tests/reliability/load.sh" > "$OUTD/out.txt" 2>&1
rc=$?
took=$(($(date +%s) - start))
if [ "$rc" -eq 77 ]; then
    echo "skipped: $(grep 'cannot run' "$OUTD/out.txt" | head -n 1)"
    exit 77
fi
[ "$rc" -eq 0 ] && ok "load.sh succeeded in $took s" || bad "load.sh exit $rc"
J=$OUTD/load.json
if [ -s "$J" ]; then
    runs=$(grep -c '"target": ' "$J")
    [ "$runs" -eq 8 ] && ok "8 wrk runs reported" || bad "8 wrk runs reported (got $runs)"
    grep '"target": ' "$J" | grep -v '"non2xx": 0,' > "$OUTD/bad" && bad "non-2xx answers: $(cat "$OUTD/bad")"
    grep '"target": ' "$J" | grep -v '"socket_errors": {"connect": 0, "read": 0, "write": 0, "timeout": 0}' > "$OUTD/bad" \
        && bad "socket errors: $(cat "$OUTD/bad")"
    grep '"target": ' "$J" | grep -q -E '"req_s": -|"p99_ms": -' && bad "a run without figures"
    for c in idle "2 bakes"; do
        r=$(grep "\"target\": \"health\", \"condition\": \"$c\"" "$J" | sed -n 's/.*"req_s": \([0-9.]*\).*/\1/p')
        awk -v r="${r:-0}" 'BEGIN { exit !(r > 0) }' && ok "health $c: $r req/s" || bad "health $c: req/s '$r'"
    done
    grep -q '"running_bakes": \["2", "2"\]' "$J" || echo "note: no run saw 2 bakes running from start to end"
else
    bad "no load.json"
fi
[ "$took" -lt 60 ] || echo "note: took $took s, over the 60 s budget"
if [ "$fails" -ne 0 ]; then
    echo "--- load.sh output:"; tail -n 40 "$OUTD/out.txt"
    exit 1
fi
exit 0
