#!/bin/sh
# deploy_unit.sh — issue 11, "one machine": `make install` (PREFIX, DESTDIR)
# installs what it should, the installed daemon runs with the installed default
# config, and deploy/sylvad.service passes `systemd-analyze verify` (when that
# command exists; otherwise the test ends with exit 77, a skip) with the hardening the
# issue asks for. Also checks that the config, the unit and the nginx example
# agree with each other (store path, upload limit).
set -u
: "${SYLVA_ROOT:=$(cd "$(dirname "$0")/../.." && pwd)}"
: "${BUILD:=build}"
case "$BUILD" in /*) B=$BUILD ;; *) B=$SYLVA_ROOT/$BUILD ;; esac
for x in sylvad sylva sylva-bake; do
    [ -x "$B/$x" ] || { echo "skipped: $B/$x not built"; exit 77; }
done
T=$(mktemp -d /tmp/sylva-deploy-unit.XXXXXX)
DPID=""
cleanup() {
    [ -n "$DPID" ] && kill -9 "$DPID" 2>/dev/null
    [ -n "${KEEP_T:-}" ] || rm -rf "$T"
}
trap cleanup EXIT
fails=0
ok() { echo "ok   - $1"; }
bad() { echo "FAIL - $1"; fails=$((fails + 1)); }
check() { if [ "$2" = "$3" ]; then ok "$1"; else bad "$1 (want '$2', got '$3')"; fi; }
has() { # has DESCRIPTION FILE PATTERN (grep -E, whole line)
    if grep -q -x -E "$3" "$2" 2>/dev/null; then ok "$1"; else bad "$1 (no line /$3/ in $2)"; fi
}
inst() { # inst DESTDIR PREFIX: make install, quiet unless it fails
    make -s -C "$SYLVA_ROOT" BUILD="$BUILD" install DESTDIR="$1" PREFIX="$2" > "$T/make.log" 2>&1 ||
        { cat "$T/make.log"; return 1; }
}

# ---- make install, PREFIX=/usr/local
R=$T/root
inst "$R" /usr/local
check "make install DESTDIR=... PREFIX=/usr/local succeeds" 0 $?
P=$R/usr/local
for x in sylvad sylva sylva-bake; do
    [ -x "$P/bin/$x" ] && cmp -s "$P/bin/$x" "$B/$x" && ok "bin/$x installed" || bad "bin/$x missing or not the built one"
    m=$P/share/man/man1/$x.1
    # written by hand (deploy/man/); doc_examples.sh checks that each one
    # describes every option of its program's --help
    up=$(printf '%s' "$x" | tr '[:lower:]' '[:upper:]')
    if [ -s "$m" ] && grep -q "^\.TH $up 1 " "$m" && ! grep -q '@[A-Z]*@' "$m"; then
        ok "man page $x.1 installed, paths filled in"
    else
        bad "man page $x.1 missing, or a @PLACEHOLDER@ left"
    fi
    if command -v man >/dev/null && [ -s "$m" ]; then
        man -l "$m" 2>/dev/null | grep -q "^NAME" && ok "man renders $x.1" || bad "man cannot render $x.1"
    fi
done
cmp -s "$P/etc/sylva/sylvad.conf" "$SYLVA_ROOT/deploy/sylvad.conf" && ok "default config in PREFIX/etc/sylva/" \
    || bad "PREFIX/etc/sylva/sylvad.conf missing or different"
for d in operations.md api.md client.md spec.md deploy.md nginx/sylva.conf nginx/sylva-nodes.conf; do
    [ -s "$P/share/doc/sylva/$d" ] || bad "share/doc/sylva/$d missing"
done
ok "guides and nginx example in share/doc/sylva/"
V=$P/share/sylva/viewer
[ -s "$V/index.html" ] && [ -s "$V/octahedral.frag.glsl" ] && [ -s "$V/three/three.module.js" ] &&
    [ -s "$V/three/addons/loaders/GLTFLoader.js" ] && [ ! -e "$V/.stamp" ] &&
    ok "viewer page, shaders and three.js in share/sylva/viewer/" || bad "viewer files missing from $V"
U=$P/lib/systemd/system/sylvad.service
has "unit starts the installed daemon with the installed config" "$U" \
    'ExecStart=/usr/local/bin/sylvad --config /usr/local/etc/sylva/sylvad.conf'
has "sysusers entry creates the sylva user" "$P/lib/sysusers.d/sylva.conf" 'u sylva .*'
[ -z "$(find "$R" -type f \( -name '*.o' -o -name '*.d' -o -name 'test_*' \))" ] && ok "no build debris installed" \
    || bad "build debris installed: $(find "$R" -type f \( -name '*.o' -o -name 'test_*' \) | head -3)"

# ---- a second install keeps an edited config
echo "# edited by the admin" >> "$P/etc/sylva/sylvad.conf"
inst "$R" /usr/local
grep -q "edited by the admin" "$P/etc/sylva/sylvad.conf" && cmp -s "$P/etc/sylva/sylvad.conf.new" \
    "$SYLVA_ROOT/deploy/sylvad.conf" && ok "reinstall keeps the edited config, new default as .new" \
    || bad "reinstall overwrote the config or wrote no sylvad.conf.new"

# ---- PREFIX=/usr: the config goes to /etc
R2=$T/root-usr
inst "$R2" /usr
[ -s "$R2/etc/sylva/sylvad.conf" ] && [ ! -e "$R2/usr/etc" ] && ok "PREFIX=/usr puts the config in /etc/sylva/" \
    || bad "PREFIX=/usr: config not in /etc/sylva/"
has "PREFIX=/usr unit paths" "$R2/usr/lib/systemd/system/sylvad.service" \
    'ExecStart=/usr/bin/sylvad --config /etc/sylva/sylvad.conf'

# ---- the installed daemon accepts the installed config (every key is known)
"$P/bin/sylvad" --config "$P/etc/sylva/sylvad.conf" --listen 127.0.0.1:0 --store "$T/store" \
    --port-file "$T/port" --workers 1 2> "$T/daemon.log" &
DPID=$!
k=0
while [ ! -s "$T/port" ] && [ $k -lt 100 ] && kill -0 "$DPID" 2>/dev/null; do sleep 0.1; k=$((k + 1)); done
if [ -s "$T/port" ]; then
    check "installed sylvad runs with the default config" '{"status":"ok"' \
        "$(curl -s "http://127.0.0.1:$(cat "$T/port")/v1/health" | cut -c1-14)"
    kill -TERM "$DPID"; wait "$DPID"; rc=$?; DPID=""
    check "installed sylvad drains and exits 0 on SIGTERM" 0 "$rc"
else
    bad "installed sylvad did not start with the default config: $(tail -n 3 "$T/daemon.log")"
fi

# ---- the unit: what the issue asks for, consistent with the config
S=$SYLVA_ROOT/deploy/sylvad.service
store=$(sed -n 's/^store[[:space:]]*=[[:space:]]*//p' "$SYLVA_ROOT/deploy/sylvad.conf")
has "unit: own user" "$S" 'User=sylva'
has "unit: NoNewPrivileges" "$S" 'NoNewPrivileges=yes'
has "unit: ProtectSystem=strict" "$S" 'ProtectSystem=strict'
has "unit: the store ($store) is the only writable path" "$S" "ReadWritePaths=$store"
check "unit: one ReadWritePaths line" 1 "$(grep -c '^ReadWritePaths=' "$S")"
has "unit: PrivateTmp" "$S" 'PrivateTmp=yes'
has "unit: a memory limit" "$S" 'MemoryMax=[0-9]+[KMGT]?'
has "unit: Restart=on-failure" "$S" 'Restart=on-failure'
grep -q '^MemoryDenyWriteExecute=yes' "$S" && bad "unit: MemoryDenyWriteExecute breaks llvmpipe's JIT in workers" \
    || ok "unit: no MemoryDenyWriteExecute (workers JIT with llvmpipe)"
