#!/usr/bin/env bash
# Flash and static RAM the protocol codec takes on thumbv7em-none-eabihf (release, opt-level
# "s", LTO): the size of a bare binary that encodes and decodes every message, minus the
# same binary without the codec. Measured as the boards build it, and with the library's
# `compact` feature (no fast paths). Both binaries link memcpy, memset and memcmp, which every
# firmware has, so those are not counted as the codec's. Each figure is shown against issue
# 13's target (12 KiB for the panel's direction, 16 KiB both ways), as met or not.
#
# `--parts [features]` instead lists where one build's flash goes, by the source file each
# instruction was inlined from (LLVM's objdump and addr2line, Debian's `llvm`). Features as
# cargo takes them; the default is the compact panel, "codec compact".
set -euo pipefail
cd "$(dirname "$0")/../tools/codec-size"
export RUSTFLAGS="-C link-arg=-e_start -C link-arg=--gc-sections"
# The bare binary has no memory layout, which flip-link (the firmware's linker) needs: link
# it with the target's own linker instead.
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_LINKER=rust-lld
target=thumbv7em-none-eabihf
# Builds with the features "$1" (none: the baseline) and prints the binary's path, which the
# next build replaces: read it first. The builds share a target directory of their own (the
# flags above would rebuild the firmware's), so that the dependencies are built once, not
# once a feature set.
build() {
    cargo build --release --quiet --target "$target" --target-dir target --features "$1"
    echo "target/$target/release/x30-codec-size"
}
# The section sizes of the binary "$1": text+rodata are flash; data is flash and RAM; bss
# is RAM.
sections() { llvm-size -A "$1" 2>/dev/null || size -A "$1"; }
size_of() { sections "$(build "$1")"; }
sum() { awk -v want="$1" '$1 ~ want { s += $2 } END { print s + 0 }'; }
flash() { echo "$1" | sum '^\.(text|rodata|data)$'; }
ram() { echo "$1" | sum '^\.(data|bss)$'; }
base=$(size_of "")
# Where the flash of the binary built with features "$1" goes, by source file: each
# instruction counts for the innermost function of this crate it was inlined from (debug
# line tables); constants by the module that names them.
parts() {
    local elf sizes
    elf=$(build "$1")
    sizes=$(mktemp)
    # "address size" of every instruction and literal, from the disassembly's raw bytes.
    llvm-objdump -d "$elf" | awk -F '\t' '/^ +[0-9a-f]+:/ {
        split($1, f, ":"); gsub(/^ +/, "", f[1]); print "0x" f[1], gsub(/[0-9a-f][0-9a-f]/, "", f[2])
    }' > "$sizes"
    {
        echo "sections $(flash "$(sections "$elf")")"
        cut -d' ' -f1 "$sizes" | llvm-addr2line -e "$elf" -a -i
        echo "--- constants"
        nm -t d -S -C "$elf" | awk '$3 ~ /^[rRdD]$/'
    } | awk -v root="$(cd ../.. && pwd)/" -v sizes="$sizes" '
        BEGIN { while ((getline line < sizes) > 0) { split(line, f, " "); size[f[1]] = f[2] } }
        function settle() { if (at != "") { part[owner == "" ? "outside the crate (memory routines, core)" : owner] += size[at] } }
        /^sections / { flash = $2; next }
        /^--- constants/ { settle(); at = ""; constants = 1; next }
        !constants && /^0x/ { settle(); at = $1; owner = ""; next }
        !constants {
            if (owner == "" && index($0, root "src/") == 1) {
                owner = substr($0, length(root) + 1); sub(/:.*/, "", owner)
            }
            next
        }
        {
            name = $0; sub(/^[0-9]+ [0-9]+ . /, "", name)
            if (match(name, /x30_panel::[a-z_0-9:]*::/)) {
                p = substr(name, RSTART, RLENGTH - 2); sub(/::[A-Z_0-9]*$/, "", p)
                part["constants of " p] += $2
            } else {
                part["constants (unnamed)"] += $2
            }
        }
        END {
            for (p in part) { printf "%7d  %s\n", part[p], p; total += part[p] }
            printf "%7d  %s\n", flash - total, "constants without a symbol (tables, names)"
            printf "%7d  %s\n", flash, "the whole binary (text, rodata, data)"
        }' | sort -n
    rm -f "$sizes"
    echo "The codec's figure is the whole binary less the baseline's $(flash "$base") bytes."
}
if [ "${1:-}" = --parts ]; then
    parts "${2:-codec compact}"
    exit
fi
# One line of the report: the build with features "$1", described as "$2", against issue
# 13's flash target of "$3" KiB.
report() {
    local sizes f r met
    sizes=$(size_of "$1")
    f=$(( $(flash "$sizes") - $(flash "$base") ))
    r=$(( $(ram "$sizes") - $(ram "$base") ))
    met="met"
    [ "$f" -le $(( $3 * 1024 )) ] || met="NOT met"
    printf '%-56s flash %6d bytes (%4.1f KiB), target %d KiB %-7s  static RAM %d bytes\n' "$2" "$f" "$(awk -v f="$f" "BEGIN { print f / 1024 }")" "$3" "$met" "$r"
}
report codec "panel: encode every request, decode every response" 12
report robot-side "both directions: also decode requests, encode responses" 16
report "codec compact" "compact build, panel" 12
report "robot-side compact" "compact build, both directions" 16
