#!/bin/sh
# lod_chain.sh — the LOD chain of issue 6 on every tree in ../shared/data:
# full mesh → stochastic levels → the spec's method → crossed quads. Each bake
# must succeed, model.glb must validate (Khronos validator), and every standalone
# lod<i>_<name>.glb (on the trees over 25k triangles those of at most 25k) must
# validate and load in three.js (GLTFLoader: one node, the level's triangles,
# its atlas texture, the tree's height), the stochastic
# LODs must carry _LEAF_CENTRE/_LEAF_ORDER and their fade window, switch sizes
# must not increase along the chain, and report.json must say which λ terms
# were used and which LODs were skipped.
# The chain bakes come from the per-pass cache (lib.inc, tree_cache: leaf
# clusters seen from 2 to 100 bounding radii, so the whole chain is planned),
# shared with trees_all.sh. Exit 77 (skip) without the data.
# sylva-test: cost=140
set -eu
. "$(dirname "$0")/lib.inc"
[ -d "$data" ] || skip "no tree data at $data"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
v=$(ensure_validator) || skip "cannot install the glTF validator (npm)"

# glb_check FILE: the chain's structural promises, read from the GLB's JSON chunk
glb_check() {
    python3 - "$1" "$2" <<'EOF'
import json, struct, sys
b = open(sys.argv[1], 'rb').read()
n = struct.unpack_from('<I', b, 12)[0]
g = json.loads(b[20:20 + n])
rep = json.load(open(sys.argv[2]))
nodes = g['nodes']
names = [nd['name'] for nd in nodes]
lods = [l['name'] for l in rep['lods']]
# nodes follow the <asset>_LOD<i> convention; meshes keep the level's name
assert names == [l['node'] for l in rep['lods']], (names, rep['lods'])
assert all(nd['name'].endswith('_LOD%d' % i) for i, nd in enumerate(nodes)), names
assert [g['meshes'][nd['mesh']]['name'] for nd in nodes if 'mesh' in nd] == \
    [l['name'] for l, nd in zip(rep['lods'], nodes) if 'mesh' in nd], names
# one standalone file per level: its scene is that level's node alone
import os
for i, l in enumerate(rep['lods']):
    assert l['file'] == 'lod%d_%s.glb' % (i, l['name']), l['file']
    s = open(os.path.join(os.path.dirname(sys.argv[1]), l['file']), 'rb').read()
    sg = json.loads(s[20:20 + struct.unpack_from('<I', s, 12)[0]])
    assert len(sg['scenes']) == 1 and len(sg['nodes']) == 1, l['file']
    assert sg['nodes'][0]['name'] == l['node'] and 'MSFT_lod' not in sg.get('extensionsUsed', [])
stoch = [l for l in rep['lods'] if l['source'] == 'stochastic']
for l in stoch:
    nd = nodes[names.index(l['node'])]
    ex = nd['extras']['sylva_stochastic']
    lo, hi = ex['fade_window']
    # centred on the fraction of leaves drawn (>= λ: simplified leaves fit
    # more; leaves drawn whole instead of as slivers, or a copy of a coarser
    # level that scored higher, may draw fewer)
    assert 0 <= lo <= ex['leaf_fraction'] <= hi <= 1, ex
    assert ex['leaf_fraction'] >= ex['lambda'] or l.get('leaves_whole', 0) > 0 or \
        'copy_of_lambda' in l, (ex, l)
    prim = g['meshes'][nd['mesh']]['primitives'][0]
    assert '_LEAF_CENTRE' in prim['attributes'] and '_LEAF_ORDER' in prim['attributes'], prim
sw = [l['switch_pixels'] for l in rep['lods']]
assert all(sw[i] >= sw[i + 1] for i in range(len(sw) - 1)), sw
# atlases sized by where a level is drawn (issue 19 item 3): a quad level
# after the first, drawn at most S px tall, has no texel finer than half of
# the tree's height / (4 S), unless its atlas is already at 64x64 or less
h = rep['input']['bounds']['size'][1]
for l in rep['lods'][1:]:
    if l['texels'] > 64 * 64:
        assert 2 * l['texel_size'] * 4 * l['switch_pixels'] * 1.01 >= h, \
            (l['name'], l['texel_size'], l['switch_pixels'], h)
c = rep['lod_chain']
assert isinstance(c['skipped'], list)
if 'stochastic' in c:
    terms = {t['term']: t['status'] for t in c['stochastic']['lambda_terms']}
    assert terms['size'] == 'done'
    assert 0 < c['stochastic']['visible_ratio']['r'] <= 1
print(len(lods), 'LODs:', ' '.join('%s(%d)' % (l['name'], l['triangles']) for l in rep['lods']),
      '| skipped:', ' '.join(s['name'] for s in c['skipped']) or '-')
EOF
}

