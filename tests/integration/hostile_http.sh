#!/bin/sh
# hostile_http.sh — the hostile corpus (tests/corpus/) through sylvad's
# POST /v1/bakes with the REAL worker: each upload is refused with a 4xx, or
# accepted and then failed with a clear input error code (never `crash`, never
# `internal`, never `done`); the daemon answers /v1/health after every one; the
# canary's marker appears in no response, log, job directory or artifact (the
# daemon and its workers run in a directory holding canary.mtl). Then hostile
# HTTP: malformed multipart, huge headers, an oversized chunked body, a client
# hanging up mid-upload — each answered or cut off, nothing left in tmp/.
# (daemon_upload.sh covers Content-Length 413, bad spec, 415, bad names.)
# sylva-test: no-sanitize (test_hostile runs the corpus through the import path under ASan in-process; daemon_upload and daemon_faults cover the server side) cost=45
. "$(dirname "$0")/daemon_lib.inc"
corpus=$SYLVA_ROOT/tests/corpus
WORKER=$B/sylva-bake
[ -x "$WORKER" ] || { echo "skipped: $WORKER not built"; exit 77; }
marker=$(cat "$corpus/CANARY_MARKER")
mkdir -p "$T/cwd"
cp "$corpus/canary.mtl" "$T/cwd/canary.mtl"
cd "$T/cwd" || exit 1
start_daemon --worker "$WORKER" --workers 2 --job-timeout 60 --max-upload-bytes 4M \
    --connection-timeout 5
SPEC='{"method":"crossed_quads","evaluate":{"views":4}}'
codes="parse invalid limit refused missing format io unbakeable"
health() { curl -s -o /dev/null -w '%{http_code}' --max-time 5 "$URL/v1/health"; }

names=$(grep -v '^#' "$corpus/MANIFEST.tsv" | cut -f1)
n=0 refused=0 accepted=""
for name in $names; do
    n=$((n + 1))
    code=$(curl -s -o "$T/up_$name" -w '%{http_code}' --max-time 30 \
        -F "spec=$SPEC;type=application/json" -F "mesh=@$corpus/$name" "$URL/v1/bakes")
    case "$code" in
    202|200) accepted="$accepted $name" ;;
    4??)
        refused=$((refused + 1))
        grep -q '"error":{"code":"[a-z_]*","message":"[^"]' "$T/up_$name" &&
            ok "$name: $code $(json_str code < "$T/up_$name")" ||
            bad "$name: $code without an error body: $(head -c 200 "$T/up_$name")" ;;
    *) bad "$name: upload answered $code" ;;
    esac
    check "daemon healthy after $name" 200 "$(health)"
done
# Accepted uploads: every job must fail with an input error code.
for name in $accepted; do
    key=$(json_str key < "$T/up_$name")
    if wait_state "$key" failed 90; then
        curl -s "$URL/v1/bakes/$key" > "$T/st_$name"
        c=$(sed -n 's/.*"error":{"code":"\([a-z_]*\)".*/\1/p' "$T/st_$name")
        case " $codes " in
        *" $c "*) ok "$name: accepted, then failed with '$c'" ;;
        *) bad "$name: failed with code '$c': $(head -c 300 "$T/st_$name")" ;;
        esac
    else
        bad "$name: job $key did not fail: $(curl -s "$URL/v1/bakes/$key" | head -c 300)"
    fi
done
echo "# corpus: $n files, $refused refused at upload, $(echo $accepted | wc -w) failed as jobs"
check "the daemon is still the same process" "$DPID" "$(pgrep -f "port-file $T/port" | head -n 1)"
check "no worker crashed" 0 "$(curl -s "$URL/v1/metrics" | sed -n 's/^sylva_worker_crashes_total{reason="crash"} \([0-9]*\).*/\1/p' | head -n 1 | grep . || echo 0)"

# --- hostile HTTP
b="--xyzBOUNDARYxyz"
raw() { # raw FILE -> status of a POST of FILE as a multipart body
    curl -s -o "$T/raw" -w '%{http_code}' --max-time 10 -X POST \
        -H "Content-Type: multipart/form-data; boundary=${b#--}" --data-binary "@$1" "$URL/v1/bakes"
}
printf '%s\r\nContent-Disposition: form-data; name="mesh"; filename="a.obj"\r\n\r\nv 0 0 0\r\n' "$b" > "$T/m1"
check "multipart without its closing delimiter is 400" 400 "$(raw "$T/m1")"
printf '%s\r\nContent-Disposition: form-data\r\n\r\nx\r\n%s--\r\n' "$b" "$b" > "$T/m2"
check "a part without a name is 400" 400 "$(raw "$T/m2")"
{ printf '%s\r\nContent-Disposition: form-data; name="mesh"; filename="a.obj"\r\nX-Pad: ' "$b"
  head -c 20000 /dev/zero | tr '\0' a; printf '\r\n\r\nv 0 0 0\r\n%s--\r\n' "$b"; } > "$T/m3"
