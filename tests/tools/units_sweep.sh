#!/bin/sh
# units_sweep.sh — the units check (docs/spec.md "Plausibility checks") on
# every tree of ../shared/data and, when tests/bench/heldout.py has cached
# them in BUILD/heldout (or HELDOUT), the held-out trees: with its right
# units each must warn nothing; read in metres (when that is wrong), and
# read 1000 times too large (its units x 1000, as a file scaled x1000), it
# must be implausible and name a unit within 2.5 times of the right one.
# Prints one line per case and a count; exit 1 on any miss. Not in `make
# test` (about 40 `sylva-bake info` runs); docs/testing.md has its last result.
# usage: tests/tools/units_sweep.sh [BUILD]
set -u
export PYTHONDONTWRITEBYTECODE=1 # heldout.py is imported: no __pycache__ in the checkout
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-${BUILD:-build}}
case "$build" in /*) ;; *) build=$root/$build ;; esac
data=${SYLVA_DATA:-$root/../shared/data}
held=${HELDOUT:-$build/heldout}
bake=$build/sylva-bake
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# the right units: trees.tsv's, but the ez-tree trees' (about 0.2 m a unit,
# ../shared/data/README.md) and the decorative plant's (1 m tall in cm; its
# README gives none) which trees.tsv reads in metres for the benchmarks
right() {
    case "$1" in
    eztree_*) echo 0.2 ;;
    blendswap_cc0_decorativePlant) echo '"cm"' ;;
    *) case "$2" in m) echo '"m"' ;; cm) echo '"cm"' ;; *) echo "$2" ;; esac ;;
    esac
}
mpu() { case "$1" in '"m"') echo 1 ;; '"cm"') echo 0.01 ;; '"mm"') echo 0.001 ;; *) echo "$1" ;; esac; }
n=0 miss=0
case_() { # case_ LABEL UNITS WANT(metres per unit, or "plausible") FILES...
    label=$1 u=$2 want=$3
    shift 3
    n=$((n + 1))
    echo "{\"import\":{\"units\":$u}}" >"$T/s.json"
    "$bake" info "$@" --spec "$T/s.json" --json >"$T/i.json" 2>/dev/null
    got=$(python3 -c '
import json, sys
d = json.load(open(sys.argv[1])); u = d["units_check"]; want = sys.argv[2]
if u["plausible"]:
    got = "plausible"
else:
    got = "%s (%g m a unit)" % (u.get("likely_units", "none"), u.get("likely_metres_per_unit", 0))
ok = got == "plausible" if want == "plausible" else (not u["plausible"] and
     u.get("likely_metres_per_unit", 0) > 0 and 1 / 2.5 <= u["likely_metres_per_unit"] / float(want) <= 2.5)
print(("ok  " if ok else "MISS") + " %-44s units %-6s -> %-26s H %.3g L %.3g D %.3g" % (
    sys.argv[3], sys.argv[4], got, u["height"], u["leaf_size"], u["trunk_diameter"]))' \
        "$T/i.json" "$want" "$label" "$u") || got="MISS $label: info failed"
    echo "$got"
    case "$got" in MISS*) miss=$((miss + 1)) ;; esac
}
trees() {
    grep -v '^#' "$root/tests/data/trees.tsv" | while IFS="$(printf '\t')" read -r dir mesh units _; do
        printf '%s\t%s\t%s\t%s\n' "$dir" "$data/$dir/$mesh" "$(right "$dir" "$units")" "$dir/$mesh"
    done
    if [ -d "$held" ]; then
        python3 - "$root" "$held" <<'PY'
import sys, os, json
sys.path.insert(0, os.path.join(sys.argv[1], "tests", "bench"))
import heldout
for name, files, units in heldout.generate(sys.argv[2]):
    u = json.dumps(units) if isinstance(units, str) else repr(units)
    print("heldout\t%s\t%s\theldout %s" % (" ".join(files), u, name))
PY
    fi
}
trees >"$T/list"
while IFS="$(printf '\t')" read -r dir files u label; do
    # shellcheck disable=SC2086
    case_ "$label" "$u" plausible $files
    m=$(mpu "$u")
    if [ "$u" != '"m"' ]; then
        # shellcheck disable=SC2086
        case_ "$label" '"m"' "$m" $files
    fi
    # shellcheck disable=SC2086
    case_ "$label" "$(python3 -c "print(repr($m * 1000))")" "$m" $files
done <"$T/list"
echo "units_sweep: $((n - miss)) of $n right"
[ "$miss" -eq 0 ]
