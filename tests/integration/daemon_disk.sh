#!/bin/sh
# The store's disk (docs/reliability.md, "Third campaign"): a bake is accepted
# only when the disk has room for its outputs (an estimate from its atlas
# size) beside those of the bakes not finished and disk_reserve_bytes; a bake
# that cannot have it is 507 naming the disk, and finished bakes are not
# evicted for a request that evicting them could not satisfy; /v1/health says
# when the disk is low. The disk is made "small" through disk_reserve_bytes,
# set from what df says is free (the test never fills a real disk).
# sylva-test: cost=10
. "$(dirname "$0")/daemon_lib.inc"
avail() { df -B1 --output=avail "$T" | tail -n 1 | tr -d ' '; }
small_spec() { printf '{"bake":{"max_atlas":256}}' > "$T/small.json"; }
post_spec() { # post_spec SPECFILE MESH -> body; status in $T/status
    curl -s -o "$T/body" -w '%{http_code}' -F "spec=@$1;type=application/json" -F "mesh=@$2" \
        "$URL/v1/bakes" > "$T/status"
    cat "$T/body"
}
small_spec
start_daemon --workers 1
h=$(curl -s "$URL/v1/health")
contains "health reports the disk" '"disk":"ok","disk_free_bytes":' "$h"
kept=$(post_spec "$T/small.json" "$(mesh keep.obj ok)" | json_str key)
wait_state "$kept" done && ok "a finished bake" || bad "the first bake did not finish"
stop_daemon

# -- 70 MB of room beyond the reserve: a 256² atlas bake (about 2 MB of
# outputs) fits, a default 2048² one (about 134 MB) does not
start_daemon --workers 1 --disk-reserve-bytes $(( $(avail) - 70000000 ))
post_spec "$T/small.json" "$(mesh small.obj ok)" > /dev/null
check "a bake whose outputs fit the disk is accepted" 202 "$(cat "$T/status")"
printf '{}' > "$T/default.json"
body=$(post_spec "$T/default.json" "$(mesh big.obj ok)")
check "a bake whose outputs do not fit the disk is 507" 507 "$(cat "$T/status")"
contains "  naming the disk" "the store's disk has" "$body"
check "  and the finished bake was not evicted for it" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"
stop_daemon

# -- the disk below the reserve: health says low, uploads 507, reads served
start_daemon --workers 1 --disk-reserve-bytes $(( $(avail) + 1000000000 ))
h=$(curl -s -w ' %{http_code}' "$URL/v1/health")
contains "health says the disk is low (still 200: reads are served)" '"disk":"low"' "$h"
contains "  200" ' 200' "$h"
post_spec "$T/small.json" "$(mesh late.obj ok)" > /dev/null
check "an upload on a low disk is 507" 507 "$(cat "$T/status")"
check "  the finished bake is still served" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"
finish
