#!/bin/sh
# Uploads hold store room for the bytes they have sent, not for what they
# declare (docs/reliability.md, "Third campaign"): clients that send only
# headers declaring the upload limit and then trickle cannot evict finished
# bakes or make other uploads 507; a client that closes in mid-body gives its
# room and its tmp/ folder back at once, not after the idle timeout; one
# client's uploads in progress hold at most client_upload_bytes; an upload
# lasts at most upload_timeout.
# sylva-test: cost=25
. "$(dirname "$0")/daemon_lib.inc"
PARTIAL="python3 $SYLVA_ROOT/tests/tools/partial_upload.py"
ups() { ls -A "$T/store/tmp" 2>/dev/null | grep -c "^up-"; }
# big NAME BYTES: an OBJ for the fake worker of about BYTES bytes
big() {
    { printf '# mode=ok\n# %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' "$1"
      head -c "$2" /dev/zero | tr '\0' '#' | fold -w 1023; printf '\n'; } > "$T/$1"
    echo "$T/$1"
}
start_daemon --workers 1 --store-max-bytes 2M --max-upload-bytes 2M
pick_spec
kept=$(post "$(mesh keep.obj ok)" | json_str key)
wait_state "$kept" done && ok "a finished bake" || bad "the first bake did not finish"

# -- the trickle: two uploads declare the whole store and send 200 bytes
$PARTIAL "$PORT" 2097152 200 hold 15 > "$T/t1" &
t1=$!
$PARTIAL "$PORT" 2097152 200 hold 15 > "$T/t2" &
t2=$!
i=0; while [ "$(cat "$T/t1" "$T/t2" | grep -c sent)" -lt 2 ] && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
check "two trickling uploads are in progress" 2 "$(ups)"
check "  the finished bake stays readable" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"
m=$(big other.obj 1000000)
body=$(post "$m")
check "  another 1 MB upload is accepted" 202 "$(cat "$T/status")"
check "  the finished bake is still readable after it" 200 \
    "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/bakes/$kept/artifacts/model.glb")"

# -- EOF in mid-body: room and folder given back at once
$PARTIAL "$PORT" 2097152 700000 close > /dev/null
sleep 1.5
check "a client that closed in mid-body leaves no upload folder (within 1.5 s)" 2 "$(ups)"
grep -q '"upload_ended_early".*closed before the end' "$T/daemon.log" &&
    ok "  logged upload_ended_early" || bad "  no upload_ended_early in the log"
kill "$t1" "$t2" 2>/dev/null; wait "$t1" "$t2" 2>/dev/null
stop_daemon

# -- one client's uploads in progress: at most client_upload_bytes together
start_daemon --workers 1 --store-max-bytes 8M --max-upload-bytes 4M --client-upload-bytes 512K
pick_spec
m=$(big over.obj 1000000)
body=$(post "$m")
check "an upload over client_upload_bytes is 507" 507 "$(cat "$T/status")"
contains "  naming client_upload_bytes" "client_upload_bytes is 524288" "$body"
check "  its folder is gone" 0 "$(ups)"
stop_daemon

# -- upload_timeout bounds a request however slowly its bytes come
start_daemon --workers 1 --upload-timeout 2
$PARTIAL "$PORT" 100000 200 hold 30 > "$T/t3" &
t3=$!
i=0; while ! grep -q sent "$T/t3" && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
check "a trickling upload is in progress" 1 "$(ups)"
i=0; while [ "$(ups)" != 0 ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
check "  it is ended after upload_timeout (2 s), not at the idle timeout (30 s)" 0 "$(ups)"
grep -q 'upload over upload_timeout' "$T/daemon.log" && ok "  logged" || bad "  not logged"
kill "$t3" 2>/dev/null; wait "$t3" 2>/dev/null
finish
