#!/bin/sh
# daemon_store_quota.sh — issue 22 item 5: store_max_bytes holds while uploads
# stream. Three concurrent 4 MiB uploads into a 10 MiB store: each upload
# reserves the bytes it has written as they stream (never its declared length:
# daemon_reservations.sh), and the one that finds the store full gives its
# room back in the same step, so two are taken and the third gets 507
# with a message that says how the store is used (before the fix all three
# were written, 12 MiB in a 10 MiB store, and the 507 that came later said
# "full of jobs that are not finished" of an empty store).
# sylva-test: cost=5
. "$(dirname "$0")/daemon_lib.inc"
start_daemon --workers 1 --store-max-bytes 10M --drain-timeout 1
for i in 1 2 3; do
    { printf '# mode=sleep\n# %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' "$i"
      head -c 4194304 /dev/zero | tr '\0' '#' | fold -w 1023; printf '\n'; } > "$T/big$i.obj"
done
pids=""
for i in 1 2 3; do
    curl -s -o "$T/b$i" -w '%{http_code}' --limit-rate 8M -F "spec=$SPEC" -F "mesh=@$T/big$i.obj" \
        "$URL/v1/bakes" > "$T/s$i" &
    pids="$pids $!"
done
for p in $pids; do wait "$p"; done
codes=$(cat "$T/s1" "$T/s2" "$T/s3" | tr -d '\n' | fold -w3 | sort | tr '\n' ' ')
check "two of three 4 MiB uploads fit a 10 MiB store, the third is 507" "202 202 507 " "$codes"
for i in 1 2 3; do
    [ "$(cat "$T/s$i")" = 507 ] && contains "  the 507 says how the store is used" \
        "store_max_bytes is 10485760" "$(cat "$T/b$i")"
done
used=$(du -sb "$T/store/jobs" | cut -f1)
[ "$used" -le 10485760 ] && ok "the store holds $used bytes, within 10 MiB" ||
    bad "the store holds $used bytes, over 10 MiB"
check "no upload left in tmp/" "" "$(ls -A "$T/store/tmp" | grep "^up-")"
finish
