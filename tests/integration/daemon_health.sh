#!/bin/sh
# sylvad answers health, info, metrics, and JSON errors for unknown routes.
. "$(dirname "$0")/daemon_lib.inc"
start_daemon --workers 1
check "health answers 200" 200 "$(curl -s -o "$T/b" -w '%{http_code}' "$URL/v1/health")"
contains "health body says ok" '"status":"ok"' "$(cat "$T/b")"
info=$(curl -s "$URL/v1/info")
contains "info lists methods" '"methods":[' "$info"
contains "info lists limits" '"max_upload_bytes"' "$info"
check "unknown route is 404" 404 "$(curl -s -o "$T/b" -w '%{http_code}' "$URL/v2/nothing")"
contains "404 is a JSON error" '"error":{"code":"not_found"' "$(cat "$T/b")"
check "wrong method is 405" 405 "$(curl -s -o /dev/null -w '%{http_code}' -X POST "$URL/v1/health")"
check "bad key is 400" 400 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/zzz")"
# key prefixes (docs/api.md "Keys"): two uploads whose keys share their first
# 8 hex digits (found once by a birthday search over the upload name: the
# key is the SHA-256 of spec "{}", mesh NAME and these bytes)
printf '# mode=ok\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$T/m.obj"
KA=a28d2b88b2625bf686c02679f647ff6c4f0474cb8502f98eb78dc5566a99459e
KB=a28d2b8817ed60a22caca1d0d26bba251b667859a3d11250d8b51960401eaac9
for n in p38683 p110638; do
    curl -s -o /dev/null -F 'spec={};type=application/json' -F "mesh=@$T/m.obj;filename=$n.obj" "$URL/v1/bakes"
done
code() { curl -s -o "$T/b" -w '%{http_code}' "$@"; }
check "the whole key of the first upload is as computed" 200 "$(code "$URL/v1/bakes/$KA")"
check "a unique prefix (12 digits) answers its bake" 200 "$(code "$URL/v1/bakes/a28d2b88b262")"
contains "  with the whole key in the status document" "\"key\":\"$KA\"" "$(cat "$T/b")"
check "a prefix two keys share is 409" 409 "$(code "$URL/v1/bakes/a28d2b88")"
contains "  ambiguous_key, listing both candidates in order" \
    "\"code\":\"ambiguous_key\",\"message\":\"key prefix a28d2b88 names 2 bakes: give more of the key\",\"candidates\":[\"$KB\",\"$KA\"]" "$(cat "$T/b")"
"$B/sylva" --server "$URL" status a28d2b88 >/dev/null 2>"$T/amb.err"
check "sylva status of the shared prefix exits 1" 1 $?
contains "  listing both keys" "($KB, $KA)" "$(cat "$T/amb.err")"
check "  on an artifact too" 409 "$(code "$URL/v1/bakes/a28d2b88/artifacts/model.glb")"
check "a prefix no key has is 404" 404 "$(code "$URL/v1/bakes/a28d2b89")"
contains "  naming the prefix" "no bake whose key starts with a28d2b89" "$(cat "$T/b")"
check "7 hex digits are 400" 400 "$(code "$URL/v1/bakes/a28d2b8")"
contains "  saying at least 8" "at least 8" "$(cat "$T/b")"
check "PUT with a prefix is 400 (it names the bytes)" 400 "$(code -X PUT "$URL/v1/bakes/a28d2b8817ed")"
wait_state "$KB" done 20
check "an artifact by a unique prefix" 200 "$(code "$URL/v1/bakes/a28d2b8817ed/artifacts/model.glb")"
check "  is the bake's" "$(cat "$T/m.obj")" "$(cat "$T/b")"
check "the inputs list by a unique prefix" 200 "$(code "$URL/v1/bakes/a28d2b8817ed/inputs")"
check "DELETE by a unique prefix" 200 "$(code -X DELETE "$URL/v1/bakes/a28d2b8817ed")"
check "  deletes that bake only" "404 200" "$(code "$URL/v1/bakes/$KB") $(code "$URL/v1/bakes/$KA")"
check "  after which the shared prefix is unique" 200 "$(code "$URL/v1/bakes/a28d2b88")"
metrics=$(curl -s "$URL/v1/metrics")
contains "metrics has queue depth" "sylva_queue_depth 0" "$metrics"
contains "metrics counts requests by route and status" 'sylva_requests_total{route="health",status="200"} 1' "$metrics"
grep -q '"event":"listening"' "$T/daemon.log" && ok "log line announces the port" || bad "no listening log line"
stop_daemon
grep -q '"event":"stopped"' "$T/daemon.log" && ok "SIGTERM stops cleanly" || bad "no stopped log line"
finish
