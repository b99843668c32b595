#!/bin/sh
# The viewer's routes on a real sylvad (issue 21 item 4; docs/api.md, "Viewer"):
# GET /v1/viewer/PATH serves the page's files and nothing outside viewer_dir
# (no traversal, no dot files, GET/HEAD only); GET /v1/bakes/{key}/view is the
# page for a finished bake (404 unknown, 409 not done); GET /v1/bakes/{key}/inputs
# lists the uploaded files and .../inputs/NAME serves them byte for byte (ETag,
# 304, ranges, 404 for other names); with --tokens a bake's view and inputs are
# its owners' alone (404 to anyone else, as its status and artifacts); a
# missing viewer_dir is a warning at start and a JSON 404.
# Fake worker: the routes are the daemon's, not the baker's.
. "$(dirname "$0")/daemon_lib.inc"
V=$B/viewer
[ -s "$V/index.html" ] && [ -s "$V/three/three.module.js" ] || { echo "FAIL - $V not built (make)"; exit 1; }

# status URL [curl args...] -> HTTP status; body in $T/body, headers in $T/hdr
status() { u=$1; shift; curl -s -o "$T/body" -D "$T/hdr" -w '%{http_code}' "$@" "$u"; }
is_json_error() { grep -q '^{"error":{"code":"[a-z_]*","message":"[^"]*"}}$' "$T/body"; }
ctype() { tr -d '\r' < "$T/hdr" | sed -n 's/^[Cc]ontent-[Tt]ype: //p'; }

start_daemon --workers 1
# ---- the page's own files
check "GET /v1/viewer/index.html" 200 "$(status "$URL/v1/viewer/index.html")"
cmp -s "$T/body" "$V/index.html" && ok "index.html served byte for byte" || bad "index.html differs"
check "html content type" "text/html; charset=utf-8" "$(ctype)"
check "GET /v1/viewer/three/addons/loaders/GLTFLoader.js" 200 "$(status "$URL/v1/viewer/three/addons/loaders/GLTFLoader.js")"
check "javascript content type (module scripts need it)" "text/javascript; charset=utf-8" "$(ctype)"
check "a shader" 200 "$(status "$URL/v1/viewer/octahedral.frag.glsl")"
for p in '%2e%2e/sylvad' '..%2fsylvad' 'three/%2e%2e/%2e%2e/sylvad' '.stamp' 'three/.hidden' 'three//three.module.js' \
         'three/' '' '%2fetc%2fpasswd' 'a%00b' 'no-such-file.js' 'three'; do
    code=$(status "$URL/v1/viewer/$p" --path-as-is)
    if [ "$code" = 404 ] && is_json_error; then ok "/v1/viewer/$p is a JSON 404"; else bad "/v1/viewer/$p: $code $(head -c 200 "$T/body")"; fi
done
check "POST to a viewer file is 405" 405 "$(status "$URL/v1/viewer/index.html" -X POST)"
tr -d '\r' < "$T/hdr" | grep -q '^Allow: GET, HEAD$' && ok "405 names GET, HEAD" || bad "405 without Allow: GET, HEAD"

# ---- a bake: view, inputs
check "view of an unknown key is 404" 404 "$(status "$URL/v1/bakes/$(printf '%064d' 0)/view")"
is_json_error && ok "its body is a JSON error" || bad "404 body: $(cat "$T/body")"
m=$(mesh held.obj hold)
printf '# until=%s\n' "$T/release" >> "$m"
printf 'newmtl x\n' > "$T/held.mtl"
curl -s -o "$T/up" -F "spec=$SPEC;type=application/json" -F "mesh=@$m" -F "file=@$T/held.mtl" "$URL/v1/bakes"
key=$(json_str key < "$T/up")
wait_state "$key" running 20 || bad "held bake not running"
check "view of a running bake is 409" 409 "$(status "$URL/v1/bakes/$key/view")"
grep -q '"code":"not_ready"' "$T/body" && ok "409 says not_ready" || bad "409 body: $(cat "$T/body")"
check "inputs of a running bake are listed" 200 "$(status "$URL/v1/bakes/$key/inputs")"
grep -q '"mesh":"held.obj"' "$T/body" && grep -q '"name":"held.mtl"' "$T/body" && ok "the list names the mesh and the companion" \
    || bad "inputs list: $(cat "$T/body")"
