#!/usr/bin/env bash
# Measures settings saves on the QEMU board: boots the QEMU firmware (x30-qemu) against
# x30-sim on loopback, changes a setting and types `save` on the console SAVES times, and
# prints the time of each kind of save the console reported ("saved KEY in N ms", with
# "(1 page erased)" when the store changed pages).
#
#   scripts/save-times.sh [SAVES [KEY]]
#
# KEY is `lights` (default: eight presets, a blob near its usual largest) or `repeat-ms`
# (one small change, the most items a page holds). 400 saves of `lights` or 3000 of
# `repeat-ms` fill a 32 KiB page at least once.
set -euo pipefail
cd "$(dirname "$0")/.."
saves=${1:-400}
key=${2:-lights}
case $key in
    lights | repeat-ms) ;;
    *) echo "usage: $0 [SAVES [lights|repeat-ms]]" >&2; exit 2 ;;
esac
source scripts/setup.sh
(cd tools && cargo build --release -q -p x30-sim -p x30-qemu)
bin=tools/target/x86_64-unknown-linux-gnu/release
work=$(mktemp -d)
trap 'kill "${sim:-}" 2>/dev/null || true; rm -rf "$work"' EXIT

# Port 0: the simulator picks a free loopback port and says which.
"$bin/x30-sim" --listen 127.0.0.1:0 >"$work/sim.out" 2>&1 &
sim=$!
addr=""
for _ in $(seq 100); do
    addr=$(sed -n 's/^x30-sim listening on //p' "$work/sim.out")
    [ -n "$addr" ] && break
    sleep 0.1
done
[ -n "$addr" ] || { echo "x30-sim did not start" >&2; cat "$work/sim.out" >&2; exit 1; }

{
    echo "wait led link on"
    for i in $(seq "$saves"); do
        # Two values that alternate, so that every save changes something.
        if [ "$key" = lights ]; then
            colour=$(printf '%06X' $((i % 2)))
            echo "console set lights $colour:10,00FF00:100,FFBF00:100,FF0000:100:breathing,0000FF:50,FFFFFF:100,00FFFF:20,FF00FF:30"
        else
            echo "console set repeat-ms $((200 + i % 2))"
        fi
        echo "console save"
        echo "wait console: saved $key in"
    done
} >"$work/session"

"$bin/x30-qemu" --robot "$addr" --settings "$work/settings.bin" --timeout-s 600 \
    <"$work/session" >"$work/out" 2>"$work/err"
grep -o "saved $key in [0-9]* ms.*" "$work/out" | awk '
    { ms = $4; erased = ($0 ~ /erased/); n[erased]++; sum[erased] += ms
      if (ms > max[erased]) max[erased] = ms }
    END {
        printf "saves without an erase: %d, mean %.1f ms, max %d ms\n", n[0], n[0] ? sum[0] / n[0] : 0, max[0]
        printf "saves with a page erase: %d, mean %.1f ms, max %d ms\n", n[1], n[1] ? sum[1] / n[1] : 0, max[1]
    }'
