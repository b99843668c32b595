#!/bin/sh
# daemon_pool.sh — issue 20 item 1: sylvad's resident worker pool (a
# `sylva-bake zygote` per worker thread forks each bake; docs/design.md,
# "The worker pool") with the REAL worker:
#  1. a small bake with the pool on is byte-identical to the same bake with
#     worker_pool = off (report.json but for its "times"), and really ran in
#     a zygote's child (log, parent pid) with the limits and nice of today;
#  2. the zygote SIGKILLed while idle is reaped and replaced: the next job
#     is done by a new zygote;
#  3. DELETE of a running bake and a job timeout kill the zygote's child: no
#     process of the job is left;
#  4. a worker that dies by a signal (SIGSEGV sent to it) is reported as
#     before ("worker killed by signal 11", a crash in the metrics); a
#     zygote SIGKILLed mid-bake takes its child with it and the job counts
#     as a crash.
# sylva-test: no-sanitize (zygote supervision; under ASan the zygote forks every real-worker bake of client_cli and sandbox_seccomp's, supervision of failing workers runs in daemon_faults; CI time, 49 s under ASan) cost=20
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
OAK=$SYLVA_ROOT/examples/oak_large/oak_large.glb
[ -x "$BAKE" ] || { echo "skipped: $BAKE not built"; exit 77; }
[ -f "$OAK" ] || { echo "skipped: $OAK missing"; exit 77; }
command -v python3 > /dev/null || { echo "skipped: python3 missing"; exit 77; }
case "$B" in *asan*) ASAN=1; WAIT=600 ;; *) ASAN=0; WAIT=120 ;; esac

python3 "$SYLVA_ROOT/tests/tools/synth_tree.py" "$T/tree.obj" 40 4242
CHEAP='{"method":"crossed_quads","lod":{"chain":false},"bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}}'
# post_tree: the synthetic tree (tree.obj + tree.mtl) with the cheap spec
post_tree() {
    curl -s -o "$T/body" -w '%{http_code}' -F "spec=$CHEAP;type=application/json" \
        -F "mesh=@$T/tree.obj" -F "file=@$T/tree.mtl" "$URL/v1/bakes" > "$T/status"
    json_str key < "$T/body"
}
# post_oak SPEC: the oak, a bake of many seconds to kill
post_oak() {
    curl -s -o "$T/body" -w '%{http_code}' -F "spec=$1;type=application/json" -F "mesh=@$OAK" \
        "$URL/v1/bakes" > "$T/status"
    json_str key < "$T/body"
}
# fetch KEY DIR: every artifact of a done bake, from its status document
fetch() {
    mkdir -p "$2"
    curl -s "$URL/v1/bakes/$1" > "$2.status"
    for f in $(python3 -c 'import json,sys; [print(a["name"]) for a in json.load(open(sys.argv[1]))["manifest"]["artifacts"]]' "$2.status"); do
        curl -s -o "$2/$f" "$URL/v1/bakes/$1/artifacts/$f"
    done
}
# worker_of KEY: the pid of the process baking KEY (its command line holds
# the job's folder: a zygote's child writes it over its argv), waiting ≤ 20 s
worker_of() {
    i=0 wp=""
    while [ -z "$wp" ] && [ $i -lt 200 ]; do
        wp=$(pgrep -f "jobs/$1/" | head -n 1); i=$((i + 1))
        [ -n "$wp" ] || sleep 0.1
    done
    echo "$wp"
}
ppid_of() { awk '{print $4}' "/proc/$1/stat" 2>/dev/null; }
limit_of() { # limit_of PID NAME: the hard limit in /proc/PID/limits (sylva-bake
    # sets RLIMIT_CPU's soft one a little lower itself: its SIGXCPU message)
    sed -n "s/^$2  *[^ ]*  *\([^ ]*\) .*/\1/p" "/proc/$1/limits" 2>/dev/null
}
gone() { # gone PID: true once PID has exited and been reaped (≤ 5 s)
    i=0
    while [ -d "/proc/$1" ] && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
    [ ! -d "/proc/$1" ]
}
strip='/"times":[[:space:]]*{[^}]*$/,/}/d; s/"times":[[:space:]]*{[^}]*}//'

