#!/bin/sh
# shader_cache.sh — issue 20: sandboxed bakes load llvmpipe's JIT code from a
# read-only cache the daemon warms at start (worker_shader_cache; core/cli/
# warm_shaders.h, docs/operations.md) instead of compiling it in every job:
#  1. `sylva-bake warm-shaders DIR` prints a Fossilize DB under DIR;
#  2. a sandboxed bake given that DB compiles nothing (its own writable cache
#     stays an empty DB), while the same bake given a DB that does not exist
#     compiles and writes its shaders there (so the first check can fail);
#  3. the outputs are byte-identical with the cache and without it (report.json
#     but for its "times");
#  4. sylvad warms one at start (shader_cache_ready), makes it read-only
#     (files 0444, folders 0555), gives it to jobs, deletes each job's
#     writable folder after the job and the warmed one at its stop.
# sylva-test: no-sanitize (llvmpipe's own cache and byte identity: Mesa's code, not ours; warm-shaders runs under ASan at every real-worker daemon start) cost=25
. "$(dirname "$0")/daemon_lib.inc"
BAKE=$B/sylva-bake
[ -x "$BAKE" ] || { echo "skipped: $BAKE not built"; exit 77; }
command -v python3 > /dev/null || { echo "skipped: python3 missing"; exit 77; }
case "$B" in *asan*) WAIT=600 ;; *) WAIT=120 ;; esac

python3 "$SYLVA_ROOT/tests/tools/synth_tree.py" "$T/tree.obj" 40 4242
CHEAP='{"method":"crossed_quads","lod":{"chain":false},"bake":{"max_atlas":256},"evaluate":{"views":4,"sizes":[64]}}'
printf '%s\n' "$CHEAP" > "$T/spec.json"
# foz_bytes DIR: the size of the single-file DB Mesa wrote under DIR (0: none)
foz_bytes() {
    f=$(find "$1" -name foz_cache.foz 2>/dev/null | head -n 1)
    [ -n "$f" ] && wc -c < "$f" | tr -d ' ' || echo 0
}
strip='/"times":[[:space:]]*{[^}]*$/,/}/d; s/"times":[[:space:]]*{[^}]*}//'
same_outputs() { # same_outputs DIR_A DIR_B: every file equal, report.json but for times
    r=0
    for f in $(cd "$1" && ls); do
        if [ "$f" = report.json ]; then
            [ "$(sed "$strip" "$1/$f")" = "$(sed "$strip" "$2/$f")" ] || { echo "differs: $f"; r=1; }
        else
            cmp -s "$1/$f" "$2/$f" || { echo "differs: $f"; r=1; }
        fi
    done
    [ "$(cd "$1" && ls)" = "$(cd "$2" && ls)" ] || { echo "not the same files"; r=1; }
    return $r
}

