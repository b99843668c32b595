#!/bin/sh
# Runs sylva's tests. Usage: tests/run.sh [unit|integration]   (default: both)
# BUILD names the build directory (build/ or build/asan/). Fails on any failure.
set -u
BUILD=${BUILD:-build}
export BUILD
what=${1:-all}
here=$(cd "$(dirname "$0")" && pwd)
export SYLVA_ROOT=$(cd "$here/.." && pwd)
export SYLVA_DATA=${SYLVA_DATA:-$SYLVA_ROOT/../shared/data}
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:detect_leaks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$here/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
fail=0
passed=0
failed_list=""
run_one() {
    name=$1; shift
    start=$(date +%s)
    if "$@" > "$BUILD/test-logs/$name.log" 2>&1; then
        passed=$((passed + 1))
        echo "PASS $name ($(( $(date +%s) - start ))s)"
    else
        fail=$((fail + 1))
        failed_list="$failed_list $name"
        echo "FAIL $name (log: $BUILD/test-logs/$name.log)"
        # the checks that failed first (a test's own tail may be its diagnostics)
        grep -E '^(FAIL|not ok)' "$BUILD/test-logs/$name.log" | head -n 20 | sed 's/^/    /'
        tail -n 30 "$BUILD/test-logs/$name.log" | sed 's/^/    /'
    fi
}
mkdir -p "$BUILD/test-logs"
if [ "$what" = all ] || [ "$what" = unit ]; then
    for t in "$BUILD"/tests/test_*; do
        [ -x "$t" ] || continue
        case "$t" in *.o|*.d) continue ;; esac
        run_one "$(basename "$t")" "$t"
    done
fi
if [ "$what" = all ] || [ "$what" = integration ]; then
    for t in "$here"/integration/*.sh; do
        [ -f "$t" ] || continue
        run_one "$(basename "$t" .sh)" sh "$t"
    done
fi
echo "== $passed passed, $fail failed${failed_list:+:$failed_list}"
[ "$fail" -eq 0 ]
