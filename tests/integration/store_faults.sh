#!/bin/sh
# store_faults.sh — the store's write path under injected faults (issue 12,
# "Faults"), with strace's syscall tampering and the fake worker:
#  1. crash: for k = 1, 2, … the daemon is SIGKILLed at its k-th
#     write / fsync / rename (`strace -f -p PID -e inject=SET:signal=KILL:when=k`,
#     attached after start-up) while it takes an upload and installs the
#     worker's result;
#     after a clean restart no accepted (202/200) job is lost and all complete,
#     tmp/ is empty, no job directory is partial, and every object's SHA-256
#     matches its name (inputs.json, manifest.json, and the key itself is
#     recomputed from spec.json + in/ per docs/api.md).
#  2. failure loops: the N-th fsync returns EIO / the N-th write ENOSPC in the
#     HTTP thread: the upload that hits it gets 5xx (507 for ENOSPC), the
#     daemon survives, and the next upload is accepted and completes.
# Bounded: K_MAX per syscall set, the whole script stays within ~3 minutes.
# sylva-test: no-sanitize (store and journal faults; test_server_store and test_server_journal cover that code under ASan; CI time) cost=55
. "$(dirname "$0")/daemon_lib.inc"
command -v strace > /dev/null || { echo "skipped: strace missing"; exit 77; }
strace -f -qq -o /dev/null -e trace=none true 2> /dev/null ||
    { echo "skipped: strace cannot trace here (ptrace not permitted)"; exit 77; }
K_MAX=${K_MAX:-20}
WRITE_KS=${WRITE_KS:-"1 2 3 4 5 6 8 10 13 17 21 27 34 44 55"}
deadline=$(( $(date +%s) + ${STORE_FAULTS_BUDGET:-170} ))
accepted=""   # every key the daemon ever answered 202/200 for
n_kills=0 n_iter=0