check "part headers over 8 KiB are 400" 400 "$(raw "$T/m3")"
printf 'no boundary at all\r\n' > "$T/m4"
check "a body with no delimiter is 400" 400 "$(raw "$T/m4")"
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 10 -X POST \
    -H 'Content-Type: multipart/form-data' --data-binary @"$T/m1" "$URL/v1/bakes")
check "multipart without a boundary parameter is 400" 400 "$code"
pad=$(head -c 100000 /dev/zero | tr '\0' a)
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 10 -H "X-Huge: $pad" "$URL/v1/health")
case "$code" in 4??|000) ok "a 100 KB header is refused ($code)" ;; *) bad "a 100 KB header answered $code" ;; esac
# chunked body over max_upload_bytes (4M): cut off, nothing stored.
{ printf '%s\r\nContent-Disposition: form-data; name="mesh"; filename="big.obj"\r\n\r\n' "$b"
  head -c 6000000 /dev/zero | tr '\0' '#'; printf '\r\n%s--\r\n' "$b"; } > "$T/big"
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 20 -X POST -H 'Transfer-Encoding: chunked' \
    -H "Content-Type: multipart/form-data; boundary=${b#--}" --data-binary @"$T/big" "$URL/v1/bakes")
# (curl reports 100 or 000 when the server closes the connection mid-body)
case "$code" in 413|100|000) ok "an oversized chunked upload is cut off ($code)" ;; *) bad "oversized chunked upload answered $code" ;; esac
grep -q '"event":"upload_cut_off"' "$T/daemon.log" && ok "the cut-off is logged" || bad "no upload_cut_off in the log"
# a client that hangs up in the middle of its body
python3 - "$PORT" <<'EOF'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
b = "xyzBOUNDARYxyz"
s.sendall(("POST /v1/bakes HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000\r\n"
           "Content-Type: multipart/form-data; boundary=%s\r\n\r\n--%s\r\n"
           "Content-Disposition: form-data; name=\"mesh\"; filename=\"half.obj\"\r\n\r\n"
           % (b, b)).encode() + b"v 0 0 0\n" * 2000)
s.close()
EOF
i=0
while [ $i -lt 50 ] && [ -n "$(ls -A "$T/store/tmp" 2>/dev/null)" ]; do sleep 0.1; i=$((i + 1)); done
check "a hung-up upload leaves nothing in tmp/" "" "$(ls -A "$T/store/tmp" 2>/dev/null)"
# issue 22 item 13: 1000 query arguments exhausted MHD's connection pool and
# the connection hung 30 s unanswered; now a 431 at once (--max-time 10 with
# the daemon's idle timeout at 5 s: an answer, not a timeout)
q=$(python3 -c "print('&'.join('a%d=%d' % (i, i) for i in range(1000)))")
code=$(curl -s -o "$T/many" -w '%{http_code}' --max-time 10 "$URL/v1/health?$q")
check "1000 query arguments: 431" 431 "$code"
contains "  with a JSON error naming the arguments" "query arguments" "$(cat "$T/many")"
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 10 "$URL/v1/bakes?limit=2&before=5")
check "  while two are fine" 200 "$code"
# issue 22 item 6: one address holding 200 slow-header connections (over
# max_conns_per_ip, 64) leaves the server to the others: /v1/health from
# another address answers at once, and the connections over the limit are
# closed by the server
python3 - "$PORT" > "$T/perip" <<'PY' &
import socket, sys, time
port = int(sys.argv[1])
socks, closed = [], 0
for i in range(200):
    s = socket.create_connection(("127.0.0.1", port))
    s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\n")  # never finished
    socks.append(s)
time.sleep(1.0)
for s in socks:
    s.settimeout(0.05)
    try:
        closed += s.recv(1) == b""
    except socket.timeout:
        pass
    except OSError:
        closed += 1
print(closed)
time.sleep(2.0)
PY
perip=$!
sleep 0.6
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 5 --interface 127.0.0.2 "$URL/v1/health")
check "200 slow connections from one address: /v1/health from another answers" 200 "$code"
wait "$perip"
check "  the 136 over max_conns_per_ip were closed" 136 "$(cat "$T/perip")"
check "daemon healthy after hostile HTTP" 200 "$(health)"

# The canary: its marker in no byte the daemon answered, logged or stored.
leak=$(grep -r -l -a -F "$marker" "$T" 2>/dev/null | grep -v "^$T/cwd/canary.mtl$")
check "the canary's bytes appear nowhere" "" "$leak"
grep -q -F "$marker" "$T/cwd/canary.mtl" && ok "the canary check can see the marker" ||
    bad "canary marker missing"
cd /
finish
