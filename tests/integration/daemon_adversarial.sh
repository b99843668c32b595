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

check "the first bake is still readable" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"
finish
