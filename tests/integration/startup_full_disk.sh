#!/bin/sh
# startup_full_disk.sh — sylvad starts, and serves what it stored, when its
# disk is full (issue 22, item 3; docs/operations.md "A full disk"). A store
# with one finished bake is restarted under strace's fault injection
# (`strace -D -f -e inject=…`, from start-up on, as store_faults.sh does
# after it):
#  1. every write(2) to journal.tmp fails with ENOSPC: journal compaction
#     fails, is logged (journal_compaction_failed), the journal is kept byte
#     for byte, the stored result is served, and an upload is accepted and
#     baked (its records go after the kept journal: a clean restart has it);
#  2. fsync of the store directory fails with EIO (compaction fails after its
#     rename): an upload accepted then is still there after a clean restart
#     (the daemon must append to the renamed journal, not the unlinked one);
#  3. the disk is full: every write(2) fails with ENOSPC, every mkdir(2) too:
#     the daemon starts (it does not re-create tmp/), answers health, the
#     status and the artifact of the stored bake, and an upload gets 507
#     store_full before its body is read.
# Before the fix sylvad exited at start-up in all three ("startup_failed").
# sylva-test: cost=20
. "$(dirname "$0")/daemon_lib.inc"
command -v strace > /dev/null || { echo "skipped: strace missing"; exit 77; }
strace -f -qq -o /dev/null -e trace=none true 2> /dev/null ||
    { echo "skipped: strace cannot trace here (ptrace not permitted)"; exit 77; }
command -v ss > /dev/null || { echo "skipped: ss (iproute2) missing"; exit 77; }

# start_faulty LABEL PATH|- INJECT...: starts sylvad under strace, each INJECT a
# "SYSCALL:error=E" applied to calls on PATH (- for all). The port is read
# from the listening socket (the port file cannot be written on a full disk).
start_faulty() {
    label=$1 path=$2; shift 2
    set -- "$@" # the injections
    trace="" injects=""
    for inj in "$@"; do
        trace="$trace${trace:+,}${inj%%:*}"
        injects="$injects -e inject=$inj"
    done
    pflag=""
    [ "$path" != - ] && pflag="-P $path"
    echo "# $label: strace -e trace=$trace$injects $pflag" >> "$T/daemon.log"
    # LeakSanitizer cannot run under ptrace (the untraced restarts check leaks)
    # shellcheck disable=SC2086
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" \
        strace -D -f -qq -o /dev/null -e trace="$trace" $injects $pflag \
        "$SYLVAD" --listen 127.0.0.1:0 --store "$T/store" --worker "$FAKE" --workers 1 \
        --log-level debug 2>> "$T/daemon.log" &
    DPID=$!  # with -D the daemon keeps the shell's child pid; strace is a grandchild
    PORT="" i=0
    while [ -z "$PORT" ] && [ $i -lt 150 ] && kill -0 "$DPID" 2> /dev/null; do
        sleep 0.1
        i=$((i + 1))
        PORT=$(ss -Htlnp 2> /dev/null | sed -n "s/.*127\.0\.0\.1:\([0-9]*\) .*pid=$DPID,.*/\1/p" | head -n 1)
    done
    URL=http://127.0.0.1:$PORT
    if [ -z "$PORT" ]; then
        why=$(awk -v m="# $label:" 'index($0, m) == 1 { on = 1 } on' "$T/daemon.log" |
            grep -o '"event":"startup_failed".*' | tail -n 1)
        bad "$label: sylvad did not start (${why:-its log could not be written})"
        kill -9 "$DPID" 2> /dev/null
        wait "$DPID" 2> /dev/null
        DPID=""
        return 1
    fi
    ok "$label: sylvad starts"
}
stop_faulty() {
    [ -n "$DPID" ] || return 0
    kill -TERM "$DPID" 2> /dev/null
    i=0
    while kill -0 "$DPID" 2> /dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    kill -9 "$DPID" 2> /dev/null
    wait "$DPID" 2> /dev/null
    DPID=""
}
served() { # served LABEL: the stored bake's status and artifact are answered
    check "$1: the stored bake's status" done "$(curl -s --max-time 5 "$URL/v1/bakes/$A" | json_str state)"
    code=$(curl -s -o "$T/got.glb" -w '%{http_code}' --max-time 5 "$URL/v1/bakes/$A/artifacts/model.glb")
    check "$1: its artifact is served" 200 "$code"
    cmp -s "$T/got.glb" "$ma" && ok "$1: the artifact's bytes" || bad "$1: the artifact differs"
}
upload_ok() { # upload_ok LABEL NAME: an upload is accepted and baked; sets KEY
    m=$(mesh "$2" ok)
    body=$(post "$m")
    check "$1: an upload is accepted" 202 "$(cat "$T/status")"
    KEY=$(echo "$body" | json_str key)
    wait_state "$KEY" done 20 && ok "$1: it is baked" || bad "$1: the upload did not finish"
}

