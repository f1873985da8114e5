#!/usr/bin/env bash
# Boots a firmware image for the QEMU mps2-an386 board: the Cargo runner of the QEMU board
# (scripts/qemu-test.sh sets it) and the way to start the virtual panel by hand:
#
#   scripts/qemu-run.sh target/thumbv7em-none-eabihf/release/x30-panel [ROBOT]
#
# ROBOT (default $X30_QEMU_ROBOT, else 10.0.2.2:30000) reaches the firmware on the semihosting
# command line. QEMU's user networking (the only network used) gives the board 10.0.2.15 by
# DHCP and forwards 10.0.2.2:PORT to the host's 127.0.0.1:PORT. The virtual panel's buttons
# are read from standard input (`+forward`, `-forward`, ...); logs and LED changes go to
# standard output. QEMU's exit status is the firmware's (semihosting exit). With
# X30_QEMU_TIMEOUT=SECONDS, QEMU is stopped after that long (status 124).
set -euo pipefail

if [ $# -lt 1 ]; then
    echo "usage: $0 ELF [ROBOT]" >&2
    exit 2
fi
elf=$1
robot=${2:-${X30_QEMU_ROBOT:-10.0.2.2:30000}}

# The board's code memory is the 4 MiB at address 0, where its firmware's entry point lies;
# a Nucleo build (same path) starts at 0x0800_0000, and QEMU would only report a CPU lockup.
[ -f "$elf" ] || { echo "$elf: no such file" >&2; exit 2; }
# A file too short for a header reads as no magic or no entry point.
magic=$(od -An -t x1 -N 4 "$elf" 2>/dev/null | tr -d ' \n') || true
entry=$(od -An -t u4 -j 24 -N 4 "$elf" 2>/dev/null | tr -d ' \n') || true
if [ "$magic" != 7f454c46 ] || [ -z "$entry" ] || [ "$entry" -ge 4194304 ]; then
    echo "$elf: not the QEMU board's firmware (an ELF whose entry point lies below 0x400000);" \
        "build it with cargo build-qemu (cargo build-nucleo writes the same path)" >&2
    exit 2
fi

if ! command -v qemu-system-arm >/dev/null; then
    echo "qemu-system-arm not found: apt-get install qemu-system-arm" >&2
    exit 127
fi

qemu=(
    qemu-system-arm -M mps2-an386 -nographic -monitor none -serial stdio
    -semihosting-config "enable=on,target=native,arg=$(basename "$elf"),arg=$robot"
    -nic user,model=lan9118
    -kernel "$elf"
)
if [ "${X30_QEMU_TIMEOUT:-0}" != 0 ]; then
    exec timeout --foreground "$X30_QEMU_TIMEOUT" "${qemu[@]}"
fi
exec "${qemu[@]}"
