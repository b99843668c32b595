#!/bin/sh
# client_refetch.sh — failover between "done" and the download (docs/deploy.md):
# when a bake's artifacts answer 404 (the node that baked it is gone and the
# request reached another node), `sylva bake` submits the same inputs again,
# waits, downloads and exits 0 — for one bake and for a batch. A proxy
# (client_refetch_proxy.py) deletes each bake on the real daemon just before
# its first download, so the daemon's own 404 is what the client sees.
# Uses the real daemon with the fake worker (tests/integration/fake-worker).
. "$(dirname "$0")/daemon_lib.inc"
SYLVA=${SYLVA_CLI:-$B/sylva}
[ -x "$SYLVA" ] || { echo "skipped: $SYLVA not built"; exit 77; }
command -v python3 >/dev/null || { echo "skipped: python3 missing"; exit 77; }
start_daemon --workers 2
python3 "$SYLVA_ROOT/tests/integration/client_refetch_proxy.py" "$URL" "$T/pport" 2>"$T/proxy.log" &
PPID_=$!
i=0
while [ ! -s "$T/pport" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
[ -s "$T/pport" ] || { echo "proxy did not start"; cat "$T/proxy.log"; exit 1; }
PX=http://127.0.0.1:$(cat "$T/pport")
accepted() { grep '"job_accepted"' "$T/daemon.log" | grep -c "$1"; }

m=$(mesh one.obj ok)
"$SYLVA" --server "$PX" --progress none bake "$m" --out "$T/out1" > "$T/c1.out" 2> "$T/c1.err"
check "one bake whose artifacts vanished before the download still exits 0" 0 "$?"
key=$("$SYLVA" --json bake "$m" --out "$T/out1b" --server "$URL" 2>/dev/null | json_str key)
check "... the bake was submitted again (accepted twice)" 2 "$(accepted "$key")"
[ -s "$T/out1/model.glb" ] && ok "... and its artifacts were downloaded" || bad "no out1/model.glb: $(cat "$T/c1.err")"

mkdir -p "$T/a" "$T/b"
printf '# mode=ok\n# batch a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/a/ta.obj"
printf '# mode=ok\n# batch b\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' > "$T/b/tb.obj"
"$SYLVA" --server "$PX" --json bake "$T/a/ta.obj" "$T/b/tb.obj" --out "$T/out2" > "$T/c2.json" 2> "$T/c2.err"
check "a batch whose artifacts vanished before the download still exits 0" 0 "$?"
n=$(python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print(sum(b["state"]=="done" for b in j["bakes"]))' "$T/c2.json" 2>/dev/null)
check "... both bakes done" 2 "$n"
[ -s "$T/out2/ta/model.glb" ] && [ -s "$T/out2/tb/model.glb" ] && ok "... both downloaded" || bad "batch artifacts missing: $(cat "$T/c2.err")"
kill "$PPID_" 2>/dev/null; wait "$PPID_" 2>/dev/null
finish
