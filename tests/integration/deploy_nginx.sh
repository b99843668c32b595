#!/bin/sh
# deploy_nginx.sh — issue 11, "many machines", on loopback: Debian's nginx with
# deploy/nginx/sylva.conf in front of three sylvad nodes (real sylva-bake
# workers, one per node), NT (20) distinct small trees baked through it with the
# `sylva` command.
#  1. every bake completes; each key is baked once, on one node; repeated
#     requests for a key reach that node; a second identical run bakes nothing.
#  2. NT more trees; a node holding unfinished bakes is killed (SIGKILL) in the
#     middle: every bake still completes with `sylva` exit 0 (its retries absorb
#     the failover), the dead node's unfinished keys are baked again on exactly
#     one survivor, keys on the survivors do not move.
# Skips (exit 77, "skipped: ...") only when nginx is missing and cannot be
# installed (deploy/apt-packages.txt lists nginx-light; `make deps`).
# sylva-test: no-sanitize (nginx configuration and three nodes; docs/testing.md) cost=60
set -u
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
SYLVAD=${SYLVAD:-$B/sylvad}
SYLVA=${SYLVA_CLI:-$B/sylva}
BAKE=${SYLVA_BAKE:-$B/sylva-bake}
for x in "$SYLVAD" "$SYLVA" "$BAKE"; do
    [ -x "$x" ] || { echo "skipped: $x not built"; exit 77; }
done
for c in curl python3; do
    command -v $c >/dev/null || { echo "skipped: $c missing"; exit 77; }
done
NGINX=$(command -v nginx || { [ -x /usr/sbin/nginx ] && echo /usr/sbin/nginx; })
if [ -z "$NGINX" ]; then
    # only where apt can run without a password prompt (root, or sudo -n)
    if [ "$(id -u)" = 0 ] || sudo -n true 2>/dev/null; then
        echo "nginx missing: trying deploy/install-deps.sh (nginx-light)"
        "$SYLVA_ROOT/deploy/install-deps.sh" < /dev/null || true
    fi
    NGINX=$(command -v nginx || { [ -x /usr/sbin/nginx ] && echo /usr/sbin/nginx; })
    [ -n "$NGINX" ] || { echo "skipped: nginx is not installed and could not be installed (apt)"; exit 77; }
fi

