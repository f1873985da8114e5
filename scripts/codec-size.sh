#!/usr/bin/env bash
# Flash and static RAM the protocol codec takes on thumbv7em-none-eabihf (release, opt-level
# "s", LTO): the size of a bare binary that encodes and decodes every message, minus the
# same binary without the codec. Measured as the boards build it, and with the library's
# `compact` feature (no fast paths). Both binaries link memcpy, memset and memcmp, which every
# firmware has, so those are not counted as the codec's.
set -euo pipefail
cd "$(dirname "$0")/../tools/codec-size"
export RUSTFLAGS="-C link-arg=-e_start -C link-arg=--gc-sections"
# The bare binary has no memory layout, which flip-link (the firmware's linker) needs: link
# it with the target's own linker instead.
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_LINKER=rust-lld
target=thumbv7em-none-eabihf
# Builds with the features "$1" (none: the baseline), each set in a target directory of its own.
size_of() {
    local dir="target/${1:-base}"
    dir=${dir// /-}
    cargo build --release --quiet --target "$target" --target-dir "$dir" --features "$1"
    local elf="$dir/$target/release/x30-codec-size"
    # text+rodata are flash; data is flash and RAM; bss is RAM.
    llvm-size -A "$elf" 2>/dev/null || size -A "$elf"
}
sum() { awk -v want="$1" '$1 ~ want { s += $2 } END { print s + 0 }'; }
base=$(size_of "")
flash() { echo "$1" | sum '^\.(text|rodata|data)$'; }
ram() { echo "$1" | sum '^\.(data|bss)$'; }
report() {
    local sizes f r
    sizes=$(size_of "$1")
    f=$(( $(flash "$sizes") - $(flash "$base") ))
    r=$(( $(ram "$sizes") - $(ram "$base") ))
    printf '%-60s flash %6d bytes (%4.1f KiB), static RAM %d bytes\n' "$2" "$f" "$(awk -v f="$f" "BEGIN { print f / 1024 }")" "$r"
}
report codec "panel: encode every request, decode every response"
report robot-side "both directions: also decode requests, encode responses"
report "codec compact" "compact build, panel"
report "robot-side compact" "compact build, both directions"
