#!/usr/bin/env bash
# Flash (text + rodata + data) and static RAM (data + bss) of firmware images: the ELF files
# given as arguments, or the one the last `cargo build --release` wrote (every board's build
# writes the same path, so measure each right after building it).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -eq 0 ]; then
    set -- target/thumbv7em-none-eabihf/release/x30-panel
fi
for elf in "$@"; do
    [ -f "$elf" ] || { echo "missing $elf: run cargo build --release first" >&2; exit 1; }
    llvm-size -A "$elf" | awk -v elf="$elf" '
        $1 ~ /^\.(vector_table|text|rodata|data)$/ { flash += $2 }
        $1 ~ /^\.(data|bss|uninit)$/ { ram += $2 }
        END { printf "%s: flash %d bytes (%.1f KiB), static RAM %d bytes (%.1f KiB)\n", elf, flash, flash / 1024, ram, ram / 1024 }'
done
