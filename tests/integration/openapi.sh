#!/bin/sh
# openapi.sh — GET /v1/openapi.json: sylvad serves server/openapi.json byte for
# byte, as JSON; the document validates against the OpenAPI 3.1 schema with
# @seriousme/openapi-schema-validator (npm, tests/openapi/, installed under
# build/test-npm/) and every $ref resolves; a document broken on purpose (a
# response without its description) is refused, so the check can fail; with
# tokens the route needs one. That it lists exactly the daemon's routes is
# tests/unit/test_server_routes.c's check (against the route table).
# sylva-test: no-sanitize (a static document and a Node validator; the route runs under ASan in test_server_routes and daemon_health) cost=4
. "$(dirname "$0")/daemon_lib.inc"
. "$(dirname "$0")/npm.inc"
command -v node >/dev/null && command -v npm >/dev/null ||
    { echo "skipped: node/npm missing (deploy/apt-packages.txt installs them)"; exit 77; }
V=$(npm_tool openapi) || { bad "npm ci of the OpenAPI validator failed"; finish; }
start_daemon --workers 1
check "GET /v1/openapi.json is 200" 200 \
    "$(curl -s -o "$T/openapi.json" -D "$T/h" -w '%{http_code}' "$URL/v1/openapi.json")"
grep -qi '^content-type: application/json' "$T/h" && ok "  as application/json" || bad "  not application/json"
cmp -s "$T/openapi.json" "$SYLVA_ROOT/server/openapi.json" && ok "  server/openapi.json byte for byte" ||
    bad "  differs from server/openapi.json"
node "$V/validate.mjs" "$T/openapi.json" >"$T/v.out" 2>&1
check "the document validates as OpenAPI 3.1" 0 $?
contains "  version 3.1, no errors" '{"valid":true,"version":"3.1","errors":[]}' "$(cat "$T/v.out")"
python3 -c 'import json,sys
d = json.load(open(sys.argv[1]))
del d["paths"]["/v1/health"]["get"]["responses"]["200"]["description"]
json.dump(d, open(sys.argv[2], "w"))' "$T/openapi.json" "$T/broken.json"
node "$V/validate.mjs" "$T/broken.json" >"$T/vb.out" 2>&1
check "a response without its description is refused" 1 $?
contains "  naming it" "must have required property 'description'" "$(cat "$T/vb.out")"
check "POST /v1/openapi.json is 405" 405 "$(curl -s -o /dev/null -w '%{http_code}' -X POST "$URL/v1/openapi.json")"
stop_daemon
printf 'openapi-test-token client-a\n' >"$T/tokens"
chmod 600 "$T/tokens"
start_daemon --workers 1 --tokens "$T/tokens"
check "with tokens it needs one (401)" 401 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/openapi.json")"
check "  and answers with one" 200 "$(curl -s -o /dev/null -w '%{http_code}' \
    -H 'Authorization: Bearer openapi-test-token' "$URL/v1/openapi.json")"
finish
