#!/bin/sh
# Runs sylva's tests, SYLVA_TEST_JOBS at a time (default 2), and reports
# PASS / FAIL / SKIP separately (docs/testing.md).
#
# Usage: tests/run.sh [SET] [NAME...]
#   SET   all (default): every unit test and integration script
#         unit | integration: one kind only
#         sanitize: what `make sanitize` runs under ASan+UBSan (every unit test
#         and the integration scripts that do not say `sylva-test: no-sanitize`),
#         trees limited to the small ones (SYLVA_TREES=small)
#   NAME  run only these tests (test_trunk, scene_effects, ...) from SET
#
# A test passes with exit 0, skips with exit 77 (saying why on its output),
# fails with anything else. A skip fails the run unless the test is named in
# SYLVA_EXPECT_SKIP; with CI=true no skip is expected, whatever that says.
#
# A test script can declare, in a comment line of its own:
#   # sylva-test: serial        run alone, nothing else at the same time
#                               (timing-sensitive, or a port it reuses)
#   # sylva-test: cost=SECONDS  a rough run time: the longest start first
#   # sylva-test: no-sanitize   not in the sanitizer pass (says why)
#   # sylva-test: sanitize-only only on the ASan build (make sanitize and
#                               sanitize-full), not in make test (says why)
# (in a unit test's .c file the same words inside a /* comment */).
#
# Each test gets its own TMPDIR ($BUILD/test-tmp/NAME, removed when it passes)
# and its log in $BUILD/test-logs/NAME.log. Daemon tests bind port 0.
# BUILD names the build directory (build/ or build/asan/).
set -u
BUILD=${BUILD:-build}
export BUILD
here=$(cd "$(dirname "$0")" && pwd)
export SYLVA_ROOT=$(cd "$here/.." && pwd)
export SYLVA_DATA=${SYLVA_DATA:-$SYLVA_ROOT/../shared/data}
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:detect_leaks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$here/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
jobs=${SYLVA_TEST_JOBS:-2}
case "$jobs" in ''|*[!0-9]*|0) echo "SYLVA_TEST_JOBS must be a positive number"; exit 2 ;; esac
set_=all
case "${1:-}" in all|unit|integration|sanitize) set_=$1; shift ;; esac
only=" $* "
[ "$set_" = sanitize ] && export SYLVA_TREES=${SYLVA_TREES:-small}
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
logs=$B/test-logs
tmps=$B/test-tmp
mkdir -p "$logs" "$tmps"
# The shared tree cache (tree_cache in tests/integration/lib.inc) lives for one pass.
export SYLVA_TEST_CACHE=$B/test-cache
rm -rf "$SYLVA_TEST_CACHE"
mkdir -p "$SYLVA_TEST_CACHE"

# marker SOURCE WORD: prints WORD if a `sylva-test:` line of SOURCE holds it
marker() {
    grep -E "^[#/* ]*sylva-test:.*\b$2\b" "$1" > /dev/null 2>&1 && echo "$2"
}
# cost_of SOURCE: the number of its `sylva-test: cost=N`, if any
cost_of() {
    sed -n 's/^[#/* ]*sylva-test:.*\bcost=\([0-9][0-9]*\).*/\1/p' "$1" 2>/dev/null | head -n 1
}

# The list: "cost kind name command source" lines, kind par|ser.
list=$tmps/.list.$$
: > "$list"
add() { # add NAME SOURCE COMMAND...
    name=$1 src=$2; shift 2
    # the same name twice (a test_x.c and an x.sh) would share a log
    grep -q " $name " "$list" && { echo "two tests named $name"; exit 2; }
    case "$only" in "  ") ;; *" $name "*) ;; *) return ;; esac
    if [ "$set_" = sanitize ] && [ -n "$(marker "$src" no-sanitize)" ]; then return; fi
    case "$BUILD" in *asan*) ;; *) [ -n "$(marker "$src" sanitize-only)" ] && return ;; esac
    cost=$(cost_of "$src")
    kind=par
    [ -n "$(marker "$src" serial)" ] && kind=ser
    printf '%s %s %s %s\n' "${cost:-5}" "$kind" "$name" "$*" >> "$list"
}
if [ "$set_" != integration ]; then
    for t in "$B"/tests/test_*; do
        [ -x "$t" ] || continue
        case "$t" in *.o|*.d) continue ;; esac
        n=$(basename "$t")
        add "$n" "$SYLVA_ROOT/tests/unit/$n.c" "$t"
    done
