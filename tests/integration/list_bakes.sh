#!/bin/sh
# list_bakes.sh — GET /v1/bakes (issue 23): each caller sees its own bakes,
# newest first, paged with limit and the "next" cursor; bad parameters are
# 400 with a JSON error; a bake's state and stage are shown. Bearer tokens
# are callers. Issue 22 item 8: a bake is its uploaders' alone (status,
# ?wait, artifacts, DELETE and a bodiless PUT of its key answer anyone else
# as an unknown key); uploading the same bytes makes a caller an owner too,
# and that survives a restart. Fake worker (no real bake).
# sylva-test: cost=3
. "$(dirname "$0")/daemon_lib.inc"
A=list-bakes-token-aaaaaaaaaaaaaaaa
B=list-bakes-token-bbbbbbbbbbbbbbbb
C=list-bakes-token-cccccccccccccccc
printf '%s\n%s\n%s\n' "$A" "$B" "$C" > "$T/tokens"
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

# issue 22 item 8: a bake is its uploaders' alone. B cannot read, probe,
# download or delete A's bake: the answers are an unknown key's 404
get() { curl -s -o "$T/o" -w '%{http_code}' -H "Authorization: Bearer $1" "$URL/v1/bakes/$2$3"; }
wait_state_as() { # TOKEN KEY STATE
    i=0
    while [ $i -lt 50 ]; do
        curl -s -H "Authorization: Bearer $1" "$URL/v1/bakes/$2?wait=1" | grep -q "\"state\":\"$3\"" && return 0
        i=$((i + 1))
    done
    return 1
}
wait_state_as "$A" "$k1" done || bad "A's bake did not finish"
check "B: A's bake status is 404" 404 "$(get "$B" "$k1" "")"
unknown=$(curl -s -H "Authorization: Bearer $B" "$URL/v1/bakes/$(printf '0%.0s' $(seq 1 64))")
check "  the same answer as an unknown key" "$unknown" "$(cat "$T/o")"
check "B: A's artifact is 404" 404 "$(get "$B" "$k1" /artifacts/model.glb)"
check "B: A's bake with ?wait is 404" 404 "$(get "$B" "$k1" '?wait=1')"
check "B: DELETE of A's bake is 404" 404 "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE -H "Authorization: Bearer $B" "$URL/v1/bakes/$k1")"
check "  and it is still A's, done" 200 "$(get "$A" "$k1" "")"
# a PUT of the key alone (Expect: 100-continue, no bytes) proves nothing
other=$(mesh zzz.obj ok)
code=$(curl -s -o "$T/o" -w '%{http_code}' -X PUT -H "Authorization: Bearer $B" -H 'Expect: 100-continue' \
    -F "spec={};type=application/json" -F "mesh=@$other;filename=one.obj" "$URL/v1/bakes/$k1")
[ "$code" != 200 ] && ok "B: a PUT of A's key with other bytes is not answered with A's bake ($code)" ||
    bad "B: a PUT of A's key with other bytes got A's status"
# B uploads the same bytes: now it is B's too (and A's still)
kk=$(up "$B" "$T/one.obj")
check "B uploads the same bytes: same key" "$k1" "$kk"
check "  then B sees it" 200 "$(get "$B" "$k1" "")"
check "  and lists it" True "$(list "$B" "" | python3 -c "import json,sys; print('$k1' in [b['key'] for b in json.load(sys.stdin)['bakes']])")"
stop_daemon
start_daemon --workers 1 --tokens "$T/tokens"
check "  ownership survives a restart" 200 "$(get "$B" "$k1" "")"
check "  and a third caller still cannot see it" 404 "$(get "$C" "$k1" "")"
finish
