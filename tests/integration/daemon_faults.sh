#!/bin/sh
# A crashing worker is retried and fails after 3 attempts with the reason
# while other jobs complete; a hanging one is killed by the timeout; DELETE
# cancels a running bake; kill -9 of the daemon with jobs queued and running:
# the restart completes all of them.
# sylva-test: cost=12
. "$(dirname "$0")/daemon_lib.inc"
export FAKE_WORKER_LOG=$T/invocations
: > "$FAKE_WORKER_LOG"
start_daemon --workers 2 --job-timeout 2
pick_spec

poison=$(mesh poison.obj segv)
good=$(mesh good.obj slow)
kp=$(post "$poison" | json_str key)
kg=$(post "$good" | json_str key)
wait_state "$kp" failed 30 && ok "poison job fails" || bad "poison job did not fail"
contains "reason names signal and attempts" "worker killed by signal 11 on 3 attempts" "$(curl -s "$URL/v1/bakes/$kp")"
check "poison job ran 3 times" 3 "$(grep -c '^poison.obj ' "$FAKE_WORKER_LOG")"
wait_state "$kg" done 30 && ok "other job completes meanwhile" || bad "other job did not complete"
check "artifact of a failed bake is 422" 422 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kp/artifacts/model.glb")"
contains "metrics count crashes" 'sylva_worker_crashes_total{reason="crash"} 3' "$(curl -s "$URL/v1/metrics")"

hang=$(mesh hang.obj sleep)
kh=$(post "$hang" | json_str key)
wait_state "$kh" failed 30 && ok "hanging job fails" || bad "hanging job did not fail"
contains "timeout reason" "worker timed out after 2 s on 3 attempts" "$(curl -s "$URL/v1/bakes/$kh")"

fail=$(mesh refused.obj fail)
kf=$(post "$fail" | json_str key)
wait_state "$kf" failed 10 && ok "input failure fails at once" || bad "input failure"
contains "worker's error code is kept" '"code":"unbakeable"' "$(curl -s "$URL/v1/bakes/$kf")"
check "input failure is not retried" 1 "$(grep -c '^refused.obj ' "$FAKE_WORKER_LOG")"
check "  and uploading it again does not bake it again" failed "$(post "$fail" | json_str state)"

# issue 22 item 2: a failure of the server's (exit 1 without error.json, as on
# a full disk) is retried after a backoff, not "the worker refused the input"
printf '# mode=flaky\n# state=%s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' "$T/flaky.state" > "$T/flaky.obj"
kl=$(post "$T/flaky.obj" | json_str key)
wait_state "$kl" done 20 && ok "a transient worker failure is retried and the bake is done" ||
    bad "transient failure: $(curl -s "$URL/v1/bakes/$kl")"
contains "  on its second attempt" '"attempts":2' "$(curl -s "$URL/v1/bakes/$kl")"
# and a bake that crashed on every attempt runs again when uploaded again
check "a bake failed by crashes is queued again by a new upload" queued \
    "$(post "$poison" | json_str state)"
stop_daemon

# DELETE of a running bake stops the worker.
start_daemon --workers 1 --job-timeout 60
c=$(mesh cancel.obj sleep)
kc=$(post "$c" | json_str key)
wait_state "$kc" running 10 && ok "sleeping job runs" || bad "sleeping job not running"
# "running" comes when the daemon has spawned the worker, which logs its pid
# a moment later (later still on a loaded machine): wait for that line
wpid="" i=0
while [ -z "$wpid" ] && [ $i -lt 100 ]; do
    wpid=$(sed -n 's/^cancel.obj \([0-9]*\)$/\1/p' "$FAKE_WORKER_LOG" | tail -n 1)
    [ -n "$wpid" ] || sleep 0.1
    i=$((i + 1))
done
check "the worker runs at worker_nice (10, the default)" 10 "$(ps -o ni= -p "${wpid:-0}" | tr -d ' ')"
check "DELETE of a running job is 202" 202 "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$URL/v1/bakes/$kc")"
wait_state "$kc" cancelled 10 && ok "job is cancelled" || bad "job not cancelled"
sleep 0.3
pgrep -f "$T/store/jobs/$kc" >/dev/null && bad "worker still alive after cancel" || ok "worker process is gone"
check "DELETE of a cancelled job removes it" 200 "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$URL/v1/bakes/$kc")"
check "deleted job is 404" 404 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kc")"

# kill -9 of the daemon with one job running and three queued.
keys=""
for n in 1 2 3 4; do
    f=$(mesh "q$n.obj" slow)
    keys="$keys $(post "$f" | json_str key)"
done
sleep 0.3
kill9_daemon
start_daemon --workers 2
for k in $keys; do
    wait_state "$k" done 30 && ok "job $k completes after restart" || bad "job $k lost after restart"
done
grep -q '"event":"jobs_recovered"' "$T/daemon.log" && ok "restart logs recovery" || bad "no recovery log"
finish
