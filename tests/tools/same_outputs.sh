#!/bin/sh
# same_outputs.sh — do two builds of sylva-bake bake the same bytes? (a
# refactor must not change any output). Builds `sylva-bake` at two git
# revisions, bakes a fixed set of the shared trees with a fixed set of specs
# with each, and compares every output file by sha256. report.json is
# compared without its "times" object, the one part that differs between
# identical bakes (docs/outputs.md); the exit status of each bake and the
# list of files it wrote are compared too.
#
# Usage: tests/tools/same_outputs.sh [--all | --trees DIR,...] [--specs NAME,...] [--keep] [--jobs N] A B
#   A, B     git revisions (main, HEAD, a commit: committed sources only, built
#            from `git archive` into $SAME_OUTPUTS_DIR/bin/<commit>/ and kept
#            there, so a second run reuses the build), or the path of a
#            sylva-bake binary (e.g. build/sylva-bake for uncommitted work)
#   --all    every tree of tests/data/trees.tsv (default: four: the aspen and
#            the bonsai as OBJ, the oak and the ficus as GLB)
#   --trees DIR,...  only these trees of tests/data/trees.tsv (by folder name,
#            e.g. --trees eztree_aspen_small for a quick look)
#   --specs NAME,...  only these specs of the list below (by name, e.g.
#            --specs default,stochastic for a change to the chain's levels)
#   --keep   keep the bakes ($SAME_OUTPUTS_DIR/run-PID/; kept anyway when
#            something differs) for a look at a difference
#   --jobs N bakes at a time (default 2: A's and B's side by side)
# Prints one row per tree × spec and exits 0 when every row is identical,
# 1 on any difference, 2 on a usage or build error.
#
# Every spec is merged over a common base that keeps it affordable, the same
# for both sides: metres or centimetres from trees.tsv, atlases of at most
# 512 texels, 4 evaluation views at 64 and 32 px (docs/spec.md).
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
data=${SYLVA_DATA:-$root/../shared/data}
work=${SAME_OUTPUTS_DIR:-$root/build/same-outputs}
all=0 keep=0 jobs=2 only= only_specs=
while [ $# -gt 0 ]; do
    case "$1" in
    --all) all=1 ;;
    --keep) keep=1 ;;
    --trees) only=$2; all=1; shift ;;
    --jobs) jobs=$2; shift ;;
    --specs) only_specs=$2; shift ;;
    -h|--help) sed -n '2,29p' "$0"; exit 0 ;;
    -*) echo "same_outputs: unknown option $1" >&2; exit 2 ;;
    *) break ;;
    esac
    shift
done
[ $# -eq 2 ] || { echo "usage: $0 [--all | --trees DIR,...] [--specs NAME,...] [--keep] [--jobs N] A B" >&2; exit 2; }
case "$jobs" in ''|*[!0-9]*|0) echo "same_outputs: --jobs needs a positive number" >&2; exit 2 ;; esac

# The specs: NAME<TAB>JSON. Every method, the default chain, a target search
# (bisection over the leaf clusters' ladder, budget and IoU) and the maps of
# dynamic lighting (normal, AO, depth).
specs='default	{}
billboard_cloud	{"method": "billboard_cloud"}
leaf_clusters	{"method": "leaf_clusters"}
slicing	{"method": "slicing"}
stochastic	{"method": "stochastic"}
crossed_quads	{"method": "crossed_quads"}
octahedral	{"method": "octahedral", "octahedral": {"grid": 4}, "lod": {"chain": false}}
target	{"method": "leaf_clusters", "target": {"iou": 0.8, "max_planes": 24}}
dynamic	{"scene": {"lighting": "dynamic", "shadows": true, "ambient_occlusion": true}}'
if [ -n "$only_specs" ]; then
    specs=$(echo "$specs" | awk -F '\t' -v only=",$only_specs," 'index(only, "," $1 ",")')
    [ -n "$specs" ] || { echo "same_outputs: no spec named in --specs $only_specs" >&2; exit 2; }
fi
base='{"bake": {"max_atlas": 512}, "evaluate": {"views": 4, "sizes": [64, 32]}}'

# trees: "dir mesh units" lines
if [ "$all" = 1 ]; then
    trees=$(grep -v '^#' "$root/tests/data/trees.tsv" |
        awk -F '\t' -v only=",$only," 'only == ",," || index(only, "," $1 ",") {print $1, $2, $3}')
    [ -n "$trees" ] || { echo "same_outputs: no tree of trees.tsv in --trees $only" >&2; exit 2; }
else
    trees='eztree_aspen_small aspen_small.obj m
scopia_bonsai-tree bonsai-tree.obj cm
eztree_oak_large oak_large.glb m
scopia_ficusTree ficusTree.glb cm'
fi