# --- 1. pool on vs off: the same bytes
start_daemon --worker "$BAKE" --workers 1 --job-timeout "$WAIT"
kp=$(post_tree)
check "the tree is accepted (pool on)" 202 "$(cat "$T/status")"
wait_state "$kp" done "$WAIT" && ok "bake done with the pool" || bad "bake with the pool: $(curl -s "$URL/v1/bakes/$kp")"
fetch "$kp" "$T/on"
contains "a zygote was started" '"event":"zygote_started"' "$(cat "$T/daemon.log")"
zpid=$(zygotes)
[ -n "$zpid" ] && ok "the zygote is the daemon's child (pid $zpid)" || bad "no zygote child of the daemon"
wpid=$(grep '"event":"worker_started"' "$T/daemon.log" | tail -n 1 | sed -n 's/.*"zygote":"\([0-9]*\)".*/\1/p')
check "the worker was the zygote's child" "$zpid" "$wpid"
grep -q '"event":"worker_pool_unavailable"' "$T/daemon.log" && bad "the pool was refused: $(grep worker_pool_unavailable "$T/daemon.log")"

# --- 2. the zygote killed while idle: reaped, and the next job gets a new one
kill -9 "$zpid"
sleep 0.3
z=$(grep "^State:" "/proc/$zpid/status" 2>/dev/null)
# the daemon notices at its next job: a zombie until then is fine
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# one triangle\n' > "$T/tri.obj"
curl -s -o "$T/body" -w '%{http_code}' -F "spec=$CHEAP;type=application/json" -F "mesh=@$T/tri.obj" \
    "$URL/v1/bakes" > "$T/status"
kt=$(json_str key < "$T/body")
wait_state "$kt" done "$WAIT" && ok "the job after the zygote's death is done" ||
    bad "job after the zygote's death: $(curl -s "$URL/v1/bakes/$kt")"
check "  with one attempt" '"attempts":1' "$(curl -s "$URL/v1/bakes/$kt" | grep -o '"attempts":[0-9]*')"
z2=$(zygotes)
[ -n "$z2" ] && [ "$z2" != "$zpid" ] && ok "  by a new zygote ($zpid -> $z2; the old one was ${z:-gone})" ||
    bad "no new zygote (old $zpid, now '$z2')"
[ -d "/proc/$zpid" ] && bad "the killed zygote $zpid was not reaped" || ok "  and the dead one was reaped"
check "two zygote_started events" 2 "$(grep -c '"event":"zygote_started"' "$T/daemon.log")"
contains "  the death was noticed" '"event":"zygote_lost"' "$(cat "$T/daemon.log")"

# --- 3a. DELETE of a running bake kills the child
kc=$(post_oak '{}')
wait_state "$kc" running 30 || bad "the oak never ran"
wc_=$(worker_of "$kc")
[ -n "$wc_" ] && ok "the oak's worker runs (pid $wc_)" || bad "no worker found for the oak"
check "  a child of the zygote" "$z2" "$(ppid_of "$wc_")"
check "  at worker_nice (10)" 10 "$(ps -o ni= -p "${wc_:-0}" | tr -d ' ')"
check "  RLIMIT_NOFILE 256" 256 "$(limit_of "$wc_" 'Max open files')"
check "  RLIMIT_CORE 0" 0 "$(limit_of "$wc_" 'Max core file size')"
check "  RLIMIT_CPU 1800" 1800 "$(limit_of "$wc_" 'Max cpu time')"
check "  RLIMIT_FSIZE 4G" 4294967296 "$(limit_of "$wc_" 'Max file size')"
[ "$ASAN" = 1 ] || check "  RLIMIT_AS 8G" 8589934592 "$(limit_of "$wc_" 'Max address space')"
check "  seccomp on (Seccomp: 2)" 2 "$(sed -n 's/^Seccomp:[[:space:]]*//p' "/proc/$wc_/status" 2>/dev/null)"
check "DELETE of the running oak is 202" 202 "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$URL/v1/bakes/$kc")"
wait_state "$kc" cancelled 10 && ok "the oak is cancelled" || bad "the oak is not cancelled"
gone "$wc_" && ok "  its worker is gone (killed and reaped)" || bad "  its worker $wc_ is still there"
check "  no process of the job left" "" "$(pgrep -f "jobs/$kc/" | tr '\n' ' ')"
check "  the zygote stays" "$z2" "$(zygotes)"
stop_daemon
[ -d "/proc/$z2" ] && bad "the zygote $z2 outlived its daemon's stop" || ok "the zygote ends with its daemon"

