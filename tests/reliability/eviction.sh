#!/bin/sh
# eviction.sh — the store under 120 % load (issue 12, "Faults"). Fake worker,
# a small store_max_bytes (--store-max-bytes). Policy (server/jobs.c,
# make_room): when an upload, or a finished result, would take the store over
# the limit, finished bakes are evicted least recently used first (a status
# GET, an artifact GET or a re-upload is a use); queued and running bakes are
# never evicted.
#  1. two jobs are started that hold their workers ("# mode=hold") for the
#     whole fill: one long-polled by its client meanwhile, one whose client
#     only comes back after it finished;
#  2. distinct small jobs are baked one after the other until the bytes baked
#     reach EVICT_FILL % (default 120) of the limit; after each one the files
#     of the store stay within the limit (plus the in-flight job's reservation
#     while it runs), sampled meanwhile too; one early key is used (GET of an
#     artifact) three quarters of the way and must survive;
#  3. evicted keys answer 404 and are rebaked on a new upload of the same
#     bytes; the most recently used keys are all still there;
#  4. the held jobs were never evicted; once released they complete, and
#     their results are served (to the long-polling client, and to the one
#     that comes back later: a fresh result is a use, not the LRU victim).
# EVICT_SHORT=1: the CI form (smaller store, fewer jobs). Ends with a
# `figures:` line; exits non-zero on any failure.
set -u
. "$(dirname "$0")/../integration/daemon_lib.inc"
ok() { echo "ok - $1"; }
bad() { echo "FAIL - $1"; fails=$((fails + 1)); }
command -v python3 > /dev/null || { echo "skipped: python3 missing"; exit 77; }
if [ "${EVICT_SHORT:-0}" = 1 ]; then
    LIMIT=${EVICT_LIMIT:-4194304} MESH_KB=${EVICT_MESH_KB:-200}
else
    LIMIT=${EVICT_LIMIT:-16777216} MESH_KB=${EVICT_MESH_KB:-256}
fi
FILL=${EVICT_FILL:-120}
. "$(dirname "$0")/lib.inc"
STOP_FILES="$T/stop $T/release $T/release2"   # the held jobs' workers end too
case "$B" in *asan*) TW=60 ;; *) TW=20 ;; esac

# bigmesh NAME MODE [EXTRA LINE]: an OBJ of about MESH_KB KiB, unique per NAME
bigmesh() {
    { printf '# mode=%s\n# %s\n' "$2" "$1"; [ -n "${3:-}" ] && printf '%s\n' "$3"
      printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n'
      head -c $((MESH_KB * 1024)) /dev/zero | tr '\0' 'x' | fold -w 79 | sed 's/^/# /'; } > "$T/$1"
    echo "$T/$1"
}
up() { # up FILE -> "STATUS KEY"
    s=$(curl -s -o "$T/up" -w '%{http_code}' --max-time 30 -F "spec=$SPEC;type=application/json" -F "mesh=@$1" "$URL/v1/bakes")
    echo "$s $(json_str key < "$T/up")"
}
code_of() { curl -s -o /dev/null -w '%{http_code}' "$@"; }
files_bytes() { find "$T/store/$1" -type f -printf '%s\n' 2> /dev/null | awk '{s += $1} END {print s + 0}'; }

start_daemon --workers 3 --store-max-bytes "$LIMIT"
pick_spec

