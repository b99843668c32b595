#!/bin/sh
# plausibility.sh — a Z-up tree is warned about through every channel (issue
# 19, item 4): sylva-bake's stderr and report.json input.warnings, the daemon's
# status document ("warnings") and the sylva client's output; import.up
# "auto" turns it upright without a warning; a 4 cm tree (units "mm") is
# warned about. The Z-up tree is the shared aspen turned Z-up by a few lines of
# python ((x, y, z) -> (x, -z, y)). The client run also checks that the
# standalone per-level files (lod<i>_<name>.glb) are downloaded.
# Skips (saying so) without the shared data.
# sylva-test: cost=15
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
SYLVA=$B/sylva
D=${SYLVA_DATA:-$SYLVA_ROOT/../shared/data}/eztree_aspen_small
[ -x "$BAKE" ] && [ -x "$SYLVA" ] || { echo "FAIL: sylva-bake or sylva not built"; exit 1; }
[ -f "$D/aspen_small.obj" ] || { echo "skipped: $D/aspen_small.obj missing"; exit 77; }
command -v python3 > /dev/null || { echo "FAIL: python3 missing"; exit 1; }

mkdir -p "$T/z"
cp "$D/aspen_small.mtl" "$D/bark_birch_color_1k.jpg" "$D/leaves_aspen_color.png" "$T/z/"
python3 - "$D/aspen_small.obj" "$T/z/aspen_small.obj" <<'PY'
import sys
with open(sys.argv[1]) as f, open(sys.argv[2], 'w') as o:
    for line in f:
        if line.startswith(('v ', 'vn ')):
            p = line.split()
            x, y, z = (float(v) for v in p[1:4])
            line = '%s %.7g %.7g %.7g\n' % (p[0], x, -z, y)
        o.write(line)
PY
ZMESH="$T/z/aspen_small.obj $T/z/aspen_small.mtl $T/z/bark_birch_color_1k.jpg $T/z/leaves_aspen_color.png"
YMESH="$D/aspen_small.obj $D/aspen_small.mtl $D/bark_birch_color_1k.jpg $D/leaves_aspen_color.png"
CHEAP='"method":"crossed_quads","lod":{"chain":false},"bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}'
echo "{$CHEAP}" > "$T/spec.json"
echo "{\"import\":{\"up\":\"auto\"},$CHEAP}" > "$T/auto.json"
jget() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"; }

# offline, Z-up as given: baked (lying down) with a warning on stderr and in the report
# shellcheck disable=SC2086
"$BAKE" bake $ZMESH --spec "$T/spec.json" --out "$T/zo" 2> "$T/zo.err"
check "Z-up tree bakes (exit 0)" 0 $?
contains "sylva-bake warns on stderr" "sylva-bake: warning: the tree looks Z-up" "$(cat "$T/zo.err")"
contains "  naming import.up" 'import.up' "$(cat "$T/zo.err")"
contains "report.json input.warnings" "looks Z-up" "$(jget "$T/zo/report.json" "d['input']['warnings']")"
check "report.json up_check" "Z False" "$(jget "$T/zo/report.json" "d['input']['up_check']['looks'], d['input']['up_check']['rotated']" | tr -d "(),'")"

# offline, import.up auto: rotated upright, no warning; the Y-up original is left alone
# shellcheck disable=SC2086
"$BAKE" bake $ZMESH --spec "$T/auto.json" --out "$T/za" 2> "$T/za.err"
check "auto: bake exits 0" 0 $?
check "auto: no warning" "" "$(grep -c 'looks Z-up' "$T/za.err" | grep -v '^0$')"
check "auto: rotated, up Z" "Z True" "$(jget "$T/za/report.json" "d['input']['up'], d['input']['up_check']['rotated']" | tr -d "(),'")"
check "auto: the tree stands (height ~39 m along Y)" "39" "$(jget "$T/za/report.json" "round(d['input']['bounds']['size'][1])")"
# shellcheck disable=SC2086
"$BAKE" info $YMESH --spec "$T/auto.json" --json > "$T/ya.json"
check "auto on a Y-up tree: not rotated, no warning" "Y False []" \
    "$(jget "$T/ya.json" "d['up_check']['looks'], d['up_check']['rotated'], d['warnings']" | tr -d "(),'")"

# a 4 cm tree: the units are probably wrong
echo '{"import":{"units":"mm"}}' > "$T/mm.json"
# shellcheck disable=SC2086
"$BAKE" info $YMESH --spec "$T/mm.json" > "$T/mm.out"
contains "a 4 cm tree is warned about" "shorter than 5 cm" "$(cat "$T/mm.out")"

# through the daemon (real worker): the status document carries the warning
start_daemon --workers 1 --worker "$BAKE"
code=$(curl -s -o "$T/b" -w '%{http_code}' -F "spec=@$T/spec.json" -F "mesh=@$T/z/aspen_small.obj" \
    -F "file=@$T/z/aspen_small.mtl" -F "file=@$T/z/bark_birch_color_1k.jpg" \
    -F "file=@$T/z/leaves_aspen_color.png" "$URL/v1/bakes")
check "upload of the Z-up tree is 202" 202 "$code"
key=$(json_str key < "$T/b")
wait_state "$key" done 300 && ok "daemon bake done" || bad "daemon bake not done"
curl -s "$URL/v1/bakes/$key" > "$T/status.json"
contains "status JSON warnings" "looks Z-up" "$(jget "$T/status.json" "d['warnings']")"

# through the client: the warning in its output, every level's file downloaded
# shellcheck disable=SC2086
SYLVA_SERVER=$URL "$SYLVA" bake $ZMESH --spec "$T/spec.json" --out "$T/co" > "$T/co.out" 2>&1
check "client bake exits 0" 0 $?
contains "client prints the warning" "warning: the tree looks Z-up" "$(cat "$T/co.out")"
check "client downloaded the standalone level" "lod0_crossed.glb" "$(cd "$T/co" && ls lod*_*.glb)"
cmp -s "$T/co/lod0_crossed.glb" "$T/zo/lod0_crossed.glb" && ok "  identical to the offline one" \
    || bad "  differs from the offline one"
finish