fi
if [ "$set_" != unit ]; then
    for t in "$here"/integration/*.sh; do
        [ -f "$t" ] || continue
        add "$(basename "$t" .sh)" "$t" sh "$t"
    done
fi
# the parallel tests, longest first; then the serial ones, one at a time
sort -k1,1nr "$list" | awk '$2 == "par"' > "$list.par"
sort -k1,1nr "$list" | awk '$2 == "ser"' > "$list.ser"
total=$(wc -l < "$list")
[ "$total" -gt 0 ] || { echo "no tests match: $set_$only"; rm -f "$list"*; exit 2; }
echo "== $total tests from $BUILD ($set_), $jobs at a time; serial ones last"

passed="" failed="" skipped="" unexpected=""
running=""  # "pid:name" entries
start_one() { # start_one NAME COMMAND...
    sn=$1; shift
    rm -rf "${tmps:?}/$sn"
    mkdir -p "$tmps/$sn"
    (
        export TMPDIR="$tmps/$sn"
        s=$(date +%s)
        "$@" > "$logs/$sn.log" 2>&1 < /dev/null
        rc=$?
        # CPU seconds of the test and the children it waited for (user + sys)
        times > "$tmps/$sn.times"
        cpu=$(awk 'NR == 2 { t = 0; for (i = 1; i <= 2; i++) { split($i, a, "m"); t += a[1] * 60 + a[2] } printf "%d", t + 0.5 }' "$tmps/$sn.times")
        rm -f "$tmps/$sn.times"
        echo "$rc $(( $(date +%s) - s )) ${cpu:-0}" > "$tmps/$sn.rc.tmp"
        mv "$tmps/$sn.rc.tmp" "$tmps/$sn.rc"
    ) &
    running="$running $!:$sn"
}
finish_one() { # finish_one NAME: reads its status, prints its line
    fn=$1
    read -r rc secs cpu < "$tmps/$fn.rc" || { rc=1; secs=0; cpu=0; }
    rm -f "$tmps/$fn.rc"
    case "$rc" in
    0)
        passed="$passed $fn"
        rm -rf "${tmps:?}/$fn"
        echo "PASS $fn (${secs}s, cpu ${cpu}s)" ;;
    77)
        skipped="$skipped $fn"
        why=$(grep -m 1 -i 'skip' "$logs/$fn.log" | cut -c 1-160)
        rm -rf "${tmps:?}/$fn"
        case " ${SYLVA_EXPECT_SKIP:-} " in
        *" $fn "*) [ "${CI:-}" = true ] || { echo "SKIP $fn (expected: ${why:-no reason given})"; return; } ;;
        esac
        unexpected="$unexpected $fn"
        echo "SKIP $fn, not expected${CI:+ (CI=$CI)}: ${why:-no reason given} (log: $logs/$fn.log)" ;;
    *)
        failed="$failed $fn"
        echo "FAIL $fn (exit $rc, ${secs}s; log: $logs/$fn.log, temp files kept in $tmps/$fn)"
        # the checks that failed first (a test's own tail may be its diagnostics)
        grep -E '^(FAIL|not ok|\[  FAILED  \])' "$logs/$fn.log" | head -n 20 | sed 's/^/    /'
        tail -n 30 "$logs/$fn.log" | sed 's/^/    /' ;;
    esac
}
reap() { # reap: waits until a running test ends, then reports it
    while :; do
        left=""
        done_=""
        for e in $running; do
            # (a runner subshell that died before writing its status: a failure)
            if [ ! -f "$tmps/${e#*:}.rc" ] && ! kill -0 "${e%%:*}" 2>/dev/null; then
                [ -f "$tmps/${e#*:}.rc" ] || echo "1 0" > "$tmps/${e#*:}.rc"
            fi
            if [ -z "$done_" ] && [ -f "$tmps/${e#*:}.rc" ]; then
                wait "${e%%:*}" 2>/dev/null
                done_=${e#*:}
            else
                left="$left $e"
            fi
        done
        if [ -n "$done_" ]; then running=$left; finish_one "$done_"; return; fi
        sleep 0.2
    done
}
count() { set -- $1; echo $#; }
t0=$(date +%s)
trap 'for e in $running; do kill -TERM "${e%%:*}" 2>/dev/null; done; exit 130' INT TERM
while read -r _cost _kind tname tcmd; do
    while [ "$(count "$running")" -ge "$jobs" ]; do reap; done
    # shellcheck disable=SC2086
    start_one "$tname" $tcmd
done < "$list.par"
while [ -n "$running" ]; do reap; done
while read -r _cost _kind tname tcmd; do
    # shellcheck disable=SC2086
    start_one "$tname" $tcmd
    reap
done < "$list.ser"
[ -n "${SYLVA_TEST_KEEP_LIST:-}" ] || rm -f "$list" "$list.par" "$list.ser"

echo "== $(count "$passed") passed, $(count "$failed") failed, $(count "$skipped") skipped" \
     "in $(( $(date +%s) - t0 ))s ($BUILD, $set_)"
[ -z "$failed" ] || echo "   FAIL:$failed"
[ -z "$skipped" ] || echo "   SKIP:$skipped"
[ -z "$unexpected" ] || echo "   unexpected skips (a failure; SYLVA_EXPECT_SKIP names the allowed ones, CI=true allows none):$unexpected"
[ -z "$failed" ] && [ -z "$unexpected" ]
