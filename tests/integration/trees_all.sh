#!/bin/sh
# trees_all.sh — every tree in ../shared/data: `sylva-bake info` matches the
# triangle counts and foliage/trunk split of the data README, and a
# crossed-quads bake succeeds and validates. Skips (saying so) without the data.
set -eu
. "$(dirname "$0")/lib.inc"
if [ ! -d "$data" ]; then
    echo "skipped: no tree data at $data"
    exit 0
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
v=""
command -v npm > /dev/null 2>&1 && v=$(ensure_validator)
grep -v '^#' "$root/tests/data/trees.tsv" | while IFS="$(printf '\t')" read -r dir mesh units tris foliage; do
    d="$data/$dir"
    [ -f "$d/$mesh" ] || fail "missing $d/$mesh"
    # shellcheck disable=SC2046
    set -- "$d/$mesh" $(companions "$d" "$mesh")
    echo "{\"import\": {\"units\": \"$units\"}, \"method\": \"crossed_quads\", \"evaluate\": {\"views\": 4, \"sizes\": [64, 32]}}" > "$tmp/spec.json"
    "$bake" info "$@" --spec "$tmp/spec.json" --json > "$tmp/info.json" || fail "$mesh: info failed"
    # The README counts what was imported; validation then removes exact
    # duplicates and zero-area triangles (ficus: 48, acacia: 275), so the
    # foliage count may be lower by at most the number removed.
    got_t=$(json_get "$tmp/info.json" "j['mesh']['imported_triangles']")
    removed=$(json_get "$tmp/info.json" "j['repairs']['removed_degenerate'] + j['repairs']['removed_duplicate']")
    got_f=$(json_get "$tmp/info.json" "j['classification']['foliage_triangles']")
    [ "$got_t" = "$tris" ] || fail "$mesh: $got_t triangles imported, README says $tris"
    [ "$got_f" -le "$foliage" ] && [ $((got_f + removed)) -ge "$foliage" ] ||
        fail "$mesh: $got_f foliage triangles ($removed removed), README says $foliage"
    out="$tmp/out-$mesh"
    "$bake" bake "$@" --spec "$tmp/spec.json" --out "$out" || fail "$mesh: bake failed"
    [ -z "$v" ] || node "$v" "$out/model.glb" > /dev/null || fail "$mesh: model.glb does not validate"
    echo "ok $mesh: $got_t triangles, $got_f foliage, IoU@32 $(json_get "$out/report.json" "round(j['lods'][0]['accuracy'][-1]['iou_mean'],3)")"
done