# start_traced INJECT [flags]: starts sylvad, then attaches strace to it (SPID)
# so the count starts after start-up: the k-th call in a thread of the running
# daemon (strace counts per thread; --http-threads 1 makes the upload path's
# count exact). Sets DPID, PORT, URL.
start_traced() {
    inj=$1; shift
    # LeakSanitizer cannot run under ptrace: leaks are checked in the untraced
    # restarts; ASan's memory errors stay on.
    saved_asan=${ASAN_OPTIONS:-}
    export ASAN_OPTIONS="${saved_asan:+$saved_asan:}detect_leaks=0"
    start_daemon --workers 1 --http-threads 1 "$@"
    export ASAN_OPTIONS="$saved_asan"
    strace -f -qq -o /dev/null -e trace="${inj%%:*}" -e inject="$inj" -p "$DPID" 2> /dev/null &
    SPID=$!
    i=0  # attached once every thread of the daemon has strace as its tracer
    while [ $i -lt 100 ]; do
        untraced=$(grep -h '^TracerPid:' /proc/"$DPID"/task/*/status 2> /dev/null | grep -c -v "	$SPID\$")
        [ "$untraced" = 0 ] && break
        sleep 0.05; i=$((i + 1))
    done
    [ $i -lt 100 ] || bad "strace did not attach to $DPID"
}
alive() { [ -n "$DPID" ] && kill -0 "$DPID" 2> /dev/null && ! grep -q '^State:.*[ZX]' "/proc/$DPID/status" 2> /dev/null; }
stop_any() { # TERM, then KILL: the daemon, its workers and strace are gone afterwards
    if [ -n "$DPID" ]; then
        kill -TERM "$DPID" 2> /dev/null
        i=0
        while alive && [ $i -lt 30 ]; do sleep 0.1; i=$((i + 1)); done
        alive && kill -9 "$DPID" 2> /dev/null
        wait "$DPID" 2> /dev/null
    fi
    for p in $(pgrep -f "$T/store/" 2> /dev/null); do kill -9 "$p" 2> /dev/null; done
    kill -0 "$SPID" 2> /dev/null && { sleep 0.2; kill -9 "$SPID" 2> /dev/null; }
    wait "$SPID" 2> /dev/null
    DPID=""
    return 0
}
upload() { # upload NAME -> prints "STATUS KEY"
    m=$(mesh "$1" ok)
    rm -f "$T/up"
    s=$(curl -s -o "$T/up" -w '%{http_code}' --max-time 10 -F "spec=$SPEC" -F "mesh=@$m" "$URL/v1/bakes")
    echo "$s $(json_str key 2> /dev/null < "$T/up")"
}

# check_store LABEL: restart cleanly; every accepted job completes; invariants hold.
check_store() {
    start_daemon --workers 2
    for ak in $accepted; do
        wait_state "$ak" done 15 || bad "$1: accepted job $ak lost or not done after restart"
    done
    python3 - "$T/store" > "$T/check" 2>&1 <<'EOF'
import hashlib, json, os, sys
store = sys.argv[1]
def sha(p):
    return hashlib.sha256(open(p, "rb").read()).hexdigest()
errs = []
tmp = os.path.join(store, "tmp")
if os.path.isdir(tmp) and os.listdir(tmp):
    errs.append("tmp/ not empty after start: %s" % os.listdir(tmp))
jobs = os.path.join(store, "jobs")
for key in sorted(os.listdir(jobs)) if os.path.isdir(jobs) else []:
    d = os.path.join(jobs, key)
    try:
        inputs = json.load(open(os.path.join(d, "inputs.json")))
        spec = open(os.path.join(d, "spec.json"), "rb").read()
    except Exception as e:
        errs.append("%s: partial job directory (%s)" % (key, e)); continue
    for name, o in inputs.get("objects", {}).items():
        p = os.path.join(d, "in", name)
        if not os.path.isfile(p) or os.path.getsize(p) != o["size"] or sha(p) != o["sha256"]:
            errs.append("%s: input %s does not match its recorded size/SHA-256" % (key, name))
    # the key is the SHA-256 of the key stream (docs/api.md, "The content key")
    h = hashlib.sha256()
    h.update(b"sylva-key-v1\n")
    h.update(b"spec %d\n" % len(spec) + spec + b"\n")
    mesh = inputs["mesh"]
    mb = open(os.path.join(d, "in", mesh), "rb").read()
    h.update(b"mesh %s %d\n" % (mesh.encode(), len(mb)) + mb + b"\n")
    for f in sorted(inputs.get("files", []), key=lambda s: s.encode()):
        fb = open(os.path.join(d, "in", f), "rb").read()
        h.update(b"file %s %d\n" % (f.encode(), len(fb)) + fb + b"\n")
    if h.hexdigest() != key:
        errs.append("%s: its inputs hash to %s" % (key, h.hexdigest()))
    r = os.path.join(d, "result")
    if os.path.isdir(r):
        try:
            man = json.load(open(os.path.join(r, "manifest.json")))
        except Exception as e:
            errs.append("%s: result/ without a readable manifest (%s)" % (key, e)); continue
        for a in man.get("artifacts", []):
            p = os.path.join(r, a["name"])
            if not os.path.isfile(p) or os.path.getsize(p) != a["size"] or sha(p) != a["sha256"]:
                errs.append("%s: artifact %s does not match its manifest" % (key, a["name"]))
    for root, dirs, files in os.walk(d):
        for f in files:
            if f.endswith(".tmp"):
                errs.append("%s: temp file %s visible" % (key, os.path.join(root, f)))
print("\n".join(errs) if errs else "ok")
sys.exit(1 if errs else 0)
EOF
    [ $? -eq 0 ] || bad "$1: store invariants: $(head -c 600 "$T/check")"
    stop_daemon
}

# The spec: the first method the daemon knows (as pick_spec, without strace).
start_daemon
pick_spec
stop_daemon

# --- 1. crash at the k-th write / fsync / rename
# (one syscall per loop: strace keeps one counter per syscall and thread)
for set in fsync fdatasync rename write pwrite64; do
    case $set in write) ks=$WRITE_KS ;; *) ks=$(seq 1 "$K_MAX") ;; esac
    for k in $ks; do
        [ "$(date +%s)" -lt "$deadline" ] || { echo "# time budget reached at $set k=$k"; break 2; }
        n_iter=$((n_iter + 1))
        start_traced "$set:signal=KILL:when=$k"
        if alive; then
            r=$(upload "crash-$set-$k.obj")
            case "$r" in 202\ *|200\ *) accepted="$accepted ${r#* }" ;; esac
            # give the worker's result a chance to be installed (more write path)
            [ -n "${r#* }" ] && alive && wait_state "${r#* }" done 5 > /dev/null 2>&1
        fi
        sleep 0.3 # a SIGKILLed daemon takes a moment to be gone
        if alive; then
            survived=1
        else
            survived=0
            n_kills=$((n_kills + 1))
        fi
        stop_any
        check_store "$set k=$k"
        # once the daemon survives a whole round, larger k reach nothing new
        [ $survived -eq 1 ] && { echo "# $set: no kill at k=$k, $((k - 1)) crash points"; break; }
    done
done
echo "# crash loop: $n_iter restarts, $n_kills killed mid-write, $(echo $accepted | wc -w) accepted jobs checked"
[ $n_kills -ge 5 ] && ok "at least 5 crash points exercised ($n_kills)" || bad "only $n_kills crash points"

# --- 2. failure loops: the N-th fsync EIO, the N-th write ENOSPC (HTTP thread)
loop_fault() { # loop_fault INJECT WANT_RE LABEL
    start_traced "$1"
    got=""
    for i in 1 2 3; do
        r=$(upload "loop-$3-$i.obj")
        case "$r" in
        202\ *|200\ *) ;;
        *) got=${r%% *}; break ;;
        esac
    done
    if [ -n "$got" ]; then
        echo "$got" | grep -q -E "$2" && ok "$3: the failing upload gets $got" ||
            bad "$3: the failing upload got $got, want $2"
        alive && ok "$3: daemon survives" || bad "$3: daemon died"
        r=$(upload "loop-$3-after.obj")
        case "$r" in
        202\ *) wait_state "${r#* }" done 10 && ok "$3: the next upload works" ||
                    bad "$3: the next upload did not complete" ;;
        *) bad "$3: the next upload got $r" ;;
        esac
    else
        ok "$3: absorbed, no upload failed (3 accepted)"
    fi
    stop_any
}
n=1
while [ $n -le 6 ] && [ "$(date +%s)" -lt "$deadline" ]; do
    loop_fault "fsync:error=EIO:when=$n" '^5[0-9][0-9]$' "fsync-$n-EIO"
    n=$((n + 1))
done
for n in 1 2 3 4 6 9 14; do
    [ "$(date +%s)" -lt "$deadline" ] || break
    loop_fault "write:error=ENOSPC:when=$n" '^(507|5[0-9][0-9])$' "write-$n-ENOSPC"
done
check_store "after the failure loops"
[ "$(date +%s)" -le $((deadline + 10)) ] && ok "within the time budget" || bad "over the time budget"
finish
