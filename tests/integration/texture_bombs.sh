#!/bin/sh
# Texture decompression bombs (docs/reliability.md, "Third campaign"): small
# files of huge images within the per-side limit (a PNG of 16384² zeros, an
# RLE TGA of 16384²) are refused by the worker before their pixels are
# decoded (the per-texture decode budget, 1 GiB by default), through the CLI
# and through sylvad with the real worker: the bake fails with `limit` naming
# the texture and the budget, quickly, and the daemon goes on.
# sylva-test: cost=15
. "$(dirname "$0")/daemon_lib.inc"
WORKER=$B/sylva-bake
[ -x "$WORKER" ] || { echo "skipped: $WORKER not built"; exit 77; }
python3 - "$T" <<'PY'
import struct, sys, zlib
d = sys.argv[1]
w = h = 16384
# PNG, 8-bit RGB, every row filter 0 and zeros: about 800 KB
def chunk(t, b):
    return struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(t + b) & 0xFFFFFFFF)
c = zlib.compressobj(9)
row = b"\0" * (1 + 3 * w)
z = b"".join(c.compress(row) for _ in range(h)) + c.flush()
with open(d + "/bomb.png", "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", z) + chunk(b"IEND", b""))
# TGA, RLE true colour 32-bit: packets of 128 equal pixels
hdr = struct.pack("<BBBHHBHHHHBB", 0, 0, 10, 0, 0, 0, 0, 0, w, h, 32, 8)
with open(d + "/bomb.tga", "wb") as f:
    f.write(hdr + (b"\xff" + b"\x10\x80\x10\xff") * (w * h // 128))
PY
for ext in png tga; do
    printf 'newmtl leafy\nmap_Kd bomb.%s\n' "$ext" > "$T/t$ext.mtl"
    printf 'mtllib t%s.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl leafy\nf 1/1 2/2 3/3\n' \
        "$ext" > "$T/t$ext.obj"
done

# -- the CLI
for ext in png tga; do
    s=$(date +%s)
    out=$("$WORKER" info "$T/t$ext.obj" "$T/t$ext.mtl" "$T/bomb.$ext" 2>&1)
    rc=$?
    check "sylva-bake info with a 16384² $ext bomb: exit 1" 1 "$rc"
    contains "  naming the texture budget" "budget of a texture" "$out"
    [ $(( $(date +%s) - s )) -le 30 ] && ok "  within 30 s (decoding it took 43-115 s)" || bad "  took $(( $(date +%s) - s )) s"
done

# -- through sylvad and its real worker
start_daemon --worker "$WORKER" --workers 1 --job-timeout 60 --max-upload-bytes 16M
for ext in png tga; do
    key=$(curl -s -F 'spec={}' -F "mesh=@$T/t$ext.obj" -F "file=@$T/t$ext.mtl" \
        -F "file=@$T/bomb.$ext" "$URL/v1/bakes" | json_str key)
    check "a bake with a $ext bomb is accepted" 64 "${#key}"
    wait_state "$key" failed 60 && ok "  and fails" || bad "  did not fail"
    st=$(curl -s "$URL/v1/bakes/$key")
    contains "  with code limit" '"code":"limit"' "$st"
    contains "  naming the budget" "budget of a texture" "$st"
    contains "  on the first attempt (not a crash retried)" '"attempts":1' "$st"
done
check "the daemon is healthy after them" 200 "$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/health")"
finish
