#!/usr/bin/env bash
# Cortex-M instructions the protocol codec takes for the panel's usual work (decoding a 1002
# answer; encoding a 1003 request, a zero velocity and a soft e-stop) and for the robot's
# side of the benchmark (decoding the 1003 request, encoding the 1002 answer), in the
# firmware's release profile, as the boards build it and in the library's `compact` build.
# Each build runs in QEMU's mps2-an386 machine (a Cortex-M4) under `-icount shift=0`, which
# counts instructions, not the cycles a real chip takes (tools/codec-count says how).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
# The program has no use for flip-link's stack check; the target's own linker will do.
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_LINKER=rust-lld
target=thumbv7em-none-eabihf
echo "build    operation                instructions"
for features in "" compact robot-side robot-side,compact; do
    cargo build --release --quiet -p x30-codec-count --target "$target" --features "$features"
    timeout 300 qemu-system-arm -M mps2-an386 -nographic -monitor none -serial none \
        -icount shift=0 -semihosting-config enable=on,target=native \
        -kernel "target/$target/release/x30-codec-count"
done
