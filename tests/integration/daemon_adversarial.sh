#!/bin/sh
# The adversarial probes that got past sylvad (docs/reliability.md, "Probes
# that got through"), each through HTTP against a real daemon with the fake
# worker: every one must be answered 4xx with the JSON error body naming the
# problem, and what is already stored must stay readable.
# sylva-test: cost=15
. "$(dirname "$0")/daemon_lib.inc"
GEN="python3 $SYLVA_ROOT/tests/tools/hostile_gltf.py"
start_daemon --workers 1 --max-upload-bytes 4M
pick_spec

# a finished bake that nothing below may lose
m=$(mesh keep.obj ok)
kept=$(post "$m" | json_str key)
wait_state "$kept" done && ok "a first bake is done" || bad "the first bake did not finish"

# refused FORM WHAT: the glTF form is answered 422 naming WHAT, nothing queued
refused() {
    $GEN "$1" "$T/$1.glb"
    body=$(post "$T/$1.glb")
    check "glTF $1: 422" 422 "$(cat "$T/status")"
    contains "  names the problem" "$2" "$body"
    contains "  with the JSON error body" '"error":{"code":' "$body"
}

# -- accessors: every form against its buffer view
for f in ok sparse_ok; do
    $GEN $f "$T/$f.glb"
    post "$T/$f.glb" > /dev/null
    check "glTF $f: accepted" 202 "$(cat "$T/status")"
done
refused sparse_indices_offset "sparse indices needs 4000000002 bytes"
refused sparse_values_offset "sparse values needs"
refused sparse_count "sparse count"
refused sparse_index_past_count "sparse index 1 is 7"
refused stride_short "byteStride 4 is shorter"
refused normalized_float "normalized"
refused min_wrong_count "min is not an array of 3"
refused strip_one_vertex "1 vertices, mode 5 needs at least 3"
refused position_vec2 "POSITION accessor 0 is not a float VEC3"

# -- JSON two parsers could read differently: refused wherever it is parsed
refused dup_key 'the key \"nodes\" appears twice'
refused nul_key 'holds a NUL'
refused trailing 'content after the JSON value'
# spec SPEC WHAT: a spec answered 400 naming WHAT
spec_refused() {
    printf '%s' "$1" > "$T/spec.json"
    m=$(mesh "spec$2.obj" ok)
    body=$(curl -s -o - -w '\n%{http_code}' -F "spec=@$T/spec.json;type=application/json" \
        -F "mesh=@$m" "$URL/v1/bakes")
    check "spec $3: 400" 400 "$(echo "$body" | tail -n 1)"
    contains "  names the problem" "$4" "$(echo "$body" | head -n 1)"
}
spec_refused '{} x' 1 "with trailing garbage" "content after the JSON value"
spec_refused '{}{}' 2 "of two objects" "content after the JSON value"
spec_refused '{"method":"billboard_cloud","method":7}' 3 "with a duplicate key" 'the key \"method\" appears twice'
spec_refused '{"seed\u0000":1}' 4 "with a NUL in a key" "holds a NUL"

# -- OBJ lines as assimp reads them: '\' continuations join lines
objc() { # objc NAME FACE_VERTICES TAIL: a fan of FACE_VERTICES vertices, one index a line
    python3 - "$T/$1" "$2" "$3" <<'PY'
import math, sys
path, n, tail = sys.argv[1], int(sys.argv[2]), sys.argv[3]
with open(path, "w", newline="") as f:
    f.write("# mode=ok\n")
    for k in range(n):
        f.write("v %.4f %.4f 0\n" % (math.cos(2 * math.pi * k / n), math.sin(2 * math.pi * k / n)))
    f.write("f" + "".join(" %d \\\n" % (k + 1) for k in range(n - 1)) + " %d\n" % n)
    f.write(tail.replace("CR", "\r"))
PY
}
objc cont_ok.obj 200 ""
post "$T/cont_ok.obj" > /dev/null
check "an OBJ face of 200 vertices over 200 continued lines is accepted" 202 "$(cat "$T/status")"
objc cont_big.obj 2000 ""
body=$(post "$T/cont_big.obj")
check "an OBJ face of 2000 vertices over continued lines is 422" 422 "$(cat "$T/status")"
contains "  naming the face and the limit" "face on line 2002 has 2000 vertices (limit 256)" "$body"
objc cont_cr.obj 3 'f 1 2 \\CRf 3 2 1
'
body=$(post "$T/cont_cr.obj")
check "a '\\' continuation before a lone CR (assimp would hide the rest) is 422" 422 "$(cat "$T/status")"
contains "  naming it" "continuation that is not followed by a newline" "$body"

# -- a PUT of a held key whose bake goes away while the body comes: a new upload
m=$(mesh put.obj ok)
head -c 600000 /dev/zero | tr '\0' '#' | fold -w 1000 >> "$m"
key=$(post "$m" | json_str key)
wait_state "$key" done && ok "a bake to PUT again is done" || bad "the bake to PUT again did not finish"
curl -s -o "$T/put" -w '%{http_code}' -X PUT -H 'Expect:' --limit-rate 100K \
    -F "spec=$SPEC;type=application/json" -F "mesh=@$m" "$URL/v1/bakes/$key" > "$T/put.code" &