# --- 1. the held jobs
# each result (a copy of its mesh) is 3 meshes: more than the room a fill
# leaves, so each completion must evict something
mk=$MESH_KB
MESH_KB=$((mk * 3))
held=$(bigmesh held.obj hold "# until=$T/release")
held2=$(bigmesh held2.obj hold "# until=$T/release2")
MESH_KB=$mk
r=$(up "$held"); hkey=${r#* }
check "held job accepted" 202 "${r%% *}"
r=$(up "$held2"); hkey2=${r#* }
check "second held job accepted" 202 "${r%% *}"
# a client long-polls it for the whole test (as `sylva bake` does), from now on
( while :; do
      curl -s --max-time 70 "$URL/v1/bakes/$hkey?wait=60" > "$T/held.poll"
      s=$(json_str state < "$T/held.poll")
      case "$s" in done|failed|cancelled|"") break ;; esac
  done
  curl -s -o "$T/held.glb" -w '%{http_code}' "$URL/v1/bakes/$hkey/artifacts/model.glb" > "$T/held.code" ) &
BG="$BG $!"
n=0
while [ "$(curl -s "$URL/v1/bakes/$hkey" | json_str state)" != running ] && [ $n -lt 100 ]; do sleep 0.1; n=$((n + 1)); done
[ $n -lt 100 ] && ok "held job runs" || bad "held job not running"
n=0
while [ "$(curl -s "$URL/v1/bakes/$hkey2" | json_str state)" != running ] && [ $n -lt 100 ]; do sleep 0.1; n=$((n + 1)); done
[ $n -lt 100 ] && ok "second held job runs (its client goes away)" || bad "second held job not running"

# store sampler: the files of jobs/ + tmp/, every 0.1 s
sampler() {
    while [ ! -e "$T/stop" ]; do
        echo $(( $(files_bytes jobs) + $(files_bytes tmp) ))
        sleep 0.1
    done >> "$T/samples"
}
: > "$T/samples"
sampler & BG="$BG $!"

# --- 2. the fill
job_bytes=0 baked=0 n=0 over=0 worst=0 keys="" touched="" tkey=""
target=$((LIMIT * FILL / 100))
while [ $baked -lt $target ] && [ $n -lt 500 ]; do
    n=$((n + 1))
    f=$(bigmesh "fill$n.obj" ok)
    r=$(up "$f"); k=${r#* }
    [ "${r%% *}" = 202 ] || { bad "fill $n: upload got $r"; break; }
    wait_state "$k" done $TW || { bad "fill $n: not done"; break; }
    keys="$keys $k"
    [ $job_bytes -gt 0 ] || job_bytes=$(files_bytes "jobs/$k")
    baked=$((baked + job_bytes))
    # quiescent: nothing in flight but the held job (its inputs are counted)
    used=$(files_bytes jobs)
    [ "$used" -gt "$worst" ] && worst=$used
    [ "$used" -le "$LIMIT" ] || { over=$((over + 1)); echo "# after fill $n: $used bytes in jobs/ > $LIMIT"; }
    # three quarters of the way: use the oldest key still stored (an
    # artifact GET; found on disk, not by a status GET, which is a use too)
    if [ -z "$touched" ] && [ $baked -ge $((target * 3 / 4)) ]; then
        tn=0
        for tkey in $keys; do tn=$((tn + 1)); [ -d "$T/store/jobs/$tkey" ] && break; done
        touched=$(code_of "$URL/v1/bakes/$tkey/artifacts/model.glb")
        echo "# at fill $n: GET of an artifact of fill $tn (the oldest left) -> $touched"
    fi
    [ -d "$T/store/jobs/$hkey" ] && [ -d "$T/store/jobs/$hkey2" ] || { bad "a held job's directory is gone during fill $n"; break; }
done
nfill=$n
echo "# $nfill jobs of $job_bytes bytes baked ($baked bytes, $((baked * 100 / LIMIT)) % of the $LIMIT limit)"
[ $baked -ge $target ] && ok "filled to ${FILL} % of the limit ($nfill jobs)" || bad "fill stopped at $baked of $target bytes"
check "store within the limit after every job" 0 "$over"
peak=$(sort -n "$T/samples" | tail -n 1)
# in flight during the fill: one upload being committed + one result in tmp/out
slack=$((2 * job_bytes + 65536))
[ "${peak:-0}" -le $((LIMIT + slack)) ] && ok "sampled peak ${peak} <= limit + in-flight ($((LIMIT + slack)))" ||
    bad "sampled peak $peak over the limit + in-flight $((LIMIT + slack))"
check "key used during the fill answered 200" 200 "$touched"

# --- 3. evicted keys, recent keys
present="" evicted="" n_present=0 n_evicted=0 pattern=""
for k in $keys; do
    c=$(code_of "$URL/v1/bakes/$k")
    case "$c" in
    200) present="$present $k"; n_present=$((n_present + 1)); pattern="${pattern}P" ;;
    404) evicted="$evicted $k"; n_evicted=$((n_evicted + 1)); pattern="${pattern}e" ;;
    *) bad "key $k: status $c" ;;
    esac