# --- 3b / 4. a timeout and a crash, one attempt each
start_daemon --worker "$BAKE" --workers 1 --attempts 1 --job-timeout 4
kh=$(post_oak '{"method":"crossed_quads"}')
wait_state "$kh" running 30 || bad "the timed oak never ran"
wh=$(worker_of "$kh")
[ -n "$wh" ] && ok "the timed oak's worker runs (pid $wh)" || bad "no worker for the timed oak"
wait_state "$kh" failed 30 && ok "the timed oak fails" || bad "the timed oak did not fail"
contains "  timeout reason" "worker timed out after 4 s" "$(curl -s "$URL/v1/bakes/$kh")"
gone "$wh" && ok "  its worker is gone" || bad "  its worker $wh is still there"
check "  no process of the job left" "" "$(pgrep -f "jobs/$kh/" | tr '\n' ' ')"

ks=$(post_oak '{"method":"billboard_cloud"}')
wait_state "$ks" running 30 || bad "the crashing oak never ran"
ws=$(worker_of "$ks")
[ -n "$ws" ] && kill -SEGV "$ws"
wait_state "$ks" failed 30 && ok "a worker killed by SIGSEGV fails the job (attempts 1)" ||
    bad "the SIGSEGV'd job: $(curl -s "$URL/v1/bakes/$ks")"
contains "  reason names the signal" "worker killed by signal 11" "$(curl -s "$URL/v1/bakes/$ks")"
contains "  a crash in the metrics" 'sylva_worker_crashes_total{reason="crash"} 1' "$(curl -s "$URL/v1/metrics")"
contains "  and a timeout" 'sylva_worker_crashes_total{reason="timeout"} 1' "$(curl -s "$URL/v1/metrics")"
[ -n "$(zygotes)" ] && ok "  the zygote survives its child's crash" || bad "the zygote died with its child"

# the zygote killed mid-bake: its child dies with it, the job counts as a crash
kz=$(post_oak '{"method":"crossed_quads","seed":7}')
wait_state "$kz" running 30 || bad "the oak for the zygote kill never ran"
wz=$(worker_of "$kz")
zk=$(zygotes)
[ -n "$wz" ] && [ -n "$zk" ] && kill -9 "$zk"
wait_state "$kz" failed 30 && ok "a job whose zygote was killed fails (attempts 1)" ||
    bad "the zygote-killed job: $(curl -s "$URL/v1/bakes/$kz")"
contains "  reason: the zygote died" "zygote died during the bake" "$(curl -s "$URL/v1/bakes/$kz")"
contains "  a crash in the metrics" 'sylva_worker_crashes_total{reason="crash"} 2' "$(curl -s "$URL/v1/metrics")"
gone "$wz" && ok "  the worker died with its zygote" || bad "  the worker $wz outlived its zygote"
gone "$zk" && ok "  the zygote was reaped" || bad "  the zygote $zk is a zombie"
stop_daemon

# --- 1 (end). the same bake by exec: the same bytes
rm -rf "$T/store"
lines=$(wc -l < "$T/daemon.log")
start_daemon --worker "$BAKE" --workers 1 --job-timeout "$WAIT" --worker-pool off
ko=$(post_tree)
check "the same key with the pool off" "$kp" "$ko"
wait_state "$ko" done "$WAIT" && ok "bake done without the pool" || bad "bake without the pool: $(curl -s "$URL/v1/bakes/$ko")"
fetch "$ko" "$T/off"
check "no zygote with worker_pool = off" "" "$(zygotes)"
tail -n +"$((lines + 1))" "$T/daemon.log" | grep -q '"event":"zygote_started"' && bad "a zygote started with the pool off"
n=0
for f in $(ls "$T/on"); do
    n=$((n + 1))
    if [ "$f" = report.json ]; then
        a=$(sed "$strip" "$T/on/$f"); b=$(sed "$strip" "$T/off/$f")
        [ "$a" = "$b" ] && ok "report.json equal but for times" || bad "report.json differs beyond times"
    else
        cmp -s "$T/on/$f" "$T/off/$f" && ok "$f byte-identical (pool on / off)" || bad "$f differs (pool on / off)"
    fi
done
[ "$n" -ge 4 ] && ok "$n artifacts compared" || bad "only $n artifacts"
finish
