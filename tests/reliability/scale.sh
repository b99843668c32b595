#!/bin/sh
# scale.sh — issue 22 item 4: the job table with a long history and a long
# queue. bench_jobs (tests/tools/bench_jobs.c) stores SCALE_DONE finished
# bakes and queues SCALE_QUEUED more, then a no-op worker dispatches the queue
# while status is asked without pause. Goals (issue 22): status p99 < 10 ms,
# >= 50 jobs/s dispatched. Default 30,000 + 1,000 (the issue's figure; about
# 4 minutes, most of it storing the history); SCALE_SHORT=1: 3,000 + 300
# (CI, reliability_short.sh). The store is on /dev/shm when it exists: the
# journal fsyncs every record, and the figure is the table's, not the disk's.
set -u
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
tool=$B/tools/bench_jobs
[ -x "$tool" ] || { echo "skipped: $tool not built"; exit 77; }
if [ "${SCALE_SHORT:-0}" = 1 ]; then done_n=${SCALE_DONE:-3000} q=${SCALE_QUEUED:-300}
else done_n=${SCALE_DONE:-30000} q=${SCALE_QUEUED:-1000}; fi
base=/dev/shm
[ -d "$base" ] && [ -w "$base" ] || base=${TMPDIR:-/tmp}
d=$(mktemp -d "$base/sylva-scale.XXXXXX")
trap 'rm -rf "$d"' EXIT
out=$("$tool" "$d" "$done_n" "$q") || { echo "FAIL - bench_jobs failed"; exit 1; }
echo "$out"
python3 - "$out" <<'PY'
import json, sys
j = json.loads(sys.argv[1])
ok = True
for name, good in (("status p99 %.2f ms < 10 ms" % j["status_p99_ms"], j["status_p99_ms"] < 10),
                   ("%.0f jobs/s dispatched >= 50" % j["jobs_per_s"], j["jobs_per_s"] >= 50)):
    print(("ok   - " if good else "FAIL - ") + name)
    ok = ok and good
print("figures: done=%d queued=%d jobs_per_s=%.0f status_p50_ms=%.3f status_p99_ms=%.2f status_max_ms=%.1f"
      % (j["done"], j["queued"], j["jobs_per_s"], j["status_p50_ms"], j["status_p99_ms"], j["status_max_ms"]))
sys.exit(0 if ok else 1)
PY