# --- 1. the warm-up
db=$("$BAKE" warm-shaders "$T/warm" 2> "$T/warm.err")
check "warm-shaders exits 0" 0 $?
case "$db" in "$T"/warm/*foz_cache) ok "it prints the DB under DIR ($db)" ;;
    *) bad "warm-shaders printed '$db' ($(cat "$T/warm.err"))" ;; esac
[ -s "$db.foz" ] && [ -s "${db}_idx.foz" ] && ok "  the DB and its index hold entries ($(wc -c < "$db.foz") bytes)" ||
    bad "  no DB files at $db"

# --- 2. a bake with the DB compiles nothing; without it, it compiles
mkdir "$T/job1" "$T/job2"
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/spec.json" --out "$T/with" --quiet --sandbox \
    --shader-cache "$db" --shader-cache-dir "$T/job1"
check "the sandboxed bake with the cache exits 0" 0 $?
n1=$(foz_bytes "$T/job1")
[ "$n1" -gt 0 ] && [ "$n1" -le 64 ] && ok "  it compiled nothing (its own DB: $n1 bytes, the header)" ||
    bad "  its own DB holds $n1 bytes: shaders were compiled, the warmed DB was not read"
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/spec.json" --out "$T/miss" --quiet --sandbox \
    --shader-cache "$T/no/such/db" --shader-cache-dir "$T/job2"
check "the bake with a DB that does not exist exits 0" 0 $?
n2=$(foz_bytes "$T/job2")
[ "$n2" -gt 1000 ] && ok "  it compiled its shaders into its own DB ($n2 bytes)" ||
    bad "  its own DB holds $n2 bytes: the check above cannot tell a hit from a miss"

# a DB the bake cannot use (a relative path): a warning, the cache off, the bake done
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/spec.json" --out "$T/rel" --progress none \
    --sandbox --shader-cache relative/db --shader-cache-dir "$T/job2" 2> "$T/rel.err"
check "a bake given a relative DB exits 0" 0 $?
contains "  and warns that the cache is off" "the shader cache is off" "$(cat "$T/rel.err")"

# --- 3. same outputs with the cache, without it, and with the cache off
"$BAKE" bake "$T/tree.obj" "$T/tree.mtl" --spec "$T/spec.json" --out "$T/off" --quiet --sandbox
check "the sandboxed bake with the cache off exits 0" 0 $?
same_outputs "$T/with" "$T/off" && ok "outputs with the cache = with the cache off" ||
    bad "outputs differ with the cache"
same_outputs "$T/miss" "$T/off" && ok "outputs after a miss = with the cache off" ||
    bad "outputs differ after a miss"

# --- 4. the daemon's cache
start_daemon --worker "$BAKE" --workers 1 --job-timeout "$WAIT"
i=0
while ! grep -q '"event":"shader_cache_\(ready\|unavailable\)"' "$T/daemon.log" && [ $i -lt 600 ]; do
    sleep 0.1; i=$((i + 1))
done
contains "sylvad warmed a shader cache" '"event":"shader_cache_ready"' "$(cat "$T/daemon.log")"
ddb=$(sed -n 's/.*"event":"shader_cache_ready".*"db":"\([^"]*\)".*/\1/p' "$T/daemon.log" | head -n 1)
case "$ddb" in "$T"/store/shaders/*foz_cache) ok "  under the store's shaders/" ;;
    *) bad "  the DB is at '$ddb'" ;; esac
check "  the DB is read-only" "444 444" "$(stat -c %a "$ddb.foz" "${ddb}_idx.foz" | tr '\n' ' ' | sed 's/ $//')"
check "  its folder too" 555 "$(stat -c %a "$(dirname "$ddb")")"
check "  and the store's folder of it" 555 "$(stat -c %a "$T/store/shaders")"
curl -s -o "$T/body" -w '%{http_code}' -F "spec=$CHEAP;type=application/json" \
    -F "mesh=@$T/tree.obj" -F "file=@$T/tree.mtl" "$URL/v1/bakes" > "$T/status"
check "the tree is accepted" 202 "$(cat "$T/status")"
k=$(json_str key < "$T/body")
wait_state "$k" done "$WAIT" && ok "the daemon's bake is done" || bad "the daemon's bake: $(curl -s "$URL/v1/bakes/$k")"
mkdir -p "$T/daemon"
curl -s "$URL/v1/bakes/$k" > "$T/daemon.status"
for f in $(python3 -c 'import json,sys; [print(a["name"]) for a in json.load(open(sys.argv[1]))["manifest"]["artifacts"]]' "$T/daemon.status"); do
    curl -s -o "$T/daemon/$f" "$URL/v1/bakes/$k/artifacts/$f"
done
same_outputs "$T/daemon" "$T/off" && ok "  its outputs = the offline bake's" || bad "  the daemon's outputs differ"
check "  its writable cache folder is gone" "" "$(ls -d "$T"/store/tmp/sc-* 2>/dev/null)"
stop_daemon
check "the warmed cache is removed at the daemon's stop" "" "$(ls -d "$T"/store/shaders 2>/dev/null)"

# --- a worker that cannot warm (the fake one): logged, and jobs run as before
start_daemon
i=0
while ! grep -q '"event":"shader_cache_unavailable"' "$T/daemon.log" && [ $i -lt 100 ]; do
    sleep 0.1; i=$((i + 1))
done
contains "a worker that cannot warm is logged" '"event":"shader_cache_unavailable"' "$(cat "$T/daemon.log")"
check "  and leaves no shaders/ folder" "" "$(ls -d "$T"/store/shaders 2>/dev/null)"
pick_spec
kf=$(post "$(mesh fake.obj ok)" | json_str key)
wait_state "$kf" done 30 && ok "  and its jobs run as before" || bad "  the fake worker's job: $(curl -s "$URL/v1/bakes/$kf")"
stop_daemon
finish
