#!/bin/sh
# Upload -> wait -> artifact with ETag/304 and byte ranges (206, 416,
# If-Range); Location on the answer to an upload; idempotence (16 concurrent
# uploads bake once); key mismatch 400; oversized Content-Length 413 before
# the body; bad spec 400; unknown format 415; traversal refused.
. "$(dirname "$0")/daemon_lib.inc"
export FAKE_WORKER_LOG=$T/invocations
: > "$FAKE_WORKER_LOG"
start_daemon --workers 2 --max-upload-bytes 1M
pick_spec

m=$(mesh tree.obj ok)
body=$(post "$m")
check "new upload answers 202" 202 "$(cat "$T/status")"
key=$(echo "$body" | json_str key)
check "response carries a 64-hex key" 64 "${#key}"
wait_state "$key" done && ok "bake reaches done" || bad "bake did not finish"
st=$(curl -s "$URL/v1/bakes/$key")
contains "status has the manifest" '"artifacts":[' "$st"
code=$(curl -s -D "$T/h" -o "$T/model.glb" -w '%{http_code}' "$URL/v1/bakes/$key/artifacts/model.glb")
check "artifact answers 200" 200 "$code"
cmp -s "$T/model.glb" "$m" && ok "artifact bytes are the worker's output" || bad "artifact differs"
etag=$(sed -n 's/^ETag: *\(".*"\).*/\1/Ip' "$T/h" | tr -d '\r')
sha=$(sha256sum "$T/model.glb" | cut -d' ' -f1)
check "ETag is the SHA-256" "\"$sha\"" "$etag"
check "If-None-Match answers 304" 304 "$(curl -s -o /dev/null -w '%{http_code}' -H "If-None-Match: $etag" "$URL/v1/bakes/$key/artifacts/model.glb")"
# the connection stays usable after a 304 (keep-alive: a 304 has no body;
# libmicrohttpd 0.9.75 writes Content-Length: 0 on it, docs/api.md)
check "  a request after it on the same connection is answered" "304 200" \
    "$(curl -s -o /dev/null -w '%{http_code} ' -H "If-None-Match: $etag" "$URL/v1/bakes/$key/artifacts/model.glb" \
        --next -s -o /dev/null -w '%{http_code}' "$URL/v1/health")"
a="$URL/v1/bakes/$key/artifacts/model.glb"
n=$(wc -c < "$T/model.glb")
contains "200 says Accept-Ranges: bytes" "Accept-Ranges: bytes" "$(cat "$T/h")"
code=$(curl -s -D "$T/rh" -o "$T/part" -w '%{http_code}' -r 0-9 "$a")
check "Range 0-9 answers 206" 206 "$code"
contains "  Content-Range bytes 0-9/size" "Content-Range: bytes 0-9/$n" "$(tr -d '\r' < "$T/rh")"
check "  the first 10 bytes" "$(head -c 10 "$T/model.glb" | od -An -tx1)" "$(od -An -tx1 < "$T/part")"
curl -s -o "$T/part" -H "Range: bytes=-5" "$a"
check "suffix range: the last 5 bytes" "$(tail -c 5 "$T/model.glb" | od -An -tx1)" "$(od -An -tx1 < "$T/part")"
code=$(curl -s -D "$T/rh" -o "$T/part" -w '%{http_code}' -H "Range: bytes=$n-" "$a")
check "a range past the end answers 416" 416 "$code"
contains "  Content-Range bytes */size" "Content-Range: bytes */$n" "$(tr -d '\r' < "$T/rh")"
contains "  with a JSON error" '"code":"range"' "$(cat "$T/part")"
check "If-Range with another ETag: the whole file (200)" "200 $n" \
    "$(curl -s -o "$T/part" -w '%{http_code} %{size_download}' -r 0-9 -H 'If-Range: "0000"' "$a")"
check "If-Range with this ETag: the range (206)" "206 10" \
    "$(curl -s -o "$T/part" -w '%{http_code} %{size_download}' -r 0-9 -H "If-Range: $etag" "$a")"
