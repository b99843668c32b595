#!/bin/sh
# list_bakes.sh — GET /v1/bakes (issue 23): each caller sees its own bakes,
# newest first, paged with limit and the "next" cursor; bad parameters are
# 400 with a JSON error; a bake's state and stage are shown. Two bearer
# tokens are two callers. Fake worker (no real bake).
# sylva-test: cost=3
. "$(dirname "$0")/daemon_lib.inc"
A=list-bakes-token-aaaaaaaaaaaaaaaa
B=list-bakes-token-bbbbbbbbbbbbbbbb
printf '%s\n%s\n' "$A" "$B" > "$T/tokens"
start_daemon --workers 1 --tokens "$T/tokens"
pick_spec() { :; }
up() { # up TOKEN FILE -> key
    curl -s -H "Authorization: Bearer $1" -F "spec={};type=application/json" -F "mesh=@$2" \
        "$URL/v1/bakes" | json_str key
}
k1=$(up "$A" "$(mesh one.obj ok)")
k2=$(up "$A" "$(mesh two.obj ok)")
k3=$(up "$A" "$(mesh three.obj ok)")
kb=$(up "$B" "$(mesh other.obj ok)")
for k in "$k1" "$k2" "$k3" "$kb"; do
    [ -n "$k" ] || bad "an upload got no key"
done
list() { curl -s -H "Authorization: Bearer $1" "$URL/v1/bakes$2"; }
keys() { python3 -c 'import json,sys; j=json.load(sys.stdin); print(" ".join(b["key"][:8] for b in j["bakes"]), j["next"] is not None)'; }
short() { echo "$1" | cut -c1-8; }
check "caller A: its three bakes, newest first, no next page" \
    "$(short "$k3") $(short "$k2") $(short "$k1") False" "$(list "$A" "" | keys)"
check "caller B: its own bake only" "$(short "$kb") False" "$(list "$B" "" | keys)"
page=$(list "$A" "?limit=2")
check "limit=2: the two newest and a next page" "$(short "$k3") $(short "$k2") True" "$(echo "$page" | keys)"
next=$(echo "$page" | python3 -c 'import json,sys; print(json.load(sys.stdin)["next"])')
check "before=next: the rest" "$(short "$k1") False" "$(list "$A" "?limit=2&before=$next" | keys)"
st=$(list "$A" "" | python3 -c '
import json, sys
b = json.load(sys.stdin)["bakes"]
print(all(x["state"] in ("queued", "running", "done") and 0 <= x["progress"] <= 1
          and (x["stage"] is None or x["state"] == "running") for x in b))')
check "each bake says its state, stage and progress" True "$st"
check "no token: 401" 401 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes")"
code=$(curl -s -o "$T/e" -w '%{http_code}' -H "Authorization: Bearer $A" "$URL/v1/bakes?limit=0")
check "limit=0: 400" 400 "$code"
contains "  naming limit" '"limit: expected an integer from 1 to 1000"' "$(cat "$T/e")"
check "before=x: 400" 400 "$(curl -s -o /dev/null -w '%{http_code}' -H "Authorization: Bearer $A" "$URL/v1/bakes?before=x")"
check "PUT /v1/bakes: 405" 405 "$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H "Authorization: Bearer $A" "$URL/v1/bakes")"
finish