# binary REV: prints the path of a sylva-bake for REV, building it if needed
binary() {
    if [ -f "$1" ] && [ -x "$1" ]; then
        (cd "$(dirname "$1")" && printf '%s/%s\n' "$(pwd)" "$(basename "$1")")
        return
    fi
    sha=$(git -C "$root" rev-parse --verify -q "$1^{commit}") ||
        { echo "same_outputs: $1 is neither a revision nor a binary" >&2; return 1; }
    d=$work/bin/$sha
    if [ ! -x "$d/build/sylva-bake" ]; then
        echo "building sylva-bake at $1 ($sha) in $d" >&2
        rm -rf "$d" && mkdir -p "$d"
        git -C "$root" archive "$sha" | tar -x -C "$d"
        make -s -C "$d" -j2 BUILD=build build/sylva-bake > "$d/build.log" 2>&1 ||
            { tail -n 20 "$d/build.log" >&2; echo "same_outputs: build of $1 failed" >&2; return 1; }
    fi
    printf '%s\n' "$d/build/sylva-bake"
}

# bake_all BIN LABEL: every tree × spec into $run/LABEL/<dir>-<mesh>/<spec>/
bake_all() {
    echo "$trees" | while read -r dir mesh units; do
        d=$data/$dir
        [ -f "$d/$mesh" ] || { echo "same_outputs: missing $d/$mesh" >&2; exit 1; }
        files="$d/$mesh"
        for f in "$d"/*.mtl "$d"/*.png "$d"/*.jpg "$d"/*.jpeg "$d"/*.bin; do
            [ -f "$f" ] && [ "$f" != "$d/$mesh" ] && files="$files $f"
        done
        echo "$specs" | while IFS='	' read -r name json; do
            o=$run/$2/$dir-$mesh/$name
            mkdir -p "$o"
            python3 -c 'import json,sys
def merge(a, b):
    for k, v in b.items():
        a[k] = merge(a.get(k, {}), v) if isinstance(v, dict) and isinstance(a.get(k), dict) else v
    return a
s = merge(json.loads(sys.argv[1]), {"import": {"units": sys.argv[2]}})
print(json.dumps(merge(s, json.loads(sys.argv[3]))))' "$base" "$units" "$json" > "$o.spec.json"
            rc=0
            # shellcheck disable=SC2086
            "$1" bake $files --spec "$o.spec.json" --out "$o" --progress none > "$o.log" 2>&1 || rc=$?
            echo "$rc" > "$o.rc"
        done
    done
}

# digest DIR: "file sha256" lines for every output (report.json without times)
digest() {
    (cd "$1" && for f in $(ls -A | LC_ALL=C sort); do
        if [ "$f" = report.json ]; then
            python3 -c 'import json,sys,hashlib
j = json.load(open(sys.argv[1])); j.pop("times", None)
print(hashlib.sha256(json.dumps(j).encode()).hexdigest())' "$f" | sed "s|^|$f |"
        else
            printf '%s %s\n' "$f" "$(sha256sum < "$f" | cut -d' ' -f1)"
        fi
    done)
}

bin_a=$(binary "$1") || exit 2
bin_b=$(binary "$2") || exit 2
run=$work/run-$$ # one per invocation: two comparisons may run side by side
rm -rf "$run" && mkdir -p "$run"
echo "A = $1 ($bin_a)"
echo "B = $2 ($bin_b)"
t0=$(date +%s)
if [ "$jobs" -ge 2 ]; then
    bake_all "$bin_a" A & pa=$!
    bake_all "$bin_b" B & pb=$!
    wait "$pa" && wait "$pb" || { echo "same_outputs: a bake loop failed" >&2; exit 2; }
else
    bake_all "$bin_a" A && bake_all "$bin_b" B || exit 2
fi

printf '%-38s %-16s %5s %5s  %s\n' tree spec exit files result
bad=0 rows=0
for t in $(cd "$run/A" && ls | LC_ALL=C sort); do
    echo "$specs" | while IFS='	' read -r name json; do
        a=$run/A/$t/$name b=$run/B/$t/$name
        ra=$(cat "$a.rc") rb=$(cat "$b.rc")
        digest "$a" > "$a.sha" && digest "$b" > "$b.sha"
        n=$(wc -l < "$a.sha")
        if [ "$ra" != "$rb" ]; then
            res="DIFFERENT exit status ($ra vs $rb)"
        elif ! cmp -s "$a.sha" "$b.sha"; then
            res="DIFFERENT: $(diff "$a.sha" "$b.sha" | sed -n 's/^[<>] \([^ ]*\) .*/\1/p' | sort -u | tr '\n' ' ')"
        else
            res=identical
        fi
        printf '%-38s %-16s %5s %5s  %s\n' "$t" "$name" "$ra" "$n" "$res"
    done
done | tee "$run/table.txt"
rows=$(wc -l < "$run/table.txt")
bad=$(grep -c DIFFERENT "$run/table.txt" || true)
echo "$rows bakes per side in $(( $(date +%s) - t0 )) s: $((rows - bad)) identical, $bad different"
if [ "$keep" = 1 ] || [ "$bad" -gt 0 ]; then echo "bakes kept in $run"; else rm -rf "$run"; fi
[ "$bad" -eq 0 ]
