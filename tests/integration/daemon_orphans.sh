#!/bin/sh
# daemon_orphans.sh — issue 22 item 9: a worker never outlives its daemon.
#  1. sylvad SIGKILLed while the real worker bakes: the worker dies with it
#     (sylva-bake --parent-pid: PR_SET_PDEATHSIG), within 3 s;
#  2. a stray worker of a dead daemon still running (a process with a
#     worker's command line whose --out is in the store's tmp/) is killed by
#     the next daemon on that store before it empties tmp/, and logged.
# sylva-test: cost=12
. "$(dirname "$0")/daemon_lib.inc"
WORKER=$B/sylva-bake
[ -x "$WORKER" ] || { echo "skipped: $WORKER not built"; exit 77; }
OAK=$SYLVA_ROOT/examples/oak_large/oak_large.glb

# 1. the daemon dies mid-bake
start_daemon --worker "$WORKER" --workers 1
SPEC='{}'
key=$(post "$OAK" | json_str key)
check "the oak is accepted" 202 "$(cat "$T/status")"
wait_state "$key" running 20 || bad "the bake never ran"
i=0 wpid=""
while [ -z "$wpid" ] && [ $i -lt 50 ]; do
    wpid=$(pgrep -f -- "--out $T/store/tmp/" | head -n 1); i=$((i + 1)); sleep 0.1
done
[ -n "$wpid" ] && ok "the worker runs (pid $wpid)" || bad "no worker process found"
kill9_daemon
i=0
while kill -0 "$wpid" 2>/dev/null && [ $i -lt 30 ]; do sleep 0.1; i=$((i + 1)); done
if kill -0 "$wpid" 2>/dev/null && ! grep -q '^State:.*Z' "/proc/$wpid/status" 2>/dev/null; then
    bad "the worker outlived its SIGKILLed daemon by 3 s"
    kill -9 "$wpid" 2>/dev/null
else ok "the worker died with its daemon"; fi

# 2. a stray worker (an older daemon's, or one that missed its prctl)
mkdir -p "$T/store/tmp/out-stray"
sh -c 'while :; do sleep 0.2; done' bake --progress-fd 3 --out "$T/store/tmp/out-stray" &
stray=$!
sleep 0.2
start_daemon --worker "$FAKE"
i=0
while kill -0 "$stray" 2>/dev/null && [ $i -lt 30 ]; do sleep 0.1; i=$((i + 1)); done
wait "$stray" 2>/dev/null
if kill -0 "$stray" 2>/dev/null; then bad "the stray worker survived the next daemon's start"; kill -9 "$stray"
else ok "the next daemon killed the stray worker"; fi
contains "  and logged it" "stray_workers_killed" "$(cat "$T/daemon.log")"
# the stray's folder went with the start-up's emptying of tmp/; the oak job
# of part 1, requeued, runs on the fake worker in a tmp/ folder of its own
# until it is done (under load that can outlast the checks above)
[ ! -e "$T/store/tmp/out-stray" ] && ok "  the stray's folder is gone" || bad "  the stray's folder is still in tmp/"
i=0
while [ -n "$(ls -A "$T/store/tmp")" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
check "  tmp/ is empty once the requeued job is done" "" "$(ls -A "$T/store/tmp")"
finish
