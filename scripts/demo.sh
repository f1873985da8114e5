#!/usr/bin/env bash
# The main job: builds the Nucleo-F767ZI firmware and reports its size, then boots the QEMU
# firmware as a virtual panel against the robot simulator, plays a scripted button session
# (scripts/demo-session.txt) and summarises what the robot received. Exits non-zero if any
# step fails: a build, the firmware (panic, no link), or a check of the summary.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh

step() { printf '\n=== %s\n' "$*"; }

step "firmware build (Nucleo-F767ZI) and size"
cargo build-nucleo
scripts/firmware-size.sh

step "virtual panel: x30-sim, x30-qemu and the QEMU firmware"
(cd tools && cargo build --release -p x30-sim -p x30-qemu)
host=$(rustc -vV | sed -n 's/^host: //p')
bin="tools/target/$host/release"
# X30_QEMU_FIRMWARE names a ready ELF (built elsewhere); otherwise x30-qemu builds it.
elf=${X30_QEMU_FIRMWARE:-$("$bin/x30-qemu" --build-only)}
echo "firmware: $elf"

work=$(mktemp -d)
sim_pid=""
cleanup() {
    # The script's own status, not that of stopping the simulator, is the exit status.
    local status=$?
    if [ -n "$sim_pid" ]; then
        kill "$sim_pid" 2>/dev/null || true
        wait "$sim_pid" 2>/dev/null || true
    fi
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT

# Port 0: the simulator picks a free loopback port and says which.
"$bin/x30-sim" --listen 127.0.0.1:0 --log "$work/requests.jsonl" >"$work/sim.out" 2>&1 &
sim_pid=$!
addr=""
for _ in $(seq 100); do
    addr=$(sed -n 's/^x30-sim listening on //p' "$work/sim.out")
    [ -n "$addr" ] && break
    kill -0 "$sim_pid" 2>/dev/null || break
    sleep 0.1
done
if [ -z "$addr" ]; then
    echo "x30-sim did not start:" >&2
    cat "$work/sim.out" >&2
    exit 1
fi

# The board's web page, to open while the demo runs, forwarded to a loopback port that
# nothing listens on: the first free one of a few random picks.
http_port=""
for _ in $(seq 20); do
    port=$((20000 + RANDOM % 20000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
        http_port=$port
        break
    fi
done
[ -n "$http_port" ] || { echo "no free loopback port for the web page" >&2; exit 1; }

step "panel session (scripts/demo-session.txt) against x30-sim on $addr"
echo "web page: http://127.0.0.1:$http_port/"
session=0
"$bin/x30-qemu" --robot "$addr" --firmware "$elf" --timeout-s 120 \
    --http "127.0.0.1:$http_port" <scripts/demo-session.txt || session=$?

step "what the robot received (x30-sim's request log)"
summary=0
"$bin/x30-log-summary" "$work/requests.jsonl" \
    --expect 1002 --expect 2/1 --expect 2/6 --expect 1003 --expect 1004 \
    --expect 2/20 --expect 1101 --expect 2/13 --expect 2/15 || summary=$?

echo
if [ "$session" -ne 0 ] || [ "$summary" -ne 0 ]; then
    echo "demo FAILED (x30-qemu exit status $session, summary exit status $summary)" >&2
    exit 1
fi
echo "demo passed"