T=$(mktemp -d /tmp/sylva-deploy-nginx.XXXXXX)
NPIDS="" NGPID="" CLIPID=""
cleanup() {
    [ -n "$CLIPID" ] && kill -9 "$CLIPID" 2>/dev/null
    [ -n "$NGPID" ] && kill -TERM "$NGPID" 2>/dev/null
    for p in $NPIDS; do
        # the node's workers first (each its own process group), then the node
        for w in $(pgrep -P "$p" 2>/dev/null); do kill -9 "$w" 2>/dev/null; done
        kill -9 "$p" 2>/dev/null
    done
    wait 2>/dev/null
    [ -n "${KEEP_T:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fails=0
ok() { echo "ok   - $1"; }
bad() { echo "FAIL - $1"; fails=$((fails + 1)); }
check() { if [ "$2" = "$3" ]; then ok "$1"; else bad "$1 (want '$2', got '$3')"; fi; }
die() {
    echo "FAIL - $*"
    for i in 1 2 3; do echo "--- node $i log:"; tail -n 15 "$T/n$i/log" 2>/dev/null; done
    echo "--- nginx error log (upstream errors and warnings):"
    grep -v -e 'closed keepalive connection' -e '\[notice\]' "$T/nginx/error.log" 2>/dev/null | tail -n 20
    exit 1
}

# ---- 2 NT distinct small trees: a square trunk ("bark") and leaf quads ("leaf").
# NT = 20 per run (30 until stop 27: the same checks, 20 fewer process starts).
NT=${DEPLOY_TREES:-20}
python3 - "$T/trees" "$NT" <<'EOF'
import math, os, random, sys
out, n = sys.argv[1], int(sys.argv[2])
for t in range(2 * n):
    rnd = random.Random(7919 * (t + 1))
    d = os.path.join(out, "set%d" % (t // n + 1), "tree%02d" % t)
    os.makedirs(d)
    v, faces = [], []
    def quad(pts, mat):
        faces.append((mat, [len(v) + i + 1 for i in range(4)]))
        v.extend(pts)
    r, h = 0.08 + 0.04 * rnd.random(), 1.5 + rnd.random()
    c = [(-r, -r), (r, -r), (r, r), (-r, r)]
    for i in range(4):
        (x0, z0), (x1, z1) = c[i], c[(i + 1) % 4]
        quad([(x0, 0, z0), (x1, 0, z1), (x1, h, z1), (x0, h, z0)], "bark")
    for k in range(30 + t):
        cx, cy, cz = rnd.uniform(-1, 1), h + rnd.uniform(-0.5, 0.7), rnd.uniform(-1, 1)
        a, s = rnd.uniform(0, 2 * math.pi), 0.1 + 0.05 * rnd.random()
        ux, uz, tilt = math.cos(a) * s, math.sin(a) * s, rnd.uniform(-1, 1) * s
        quad([(cx - ux, cy - tilt, cz - uz), (cx + ux, cy - tilt, cz + uz),
              (cx + ux, cy + s, cz + uz), (cx - ux, cy + s, cz - uz)], "leaf")
    name = "tree%02d" % t
    with open(os.path.join(d, name + ".mtl"), "w") as m:
        m.write("newmtl bark\nKd 0.35 0.22 0.10\nnewmtl leaf\nKd 0.20 0.50 0.15\n")
    with open(os.path.join(d, name + ".obj"), "w") as o:
        o.write("# sylva deploy test tree %d\nmtllib %s.mtl\n" % (t, name))
        o.writelines("v %.5f %.5f %.5f\n" % p for p in v)
        cur = None
        for mat, idx in faces:
            if mat != cur:
                o.write("usemtl %s\n" % mat)
                cur = mat
            o.write("f %d %d %d %d\n" % tuple(idx))
EOF
last=$(printf 'tree%02d' $((2 * NT - 1)))
[ -f "$T/trees/set2/$last/$last.obj" ] || die "could not generate the trees"
# the cheapest real bake: the test is about placement and failover, not quality
printf '%s\n' '{"method":"crossed_quads","bake":{"max_atlas":64,"alpha_threshold":0.5},"evaluate":{"enabled":false},"lod":{"chain":false,"coarsest":"none"}}' > "$T/spec.json"

# ---- three nodes: port 0, the real port read back from --port-file.
NODES=""
for i in 1 2 3; do
    mkdir -p "$T/n$i"
    "$SYLVAD" --listen 127.0.0.1:0 --store "$T/n$i/store" --port-file "$T/n$i/port" \
        --worker "$BAKE" --workers 1 --log-level info --max-conns-per-ip 0 2>"$T/n$i/log" &
    echo $! > "$T/n$i/pid"
    NPIDS="$NPIDS $!"
done
for i in 1 2 3; do
    k=0
    while [ ! -s "$T/n$i/port" ] && [ $k -lt 100 ]; do sleep 0.1; k=$((k + 1)); done
    [ -s "$T/n$i/port" ] || die "node $i did not start"
    echo "127.0.0.1:$(cat "$T/n$i/port")" > "$T/n$i/addr"
    NODES="$NODES $(cat "$T/n$i/addr")"
done
echo "nodes:$NODES"

# ---- nginx: deploy/nginx/sylva.conf as shipped, but for the listen line and the
# node list path; pid, logs and temp files in $T (runs without root).
N=$T/nginx
mkdir -p "$N"
for a in $NODES; do echo "server $a max_fails=1 fail_timeout=10s;"; done > "$N/sylva-nodes.conf"
start_nginx() { # start_nginx PORT: 0 when nginx runs and answers
    sed -e "s#^\\([[:space:]]*\\)listen 8080;#\\1listen 127.0.0.1:$1;#" \
        -e "s#include /etc/nginx/sylva-nodes.conf;#include $N/sylva-nodes.conf;#" \
        "$SYLVA_ROOT/deploy/nginx/sylva.conf" > "$N/sylva.conf"
    [ "$(grep -c -e "listen 127.0.0.1:$1;" -e "include $N/sylva-nodes.conf;" "$N/sylva.conf")" = 2 ] ||
        die "deploy/nginx/sylva.conf no longer has 'listen 8080;' and 'include /etc/nginx/sylva-nodes.conf;'"
    {
        [ "$(id -u)" = 0 ] && echo "user root;"   # as root, workers would be 'nobody'
        cat <<EOF
daemon off;
worker_processes 1;
pid $N/nginx.pid;
error_log $N/error.log info;
events { worker_connections 512; }
http {
    log_format sylva '\$request_method \$uri \$status upstream=\$upstream_addr/\$upstream_status';
    access_log $N/access.log sylva;
    client_body_temp_path $N/body;
    proxy_temp_path $N/proxy;
    fastcgi_temp_path $N/fastcgi;
    uwsgi_temp_path $N/uwsgi;
    scgi_temp_path $N/scgi;
    include $N/sylva.conf;
}
EOF
    } > "$N/nginx.conf"
    "$NGINX" -t -q -p "$N" -c "$N/nginx.conf" -e "$N/error.log" >"$N/t.log" 2>&1 ||
        die "nginx -t refused the config: $(cat "$N/t.log")"
    "$NGINX" -p "$N" -c "$N/nginx.conf" -e "$N/error.log" 2>>"$N/error.log" &
    NGPID=$!
    k=0
    while [ $k -lt 50 ]; do
        curl -s -o /dev/null "http://127.0.0.1:$1/v1/health" && return 0
        kill -0 "$NGPID" 2>/dev/null || break
        sleep 0.1; k=$((k + 1))
    done
    kill -TERM "$NGPID" 2>/dev/null; wait "$NGPID" 2>/dev/null; NGPID=""
    return 1
}
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
started=""
for attempt in 1 2 3; do   # a free port can be taken before nginx binds it
    LBPORT=$(free_port)
    if start_nginx "$LBPORT"; then started=1; break; fi
done
[ -n "$started" ] || die "nginx did not start"
LB=http://127.0.0.1:$LBPORT
echo "balancer: $LB"

# ---- helpers
# accepted KEY: the nodes (1 2 3) whose log accepted KEY, one per acceptance
accepted() { for i in 1 2 3; do grep '"job_accepted"' "$T/n$i/log" | grep -c "$1" | sed "s/^/$i /"; done | awk '$2 > 0 { for (k = 0; k < $2; k++) printf "%s ", $1 }'; }
# node_of_addr ADDR: 1, 2 or 3
node_of_addr() { for i in 1 2 3; do [ "$(cat "$T/n$i/addr")" = "$1" ] && echo $i; done; }
# via_lb KEY: node number that answered GET /v1/bakes/KEY through nginx, and its status
via_lb() {
    curl -s -o /dev/null -D "$T/h" -w '%{http_code}' "$LB/v1/bakes/$1" > "$T/code"
    # "A, B" when nginx tried A first (a dead node, again after fail_timeout)
    a=$(tr -d '\r' < "$T/h" | sed -n 's/^[Xx]-[Ss]ylva-[Nn]ode: //p' | sed 's/.*[,:] \{1,\}//')
    echo "$(node_of_addr "$a") $(cat "$T/code")"
}
keys_of() { python3 -c 'import json,sys; [print(b["key"]) for b in json.load(open(sys.argv[1]))["bakes"]]' "$1"; }
all_done() { python3 -c '
import json, sys
j = json.load(open(sys.argv[1])); b = j["bakes"]
bad = [x["mesh"] for x in b if x.get("state") != "done" or not x.get("artifacts")]
print("%d %d %s" % (len(b), len(b) - len(bad), " ".join(bad)))' "$1"; }

# ---- 1. NT trees through the balancer
check "the balancer answers /v1/health" '{"status":"ok"' "$(curl -s "$LB/v1/health" | cut -c1-14)"
code=$(curl -s -o "$T/post" -w '%{http_code}' -F 'spec={};type=application/json' \
    -F "mesh=@$T/trees/set1/tree00/tree00.obj" "$LB/v1/bakes")
check "POST /v1/bakes is refused behind the balancer (no key to route by)" 405 "$code"
grep -q 'PUT /v1/bakes/{key}' "$T/post" && ok "the refusal says to use PUT" || bad "refusal body: $(cat "$T/post")"

t0=$(date +%s)
"$SYLVA" --server "$LB" --json bake "$T"/trees/set1/*/* --spec "$T/spec.json" --out "$T/out1" \
    > "$T/bake1.json" 2> "$T/bake1.err"
rc=$?
echo "first run: $(( $(date +%s) - t0 )) s"
check "sylva bake of $NT trees through nginx exits 0" 0 "$rc"
[ $rc = 0 ] || { cat "$T/bake1.err"; die "the first batch failed"; }
check "all $NT bakes are done with artifacts" "$NT $NT " "$(all_done "$T/bake1.json")"
keys_of "$T/bake1.json" > "$T/keys1"
check "$NT distinct keys" "$NT" "$(sort -u "$T/keys1" | wc -l | tr -d ' ')"
once=0 same=0 used=""
for k in $(cat "$T/keys1"); do
    n=$(accepted "$k")
    [ "$(echo $n | wc -w)" = 1 ] && once=$((once + 1))
    n=$(echo $n)
    echo "$k $n" >> "$T/owner1"
    used="$used $n"
    r1=$(via_lb "$k"); r2=$(via_lb "$k"); r3=$(via_lb "$k")
    [ "$r1" = "$n 200" ] && [ "$r2" = "$r1" ] && [ "$r3" = "$r1" ] && same=$((same + 1))
done
check "each key was accepted (baked) by exactly one node" "$NT" "$once"
check "repeated requests for a key reach the node that baked it" "$NT" "$same"
spread=$(echo $used | tr ' ' '\n' | sort -u | wc -l | tr -d ' ')
check "the keys are spread over the three nodes" 3 "$spread"
done_total=0
for i in 1 2 3; do
    d=$(curl -s "http://$(cat "$T/n$i/addr")/v1/metrics" | sed -n 's/^sylva_jobs_finished_total{state="done"} //p')
    done_total=$((done_total + ${d:-0}))
done
check "the nodes' metrics count $NT finished bakes in all" "$NT" "$done_total"
"$SYLVA" --server "$LB" --json bake "$T"/trees/set1/*/* --spec "$T/spec.json" --out "$T/out1b" \
    > "$T/bake1b.json" 2> "$T/bake1b.err"
check "a second identical run exits 0" 0 "$?"
check "... and is served from the nodes' stores (no new bake)" "$NT" \
    "$(cat "$T"/n*/log | grep -c '"job_accepted"')"

# ---- 2. NT more trees; kill a node holding unfinished bakes in the middle
t0=$(date +%s)
"$SYLVA" --server "$LB" --json bake "$T"/trees/set2/*/* --spec "$T/spec.json" --out "$T/out2" \
    > "$T/bake2.json" 2> "$T/bake2.err" &
CLIPID=$!
k=0   # all NT uploads accepted (2 NT acceptances in all)
while [ "$(cat "$T"/n*/log | grep -c '"job_accepted"')" -lt $((2 * NT)) ] && [ $k -lt 600 ]; do
    sleep 0.1; k=$((k + 1))
done
victim="" best=0
for i in 1 2 3; do
    grep '"job_accepted"' "$T/n$i/log" | sed -n 's/.*"key":"\([0-9a-f]*\)".*/\1/p' | sort -u > "$T/acc$i"
    grep '"job_finished"' "$T/n$i/log" | sed -n 's/.*"key":"\([0-9a-f]*\)".*/\1/p' | sort -u > "$T/fin$i"
    comm -23 "$T/acc$i" "$T/fin$i" > "$T/open$i"
    c=$(wc -l < "$T/open$i" | tr -d ' ')
    [ "$c" -gt "$best" ] && { best=$c; victim=$i; }
done
[ -n "$victim" ] || die "no node had unfinished bakes to lose (all done before the kill)"
vpid=$(cat "$T/n$victim/pid")
workers=$(pgrep -P "$vpid")
kill -9 "$vpid"
for w in $workers; do kill -9 "$w" 2>/dev/null; done
wait "$vpid" 2>/dev/null
# unfinished at the moment of the kill (a bake may have finished meanwhile)
grep '"job_finished"' "$T/n$victim/log" | sed -n 's/.*"key":"\([0-9a-f]*\)".*/\1/p' | sort -u > "$T/fin$victim"
comm -23 "$T/acc$victim" "$T/fin$victim" > "$T/open$victim"
best=$(wc -l < "$T/open$victim" | tr -d ' ')
NPIDS=$(echo "$NPIDS" | tr ' ' '\n' | grep -v "^$vpid\$" | tr '\n' ' ')
echo "killed node $victim with $best unfinished bakes after $(( $(date +%s) - t0 )) s"
k=0
while kill -0 "$CLIPID" 2>/dev/null && [ $k -lt 1800 ]; do sleep 0.1; k=$((k + 1)); done
if kill -0 "$CLIPID" 2>/dev/null; then
    kill -9 "$CLIPID"; CLIPID=""
    die "the second batch did not finish within 180 s"
fi
wait "$CLIPID"
rc=$?
CLIPID=""
echo "second run: $(( $(date +%s) - t0 )) s"
check "sylva bake with a node killed in the middle exits 0 (no 5xx left after retries)" 0 "$rc"
[ $rc = 0 ] || cat "$T/bake2.err"
check "all $NT bakes of the second run are done with artifacts" "$NT $NT " "$(all_done "$T/bake2.json")"
echo "5xx answers nginx sent the client during the run (each retried): $(grep -c ' 5[0-9][0-9] upstream=' "$N/access.log")"
keys_of "$T/bake2.json" > "$T/keys2"
moved_ok=0 stayed=0 nmoved=0 nstay=0
for k in $(cat "$T/keys2"); do
    n=$(echo $(accepted "$k"))
    if grep -q "$k" "$T/open$victim"; then
        # lost with the node: baked again on exactly one survivor, which serves it now
        nmoved=$((nmoved + 1))
        set -- $n
        if [ $# != 2 ] || [ "$1" = "$2" ]; then continue; fi
        if [ "$1" = "$victim" ]; then new=$2; elif [ "$2" = "$victim" ]; then new=$1; else continue; fi
        [ "$(via_lb "$k")" = "$new 200" ] && moved_ok=$((moved_ok + 1))
    else
        case " $n " in *" $victim "*) continue ;; esac
        nstay=$((nstay + 1))
        [ "$(echo $n | wc -w)" = 1 ] && [ "$(via_lb "$k")" = "$n 200" ] && stayed=$((stayed + 1))
    fi
done
check "the dead node's unfinished keys were baked again, each on one survivor that serves it" \
    "$nmoved" "$moved_ok"
check "keys on the surviving nodes were baked once and did not move" "$nstay" "$stayed"
[ "$nmoved" -gt 0 ] && ok "$nmoved keys moved" || bad "no key moved"
stay1=0 n1=0
while read -r k n; do
    [ "$n" = "$victim" ] && continue
    n1=$((n1 + 1))
    [ "$(via_lb "$k")" = "$n 200" ] && stay1=$((stay1 + 1))
done < "$T/owner1"
check "first-run keys of the survivors are still served by the same node" "$n1" "$stay1"

for i in 1 2 3; do
    grep -q -E "AddressSanitizer|LeakSanitizer|runtime error:" "$T/n$i/log" && bad "sanitizer report in node $i's log"
done
if [ "$fails" -ne 0 ]; then
    echo "--- client stderr:"; tail -n 20 "$T/bake2.err"
    die "$fails checks failed"
fi
exit 0