pp=$!
sleep 1.5
check "  the bake is deleted while the PUT's body comes" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$URL/v1/bakes/$key")"
wait "$pp"
check "  the PUT is a new upload: 202" 202 "$(cat "$T/put.code")"
wait_state "$key" done && ok "  and is baked again" || bad "  the PUT's bake did not finish"
# and a PUT of a held key still answers the held bake (200), body read first
check "a PUT of a held key without Expect answers 200" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Expect:' -F "spec=$SPEC;type=application/json" \
        -F "mesh=@$m" "$URL/v1/bakes/$key")"

# -- stored files are never pages of this origin
printf '<html><script>fetch("/v1/bakes")</script></html>' > "$T/evil.html"
m=$(mesh page.obj ok)
key=$(curl -s -F "spec=$SPEC;type=application/json" -F "mesh=@$m" -F "file=@$T/evil.html" \
    "$URL/v1/bakes" | json_str key)
check "a bake with an .html companion is accepted" 64 "${#key}"
curl -s -D "$T/h" -o /dev/null "$URL/v1/bakes/$key/inputs/evil.html"
hdr() { sed -n "s/^$1: *//Ip" "$T/h" | tr -d '\r' | head -n 1; }
check "  the input is served as application/octet-stream" application/octet-stream "$(hdr Content-Type)"
check "  as an attachment" attachment "$(hdr Content-Disposition)"
check "  with nosniff" nosniff "$(hdr X-Content-Type-Options)"
contains "  with a policy that allows nothing" "default-src 'none'" "$(hdr Content-Security-Policy)"
contains "  and no script even if opened as a page" "sandbox" "$(hdr Content-Security-Policy)"
curl -s -D "$T/h" -o /dev/null "$URL/v1/health"
check "a JSON answer carries nosniff too" nosniff "$(hdr X-Content-Type-Options)"
if wait_state "$key" done && [ -d "$(dirname "$SYLVAD")/viewer" ]; then
    curl -s -D "$T/h" -o "$T/view.html" "$URL/v1/bakes/$key/view"
    want=$(python3 -c '
import base64, hashlib, re, sys
t = open(sys.argv[1], "rb").read()
for m in re.finditer(rb"<script type=\"importmap\">(.*?)</script>", t, re.S):
    print("sha256-" + base64.b64encode(hashlib.sha256(m.group(1)).digest()).decode())' "$T/view.html")
    csp=$(hdr Content-Security-Policy)
    contains "the viewer page's policy allows its own import map by hash" "script-src 'self' '$want'" "$csp"
    contains "  and no other origin" "default-src 'none'" "$csp"
else
    bad "no viewer page to check (bake not done or viewer not built)"
fi

# -- framing: two Content-Length headers are refused, the hidden request unanswered
resp=$(python3 - "$PORT" <<'PY'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
hidden = b"GET /v1/info HTTP/1.1\r\nHost: x\r\n\r\n"
s.sendall(b"POST /v1/bakes HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\nContent-Length: %d\r\n"
          b"Content-Type: multipart/form-data; boundary=b\r\n\r\n" % len(hidden) + hidden)
s.settimeout(3)
out = b""
try:
    while True:
        d = s.recv(65536)
        if not d:
            break
        out += d
except socket.timeout:
    pass
print(out.count(b"HTTP/1.1 "), out.split(b"\r\n", 1)[0].decode())
print(out.decode(errors="replace").split("\r\n\r\n", 1)[-1][:300])
PY
)
check "two Content-Length headers: one answer, 400" "1 HTTP/1.1 400 Bad Request" "$(echo "$resp" | head -n 1)"
contains "  naming the problem" "more than one Content-Length" "$resp"

# -- names: invalid UTF-8 is 400, and every answer stays valid JSON
resp=$(python3 - "$PORT" <<'PY'
import json, socket, sys
b = b"nb"
mesh = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
body = (b"--nb\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"t.obj\"\r\n\r\n" + mesh +
        b"\r\n--nb\r\nContent-Disposition: form-data; name=\"file\"; filename=\"bad\xff\xfe.png\"\r\n\r\n"
        b"x\r\n--nb--\r\n")
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
s.sendall(b"POST /v1/bakes HTTP/1.1\r\nHost: x\r\nConnection: close\r\n"
          b"Content-Type: multipart/form-data; boundary=nb\r\nContent-Length: %d\r\n\r\n" % len(body) + body)
out = b""
while True:
    d = s.recv(65536)
    if not d:
        break
    out += d
head, _, doc = out.partition(b"\r\n\r\n")
print(head.split(b"\r\n", 1)[0].decode())
print(json.dumps(json.loads(doc.decode("utf-8", errors="strict"))))
PY
)
check "a file name of invalid UTF-8 is 400" "HTTP/1.1 400 Bad Request" "$(echo "$resp" | head -n 1)"
contains "  with a valid JSON body naming the problem" "not valid UTF-8" "$resp"

# -- the store lock is never followed through a symlink
stop_daemon
mkdir -p "$T/s2"
printf 'precious\n' > "$T/victim"
ln -s "$T/victim" "$T/s2/lock"
timeout 10 "$SYLVAD" --listen 127.0.0.1:0 --store "$T/s2" --worker "$FAKE" 2> "$T/s2.log"
check "a store whose lock is a symlink: sylvad refuses to start" 1 "$?"
check "  the symlink's target is untouched" precious "$(cat "$T/victim")"
contains "  naming the lock" "s2/lock" "$(cat "$T/s2.log")"

start_daemon --workers 1
check "the first bake is still readable" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"
finish