# A store with one finished bake.
start_daemon --workers 1
pick_spec
ma=$(mesh a.obj ok)
A=$(post "$ma" | json_str key)
wait_state "$A" done || bad "the first bake did not finish"
stop_daemon
cp "$T/store/journal" "$T/journal.before"

# 1. journal.tmp cannot be written
if start_faulty "journal.tmp ENOSPC" "$T/store/journal.tmp" write:error=ENOSPC; then
    grep '"event":"journal_compaction_failed"' "$T/daemon.log" | grep -q 'No space left on device' &&
        ok "journal.tmp ENOSPC: the failed compaction is logged" || bad "no journal_compaction_failed in the log"
    cmp -s "$T/store/journal" "$T/journal.before" && ok "journal.tmp ENOSPC: the journal is kept as it was" ||
        bad "journal.tmp ENOSPC: the journal changed"
    [ ! -e "$T/store/journal.tmp" ] && ok "journal.tmp ENOSPC: no journal.tmp left" || bad "journal.tmp left behind"
    served "journal.tmp ENOSPC"
    upload_ok "journal.tmp ENOSPC" b.obj
    B=$KEY
    stop_faulty
    start_daemon --workers 1
    check "journal.tmp ENOSPC: after a clean restart, the upload made meanwhile" done \
        "$(curl -s "$URL/v1/bakes/$B" | json_str state)"
    stop_daemon
fi

# 2. the store directory's fsync fails after the compaction's rename
if start_faulty "store dir fsync EIO" "$T/store" fsync:error=EIO; then
    grep '"event":"journal_compaction_failed"' "$T/daemon.log" | grep -q 'fsync failed' &&
        ok "store dir fsync EIO: the failed compaction is logged" || bad "store dir fsync EIO: not logged"
    upload_ok "store dir fsync EIO" c.obj
    C=$KEY
    stop_faulty
    start_daemon --workers 1
    check "store dir fsync EIO: after a clean restart, the upload made meanwhile" done \
        "$(curl -s "$URL/v1/bakes/$C" | json_str state)"
    stop_daemon
fi

# 3. a full disk
if start_faulty "full disk" - write:error=ENOSPC mkdir:error=ENOSPC; then
    check "full disk: /v1/health" 200 "$(curl -s -o /dev/null -w '%{http_code}' --max-time 5 "$URL/v1/health")"
    served "full disk"
    m=$(mesh d.obj ok)
    curl -s -o "$T/body" -w '%{http_code}' --max-time 10 -F "spec=$SPEC;type=application/json" \
        -F "mesh=@$m" "$URL/v1/bakes" > "$T/status"
    check "full disk: an upload gets 507" 507 "$(cat "$T/status")"
    contains "full disk: the 507 says so" '"code":"store_full"' "$(cat "$T/body")"
    stop_faulty
fi

# Back on a healthy disk, everything is there and uploads work again.
start_daemon --workers 1
check "afterwards: the first bake" done "$(curl -s "$URL/v1/bakes/$A" | json_str state)"
upload_ok "afterwards" e.obj
# (a staging entry of the bake just finished may still be on its way out:
# up to 3 s for it to go; a leftover stays and fails)
i=0
while [ -n "$(ls -A "$T/store/tmp")" ] && [ $i -lt 30 ]; do sleep 0.1; i=$((i + 1)); done
[ -z "$(ls -A "$T/store/tmp")" ] && ok "afterwards: tmp/ is empty" || bad "tmp/ not empty: $(ls -A "$T/store/tmp")"
finish