# three_check LOADED REPORT: each standalone level, as three.js's GLTFLoader
# loads it (three_load.mjs), is one node named as the report says, draws the
# level's triangles, has its atlas texture on a quad level and stands as
# tall as the tree (within 10 %)
three_check() {
    python3 - "$1" "$2" <<'EOF'
import json, os, sys
rep = json.load(open(sys.argv[2]))
got = {os.path.basename(j['file']): j for j in map(json.loads, open(sys.argv[1]))}
h = rep['input']['bounds']['size'][1]
for l in rep['lods']:
    if l['file'] not in got:  # a big tree's full-size copy, not loaded
        continue
    j = got[l['file']]
    assert j['nodes'] == [l['node']], (l['file'], j['nodes'])
    assert j['triangles'] == l['triangles'], (l['file'], j['triangles'], l['triangles'])
    assert l['texels'] == 0 or j['textured'] >= 1, (l['file'], 'no texture on a quad level')
    tall = j['box'][1][1] - j['box'][0][1]  # quads' corners may stand out
    assert 0.9 * h <= tall <= 1.6 * h, (l['file'], tall, h)
EOF
}

# under ASan only the aspen's cases below: the chain's C paths (stochastic
# levels, a quad method, crossed quads, a leafless tree's trunk levels) run
# there and in bake_cli; every tree's chain in the plain pass
case "$build" in
*asan*) : > "$tmp/trees" ;;
*) trees > "$tmp/trees" ;;
esac
while IFS="$(printf '\t')" read -r dir mesh units tris foliage _; do
    c=$(tree_cache "$dir" "$mesh" "$units") || fail "$mesh: no chain bake"
    # model.glb on every tree, and every standalone level (validator and
    # three.js) except, on the trees over 25k triangles, the copies of more
    # than 25k triangles (the full mesh and its stochastic levels: the same
    # writer path as the small trees' and minutes of CI time)
    levels=$(python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
print(' '.join(l['file'] for l in r['lods'] if int(sys.argv[2]) <= 25000 or l['triangles'] <= 25000))
" "$c/bake/report.json" "$tris")
    files=$(for f in $levels; do printf '%s ' "$c/bake/$f"; done)
    # shellcheck disable=SC2086
    node "$v" "$c/bake/model.glb" $files > /dev/null ||
        fail "$mesh: model.glb or a standalone level does not validate"
    # and three.js (which ignores MSFT_lod) builds each level's scene
    # shellcheck disable=SC2086
    node "$(dirname "$v")/three_load.mjs" $files > "$tmp/three.json" ||
        fail "$mesh: three.js cannot load a standalone level: $(grep error "$tmp/three.json")"
    three_check "$tmp/three.json" "$c/bake/report.json" ||
        fail "$mesh: a standalone level is not the level three.js draws"
    res=$(glb_check "$c/bake/model.glb" "$c/bake/report.json") || fail "$mesh: chain structure"
    # chosen by cost (docs/lod.md "Which level is drawn"): no level drawn
    # where one 10 times cheaper is within 0.02, none of over 5,000
    # triangles below 48 px, the original as LOD0
    python3 "$root/tests/tools/chain_check.py" "$c/bake/report.json" ||
        fail "$mesh: the chain draws a dearer level than its rules allow"
    echo "ok $mesh: $res (baked in $(cat "$c/bake_seconds") s)"
done < "$tmp/trees"

# One tree in detail: the motion term only with camera motion; chain off.
d="$data/eztree_aspen_small"
[ -f "$d/aspen_small.obj" ] || fail "missing $d/aspen_small.obj"
{
    # shellcheck disable=SC2046
    set -- "$d/aspen_small.obj" $(companions "$d" aspen_small.obj)
    # (under ASan only the chain off and the leafless tree: the moving and
    # far chains add no C path to the leafless tree's)
    asan=0
    case "$build" in *asan*) asan=1 ;; esac
    echo '{"method": "crossed_quads", "scene": {"camera_speed": 20},
           "evaluate": {"views": 4, "sizes": [64, 32]}}' > "$tmp/moving.json"
    [ $asan = 1 ] || "$bake" bake "$@" --spec "$tmp/moving.json" --out "$tmp/moving" || fail "moving bake"
    [ $asan = 1 ] || [ "$(json_get "$tmp/moving/report.json" "[t['status'] for t in j['lod_chain']['stochastic']['lambda_terms'] if t['term']=='motion'][0]")" = done ] ||
        fail "motion term not used with camera_speed > 0"
    echo '{"method": "crossed_quads", "lod": {"chain": false},
           "evaluate": {"views": 4, "sizes": [64, 32]}}' > "$tmp/nochain.json"
    "$bake" bake "$@" --spec "$tmp/nochain.json" --out "$tmp/nochain" || fail "chain:false bake"
    [ "$(json_get "$tmp/nochain/report.json" "[l['name'] for l in j['lods']]")" = "['crossed']" ] ||
        fail "lod.chain false still made a chain"
    "$bake" info "$@" --json > "$tmp/info.json" || fail "aspen info"
    rad=$(json_get "$tmp/info.json" "j['bounds']['radius']")
    # seen only from 60 to 100 radii (about 31 px down to 19 px), with a
    # tolerance the crossed quads meet: the original stays LOD0 (for a
    # camera nearer than the scene says) and the crossed quads are drawn
    # over the whole scene; nothing else is kept
    echo "{\"method\": \"crossed_quads\", \"lod\": {\"tolerance\": 0.5}, \"scene\": {\"distance\": [$(python3 -c "print(60*$rad, 100*$rad)" | tr ' ' ',')]},
           \"evaluate\": {\"views\": 4, \"sizes\": [64, 32]}}" > "$tmp/far.json"
    [ $asan = 1 ] || "$bake" bake "$@" --spec "$tmp/far.json" --out "$tmp/far" || fail "far bake"
    [ $asan = 1 ] || [ "$(json_get "$tmp/far/report.json" "[l['name'] for l in j['lods']]")" = "['full', 'crossed']" ] ||
        fail "a far scene: expected the original then the crossed quads, got $(json_get "$tmp/far/report.json" "[l['name'] for l in j['lods']]")"
    echo "ok aspen: motion term only with camera motion; chain off; far scene: original, then crossed quads"
    # a leafless tree (the aspen's bark alone, everything before its leaves
    # object): the original is LOD0 and at least one trunk simplified with
    # meshoptimizer comes before the quads
    mkdir -p "$tmp/bare"
    awk '/^o leaves/ { exit } { print }' "$d/aspen_small.obj" > "$tmp/bare/bare.obj"
    cp "$d/aspen_small.mtl" "$d"/*.jpg "$d"/*.png "$tmp/bare/"
    echo '{"import": {"units": 0.2}, "evaluate": {"views": 4, "sizes": [128, 64, 32]}}' > "$tmp/bare.json"
    "$bake" bake "$tmp/bare/bare.obj" "$tmp/bare/aspen_small.mtl" "$tmp/bare/"*.jpg "$tmp/bare/"*.png \
        --spec "$tmp/bare.json" --out "$tmp/bare/out" > "$tmp/bare.log" 2>&1 || fail "leafless bake: $(tail -n 3 "$tmp/bare.log")"
    json_get "$tmp/bare/out/report.json" "' '.join('%s(%d)' % (l['name'], l['triangles']) for l in j['lods'])"
    python3 - "$tmp/bare/out/report.json" <<'EOF' || fail "leafless tree: expected the original then a simplified trunk level before the quads"
import json, sys
lods = json.load(open(sys.argv[1]))['lods']
assert lods[0]['name'] == 'full' and lods[0]['triangles'] == 2496, lods[0]
first_quad = next(i for i, l in enumerate(lods) if l['quads'] > 0)
trunk = [l for l in lods[1:first_quad] if l['source'] == 'trunk' and 0 < l['triangles'] < 2496]
assert trunk, [l['name'] for l in lods]
EOF
    python3 "$root/tests/tools/chain_check.py" "$tmp/bare/out/report.json" || fail "leafless tree: chain rules"
    echo "ok aspen without leaves: the original, simplified trunk levels, then quads"
}
