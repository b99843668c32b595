#!/bin/sh
# bounded_reads.sh — sylvad never reads a body it does not take (issue 22,
# item 1; docs/api.md "Request bodies"). With --tokens, tests/tools/body_probe.py
# sends Content-Length 2^31 to an unknown route, a 405, GET /v1/health, a GET
# and a DELETE of a bake, a GET without a token, an unauthenticated POST and
# PUT, 2^32 to an authorised upload, and endless chunked bodies to
# GET /v1/health and to an unauthenticated POST. Each must be answered within
# 2 s with its status (404, 405, 413, 401) and a JSON error, and the
# connection closed (reset) after at most PROBE_MAX_SENT bytes, what the
# socket buffers hold: the daemon read no more. Its CPU over all the probes
# stays under 1 s and its RSS grows by less than 4 MiB. Afterwards
# /v1/health answers; a small body (<= 4 KiB) on a GET is read and dropped on
# a connection that stays open; an authorised upload still works.
# Before the fix each 2^31 body was read to its end (~1.6 s) before the
# answer, and the chunked ones were read until the probe gave up (4 GB in 4 s).
# sylva-test: cost=8
. "$(dirname "$0")/daemon_lib.inc"
command -v python3 > /dev/null || { echo "skipped: python3 missing"; exit 77; }
TOKEN=bounded-reads-token-0123456789
printf '# test token\n%s\n' "$TOKEN" > "$T/tokens"
start_daemon --workers 1 --tokens "$T/tokens"
# bytes a client can push before the daemon's socket is closed: the two socket
# buffers (loopback autotuning takes each to a few MiB) and what was in flight
PROBE_MAX_SENT=${PROBE_MAX_SENT:-16777216}

vm() { sed -n "s/^$1:[[:space:]]*\([0-9]*\).*/\1/p" "/proc/$DPID/status"; }
cpu() { awk '{ print $14 + $15 }' "/proc/$DPID/stat"; } # clock ticks
rss0=$(vm VmRSS)
cpu0=$(cpu)

# One Python process runs every probe (starting Python takes ~1 s on a loaded
# machine). It prints, per probe, "ok" or "FAIL", the label, and its figures.
cat > "$T/probes.py" <<'EOF'
import json, sys
sys.path.insert(0, sys.argv[1])
from body_probe import probe
port, limit, token = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
key = "0" * 64
auth = "Authorization: Bearer " + token
mp = "Content-Type: multipart/form-data; boundary=x"
big = 1 << 31
cases = [
    ("Content-Length 2^31 to an unknown route: 404 at once", 404, "GET", "/v1/nothing", big, ()),
    ("Content-Length 2^31 with a method the path does not take: 405 at once", 405, "POST", "/v1/health",
     big, ()),
    ("Content-Length 2^31 on GET /v1/health: 413 at once", 413, "GET", "/v1/health", big, ()),
    ("Content-Length 2^31 on GET of a bake: 413 at once", 413, "GET", "/v1/bakes/" + key, big, (auth,)),
    ("Content-Length 2^31 on DELETE: 413 at once", 413, "DELETE", "/v1/bakes/" + key, big, (auth,)),
    ("Content-Length 2^31 on a GET without a token: 401 at once", 401, "GET", "/v1/bakes/" + key, big, ()),
    ("an unauthenticated upload of 2^31 bytes: 401 at once", 401, "POST", "/v1/bakes", big, (mp,)),
    ("an unauthenticated PUT of 2^31 bytes: 401 at once", 401, "PUT", "/v1/bakes/" + key, big, (mp,)),
    ("an authorised upload of 2^32 bytes (over max_upload_bytes): 413 at once", 413, "POST", "/v1/bakes",
     1 << 32, (mp, auth)),
    ("an endless chunked body on GET /v1/health: 413 at once, cut off", 413, "GET", "/v1/health", None, ()),
    ("an endless chunked unauthenticated upload: 401 at once, cut off", 401, "POST", "/v1/bakes", None, (mp,)),
]
for label, want, method, path, length, headers in cases:
    o = probe(port, method, path, length=length, chunked=length is None, headers=headers,
              max_bytes=1 << 33, max_seconds=4.0)
    errs = []
    if o["status"] != want:
        errs.append("status %s, want %d" % (o["status"], want))
    if o["answer_s"] is None or o["answer_s"] > 2.0:
        errs.append("answered after %s s (limit 2 s)" % o["answer_s"])
    if o["closed"] != "reset":
        errs.append("connection not closed (%s): the daemon went on reading" % o["closed"])
    if o["sent"] > limit:
        errs.append("%d body bytes taken (limit %d)" % (o["sent"], limit))
    if '"error":{"code":' not in o["body"]:
        errs.append("no JSON error body: %r" % o["body"][:100])
    print("%s - %s%s" % ("FAIL" if errs else "ok  ", label, (": " + "; ".join(errs)) if errs else ""))
    print("#      " + json.dumps(o))
EOF
python3 "$T/probes.py" "$SYLVA_ROOT/tests/tools" "$PORT" "$PROBE_MAX_SENT" "$TOKEN" > "$T/probes"
cat "$T/probes"
n=$(grep -c '^ok  ' "$T/probes")
[ "$n" -eq 11 ] || bad "$n of 11 probes passed"

sleep 0.3
rss1=$(vm VmRSS)
cpu1=$(cpu)
tck=$(getconf CLK_TCK)
echo "# daemon: RSS $rss0 -> $rss1 KiB, CPU $(( (cpu1 - cpu0) * 1000 / tck )) ms over the probes"
[ $((rss1 - rss0)) -lt 4096 ] && ok "RSS grew by less than 4 MiB ($((rss1 - rss0)) KiB)" ||
    bad "RSS grew by $((rss1 - rss0)) KiB"
[ $((cpu1 - cpu0)) -lt "$tck" ] && ok "the daemon spent under 1 s of CPU on the probes" ||
    bad "the daemon spent $(( (cpu1 - cpu0) * 1000 / tck )) ms of CPU on the probes"

check "/v1/health still answers" 200 "$(curl -s -o /dev/null -w '%{http_code}' --max-time 5 "$URL/v1/health")"

# A small body on a route without one is read and dropped; the connection
# stays open for the next request (keep-alive).
ka=$(python3 - "$PORT" <<'EOF'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=5)
s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\nContent-Length: 4096\r\n\r\n" + b"x" * 4096 +
          b"GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n")
data = b""
while data.count(b"HTTP/1.1 ") < 2 or not data.endswith(b"}"):
    d = s.recv(65536)
    if not d:
        break
    data += d
print(" ".join(p.split()[0].decode() for p in data.split(b"HTTP/1.1 ")[1:]))
EOF
)
check "a 4 KiB body on GET is dropped and the connection kept for a second request" "200 200" "$ka"

# The upload path is unchanged for a token holder.
m=$(mesh tree.obj ok)
code=$(curl -s -o "$T/body" -w '%{http_code}' -H "Authorization: Bearer $TOKEN" \
    -F 'spec={};type=application/json' -F "mesh=@$m" "$URL/v1/bakes")
check "an authorised upload is accepted" 202 "$code"
finish
