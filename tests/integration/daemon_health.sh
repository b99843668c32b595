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
metrics=$(curl -s "$URL/v1/metrics")
contains "metrics has queue depth" "sylva_queue_depth 0" "$metrics"
contains "metrics counts requests by route and status" 'sylva_requests_total{route="health",status="200"} 1' "$metrics"
grep -q '"event":"listening"' "$T/daemon.log" && ok "log line announces the port" || bad "no listening log line"
stop_daemon
grep -q '"event":"stopped"' "$T/daemon.log" && ok "SIGTERM stops cleanly" || bad "no stopped log line"
finish
