#!/bin/sh
# boundary.sh — the method boundary the build enforces (docs/design.md,
# "Source layout" and "Adding a method"):
#   1. sylvad links no method's build half, nothing of render/ or pipeline/,
#      no libmeshoptimizer and no GL (nm, ldd): it links the methods' schema
#      halves only (method.h) to check specs;
#   2. a method file that includes a pipeline, spec or io header does not
#      compile (the folder's -I flags, Makefile);
#   3. a toy method (tests/boundary/toy/: a single vertical quad) added as a
#      folder of a copy of the tree plus one line of core/methods/registry.h
#      builds and bakes. The copy reuses this build's objects (timestamps
#      kept), so make compiles only the registry, the toy and the probes.
# sylva-test: cost=8
# sylva-test: no-sanitize (nm, ldd and include paths: a property of the build, not of C paths; the toy's run is the quad path every method takes, under ASan in the method tests)
set -eu
. "$(dirname "$0")/lib.inc"
fails=0
[ -x "$build/sylvad" ] || fail "no $build/sylvad"
T=${TMPDIR:-/tmp}/boundary.$$
mkdir -p "$T"
trap 'rm -rf "$T"' EXIT INT TERM

# 1. what sylvad links
libs=$(ldd "$build/sylvad" | grep -Ei 'meshoptimizer|libGL|OSMesa|assimp|OpenImageIO' || true)
check "sylvad links no meshoptimizer, GL, OSMesa, assimp or OpenImageIO" "" "$libs"
nm --defined-only "$build/sylvad" | awk '{print $3}' | sort -u > "$T/sylvad.syms"
# every global symbol the build halves of core define: method objects but
# their *_settings.o, the registries' build half, render/ and pipeline/
objs=$(find "$build/core/methods" "$build/core/render" "$build/core/pipeline" -name '*.o' \
    ! -name '*_settings.o' ! -name methods.o ! -name method_settings.o)
[ -n "$objs" ] || fail "no objects under $build/core"
nm --defined-only -g $objs | awk 'NF == 3 {print $3}' | sort -u > "$T/build.syms"
[ -s "$T/build.syms" ] || fail "nm found no symbol in the build halves"
linked=$(comm -12 "$T/sylvad.syms" "$T/build.syms" | head -n 5 | tr '\n' ' ')
check "sylvad has no symbol of a method's build half, render/ or pipeline/" "" "$linked"
# the check can fail: sylva-bake links them
nm --defined-only "$build/sylva-bake" | awk '{print $3}' | sort -u > "$T/bake.syms"
[ "$(comm -12 "$T/bake.syms" "$T/build.syms" | wc -l)" -gt 100 ] ||
    bad "sylva-bake has few symbols of the build halves: the check sees nothing"
for s in sv_method_find sv_spec_parse; do
    grep -qx "$s" "$T/sylvad.syms" || bad "sylvad lacks $s (the schema half it needs)"
done

# 2 and 3 in a copy of the tree with this build's objects
W="$T/tree"
mkdir -p "$W/build" "$W/client"
(cd "$root" && cp -a Makefile core common deploy "$W/") || fail "copying the tree"
cp -a "$root/client/sylva.h" "$W/client/"
for f in core pic .deps-ok libsvcore.a libsvimage.so sylva-bake; do
    [ -e "$build/$f" ] || fail "no $build/$f"
    cp -a "$build/$f" "$W/build/"
done
wmake() { (cd "$W" && make -s BUILD=build "$@") > "$T/make.log" 2>&1; }

mkdir -p "$W/core/methods/toy"
for h in pipeline.h spec.h import.h gltf.h image_io.h; do
    printf '#include "method_ops.h"\n#include "%s"\nint toy_probe;\n' "$h" > "$W/core/methods/toy/probe.c"
    if wmake build/core/methods/toy/probe.o; then
        bad "a method file including $h compiled"
    elif grep -q "$h: No such file" "$T/make.log"; then ok "a method file including $h does not compile"
    else bad "a method file including $h failed for another reason: $(head -c 300 "$T/make.log")"; fi
done
# the probe's own flags are a method's: the same file without the header compiles
printf '#include "method_ops.h"\n#include "level.h"\nint toy_probe;\n' > "$W/core/methods/toy/probe.c"
wmake build/core/methods/toy/probe.o || bad "a method file including method_ops.h and level.h: $(head -c 300 "$T/make.log")"
rm -f "$W/core/methods/toy/probe.c" "$W/build/core/methods/toy/probe.o" "$W/build/core/methods/toy/probe.d"

cp "$root/tests/boundary/toy/toy.c" "$root/tests/boundary/toy/toy_settings.c" "$W/core/methods/toy/"
echo 'SV_METHOD(toy)' >> "$W/core/methods/registry.h"
wmake build/sylva-bake || fail "the tree with the toy method does not build: $(tail -c 600 "$T/make.log")"
# a small tree: a trunk box and two leaf cards
cat > "$T/toy.obj" <<'EOF'
v -0.05 0 -0.05
v 0.05 0 -0.05
v 0.05 0 0.05
v -0.05 0 0.05
v -0.05 1 -0.05
v 0.05 1 -0.05
v 0.05 1 0.05
v -0.05 1 0.05
v -0.5 0.8 0
v 0.5 0.8 0
v 0.5 1.4 0
v -0.5 1.4 0
v 0 0.8 -0.5
v 0 0.8 0.5
v 0 1.4 0.5
v 0 1.4 -0.5
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
f 9 10 11 12
f 13 14 15 16
EOF
echo '{"method": "toy", "lod": {"chain": false, "coarsest": "none"}, "evaluate": {"views": 4, "sizes": [64]}, "bake": {"max_atlas": 256}}' > "$T/spec.json"
if "$W/build/sylva-bake" bake "$T/toy.obj" --spec "$T/spec.json" --out "$T/out" > "$T/bake.log" 2>&1; then
    check "the toy bake's one level" "toy 1" "$(json_get "$T/out/report.json" "' '.join([j['lods'][0]['name'], str(len(j['lods']))])")"
    [ -s "$T/out/atlas_toy_albedo.png" ] && ok "the toy level's atlas" || bad "no atlas_toy_albedo.png"
else
    bad "the toy bake failed: $(tail -c 400 "$T/bake.log")"
fi
# the spec check knows it as well: an unknown key of its settings is refused by name
echo '{"method": "toy", "toy": {"planes": 2}}' > "$T/bad.json"
"$W/build/sylva-bake" check-spec "$T/bad.json" > "$T/check.log" 2>&1 && bad "toy.planes accepted"
grep -q "toy.planes" "$T/check.log" && ok "toy's settings check names toy.planes" ||
    bad "toy's settings error: $(head -c 200 "$T/check.log")"
[ "$fails" = 0 ] || exit 1
