#!/bin/sh
# scale.sh — issue 22 item 4: the job table with a long history and a long
# queue. bench_jobs (tests/tools/bench_jobs.c) stores SCALE_DONE finished
# bakes and queues SCALE_QUEUED more, then a no-op worker dispatches the queue
# while status is asked without pause. Goals (issue 22): status p99 < 10 ms,
# >= 50 jobs/s dispatched. Default 30,000 + 1,000 (the issue's figure; about
# 30 s); SCALE_SHORT=1: 3,000 + 100 (CI, reliability_short.sh: it must
# dispatch the whole queue; its speeds are reported, not asserted, as timed
# checks do not belong in CI on a shared machine). Measured twice: through the table's API
# (bench_jobs) and through HTTP with a real sylvad (scale_http.py). The store
# is on /dev/shm when it exists: the
# journal fsyncs every record, and the figure is the table's, not the disk's.
set -u
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
tool=$B/tools/bench_jobs
[ -x "$tool" ] || { echo "skipped: $tool not built"; exit 77; }
if [ "${SCALE_SHORT:-0}" = 1 ]; then done_n=${SCALE_DONE:-3000} q=${SCALE_QUEUED:-100}
else done_n=${SCALE_DONE:-30000} q=${SCALE_QUEUED:-1000}; fi
base=/dev/shm
[ -d "$base" ] && [ -w "$base" ] || base=${TMPDIR:-/tmp}
d=$(mktemp -d "$base/sylva-scale.XXXXXX")
trap 'rm -rf "$d"' EXIT
# 1. the table, through its API (no HTTP, no worker process)
mkdir -p "$d/api"
out=$("$tool" "$d/api" "$done_n" "$q") || { echo "FAIL - bench_jobs failed"; exit 1; }
echo "$out"
# 2. through HTTP: sylvad on a store filled the same way, the fake worker's
#    "ok" (a file copy) as the no-op worker, one keep-alive client asking
#    status without pause until the queue is dispatched
mkdir -p "$d/http"
"$tool" "$d/http" "$done_n" "$q" --prepare > "$d/http/keys" || { echo "FAIL - bench_jobs --prepare"; exit 1; }
hout=$(python3 "$SYLVA_ROOT/tests/reliability/scale_http.py" "$B/sylvad" \
    "$SYLVA_ROOT/tests/integration/fake-worker" "$d/http/store" "$d/http/keys" "$done_n") ||
    { echo "FAIL - scale_http.py"; exit 1; }
echo "$hout"
python3 - "$out" "$hout" "${SCALE_SHORT:-0}" <<'PY'
import json, sys
j, h = json.loads(sys.argv[1]), json.loads(sys.argv[2])
short = sys.argv[3] == "1"
ok = True
for name, good in (("table: status p99 %.2f ms < 10 ms" % j["status_p99_ms"], j["status_p99_ms"] < 10),
                   ("table: %.0f jobs/s dispatched >= 50" % j["jobs_per_s"], j["jobs_per_s"] >= 50),
                   ("HTTP: status p99 %.2f ms < 10 ms" % h["status_p99_ms"], h["status_p99_ms"] < 10),
                   ("HTTP: %.0f jobs/s dispatched >= 50 (no-op worker)" % h["jobs_per_s"], h["jobs_per_s"] >= 50)):
    if short:  # CI: a shared machine; the goals are judged by the long form (make reliability)
        print("figure - " + name)
        continue
    print(("ok   - " if good else "FAIL - ") + name)
    ok = ok and good
print("figures: done=%d queued=%d jobs_per_s=%.0f status_p99_ms=%.2f http_jobs_per_s=%.0f "
      "http_status_p99_ms=%.2f http_startup_s=%.1f"
      % (j["done"], j["queued"], j["jobs_per_s"], j["status_p99_ms"], h["jobs_per_s"],
         h["status_p99_ms"], h["startup_s"]))
sys.exit(0 if ok else 1)
PY
