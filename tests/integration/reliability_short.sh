#!/bin/sh
# CI short forms of the fault suites in tests/reliability/ (issue 12):
#   worker_kills.sh  3 trials of kill -9 of the real worker (smallest trees)
#   poison.sh        alloc / spin / hang poisons and the real-worker absurd atlas
#                    (GET p99 reported, not asserted)
#   eviction.sh      a 4 MiB store filled to 120 %
#   scale.sh         3,000 stored + 100 queued bakes dispatched by a no-op
#                    worker, through the table API and through HTTP (speeds
#                    reported; the 30,000 + 1,000 long form asserts them)
# About 2 minutes on a 2-core machine; also runs with the ASan build
# (BUILD=build/asan: generous timeouts; no RLIMIT_AS on the real ASan worker).
# The long forms: sh tests/reliability/worker_kills.sh (100 trials),
# poison.sh (asserts p99 < 50 ms), eviction.sh (16 MiB store).
# sylva-test: no-sanitize (fake workers and daemon supervision; the server code under ASan is covered by daemon_faults, daemon_upload and the server unit tests; CI time) cost=45
set -u
here=$(cd "$(dirname "$0")" && pwd)
rel=$here/../reliability
fails=0 skips=0 figures=""
t0=$(date +%s)
run() { # run NAME [VAR=VALUE...]
    name=$1; shift
    start=$(date +%s)
    echo "# --- $name"
    env "$@" sh "$rel/$name.sh" > "${TMPDIR:-/tmp}/reliability_short.$$.log" 2>&1
    rc=$?
    if [ $rc -eq 0 ]; then
        cat "${TMPDIR:-/tmp}/reliability_short.$$.log"
        echo "ok - $name ($(( $(date +%s) - start )) s)"
    elif [ $rc -eq 77 ]; then
        cat "${TMPDIR:-/tmp}/reliability_short.$$.log"
        echo "skipped: $name ($(grep -m 1 '^skipped' "${TMPDIR:-/tmp}/reliability_short.$$.log"))"
        skips=$((skips + 1))
    else
        cat "${TMPDIR:-/tmp}/reliability_short.$$.log"
        echo "FAIL - $name ($(( $(date +%s) - start )) s)"
        fails=$((fails + 1))
    fi
    figures="$figures ${name}_s=$(( $(date +%s) - start ))"
    rm -f "${TMPDIR:-/tmp}/reliability_short.$$.log"
}
trap 'rm -f "${TMPDIR:-/tmp}/reliability_short.$$.log"' EXIT
# 3 kills of a real bake in the plain pass (the long form: 100), 2 under ASan
case "${BUILD:-build}" in *asan*) kt=2 ;; *) kt=3 ;; esac
run worker_kills KILL_TRIALS=${KILL_TRIALS:-$kt} KILL_MAX_TRIS=${KILL_MAX_TRIS:-10000}
run poison POISON_SHORT=1
run eviction EVICT_SHORT=1
run scale SCALE_SHORT=1
echo "figures:$figures total_s=$(( $(date +%s) - t0 ))"
[ "$fails" -eq 0 ] || exit 1
[ "$skips" -eq 0 ] || exit 77