done
echo "# per fill job, oldest first (P present, e evicted): $pattern"
[ $n_evicted -gt 0 ] && ok "$n_evicted keys evicted" || bad "nothing evicted"
tstate=$(code_of "$URL/v1/bakes/$tkey")
check "the key used during the fill stays" 200 "$tstate"
# every key after the last evicted one stays (LRU = completion order, but fill 2)
last_e=$(echo "$pattern" | sed 's/P*$//' | wc -c)
tail_p=$(( ${#pattern} - last_e + 1 ))
held_bytes=$(( $(files_bytes "jobs/$hkey") + $(files_bytes "jobs/$hkey2") ))
want_present=$(( (LIMIT - held_bytes) / job_bytes - 2 )) # the used key and a margin
[ "$tail_p" -ge "$want_present" ] && ok "the $tail_p most recently used keys all stay (>= $want_present)" ||
    bad "only the $tail_p most recent keys stay, want >= $want_present"
grep -q '"event":"store_evicted"' "$T/daemon.log" && ok "evictions logged" || bad "no store_evicted log"
for k in $evicted; do
    c=$(code_of "$URL/v1/bakes/$k/artifacts/model.glb")
    [ "$c" = 404 ] || { bad "artifact of evicted key $k: $c"; break; }
done
[ $n_evicted -gt 0 ] && ok "artifacts of evicted keys are 404"
# re-upload of the first (evicted) key: new work, rebaked
first=$(echo $keys | awk '{print $1}')
r=$(up "$T/fill1.obj")
check "re-upload of an evicted key is new work" "202 $first" "$r"
wait_state "$first" done $TW && ok "evicted key rebaked" || bad "evicted key not rebaked"
curl -s -o "$T/fill1.got" "$URL/v1/bakes/$first/artifacts/model.glb"
cmp -s "$T/fill1.obj" "$T/fill1.got" && ok "rebaked result served" || bad "rebaked result differs"

# --- 4. the held jobs
grep '"event":"store_evicted"' "$T/daemon.log" | grep -q -e "$hkey" -e "$hkey2" && bad "a running job was evicted" ||
    ok "the running jobs were never evicted"
touch "$T/release"
n=0
while [ ! -s "$T/held.code" ] && [ $n -lt $((TW * 10)) ]; do sleep 0.1; n=$((n + 1)); done
check "long-poll of the held job ends done" done "$(json_str state < "$T/held.poll")"
check "held job's result served to its client" 200 "$(cat "$T/held.code" 2> /dev/null)"
cmp -s "$held" "$T/held.glb" && ok "held job's result is its bytes" || bad "held job's result differs"
check "held job still there" 200 "$(code_of "$URL/v1/bakes/$hkey")"
# the second one: released, and its client comes back once it finished
touch "$T/release2"
n=0
while ! grep '"event":"job_finished"' "$T/daemon.log" | grep -q "$hkey2" && [ $n -lt $((TW * 10)) ]; do sleep 0.1; n=$((n + 1)); done
grep '"event":"store_evicted"' "$T/daemon.log" | grep -q "$hkey2" && bad "the second held job was evicted as it finished" ||
    ok "the second held job was not evicted as it finished"
curl -s "$URL/v1/bakes/$hkey2" > "$T/held2.status"
check "second held job done when its client comes back" done "$(json_str state < "$T/held2.status")"
check "second held job's result served" 200 "$(curl -s -o "$T/held2.glb" -w '%{http_code}' "$URL/v1/bakes/$hkey2/artifacts/model.glb")"
cmp -s "$held2" "$T/held2.glb" && ok "second held job's result is its bytes" || bad "second held job's result differs"
touch "$T/stop"
for p in $BG; do wait "$p" 2> /dev/null; done
BG=""
final=$(files_bytes jobs)
[ "$final" -le "$LIMIT" ] && ok "store within the limit at the end ($final bytes)" || bad "store at $final > $LIMIT at the end"
metric=$(curl -s "$URL/v1/metrics" | sed -n 's/^sylva_store_bytes //p')
check "tmp/ empty" "" "$(ls -A "$T/store/tmp" | tr '\n' ' ')"
du_k=$(du -sk "$T/store" | cut -f1)
stop_daemon
echo "figures: limit=$LIMIT job_bytes=$job_bytes jobs=$nfill baked_pct=$((baked * 100 / LIMIT)) evicted=$n_evicted present=$n_present peak_bytes=$peak worst_quiescent_bytes=$worst final_bytes=$final store_metric=${metric:-?} du_kib=$du_k total_s=$(( $(date +%s) - t_start ))"
finish