up=$(sed -n 's/^max_upload_bytes[[:space:]]*=[[:space:]]*//p' "$SYLVA_ROOT/deploy/sylvad.conf" | tr 'A-Z' 'a-z')
has "nginx client_max_body_size = sylvad max_upload_bytes ($up)" "$SYLVA_ROOT/deploy/nginx/sylva.conf" \
    "[[:space:]]*client_max_body_size $up;"

if command -v systemd-analyze >/dev/null 2>&1; then
    # verify checks that ExecStart exists: point it at the DESTDIR copy.
    sed -e "s#/usr/local/bin/#$P/bin/#g" "$U" > "$T/sylvad.service"
    if systemd-analyze verify "$T/sylvad.service" > "$T/verify.log" 2>&1; then
        ok "systemd-analyze verify accepts the unit"
    else
        bad "systemd-analyze verify: $(cat "$T/verify.log")"
    fi
    if systemd-analyze security --offline=yes "$T/sylvad.service" > "$T/sec.log" 2>&1; then
        score=$(sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p' "$T/sec.log")
        echo "systemd-analyze security exposure: $score"
        [ -n "$score" ] && awk "BEGIN { exit !($score <= 2.0) }" && ok "security exposure $score <= 2.0" \
            || bad "security exposure '$score' > 2.0: $(grep '✗' "$T/sec.log" | head -5)"
    else
        partial="systemd-analyze security --offline not supported here"
    fi
else
    partial="systemd-analyze not available, the unit is not verified (Debian package systemd)"
fi

if [ "$fails" -ne 0 ]; then
    echo "$fails checks failed"
    exit 1
fi
# the rest passed, but part of the test could not run: a skip, not a pass
[ -z "${partial:-}" ] || { echo "skipped: $partial"; exit 77; }
exit 0
