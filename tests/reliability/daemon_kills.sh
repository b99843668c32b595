#!/bin/sh
# daemon_kills.sh — issue 12, "Faults": kill -9 of the daemon with jobs queued
# and running, DKILL_TRIALS times (20). Per trial: a daemon (fake worker,
# `slow` bakes of about a second, 2 workers) takes 6 new jobs; after a seeded
# random delay (0–0.6 s after the 6 uploads: some jobs done, some running, some queued) the daemon
# gets SIGKILL and its workers die with it; a new daemon on the same store must
# bring every accepted job (answered 202) to `done`, with nothing left in tmp/.
# Prints ok/FAIL lines and a `figures:` line.
. "$(dirname "$0")/../integration/daemon_lib.inc"
TRIALS=${DKILL_TRIALS:-20}
SEED=${DKILL_SEED:-7}
export FAKE_WORKER_LOG=$T/invocations
: > "$FAKE_WORKER_LOG"
lost=0 accepted=0 recovered_logs=0 states=""
for trial in $(seq 1 "$TRIALS"); do
    start_daemon --workers 2
    keys=""
    for n in 1 2 3 4 5 6; do
        f=$(mesh "t${trial}_$n.obj" slow)
        k=$(post "$f" | json_str key)
        [ "$(cat "$T/status")" = 202 ] && { keys="$keys $k"; accepted=$((accepted + 1)); }
    done
    delay=$(python3 -c "import random; r = random.Random($SEED * 1000 + $trial); print('%.2f' % r.uniform(0, 0.6))")
    sleep "$delay"
    # what the jobs were doing at the kill, for the figures
    for k in $keys; do states="$states $(curl -s "$URL/v1/bakes/$k" | json_str state)"; done
    workers=$(pgrep -P "$DPID" 2>/dev/null)
    kill9_daemon
    for w in $workers; do kill -9 "$w" 2>/dev/null; done
    start_daemon --workers 2
    for k in $keys; do
        wait_state "$k" done 30 || { lost=$((lost + 1)); bad "trial $trial: job $k not done after restart"; }
    done
    grep -q '"event":"jobs_recovered"' "$T/daemon.log" && recovered_logs=$((recovered_logs + 1))
    stop_daemon
    left=$(find "$T/store/tmp" -mindepth 1 2>/dev/null | wc -l | tr -d ' ')
    [ "$left" = 0 ] || bad "trial $trial: $left entries left in tmp/"
done
check "every accepted job completes after a daemon kill -9 ($accepted jobs, $TRIALS trials)" 0 "$lost"
q=$(echo $states | tr ' ' '\n' | grep -c '^queued$')
r=$(echo $states | tr ' ' '\n' | grep -c '^running$')
d=$(echo $states | tr ' ' '\n' | grep -c '^done$')
echo "at the kills: $q queued, $r running, $d done"
[ "$q" -gt 0 ] && [ "$r" -gt 0 ] && ok "the kills caught jobs queued and running" ||
    bad "the kills did not catch both queued ($q) and running ($r) jobs"
echo "figures: trials=$TRIALS accepted=$accepted lost=$lost at_kill_queued=$q at_kill_running=$r at_kill_done=$d"
finish