check "several ranges: the whole file (200)" "200 $n" \
    "$(curl -s -o "$T/part" -w '%{http_code} %{size_download}' -r 0-1,4-5 "$a")"
check "unknown artifact is 404" 404 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$key/artifacts/inputs.json")"
check "traversal is refused" 404 "$(curl -s -o /dev/null -w '%{http_code}' --path-as-is "$URL/v1/bakes/$key/artifacts/%2e%2e%2fspec.json")"
post "$m" >/dev/null
check "same upload again answers 200" 200 "$(cat "$T/status")"
loc=$(curl -s -D - -o /dev/null -F "spec=$SPEC;type=application/json" -F "mesh=@$m" "$URL/v1/bakes" |
    sed -n 's/^Location: *//Ip' | tr -d '\r')
check "the answer to an upload says Location: /v1/bakes/KEY" "/v1/bakes/$key" "$loc"

# A PUT of a key already held: its body is read and dropped, then answered on a
# connection that stays open (closing with body bytes unread resets it, which a
# proxy takes for a dead node). With Expect: 100-continue it answers at once.
port=${URL##*:}
known=$(python3 - "$port" "$key" <<'PY'
import socket, sys, time
port, key = int(sys.argv[1]), sys.argv[2]
def head(extra, n):
    return ("PUT /v1/bakes/%s HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; "
            "boundary=b\r\nContent-Length: %d\r\n%s\r\n" % (key, n, extra)).encode()
out = []
s = socket.create_connection(("127.0.0.1", port)); s.settimeout(10)
s.sendall(head("", 200000)); time.sleep(0.3)
for i in range(20): s.sendall(b"x" * 10000)
r = s.recv(65536)
out.append(r.split(b" ")[1].decode() if r.startswith(b"HTTP/1.1 ") else "none")
out.append("close" if b"connection: close" in r.lower() else "open")
s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n"); time.sleep(0.3)
r = b""
try:
    while b"status" not in r:
        d = s.recv(65536)
        if not d: break
        r += d
except OSError: pass
out.append("reused" if b'{"status":"ok"' in r else "lost")
s.close()
s = socket.create_connection(("127.0.0.1", port)); s.settimeout(10)
s.sendall(head("Expect: 100-continue\r\n", 200000))
r = s.recv(65536)
out.append("expect:" + (r.split(b" ")[1].decode() if r.startswith(b"HTTP/1.1 ") else "none"))
print(" ".join(out))
PY
)
check "a PUT of a known key, body sent: 200 on a kept-alive connection" "200 open reused expect:200" "$known"

# 16 concurrent identical uploads of new content: one bake.
m2=$(mesh concurrent.obj slow)
i=0
pids=""
while [ $i -lt 16 ]; do
    curl -s -o "$T/c$i" -w '%{http_code}\n' -F "spec=$SPEC" -F "mesh=@$m2" "$URL/v1/bakes" >> "$T/codes" &
    pids="$pids $!"
    i=$((i + 1))
done
for p in $pids; do wait "$p"; done
check "16 uploads: exactly one 202" 1 "$(grep -c 202 "$T/codes")"
check "16 uploads: fifteen 200" 15 "$(grep -c 200 "$T/codes")"
k2=$(json_str key < "$T/c0")
wait_state "$k2" done && ok "concurrent bake done" || bad "concurrent bake not done"
check "the worker ran once for 16 uploads" 1 "$(grep -c '^concurrent.obj ' "$FAKE_WORKER_LOG")"

# PUT with the right key (computed by the server for POST) and a wrong one.
m3=$(mesh put.obj ok)
wrong=0000000000000000000000000000000000000000000000000000000000000000
code=$(curl -s -o "$T/b" -w '%{http_code}' -X PUT -F "spec=$SPEC" -F "mesh=@$m3" "$URL/v1/bakes/$wrong")
check "PUT with a wrong key is 400" 400 "$code"
contains "mismatch names the real key" "key_mismatch" "$(cat "$T/b")"
real=$(sed -n 's/.*hash to \([0-9a-f]*\).*/\1/p' "$T/b")
code=$(curl -s -o "$T/b" -w '%{http_code}' -X PUT -F "spec=$SPEC" -F "mesh=@$m3" "$URL/v1/bakes/$real")
check "PUT with the right key is 202" 202 "$code"

# 413 from Content-Length, before the body: the request is answered although
# the client never sends the 2 GiB it announces.
start=$(date +%s)
code=$(printf 'xx' | curl -s -o "$T/b" -w '%{http_code}' --max-time 5 -X POST \
    -H 'Content-Type: multipart/form-data; boundary=x' -H 'Content-Length: 2147483648' \
    --data-binary @- "$URL/v1/bakes")
check "oversized Content-Length is 413" 413 "$code"
[ $(( $(date +%s) - start )) -le 2 ] && ok "413 came without waiting for the body" || bad "413 was slow"
# Only upload directories count: the job accepted above may be baking
# right now in an out-* directory of its own.
ls "$T/store/tmp" | grep -q '^up-' && bad "413 left an upload in tmp" || ok "413 wrote nothing"

# Bad spec, unknown format, wrong content type, bad names.
code=$(curl -s -o "$T/b" -w '%{http_code}' -F 'spec={"method": 12' -F "mesh=@$m3" "$URL/v1/bakes")
check "bad spec JSON is 400" 400 "$code"
contains "bad spec names the problem" '"code":"spec"' "$(cat "$T/b")"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F 'spec={"no_such_field":1}' -F "mesh=@$m3" "$URL/v1/bakes")
check "unknown spec field is 400" 400 "$code"
head -c 300 /dev/urandom > "$T/noise.bin"
printf 'GARBAGE' | cat - "$T/noise.bin" > "$T/noise.glb"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$T/noise.glb" "$URL/v1/bakes")
check "unknown format is 415" 415 "$code"
code=$(curl -s -o /dev/null -w '%{http_code}' -H 'Content-Type: application/json' -d '{}' "$URL/v1/bakes")
check "non-multipart upload is 415" 415 "$code"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$m3;filename=../evil.obj" "$URL/v1/bakes")
check "a path in a file name is 400" 400 "$code"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$m3" -F "file=@$m3;filename=put.obj" "$URL/v1/bakes")
check "a duplicate file name is 400" 400 "$code"
# issue 22 item 12: what the import's pre-check decides is answered at upload
# (422, the worker's code), not with a 202 and a bake that fails
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n' > "$T/cut.ply"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$T/cut.ply" "$URL/v1/bakes")
check "a PLY cut before end_header is 422 at upload" 422 "$code"
contains "  naming the file and the problem" "cut.ply" "$(cat "$T/b")"
contains "  with the worker's code" '"code":"parse"' "$(cat "$T/b")"
printf '{"asset":{"version":"2.0"},"buffers":[{"uri":"tree.bin","byteLength":64}]}' > "$T/nobin.gltf"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$T/nobin.gltf" "$URL/v1/bakes")
check "a glTF whose buffer was not uploaded is 422 at upload" 422 "$code"
contains "  naming the buffer's file" "tree.bin" "$(cat "$T/b")"
check "  nothing of either is stored" "" "$(ls -A "$T/store/tmp")"
# issue 22 item 10: a name over 255 bytes is refused, not truncated to 255
long=$(printf 'a%.0s' $(seq 1 300)).obj
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$m3;filename=$long" "$URL/v1/bakes")
check "a 304-byte file name is 400" 400 "$code"
contains "  saying it is longer than 255 bytes" "longer than 255 bytes" "$(cat "$T/b")"
long=$(printf 'b%.0s' $(seq 1 251)).obj
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=$SPEC" -F "mesh=@$m3;filename=$long" "$URL/v1/bakes")
check "a 255-byte file name is taken" 202 "$code"
check "daemon still healthy" 200 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/health")"
finish