touch "$T/release"
wait_state "$key" done 20 || bad "held bake not done"
check "view of a done bake" 200 "$(status "$URL/v1/bakes/$key/view")"
cmp -s "$T/body" "$V/index.html" && ok "the view is the viewer's index.html" || bad "view body differs from index.html"
check "view content type" "text/html; charset=utf-8" "$(ctype)"
check "HEAD of the view" 200 "$(curl -s -o /dev/null -w '%{http_code}' -I "$URL/v1/bakes/$key/view")"
check "GET an input" 200 "$(status "$URL/v1/bakes/$key/inputs/held.obj")"
cmp -s "$T/body" "$m" && ok "input served byte for byte" || bad "input differs from the upload"
etag=$(tr -d '\r' < "$T/hdr" | sed -n 's/^[Ee][Tt]ag: //p')
check "its ETag is the SHA-256" "\"$(sha256sum "$m" | cut -d' ' -f1)\"" "$etag"
check "If-None-Match answers 304" 304 "$(status "$URL/v1/bakes/$key/inputs/held.obj" -H "If-None-Match: $etag")"
check "a range answers 206" 206 "$(status "$URL/v1/bakes/$key/inputs/held.obj" -r 0-3)"
check "the range's bytes" "$(head -c 4 "$m")" "$(cat "$T/body")"
for n in nothere.png inputs.json ..%2finputs.json '%2e%2e' spec.json; do
    code=$(status "$URL/v1/bakes/$key/inputs/$n" --path-as-is)
    if [ "$code" = 404 ] && is_json_error; then ok "inputs/$n is a JSON 404"; else bad "inputs/$n: $code"; fi
done
check "an input of an unknown key is 404" 404 "$(status "$URL/v1/bakes/$(printf '%064d' 0)/inputs/held.obj")"
check "DELETE of an input is 405" 405 "$(status "$URL/v1/bakes/$key/inputs/held.obj" -X DELETE)"
stop_daemon

# ---- no viewer directory
start_daemon --workers 1 --viewer-dir "$T/none"
check "view without a viewer_dir is 404" 404 "$(status "$URL/v1/bakes/$key/view")"
grep -q 'not installed' "$T/body" && is_json_error && ok "its JSON error says the page is not installed" \
    || bad "body: $(cat "$T/body")"
grep -q '"viewer_missing"' "$T/daemon.log" && ok "start-up warned viewer_missing" || bad "no viewer_missing warning"
stop_daemon

# ---- tokens: the view and the inputs are the owner's alone
printf 'tok-a\ntok-b\n' > "$T/tokens"
start_daemon --workers 1 --tokens "$T/tokens"
A='Authorization: Bearer tok-a'
Bt='Authorization: Bearer tok-b'
check "viewer file without a token is 401" 401 "$(status "$URL/v1/viewer/index.html")"
check "viewer file with a token" 200 "$(status "$URL/v1/viewer/index.html" -H "$A")"
m2=$(mesh owned.obj ok)
curl -s -o "$T/up" -H "$A" -F "spec=$SPEC;type=application/json" -F "mesh=@$m2" "$URL/v1/bakes"
k2=$(json_str key < "$T/up")
end=$(( $(date +%s) + 20 ))
until curl -s -H "$A" "$URL/v1/bakes/$k2?wait=2" | grep -q '"state":"done"' || [ "$(date +%s)" -ge "$end" ]; do :; done
check "owner sees the view" 200 "$(status "$URL/v1/bakes/$k2/view" -H "$A")"
check "owner lists the inputs" 200 "$(status "$URL/v1/bakes/$k2/inputs" -H "$A")"
check "owner gets an input" 200 "$(status "$URL/v1/bakes/$k2/inputs/owned.obj" -H "$A")"
for r in view inputs inputs/owned.obj; do
    check "another token gets 404 for $r" 404 "$(status "$URL/v1/bakes/$k2/$r" -H "$Bt")"
    check "no token gets 401 for $r" 401 "$(status "$URL/v1/bakes/$k2/$r")"
done
finish
