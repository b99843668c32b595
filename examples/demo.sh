#!/bin/sh
# make demo: bake the bundled example tree and say where the outputs are.
# Through the daemon and the client when they are built, else offline.
# usage: examples/demo.sh [BUILD [OUT]]  (OUT default out/demo in the checkout;
# the tests give one under their temporary folder: docs/testing.md)
set -eu
BUILD=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
out=${2:-$root/out/demo}
rm -rf "$out"
mkdir -p "$out"
tree="$root/examples/oak_large"
spec="$root/examples/demo-spec.json"
if [ -x "$BUILD/sylvad" ] && [ -x "$BUILD/sylva" ]; then
    store=$(mktemp -d)
    portfile="$store/port"
    "$BUILD/sylvad" --listen 127.0.0.1:0 --store "$store/store" --port-file "$portfile" \
        2> "$out/sylvad.log" &
    pid=$!
    trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null; rm -rf "$store"' EXIT
    i=0
    while [ ! -s "$portfile" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    [ -s "$portfile" ] || { echo "demo: sylvad did not start (see $out/sylvad.log)"; exit 1; }
    export SYLVA_SERVER="http://127.0.0.1:$(cat "$portfile")"
    echo "demo: sylvad on $SYLVA_SERVER; baking $tree/oak_large.obj with the sylva client"
    "$BUILD/sylva" bake "$tree/oak_large.obj" "$tree/oak_large.mtl" \
        "$tree/leaves_oak_color.png" "$tree/bark_oak_color_1k.jpg" --spec "$spec" --out "$out"
else
    echo "demo: baking $tree/oak_large.obj offline with sylva-bake"
    "$BUILD/sylva-bake" bake "$tree/oak_large.obj" "$tree/oak_large.mtl" \
        "$tree/leaves_oak_color.png" "$tree/bark_oak_color_1k.jpg" --spec "$spec" --out "$out"
fi
echo "demo: outputs in $out:"
ls -l "$out"
# the chain as a table: level, triangles, texels, switch distance, IoU at 64 px
python3 - "$out/report.json" <<'PY' || true
import json, sys
r = json.load(open(sys.argv[1]))
print("%-16s %9s %9s %10s %8s  %s" % ("level", "triangles", "texels", "switch (m)", "IoU@64", "file"))
for l in r["lods"]:
    a = [x["iou_mean"] for x in l.get("accuracy", []) if x["pixels"] == 64]
    d = l.get("switch_distance")
    print("%-16s %9d %9d %10s %8s  %s" % (l["name"], l["triangles"], l["texels"],
          "%.1f" % d if d else "-", "%.3f" % a[0] if a else "-", l.get("file", "")))
for w in r["input"].get("warnings", []):
    print("warning:", w)
PY
